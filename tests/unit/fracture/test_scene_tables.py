"""The [fracture] and [[crack]] tables (bonecontact.fracture.scene_tables): defaults, every
bad input named by its key, and cracks checked against the regions of a two-region mesh.

Runs serially and under ``mpiexec -n 2/3``.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import mesh

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import mesh_plate
from bonecontact.fracture.scene_tables import (
    FractureSpec,
    check_crack_region,
    check_strengths,
    crack_from_table,
    fracture_from_table,
)

COMM = MPI.COMM_WORLD


def test_defaults_and_a_full_table():
    assert fracture_from_table({}) == FractureSpec()
    spec = fracture_from_table(
        {
            "criterion": "tension_compression",
            "direction": "principal",
            "propagate": True,
            "increment": 1e-3,
            "max_increments": 5,
            "tip_size": 1e-4,
            "tip_grading": 0.2,
        }
    )
    assert spec.propagate and spec.increment == 1e-3 and spec.max_increments == 5
    ini = fracture_from_table({"initiate": True, "initiation_length": 2e-4, "friction": 0.3})
    assert (ini.initiate, ini.initiation_length, ini.friction) == (True, 2e-4, 0.3)
    assert fracture_from_table({"initiate": True}).initiation_length is None
    c = crack_from_table({"points": [[0, 0], [1e-3, 0]], "region": "cortex", "friction": 0.4})
    assert c.name == "crack1" and c.friction == 0.4 and c.crack.length == pytest.approx(1e-3)


@pytest.mark.parametrize(
    "table, key",
    [
        ({"criterion": "von_mises"}, "criterion"),
        ({"direction": "north"}, "direction"),
        ({"propagate": "yes"}, "propagate"),
        ({"propagate": True}, "increment"),
        ({"increment": -1.0}, "increment"),
        ({"max_increments": 0}, "max_increments"),
        ({"tip_size": 0}, "tip_size"),
        ({"speed": 1}, "speed"),
        ({"initiate": 1}, "initiate"),
        ({"initiation_length": 1e-3}, "initiation_length"),
        ({"friction": 0.3}, "friction"),
        ({"initiate": True, "initiation_length": 0.0}, "initiation_length"),
        ({"initiate": True, "friction": -0.1}, "friction"),
        ({"initiate": True, "friction": True}, "friction"),
    ],
)
def test_bad_fracture_tables(table, key):
    with pytest.raises(FractureError) as err:
        fracture_from_table(table)
    assert err.value.key == key


@pytest.mark.parametrize(
    "table, key",
    [
        ({"region": "a"}, "points"),
        ({"points": [[0, 0], [1, 0]]}, "region"),
        ({"points": [[0, 0]], "region": "a"}, "points"),
        ({"points": "here", "region": "a"}, "points"),
        ({"points": [[0, 0], [1, 0]], "region": "a", "friction": -0.1}, "friction"),
        ({"points": [[0, 0], [1, 0]], "region": "a", "tips": "middle"}, "tips"),
    ],
)
def test_bad_crack_tables(table, key):
    with pytest.raises(FractureError) as err:
        crack_from_table(table)
    assert err.value.key == key


def test_missing_strengths_are_named():
    spec = fracture_from_table({"propagate": True, "increment": 1e-3})
    ok = {"cortex": {"sigma_t": 1.3e8, "K_Ic": 4e6}}
    check_strengths(spec, ok, ["cortex"])
    with pytest.raises(FractureError, match="'marrow' has no sigma_t"):
        check_strengths(spec, ok, ["cortex", "marrow"])
    with pytest.raises(FractureError) as err:
        check_strengths(spec, {"cortex": {"sigma_t": 1.3e8}}, ["cortex"])
    assert err.value.key == "K_Ic"
    risk_only = fracture_from_table({"criterion": "tension_compression"})
    with pytest.raises(FractureError) as err:
        check_strengths(risk_only, ok, ["cortex"])
    assert err.value.key == "sigma_c"


@pytest.fixture(scope="module")
def two_regions():
    """Square [-0.5, 0.5]^2; cells with x > 0.2 get tag 2 (another body)."""
    cm = mesh_plate(0.5, 0.5, None, TipMesh(0.05, 0.3, 0.05), COMM)
    msh = cm.mesh
    n = msh.topology.index_map(2).size_local + msh.topology.index_map(2).num_ghosts
    cells = np.arange(n, dtype=np.int32)
    mid = mesh.compute_midpoints(msh, 2, cells)
    tags = mesh.meshtags(msh, 2, cells, np.where(mid[:, 0] > 0.2, 2, 1).astype(np.int32))
    return msh, tags


def test_crack_region_checks(two_regions):
    msh, tags = two_regions
    inside = crack_from_table({"points": [[-0.3, 0.0], [0.0, 0.1]], "region": "bone"})
    check_crack_region(inside, msh, tags, 1, increment=0.05)
    crossing = crack_from_table({"points": [[-0.3, 0.0], [0.4, 0.0]], "region": "bone"})
    with pytest.raises(FractureError, match="not in region 'bone'"):
        check_crack_region(crossing, msh, tags, 1)
    outside = crack_from_table({"points": [[-0.3, 0.0], [-0.7, 0.0]], "region": "bone"})
    with pytest.raises(FractureError, match="leaves the mesh"):
        check_crack_region(outside, msh, tags, 1)
    with pytest.raises(FractureError) as err:
        check_crack_region(inside, msh, tags, 1, increment=1.0)
    assert err.value.key == "increment"
