"""Published fatigue-crack-growth constants of cortical bone in data/materials.toml agree
with the passages of their sources quoted beside them, and a published Paris coefficient
converts to SI without changing the rates
(docs/theory/fracture.md#material-constants-of-cortical-bone)."""

import dolfinx_solver  # noqa: F401  (must precede dolfinx / petsc4py)

import math
import re

import numpy as np
import pytest

from bonecontact.common.errors import ParameterError
from bonecontact.fracture.fatigue import ParisLaw, paris_coefficient_si
from bonecontact.materials.library import load_reference_values

#: "3 x 10(-10)" as the abstracts write a power of ten
_POWER = re.compile(r"(\d+(?:\.\d+)?) x 10\((-?\d+)\)")


def _quoted_rates(quote: str) -> set[float]:
    return {float(a) * 10.0 ** int(b) for a, b in _POWER.findall(quote)}


def test_nalla2005_entry_matches_its_quoted_abstract():
    fcg = load_reference_values()["cortical_fatigue_crack_growth"]
    quote = fcg["quote"]
    found = re.search(r"exponents ranging from (\d+(?:\.\d+)?) to (\d+(?:\.\d+)?)", quote)
    assert found is not None
    assert (fcg["m_min"], fcg["m_max"]) == (float(found[1]), float(found[2]))
    # the three rates of the abstract (m/cycle, as quoted) are the three recorded ones
    assert "m/cycle" in quote
    recorded = [fcg["rate_min"], fcg["rate_cyclic_max"], fcg["rate_max"]]
    assert sorted(_quoted_rates(quote)) == pytest.approx(recorded, rel=1e-12)
    assert fcg["rate_min"] < fcg["rate_cyclic_max"] < fcg["rate_max"]
    # "spanning five orders of magnitude"
    assert "five orders of magnitude" in quote
    assert math.log10(fcg["rate_max"] / fcg["rate_min"]) == pytest.approx(5.0, abs=0.05)
    # "in the proximal-distal direction": the crack grows along the bone axis
    assert "proximal-distal" in quote and fcg["orientation"] == "longitudinal"


def test_what_the_source_does_not_give_is_named_not_filled():
    fcg = load_reference_values()["cortical_fatigue_crack_growth"]
    missing = set(fcg["not_recorded"])
    assert not missing & set(fcg), "a value listed as not recorded is also recorded"
    # every ParisLaw parameter but m (m_min..m_max) is recorded or named as missing
    for key in ("C", "delta_K_th", "R"):
        assert key in fcg or key in missing, key


def test_cancellous_transfer_uses_the_cortical_numbers_it_names():
    ref = load_reference_values()
    cortical, cancellous = (
        ref["cortical_fatigue_crack_growth"],
        ref["cancellous_fatigue_crack_growth"],
    )
    assert cancellous["m"] == cortical["m_min"]
    assert cancellous["rate_at_K_Ic"] == cortical["rate_max"]


def test_norman1995_toughness_matches_its_quote_and_the_range():
    ref = load_reference_values()
    kc = ref["cortical_fracture_toughness_norman1995"]
    found = re.search(r"equaled (\d+\.\d+) and (\d+\.\d+) MN m-3/2", kc["quote"])
    assert found is not None
    # MN m^-3/2 = MPa m^0.5 = 1e6 Pa m^0.5
    assert (kc["K_c_2mm"], kc["K_c_3mm"]) == pytest.approx(
        (float(found[1]) * 1e6, float(found[2]) * 1e6), rel=1e-12
    )
    rng = ref["cortical_fracture_toughness"]
    for value in (kc["K_c_2mm"], kc["K_c_3mm"]):
        assert rng["K_Ic_min"] <= value <= rng["K_Ic_max"]


@pytest.mark.parametrize("m", [3.0, 4.4, 9.5])
def test_mpa_coefficient_converts_without_changing_the_rate(m):
    c_mpa = 2.5e-9  # m/cycle per (MPa m^0.5)^m (any number: the rates are compared)
    dk_mpa = np.array([0.3, 1.0, 2.7])
    law = ParisLaw(paris_coefficient_si(c_mpa, m), m)
    assert law.rate(dk_mpa * 1e6) == pytest.approx(c_mpa * dk_mpa**m, rel=1e-12)
    assert paris_coefficient_si(c_mpa, m) == pytest.approx(c_mpa * 10.0 ** (-6 * m), rel=1e-12)


def test_mm_and_mpa_root_mm_coefficient_converts():
    c, m = 4.0e-7, 3.5  # mm/cycle per (MPa mm^0.5)^m
    dk_si = np.array([0.5e6, 1.5e6])  # Pa m^0.5
    dk_mm = dk_si / 1e6 * math.sqrt(1000.0)  # 1 MPa m^0.5 = sqrt(1000) MPa mm^0.5
    rate_m = c * dk_mm**m * 1e-3
    law = ParisLaw(paris_coefficient_si(c, m, "MPa*mm^0.5", "mm"), m)
    assert law.rate(dk_si) == pytest.approx(rate_m, rel=1e-12)


def test_unknown_units_are_refused():
    with pytest.raises(ParameterError, match="k_unit"):
        paris_coefficient_si(1e-8, 4.0, "MPa*cm^0.5")
    with pytest.raises(ParameterError, match="length_unit"):
        paris_coefficient_si(1e-8, 4.0, length_unit="cm")
    with pytest.raises(ParameterError, match="C"):
        paris_coefficient_si(0.0, 4.0)
