"""Mortar geometry: the cost of building a 3D contact interface against one linear solve.

The 3D Hertz meshes (hemisphere R = 10 mm on a block, non-matching, refined to
``h_contact`` within 1.5 mm of the contact point, 3 mm away from it), at several
refinements.  For each: the number of slave facets, of candidate pairs and of integrated
(overlapping) pairs, the wall time of each phase of ``build_interface`` (gather: surfaces,
normals, nearby master facets; search; integrate: projection, clipping, quadrature;
assemble: local D, M, gap; distribute: sums over ranks and M̂ rows to their owners), the
time per slave facet, and the ratio of the whole build to ONE linear solve of the same
mesh (MUMPS: symbolic + numeric factorisation + solve; the hemisphere held by its flat
face, so the system is the contact problem's without contact).  Best of 2 runs of each
(the machine is shared: load only ever adds time).  Phase times are the maximum over
ranks; counts are summed over ranks.

Usage: python benchmarks/bench_mortar.py [--quick] [--h H ...]   (also under mpiexec -n K)
Writes benchmarks/results/mortar.csv (appends) and mortar.md (the table of the csv).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import argparse
from pathlib import Path

from mpi4py import MPI

from common import time_one_direct_solve, write_rows  # (benchmarks/ is the script directory)
from summarize import generic_table

from bonecontact.contact.interface import build_interface
from bonecontact.materials.laws import Isotropic
from bonecontact.mechanics.integrator import Integrator
from bonecontact.mechanics.model import Mechanics
from bonecontact.meshing import shapes as meshing

COMM = MPI.COMM_WORLD
E1, E2, NU = 2.0e9, 2.0e12, 0.3
OUT = Path(__file__).parent / "results"
PHASES = ("t_gather", "t_search", "t_integrate", "t_assemble", "t_distribute", "t_total")
COUNTS = ("n_slave_facets", "n_candidates", "n_pairs")


def _model(h: float) -> tuple[Mechanics, object, dict]:
    """The 3D Hertz mesh and elasticity model; the sphere's flat face is held."""
    md = meshing.hertz_3d(COMM, h_contact=h, zone=1.5e-3)
    pg = {k: v.tag for k, v in md.physical_groups.items()}
    m = Mechanics(
        md.mesh,
        {pg["sphere"]: Isotropic(E=E1, nu=NU), pg["block"]: Isotropic(E=E2, nu=NU)},
        md.cell_tags,
        md.facet_tags,
    )
    for c in range(3):
        m.add_dirichlet(m.facets(pg["block_bottom"]), c, 0.0)
        m.add_dirichlet(m.facets(pg["sphere_top"]), c, -1e-6 if c == 1 else 0.0)
    return m, md.facet_tags, pg


def _build(m: Mechanics, facet_tags, pg: dict) -> dict:
    """Build the interface once; its phase times (max over ranks) and counts (sums)."""
    COMM.barrier()
    itf = build_interface(
        m.V, facet_tags, pg["sphere_contact"], pg["block_contact"], dirichlet_dofs=m.bc_dofs()
    )
    st = itf.build_stats
    out = {k: COMM.allreduce(float(st.get(k, 0.0)), op=MPI.MAX) for k in PHASES}
    out.update({k: COMM.allreduce(int(st.get(k, 0)), op=MPI.SUM) for k in COUNTS})
    return out


def mortar_case(h: float, repeat: int = 2) -> dict:
    m, facet_tags, pg = _model(h)
    builds = [_build(m, facet_tags, pg) for _ in range(repeat)]
    best = {k: min(b[k] for b in builds) for k in PHASES}
    integ = Integrator(m, "static", 1.0, linear="direct")
    t_lin = min(time_one_direct_solve(integ, "bench_mortar_lin_") for _ in range(repeat))
    integ.destroy()
    counts = builds[0]
    row = {
        "h_mm": round(h * 1e3, 4),
        "dofs": m.num_dofs,
        "ranks": COMM.size,
        "slave_facets": counts["n_slave_facets"],
        "candidates": counts["n_candidates"],
        "pairs": counts["n_pairs"],
    }
    row.update({f"{k}_s": round(v, 4) for k, v in best.items()})
    row["us_per_slave_facet"] = round(1e6 * best["t_total"] / counts["n_slave_facets"], 1)
    row["t_linear_s"] = round(t_lin, 3)
    row["ratio"] = round(best["t_total"] / t_lin, 3)
    return row


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="one small mesh")
    p.add_argument("--h", type=float, nargs="*", help="contact mesh sizes (m)")
    args = p.parse_args()
    sizes = args.h or ([3e-4] if args.quick else [3e-4, 1.25e-4, 6e-5])
    rows = []
    for h in sizes:
        rows.append(mortar_case(h))
        if COMM.rank == 0:
            print("mortar", rows[-1], flush=True)
    write_rows(OUT, "mortar", rows)
    if COMM.rank == 0:
        (OUT / "mortar.md").write_text(generic_table(OUT / "mortar.csv"))


if __name__ == "__main__":
    main()
