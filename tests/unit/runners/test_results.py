"""The one results writer (bonecontact.runners.results): summary.json, history.csv, growth.csv.

Collective: runs serially and under ``mpiexec -n 2/3`` (rank 0 writes, every rank returns
the same content).
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import csv
import json
import math
from pathlib import Path

from mpi4py import MPI

import dolfinx
import numpy as np

from bonecontact.common.version import __version__
from bonecontact.runners.results import (
    ENERGY_COLUMNS,
    GROWTH_UNITS,
    HISTORY_COLUMNS,
    MECHANICS_UNITS,
    SUMMARY_FORMAT,
    GrowthTable,
    ResultsWriter,
    run_summary,
    write_points,
    write_summary,
)

COMM = MPI.COMM_WORLD

HEADER_KEYS = [
    "scene",
    "format",
    "status",
    "ranks",
    "wall_time_s",
    "peak_memory_mb",
    "units",
    "bonecontact_version",
    "dolfinx_version",
]


def _rows(path: Path) -> list[list[str]]:
    with open(path, newline="") as f:
        return list(csv.reader(f))


def test_summary_format_number_is_one():
    assert SUMMARY_FORMAT == 1


def test_run_summary_header_then_info_in_order():
    s = run_summary("demo", "converged", COMM, 1.5, steps=3, extra={"a": 1})
    assert list(s) == HEADER_KEYS + ["steps", "extra"]
    assert s["scene"] == "demo" and s["format"] == 1 and s["status"] == "converged"
    assert s["ranks"] == COMM.size and s["wall_time_s"] == 1.5
    mem = s["peak_memory_mb"]  # this pytest process holds DOLFINx and PETSc: > 50 MiB a rank
    assert 50.0 * COMM.size <= mem["total"] and 50.0 <= mem["max_rank"] <= mem["total"]
    assert (
        s["units"] == MECHANICS_UNITS == "SI (m, kg, s, Pa, N; 2D plane strain: per unit thickness)"
    )
    assert s["bonecontact_version"] == __version__ and s["dolfinx_version"] == dolfinx.__version__
    g = run_summary("g", "failed", COMM, 0.0, units=GROWTH_UNITS, wall_time_s=9.0)
    assert g["units"] == "SI (m, kg, s, Pa, N; 2D: per unit thickness)"
    assert g["wall_time_s"] == 9.0  # info overrides the header


def test_write_summary_json_round_trip(tmp_shared_path):
    s = run_summary(
        "demo",
        "converged",
        COMM,
        0.25,
        steps=np.int64(4),
        force=np.float64(17500.0),
        mesh=tmp_shared_path / "m.msh",
        nested={"max": np.int32(2)},
    )
    write_summary(COMM, tmp_shared_path, s)
    COMM.barrier()
    back = json.loads((tmp_shared_path / "summary.json").read_text())
    assert list(back) == list(s)
    assert back["format"] == 1
    assert back["steps"] == 4 and isinstance(back["steps"], int)
    assert back["force"] == 17500.0
    assert back["mesh"] == str(tmp_shared_path / "m.msh")
    assert back["nested"] == {"max": 2}


def test_writer_history_and_summary(tmp_shared_path):
    out = tmp_shared_path / "run"
    w = ResultsWriter(COMM, out, "scene-a", None, ENERGY_COLUMNS)
    rows = [
        [0, 0.0, "", 0.0, 0.0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [
            1,
            0.1,
            "tibiofemoral",
            17500.0,
            -12.5,
            np.int64(7),
            3,
            4,
            5,
            1 / 3,
            2e-9,
            1.0,
            -0.0,
            0.5,
            0.25,
            1e-300,
        ],
    ]
    w.history(rows)
    s = w.summary("converged", steps=1, wall_time_s=2.0)
    w.close()
    COMM.barrier()
    table = _rows(out / "history.csv")
    assert table[0] == HISTORY_COLUMNS + ENERGY_COLUMNS
    assert table[0][:11] == [
        "step",
        "time",
        "pair",
        "normal_force",
        "tangential_force",
        "n_active",
        "n_stick",
        "n_slip",
        "pdas_iterations",
        "kinetic_energy",
        "strain_energy",
    ]
    assert table[1][:3] == ["0", "0.0", ""]
    assert table[2][:9] == ["1", "0.1", "tibiofemoral", "17500.0", "-12.5", "7", "3", "4", "5"]
    # floats are written exactly (repr): the values read back bit for bit
    assert [float(v) for v in table[2][9:]] == [1 / 3, 2e-9, 1.0, -0.0, 0.5, 0.25, 1e-300]
    back = json.loads((out / "summary.json").read_text())
    assert back == s
    assert list(back)[: len(HEADER_KEYS)] == HEADER_KEYS
    assert back["scene"] == "scene-a" and back["format"] == 1 and back["status"] == "converged"
    assert back["steps"] == 1 and back["wall_time_s"] == 2.0


def test_growth_table(tmp_shared_path):
    out = tmp_shared_path / "g"
    t = GrowthTable(COMM, out, ("time", "volume", "surface_area", "equivalent_radius", "pressure"))
    dt = 0.1
    radii = [1.0, 1.05, 1.1025]
    for k, R in enumerate(radii):
        t.row(k * dt, [math.pi * R**2, 2 * math.pi * R, R, 12.5])
    t.close()
    COMM.barrier()
    table = _rows(out / "growth.csv")
    assert table[0] == ["time", "volume", "surface_area", "equivalent_radius", "pressure"]
    # time as written (k*dt to 15 digits: 0.30000000000000004 -> 0.3), values exactly
    assert [r[0] for r in table[1:]] == ["0", "0.1", "0.2"]
    assert [float(r[3]) for r in table[1:]] == radii
    assert [float(r[1]) for r in table[1:]] == [math.pi * R**2 for R in radii]
    assert all(r[4] == "12.5" for r in table[1:])
    assert len(table) == 1 + len(radii)


def test_write_points(tmp_shared_path):
    pts = np.array([[0.0, 1.0], [1 / 3, -2.5e-7]])
    if COMM.rank == 0:
        write_points(tmp_shared_path / "p.csv", ["x", "y"], pts)
    COMM.barrier()
    table = _rows(tmp_shared_path / "p.csv")
    assert table == [["x", "y"], ["0.0", "1.0"], [repr(1 / 3), "-2.5e-07"]]
