"""Propagation options and bookkeeping (bonecontact.fracture.propagation): bad input is
named, a too-coarse tip mesh is refused, records follow the fracture-table columns, and a
fixed-increment run grows each tip by exactly Δa per increment."""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import csv

from mpi4py import MPI

import numpy as np
import pytest

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import centre_crack, rectangle_outline, solve_tension
from bonecontact.fracture.propagation import (
    FRACTURE_COLUMNS,
    PropagationOptions,
    propagate,
    write_fracture_table,
)
from bonecontact.materials.laws import Isotropic

COMM = MPI.COMM_WORLD
MAT = Isotropic(E=10.0e9, nu=0.3)
PLATE = rectangle_outline(-0.5, -0.5, 0.5, 0.5)


def solve(cm):
    s = solve_tension(cm, MAT, 1.0e6)
    return s.model, s.u


@pytest.mark.parametrize(
    "kwargs, key",
    [
        ({"increment": 0.0}, "increment"),
        ({"direction": "random"}, "direction"),
        ({"K_Ic": -1.0}, "K_Ic"),
        ({"max_increments": 0}, "max_increments"),
    ],
)
def test_bad_options_are_named(kwargs, key):
    args = {"increment": 0.01, "tip_mesh": TipMesh(0.001)} | kwargs
    with pytest.raises(FractureError) as err:
        PropagationOptions(**args)
    assert err.value.key == key


def test_coarse_tip_mesh_is_refused():
    opts = PropagationOptions(0.02, TipMesh(0.02), max_increments=1)
    with pytest.raises(FractureError, match="h_tip"):
        propagate(PLATE, centre_crack(0.05), solve, MAT, opts, COMM)


@pytest.mark.parametrize("direction", ["mts", "principal"])
def test_fixed_increments_grow_both_tips(direction):
    da = 0.02
    opts = PropagationOptions(da, TipMesh(da / 8, 0.2, 0.1), direction, max_increments=2)
    res = propagate(PLATE, centre_crack(0.05), solve, MAT, opts, COMM)
    assert res.crack.length == pytest.approx(0.1 + 4 * da, rel=1e-12)
    assert len(res.records) == 4 and len(res.paths) == 3
    assert [r.increment for r in res.records] == [0, 0, 1, 1]
    row = res.records[0].row()
    assert len(row) == len(FRACTURE_COLUMNS) and row[-1] == "grows"
    np.testing.assert_allclose(res.paths[0], centre_crack(0.05).points)
    # mode I: the crack stays close to its line (mesh asymmetry only)
    assert np.max(np.abs(res.crack.points[:, 1])) < 0.1 * da


def test_fracture_table_round_trips(tmp_shared_path):
    da = 0.02
    opts = PropagationOptions(da, TipMesh(da / 8, 0.2, 0.1), max_increments=1)
    res = propagate(PLATE, centre_crack(0.05), solve, MAT, opts, COMM)
    path = tmp_shared_path / "fracture.csv"
    write_fracture_table(res.records, path, COMM)
    with open(path) as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == list(FRACTURE_COLUMNS) and len(rows) == len(res.records)
    for row, rec in zip(rows, res.records, strict=True):
        assert float(row["K_I"]) == rec.K_I and float(row["angle_deg"]) == rec.angle_deg
        assert int(row["tip"]) == rec.tip and row["status"] == rec.status
