"""Frictional dynamic contact does not cycle at the rim of the friction disc or at the
edge of the contact zone (issue #23, F3 of the robustness matrix; the Newmark scheme's
redistributed mass).

Two families, both checked against references independent of the PDAS:

* 3D curved-on-curved impact (bonecontact.verification.robustness: load-driven,
  dynamic, reduced mesh; a gap of one slave element at E_slave = 1 GPa, touching at
  10 MPa, whose load is too small to close the gap within the 4 steps) over the
  stiffness contrasts 1e2/1e4, the slave moduli 1e7/1e9 Pa and Tresca/Coulomb: every
  step converges, the bodies touch (peak pressure above 0.1 of the design's) and the
  energy balance closes to 1e-8 of the largest energy (the record's ``balance``); on
  2 or 3 ranks each rank also solves it alone and the pressures agree to 1e-8 of the
  peak with the same PDAS iterations.  Before the rule that holds stick/slip switches
  while the 3D slip directions turn (docs/theory/pdas.md#active-set-rule), contrast
  1e4 with E_slave = 1 GPa and Tresca cycled at step 1 (a node toggling stick <-> slip
  with |λ_t| = 1.007 ĝ in stick and a reversed slip of 1.3e-8 m in slip).
* 2D clamped bars struck once per period with the redistributed mass (the slave nodes
  carry no inertia): Tresca/Coulomb at 20, 30 and 40 steps per wave, 600 steps; the energy
  never grows (1e-12 of the initial energy), the balance closes to 1e-9 and the
  contact work is never positive.  Before the rule that keeps a slip node active when it
  was released while slipping against its traction, Coulomb at 20 steps per wave cycled
  open <-> slip in step 66; before the edge rule's reversal (an edge node slipping
  against its traction sticks) and its entry holding the other nodes, Tresca at 40
  steps per wave cycled (docs/theory/pdas.md#edge-of-the-contact-zone).
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

import sys
from pathlib import Path

from mpi4py import MPI

import pytest

from bonecontact.verification import robustness
from bonecontact.verification.robustness import Config, run_config, same_answer

sys.path.insert(0, str(Path(__file__).parent))
from test_newmark import _check_no_growth, clamped_bars

COMM = MPI.COMM_WORLD

#: (contrast, E_slave, friction) run by default (F3 of the robustness matrix); the others
#: are ``slow`` (each 10-15 s serially on a busy machine).
DEFAULT = {(1.0e4, 1.0e9, "tresca")}


def _cases():
    for contrast in (1.0e2, 1.0e4):
        for e_slave in (1.0e7, 1.0e9):
            for friction in ("tresca", "coulomb"):
                marks = () if (contrast, e_slave, friction) in DEFAULT else (pytest.mark.slow,)
                yield pytest.param(
                    contrast, e_slave, friction,
                    id=f"c{contrast:.0e}-E{e_slave:.0e}-{friction}", marks=marks,
                )  # fmt: skip


@pytest.mark.parametrize(("contrast", "e_slave", "friction"), list(_cases()))
def test_3d_impact_converges(contrast, e_slave, friction, tmp_shared_path, monkeypatch):
    """Every step converges, the energy balance closes, the same answer on every rank."""
    monkeypatch.setattr(robustness, "E_SLAVE", e_slave)
    # the load of the design scales with E_slave but the mass does not: a 10 MPa slave
    # body does not cross a gap of one element within the 4 steps, so it starts touching
    gap = 1.0 if e_slave >= 1.0e9 else 0.0
    cfg = Config(3, "curved_curved", "between", gap, "load", contrast, 0.25, friction, "dynamic")
    rec = run_config(cfg, tmp_shared_path / "all", COMM)
    assert rec.status == "converged", rec.message
    assert rec.steps == 4
    assert rec.balance <= robustness.ENERGY_TOL, rec.balance
    assert rec.pressures[:, -1].max() > 0.1 * robustness.design(cfg).pressure  # touched
    if COMM.size > 1:
        own = tmp_shared_path / f"rank{COMM.rank}"
        own.mkdir()
        ref = run_config(cfg, own, MPI.COMM_SELF)
        assert same_answer(rec, ref) <= 1.0e-8
        assert rec.iterations == ref.iterations


@pytest.mark.parametrize("friction", ["tresca", "coulomb"])
@pytest.mark.parametrize("per_wave", [20, pytest.param(30, marks=pytest.mark.slow), 40])
def test_clamped_bars_redistributed_mass(friction, per_wave):
    """600 steps of repeated impacts with mass-free slave nodes: no step cycles, the
    energy never grows and the balance closes."""
    energy, active, bal = clamped_bars(friction, 600, per_wave=per_wave)
    _check_no_growth(energy, active, bal, min_episodes=4)
