"""Tumour growth (SPEC §6.1) against its exact reductions."""

import dolfinx_solver  # noqa: F401

import math

import numpy as np
import pytest
from mpi4py import MPI
from scipy.integrate import solve_ivp
from scipy.special import iv

from bonecontact.tumour import TumourError, TumourModel, TumourParameters


def _run(model, dt, t_end):
    ts, rs = [0.0], [model.equivalent_radius()]
    while model.t < t_end - 1e-12:
        model.step(dt)
        ts.append(model.t)
        rs.append(model.equivalent_radius())
    return np.array(ts), np.array(rs)


def test_radial_quasi_steady_2d():
    """Byrne-Chaplain reduction: R(t) follows dR/dt = mu[I1/I0 - u~ R/2] within 1%."""
    mu, ut = 1.0, 0.5
    p = TumourParameters(K_B=lambda c: mu * (c - ut), u_p0=1.0)
    m = TumourModel.disc(MPI.COMM_WORLD, 1.0, p, h=0.25)
    ts, rs = _run(m, 0.2, 12.0)
    ode = solve_ivp(lambda t, R: mu * (iv(1, R) / iv(0, R) - ut * R / 2), (0, ts[-1]), [rs[0]],
                    t_eval=ts, rtol=1e-11, atol=1e-12)
    err = np.max(np.abs(rs / ode.y[0] - 1))
    assert rs[-1] > 2 * rs[0]
    assert err < 0.01, err
    # approaches the stationary radius (root of I1/I0 = u~ R/2)
    from scipy.optimize import brentq
    Rs = brentq(lambda R: iv(1, R) / iv(0, R) - ut * R / 2, 1.0, 10.0)
    assert abs(rs[-1] - Rs) < 0.5 * abs(rs[-2 * len(rs) // 3] - Rs)
    assert abs(rs[-1] / Rs - 1) < 0.15
    # u_p stays exactly 1 (f = 0)
    assert np.allclose(m.u_p.x.array, 1.0, atol=1e-12)


def test_uniform_densities_with_surface_tension():
    """Constant rates, uniform data: u_p, u_q obey their ODEs and R = R0 exp(int h dt / 2)."""
    rates = dict(K_B=1.0, K_Q=0.5, K_A=0.1, K_P=0.2, K_D=0.1, K_R=0.3)
    p = TumourParameters(**rates, gamma=0.02, u_p0=0.6, u_q0=0.2)
    m = TumourModel.disc(MPI.COMM_WORLD, 1.0, p, h=0.25)
    ts, rs = _run(m, 0.02, 0.6)
    KB, KQ, KA, KP, KD, KR = (rates[k] for k in ("K_B", "K_Q", "K_A", "K_P", "K_D", "K_R"))

    def rhs(t, y):
        up, uq, lnr = y
        h = (KB + KR) * up + KR * uq - KR
        return [(KB - KQ - KA) * up + KP * uq - h * up, KQ * up - (KP + KD) * uq - h * uq, h / 2]

    ode = solve_ivp(rhs, (0, ts[-1]), [0.6, 0.2, math.log(rs[0])], t_eval=ts, rtol=1e-11, atol=1e-12)
    assert np.max(np.abs(rs / np.exp(ode.y[2]) - 1)) < 0.01
    assert rs[-1] > 1.1 * rs[0]
    up, uq = m.u_p.x.array, m.u_q.x.array
    assert np.max(np.abs(up - ode.y[0][-1])) < 0.01 * ode.y[0][-1]
    assert np.max(np.abs(uq - ode.y[1][-1])) < 0.01 * ode.y[1][-1]
    assert np.all(up >= 0) and np.all(uq >= 0) and np.all(up + uq <= 1 + 1e-12)


def test_bad_parameters():
    with pytest.raises(TumourError, match="unknown key 'K_X'"):
        TumourParameters.from_dict({"K_X": 1.0})
    with pytest.raises(TumourError, match="u_p0"):
        TumourParameters.from_dict({"u_p0": 0.8, "u_q0": 0.5})
    p = TumourParameters.from_dict({"lambda": 2.0, "K_B": "nonsense"} if False else {"lambda": 2.0})
    assert p.lambda_ == 2.0
