"""Cost of the mesh checks of a scene (bonecontact.scene.mesh_checks) next to reading the mesh.

Cases: the meshes of ``data/scenes/`` (2D knee, long bone, 3D jaw) and structured
rectangles of growing size (rectangle of 2 × 1 cm, n × n/2 element edges, one region
"body", left side fixed, right side loaded).  *read* = reading the gmsh file into the
distributed mesh, the group checks and the mesh checks (as a run does); *check* = the mesh
checks alone again (:func:`mesh_findings`, all five,
collective); both wall times of one call on the slowest rank.

Usage:  python benchmarks/bench_mesh_checks.py [--quick] [--out benchmarks/results/mesh_checks.csv]
"""

import dolfinx_solver  # noqa: F401

import argparse
import csv
import platform
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

from bonecontact.meshing import shapes
from bonecontact.runners.mechanics import read_mesh
from bonecontact.scene import load_scene
from bonecontact.scene.mesh_checks import mesh_findings

ROOT = Path(__file__).resolve().parents[1]
RECT = """format = 1
[scene]
name = "rect"
mesh = "{mesh}"
dimension = 2
[analysis]
kind = "static"
t_end = 1.0
dt = 1.0
[[material]]
name = "bone"
regions = ["body"]
model = "isotropic"
E = 17.0e9
nu = 0.3
[[dirichlet]]
boundary = "left"
value = [0.0, 0.0]
[[traction]]
boundary = "right"
value = [0.0, -1.0e6]
"""


def measure(scene_path: Path, comm: MPI.Comm) -> dict:
    scene = load_scene(scene_path)
    comm.barrier()
    t0 = time.perf_counter()
    md, groups = read_mesh(scene, comm)
    t1 = time.perf_counter()
    found = mesh_findings(scene, md, groups, comm)
    t2 = time.perf_counter()
    msh = md.mesh
    return dict(
        mesh=scene.mesh_path.name,
        dim=msh.topology.dim,
        cells=msh.topology.index_map(msh.topology.dim).size_global,
        ranks=comm.size,
        read_s=comm.allreduce(t1 - t0, op=MPI.MAX),
        check_s=comm.allreduce(t2 - t1, op=MPI.MAX),
        findings=len(found),
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/results/mesh_checks.csv"))
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    rows = []
    for name in ("knee2d.toml", "long_bone.toml", "jaw_cyst3d.toml"):
        rows.append(measure(ROOT / "data/scenes" / name, comm))
    tmp = Path(comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0))
    for n in (100,) if args.quick else (100, 300, 600):
        path = tmp / f"rect{n}.msh"
        # collective (gmsh on rank 0, the others wait for the file)
        shapes.rectangle(0.02, 0.01, n, n // 2, comm, path=path, structured=True)
        if comm.rank == 0:
            (tmp / f"rect{n}.toml").write_text(RECT.format(mesh=path.name))
        comm.barrier()
        rows.append(measure(tmp / f"rect{n}.toml", comm))
    if comm.rank == 0:
        stamp = dict(
            machine=platform.processor() or platform.machine(), date=time.strftime("%Y-%m-%d")
        )
        out = Path(args.out)
        new = not out.exists()
        with out.open("a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=[*rows[0], *stamp])
            if new:
                w.writeheader()
            for r in rows:
                w.writerow({**r, **stamp})
        for r in rows:
            print(r)


if __name__ == "__main__":
    main()
