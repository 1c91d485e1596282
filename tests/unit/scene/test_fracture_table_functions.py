"""The [fracture] and [[crack]] tables read as mappings (bonecontact.scene.fracture_tables):
defaults, every bad input named by its key, and cracks checked against the regions of a
two-region mesh (bonecontact.scene.crack_region).

Runs serially and under ``mpiexec -n 2/3``.
"""

import dolfinx_solver  # noqa: F401  (must precede dolfinx)

import warnings

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import mesh

from bonecontact.fracture.crack import FractureError
from bonecontact.fracture.meshing import TipMesh
from bonecontact.fracture.plates import mesh_plate
from bonecontact.scene.crack_region import check_crack_region
from bonecontact.scene.errors import SceneError
from bonecontact.scene.fracture_tables import (
    crack_from_table,
    fracture_from_table,
    missing_strength,
)
from bonecontact.scene.keys import SceneDeprecationWarning
from bonecontact.scene.spec import FractureSpec

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
    ini = fracture_from_table({"initiate": True, "initiation_length": 2e-4, "coefficient": 0.3})
    assert (ini.initiate, ini.initiation_length, ini.coefficient) == (True, 2e-4, 0.3)
    assert fracture_from_table({"initiate": True}).initiation_length is None
    c = crack_from_table({"points": [[0, 0], [1e-3, 0]], "region": "cortex", "coefficient": 0.4})
    assert c.name == "crack1" and c.coefficient == 0.4 and c.crack.length == pytest.approx(1e-3)


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
        ({"coefficient": 0.3}, "coefficient"),
        ({"initiate": True, "initiation_length": 0.0}, "initiation_length"),
        ({"initiate": True, "coefficient": -0.1}, "coefficient"),
        ({"initiate": True, "coefficient": True}, "coefficient"),
        ({"initiate": True, "friction": -0.1}, "friction"),  # the old name is named
        ({"initiate": True, "friction": True}, "friction"),
    ],
)
def test_bad_fracture_tables(table, key):
    with pytest.raises(SceneError) as err, warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneDeprecationWarning)
        fracture_from_table(table)
    assert (err.value.table, err.value.key) == ("[fracture]", key)


@pytest.mark.parametrize(
    "table, key",
    [
        ({"region": "a"}, "points"),
        ({"points": [[0, 0], [1, 0]]}, "region"),
        ({"points": [[0, 0]], "region": "a"}, "points"),
        ({"points": "here", "region": "a"}, "points"),
        ({"points": [[0, 0], [1, 0]], "region": "a", "coefficient": -0.1}, "coefficient"),
        ({"points": [[0, 0], [1, 0]], "region": "a", "friction": -0.1}, "friction"),
        ({"points": [[0, 0], [1, 0]], "region": "a", "tips": "middle"}, "tips"),
    ],
)
def test_bad_crack_tables(table, key):
    with pytest.raises(SceneError) as err, warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneDeprecationWarning)
        crack_from_table(table)
    assert (err.value.table, err.value.key) == ("[[crack]] #1", key)


def test_missing_strengths_are_named():
    spec = fracture_from_table({"propagate": True, "increment": 1e-3})
    ok = {"sigma_t": 1.3e8, "K_Ic": 4e6}
    assert missing_strength(spec, ok) is None
    assert missing_strength(spec, {}) == "sigma_t"
    assert missing_strength(spec, {"sigma_t": 1.3e8}) == "K_Ic"
    assert missing_strength(spec, {"sigma_t": 0.0, "K_Ic": 4e6}) == "sigma_t"
    risk_only = fracture_from_table({"criterion": "tension_compression"})
    assert missing_strength(risk_only, ok) == "sigma_c"
    assert missing_strength(risk_only, {"sigma_t": 1.3e8, "sigma_c": 1.9e8}) is None


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
