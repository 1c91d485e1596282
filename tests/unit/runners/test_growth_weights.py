"""The growth weights and stops shared by the 3D surface and interior crack runners
(bonecontact.runners.crack_fatigue.growth_weights, growth_stop) against their rules
written out: fatigue, the Paris rate C ((1 − R) K)^m above ΔK_th, else 0; one load,
(K/K_max)² at the points with K ≥ K_Ic, else 0."""

from __future__ import annotations

import numpy as np
import pytest

from bonecontact.runners.crack_fatigue import growth_stop, growth_weights
from bonecontact.scene.spec import FatigueSpec

K = np.array([1.0e6, 2.0e6, 0.5e6, 1.5e6])
SPEC = FatigueSpec(C=1e-30, m=3.0, da_max=1e-4, delta_K_th=0.8e6, R=0.2, max_blocks=5)


def test_fatigue_weights_are_the_paris_rates() -> None:
    dk = 0.8 * K
    expect = np.where(dk > 0.8e6, 1e-30 * dk**3, 0.0)
    np.testing.assert_allclose(growth_weights(K, SPEC, None), expect, rtol=1e-14)
    assert growth_weights(K, SPEC, None)[0] == 0.0  # ΔK = ΔK_th: no growth


def test_one_load_weights_at_the_toughness() -> None:
    w = growth_weights(K, None, 1.2e6)
    np.testing.assert_allclose(w, [0.0, 1.0, 0.0, 0.5625], rtol=1e-14)
    assert not growth_weights(K, None, None).any()  # no K_Ic: nothing grows


@pytest.mark.parametrize(
    ("k_max", "lead", "spec", "k_ic", "done", "stop"),
    [
        (2e6, 1e-9, SPEC, 1.9e6, 0, "fractured"),
        (2e6, 1e-9, SPEC, None, 0, None),
        (2e6, 0.0, SPEC, 3e6, 0, "arrested"),
        (2e6, 1e-9, SPEC, 3e6, 5, "max_blocks"),
        (2e6, 1.0, None, 1.9e6, 0, None),  # one load: K_Ic is the rule, not a stop
        (2e6, 0.0, None, 3e6, 0, "arrested"),
        (2e6, 1.0, None, 1.9e6, 5, "max_increments"),
    ],
)
def test_stops(k_max, lead, spec, k_ic, done, stop) -> None:
    assert growth_stop(k_max, lead, spec, k_ic, done, 5) == stop
