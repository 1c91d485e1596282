"""Time per call of :func:`bonecontact.fracture.faces.face_traction` against the direct
method it replaced (every local dof visited in Python with a coordinate key, and every
dof's distance to every tip), on a closed 3D surface crack.

The crack is the semi-elliptical surface crack of bonecontact.verification.surface_crack
(a = c = 0.2, plate 4 × 4 × 1, front a/10) closed by compression S = −1, its faces a
frictionless contact pair; the arguments of the call the solve makes (its front nodes as
the tips, the recovery of the scenes: reach 6) are captured and the call repeated with
both methods.  The plate's largest element ``h_max`` sets the size (dofs); the face
(and so the recovery) is the same at every size.  The direct method is the reference of
tests/unit/fracture/test_face_traction_fill.py (imported from there); both fields are
checked equal.

Usage::

    python benchmarks/bench_face_traction.py --h-max 0.4,0.1,0.05 --repeats 3
    mpiexec -n 2 python benchmarks/bench_face_traction.py --h-max 0.1

Writes ``results/face_traction_<ranks>.json``: per size the dofs, the face nodes, the
median wall time per call of each method (largest rank), their ratio, the part both
share (``face_data_s``: the gather and the recovery near the front, whose cost does not
grow with the mesh), the largest difference of the fields and the machine's load
average (the timings are of a busy machine when it is high).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import argparse
import importlib.util
import json
import os
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

import bonecontact.verification.surface_crack as surface_crack
from bonecontact.fracture.faces import face_data, face_traction
from bonecontact.fracture.surface3d import SurfaceCrack

HERE = Path(__file__).resolve().parent
TEST = HERE.parent / "tests" / "unit" / "fracture" / "test_face_traction_fill.py"


def _reference():
    """The direct method (the test module's reference)."""
    spec = importlib.util.spec_from_file_location("face_traction_reference", TEST)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.reference_face_traction


def _captured_call(h_max: float, comm: MPI.Comm) -> tuple[tuple, dict, int]:
    """The arguments of the solve's face_traction call and the dofs."""
    calls = []

    def spy(*args, **kwargs):
        calls.append((args, kwargs))
        return face_traction(*args, **kwargs)

    surface_crack.face_traction = spy
    try:
        p = surface_crack.PlateProblem(
            SurfaceCrack("semi_elliptical", 0.2, 0.2),
            b=2.0,
            h=2.0,
            t=1.0,
            h_front=0.02,
            grading=0.15,
            h_max=h_max,
            r_out=0.06,
            S=-1.0,
            contact=True,
        )
        sol = surface_crack.solve_plate(p, comm)
    finally:
        surface_crack.face_traction = face_traction
    return calls[0][0], calls[0][1], sol.dofs


def _median_time(fn, repeats: int, comm: MPI.Comm) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        comm.barrier()
        t0 = time.perf_counter()
        out = fn()
        times.append(comm.allreduce(time.perf_counter() - t0, op=MPI.MAX))
    return float(np.median(times)), out


def measure(h_max: float, repeats: int, reference, comm: MPI.Comm) -> dict:
    args, kwargs, dofs = _captured_call(h_max, comm)
    t_data, _ = _median_time(lambda: face_data(*args, **kwargs), repeats, comm)
    t_new, new = _median_time(lambda: face_traction(*args, **kwargs), repeats, comm)
    t_old, old = _median_time(lambda: reference(*args, **kwargs), repeats, comm)
    diff = max(
        float(np.max(np.abs(new.plus.x.array - old[0]), initial=0.0)),
        float(np.max(np.abs(new.minus.x.array - old[1]), initial=0.0)),
    )
    n_face = comm.allreduce(args[1].num_owned, op=MPI.SUM)
    return {
        "h_max": h_max,
        "dofs": dofs,
        "face_nodes": n_face,
        "front_nodes": len(args[4]),
        "face_data_s": t_data,
        "new_s": t_new,
        "old_s": t_old,
        "speed_up": t_old / t_new,
        "max_field_difference": comm.allreduce(diff, op=MPI.MAX),
        "load_average": os.getloadavg()[0],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--h-max", default="0.4,0.1,0.05", help="plate element sizes")
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    comm = MPI.COMM_WORLD
    reference = _reference()
    rows = []
    for h in (float(v) for v in a.h_max.split(",")):
        row = measure(h, a.repeats, reference, comm)
        rows.append(row)
        if comm.rank == 0:
            print(json.dumps(row), flush=True)
    if comm.rank == 0:
        out = HERE / "results" / f"face_traction_{comm.size}.json"
        out.write_text(json.dumps({"ranks": comm.size, "rows": rows}, indent=1) + "\n")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
