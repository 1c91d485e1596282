"""A 3D edge node whose friction traction was measured along a stale direction does not
cycle (issue #24; docs/theory/pdas.md#edge-of-the-contact-zone).

The 3D curved-on-curved impact of the robustness matrix (bonecontact.verification.
robustness: load-driven, dynamic, a slave of E = 1 GPa on a master 1e4 times stiffer,
Tresca bound 0.2 p₀) with slave elements half the master's, touching or one element
apart.  Before the edge rule kept an edge node whose direction still turned, both were
stopped as cycling (step 1 and step 2): one node at the rim of the contact zone went
slip → open → edge → slip with a period of three iterations — pulled open by its own
traction ĝ s when slipping (λ_n = −2.4e-3 ĝ), penetrating by 9e-8 m when open, and in
the edge state needing β = 1.09 ĝ along the direction s it was given, which had turned
by 3° in that solve.

Checks against references independent of the PDAS: every step converges; the Tresca
law at every node from the reported pressure, traction, slip and status (``|t| ≤ ĝ``,
no slip where sticking, ``t = ĝ s/|s|`` where slipping under a pressure above 1e-8 of
the peak: edge nodes have zero pressure to round-off); the energy balance closes (the
record's ``balance``); the bodies touch; on 2 ranks each rank also solves it alone
with the same pressures (1e-8 of the peak) and PDAS iterations.
"""

from __future__ import annotations

import dolfinx_solver  # noqa: F401

from mpi4py import MPI

import numpy as np
import pytest
from recorded_solves import recorded_solves

from bonecontact.verification import robustness
from bonecontact.verification.robustness import Config, run_config, same_answer

COMM = MPI.COMM_WORLD
#: the law's tolerance relative to the bound
LAW_TOL = 1.0e-5


def tresca_defect(results: list, bound: float, comm: MPI.Comm) -> float:
    """The largest violation of the Tresca law over the solves, relative to the bound."""
    worst = 0.0
    for res in results:
        t, s, p, status = res.traction_t[0], res.slip[0], res.pressure[0], res.status[0]
        tn, sn = np.linalg.norm(t, axis=1), np.linalg.norm(s, axis=1)
        act = status != "open"
        bad = [np.maximum(tn - bound, 0.0)[act]]
        stick = status == "stick"
        bad.append(sn[stick] * 1.0e3 / max(float(sn.max(initial=0.0)), 1e-300))
        # (an edge node: zero pressure to round-off, a traction in [0, ĝ])
        pmax = comm.allreduce(float(p.max(initial=0.0)), op=MPI.MAX)
        at_bound = (status == "slip") & (p > 1.0e-8 * pmax) & (sn > 0.0)
        along = bound * s[at_bound] / sn[at_bound, None]
        bad.append(np.linalg.norm(t[at_bound] - along, axis=1))
        local = max(float(b.max(initial=0.0)) for b in bad)
        worst = max(worst, comm.allreduce(local, op=MPI.MAX) / bound)
    return worst


def run_recording(cfg: Config, folder, comm: MPI.Comm, monkeypatch) -> tuple:
    """:func:`run_config` with every contact solve's result kept."""
    with recorded_solves(monkeypatch) as results:
        rec = run_config(cfg, folder, comm)
    return rec, results


@pytest.mark.parametrize("gap", [0.0, 1.0], ids=["touching", "one-element-apart"])
def test_edge_node_with_a_turning_direction(gap, tmp_shared_path, monkeypatch):
    """Every step converges, the Tresca law holds at every node, the energy balance
    closes and every rank count gives the same answer."""
    monkeypatch.setattr(robustness, "E_SLAVE", 1.0e9)
    cfg = Config(3, "curved_curved", "between", gap, "load", 1.0e4, 0.5, "tresca", "dynamic")
    rec, results = run_recording(cfg, tmp_shared_path / "all", COMM, monkeypatch)
    assert rec.status == "converged", rec.message
    assert rec.steps == 4
    assert rec.balance <= robustness.ENERGY_TOL, rec.balance
    design = robustness.design(cfg)
    assert rec.pressures[:, -1].max() > 0.1 * design.pressure  # touched
    bound = robustness.TRESCA_FRACTION * design.pressure
    assert any((r.status[0] == "slip").any() for r in results) or COMM.size > 1
    assert tresca_defect(results, bound, COMM) <= LAW_TOL
    if COMM.size > 1:
        own = tmp_shared_path / f"rank{COMM.rank}"
        own.mkdir()
        ref = run_config(cfg, own, MPI.COMM_SELF)
        assert same_answer(rec, ref) <= 1.0e-8
        assert rec.iterations == ref.iterations
