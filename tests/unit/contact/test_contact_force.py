"""Contact forces in the original basis and the support reactions next to them.

A slave node without a multiplier (a Dirichlet node at the edge of the slave surface)
receives its share of its neighbour's multiplier (the modified dual basis).  The
residual of the assembled system at its support dof is that share plus the support's
reaction, so reactions taken from the residual alone missed 0.86 % of the load when the
share is tangential (Coulomb stick, the slave surface's end node guided sideways; found
with the reaction columns).  References: the contact forces
(:meth:`ContactSolver.contact_force`) are internal (they sum to zero over both bodies,
1e-12 of the load), equal the residual at every free dof (1e-9), and the reactions that
``bonecontact run`` reports balance the loads (1e-12), frictionless and with Coulomb or
Tresca friction, static and quasi-static.  Serial (writes a mesh and runs scenes).
"""

from __future__ import annotations

import csv
from pathlib import Path

from mpi4py import MPI

import pytest

import bonecontact as bc
from bonecontact.meshing import shapes

pytestmark = pytest.mark.serial

SCENE = """format = 1
[scene]
name = "blocks"
mesh = "{mesh}"
dimension = 2
[analysis]
{analysis}
[[material]]
name = "m_lower"
regions = ["lower"]
model = "isotropic"
E = 1.0e9
nu = 0.3
[[material]]
name = "m_upper"
regions = ["upper"]
model = "isotropic"
E = 1.0e9
nu = 0.3
tau_v = 0.01
[[contact]]
name = "joint"
slave = "upper_contact"
master = "lower_contact"
{friction}
[[dirichlet]]
boundary = "bottom"
value = [0.0, 0.0]
[[dirichlet]]
boundary = "upper_left"
value = [0.0, "free"]
[[force]]
boundary = "top"
value = [300.0, -2000.0]
schedule = [[0.0, 0.0], [0.5, 1.0], [1.0, 1.0]]
[output]
directory = "{out}"
fields_every = 0
"""

ANALYSES = {
    "static": 'kind = "static"\nload_steps = 2',
    "quasistatic": 'kind = "quasistatic"\nt_end = 1.0\ndt = 0.5',
}
FRICTION = {
    "none": "",
    "coulomb": 'friction = "coulomb"\ncoefficient = 0.5',
    "tresca": 'friction = "tresca"\nbound = 2.0e5',
}


@pytest.mark.parametrize("analysis", ["static", "quasistatic"])
@pytest.mark.parametrize("friction", ["none", "coulomb", "tresca"])
def test_reactions_balance_with_a_guided_slave_end_node(tmp_path, friction, analysis):
    assert MPI.COMM_WORLD.size == 1
    mesh = shapes.two_blocks_2d(
        MPI.COMM_SELF, path=tmp_path / "blocks.msh", upper_width=0.012, upper_offset=0.004
    )
    text = SCENE.format(
        mesh=mesh, analysis=ANALYSES[analysis], friction=FRICTION[friction], out=tmp_path / "o"
    )
    if analysis == "static":
        text = text.replace("schedule = [[0.0, 0.0], [0.5, 1.0], [1.0, 1.0]]\n", "")
    (tmp_path / "s.toml").write_text(text)
    result = bc.run(bc.load_scene(tmp_path / "s.toml"), progress=False)
    assert result.status == "converged"
    with open(Path(result.output) / "history.csv", newline="") as f:
        row = list(csv.DictReader(f))[-1]
    for c in "xy":
        total = float(row[f"reaction_bottom_{c}"]) + float(row[f"reaction_upper_left_{c}"])
        assert total + float(row[f"load_{c}"]) == pytest.approx(0.0, abs=1e-12 * 2000.0)
    if friction != "none":  # the case that missed 0.86 %: stick with a tangential share
        assert float(row["n_stick"]) > 0


def test_contact_force_is_internal_and_equals_the_free_residual(tmp_path):
    """On the Coulomb case: Σ contact forces = 0, residual − contact force = 0 at free
    dofs, and the support dofs carry the whole load."""
    import numpy as np

    from bonecontact.runners.mechanics import analysis_steps, build_model, scene_integrator

    mesh = shapes.two_blocks_2d(
        MPI.COMM_SELF, path=tmp_path / "blocks.msh", upper_width=0.012, upper_offset=0.004
    )
    text = SCENE.format(
        mesh=mesh, analysis=ANALYSES["static"], friction=FRICTION["coulomb"], out=tmp_path / "o"
    ).replace("schedule = [[0.0, 0.0], [0.5, 1.0], [1.0, 1.0]]\n", "")
    (tmp_path / "s.toml").write_text(text)
    scene = bc.load_scene(tmp_path / "s.toml")
    sm = build_model(scene)
    n, dt = analysis_steps(scene)
    integ = scene_integrator(scene, sm, dt, False)
    for _ in range(n):
        integ.step()
    g = integ.residual.duplicate()
    integ.contact.contact_force(g)
    r, f = integ.residual.array_r.reshape(-1, 2), g.array_r.reshape(-1, 2)
    load = integ.load.array_r.reshape(-1, 2).sum(axis=0)
    np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-12 * 2000.0)
    fixed = np.zeros(r.size, bool)
    fixed[sm.model.bc_dofs()] = True
    d = (r - f).ravel()
    assert np.abs(d[~fixed]).max() < 1e-9 * 2000.0
    np.testing.assert_allclose(
        [d[fixed & (np.arange(d.size) % 2 == c)].sum() for c in (0, 1)], -load, atol=1e-9
    )
    # the guided end node of the slave surface does carry a tangential share
    assert np.abs(f.ravel()[fixed & (np.arange(d.size) % 2 == 0)]).max() > 1.0
    g.destroy()
    integ.destroy()
