"""Text of numbers in the result tables (bonecontact.common.formatting): exact round trip."""

import numpy as np
import pytest

from bonecontact.common.formatting import format_cell, format_float


@pytest.mark.parametrize(
    "x, text",
    [
        (0.1, "0.1"),
        (1e-9, "1e-09"),
        (3, "3.0"),
        (np.float32(0.5), "0.5"),
        (np.int64(7), "7.0"),
        (-2.5e300, "-2.5e+300"),
        (float("inf"), "inf"),
        (float("nan"), "nan"),
    ],
)
def test_format_float_is_repr_of_float(x, text):
    assert format_float(x) == text


def test_format_float_round_trips():
    rng = np.random.default_rng(1)
    for x in rng.standard_normal(200) * 10.0 ** rng.integers(-30, 30, 200):
        assert float(format_float(x)) == x


@pytest.mark.parametrize(
    "x, text",
    [
        (3, "3"),
        (np.int32(-4), "-4"),
        (True, "1"),
        ("pair", "pair"),
        ("", ""),
        (2.0, "2.0"),
        (np.float64(1 / 3), repr(1 / 3)),
    ],
)
def test_format_cell_keeps_integers_and_strings(x, text):
    assert format_cell(x) == text
