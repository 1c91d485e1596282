"""PDASOptions grouped by strategy (linear solve, active set, friction iteration) and
the deprecation path of the former flat keywords."""

from __future__ import annotations

import dataclasses
import warnings

import pytest

from bonecontact.contact.friction import FrictionLaw
from bonecontact.contact.options import (
    ActiveSetOptions,
    LinearOptions,
    PDASOptions,
    SlipOptions,
)

GROUPS = {"linear": LinearOptions, "active_set": ActiveSetOptions, "slip": SlipOptions}

#: A non-default, valid value for every field of every group.
VALUES = {
    "strategy": "refactor",
    "prefix": "my_contact_",
    "max_columns": 17,
    "rebase_ratio": 3.0,
    "memory_ratio": 0.25,
    "full_ratio": 0.5,
    "split_basis": False,
    "pc_reuse_rows": 0.5,
    "pc_reuse_growth": 2.0,
    "loose_rtol": 1e-3,
    "multigrid": "compressed",
    "multigrid_cycle": "v",
    "c_n": 1.0e12,
    "c_t": 2.0e12,
    "gap_tol": 1e-8,
    "cold_start_fraction": 0.3,
    "cold_start_3d": "damped",
    "fp_every": 3,
    "fp_tol": 1e-6,
    "direction_tol": 1e-5,
    "slip_3d": "fixed_point",
    "warm_slip": True,
}

#: An invalid value for every field that is validated.
BAD = {
    "strategy": "fastest",
    "memory_ratio": 0.0,
    "full_ratio": -0.1,
    "pc_reuse_rows": -1.0,
    "pc_reuse_growth": 0.5,
    "loose_rtol": 1.0,
    "multigrid": "ml",
    "multigrid_cycle": "f",
    "cold_start_fraction": 1.5,
    "cold_start_3d": "guess",
    "slip_3d": "sideways",
}

FIELDS = [(g, f.name) for g, cls in GROUPS.items() for f in dataclasses.fields(cls)]


def test_every_group_field_has_a_test_value():
    assert sorted(VALUES) == sorted(name for _, name in FIELDS)


@pytest.mark.parametrize("group, name", FIELDS)
def test_flat_keyword_is_the_group_field_with_a_deprecation_warning(group, name):
    value = VALUES[name]
    with pytest.warns(DeprecationWarning, match=rf"{name}=.*{GROUPS[group].__name__}"):
        flat = PDASOptions(**{name: value})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the grouped form warns about nothing
        grouped = PDASOptions(**{group: GROUPS[group](**{name: value})})
    assert flat == grouped
    assert getattr(getattr(flat, group), name) == value
    assert getattr(flat, name) == value  # the former flat attribute still reads
    for other, cls in GROUPS.items():  # the other groups keep their defaults
        if other != group:
            assert getattr(flat, other) == cls()


@pytest.mark.parametrize("name", sorted(BAD))
def test_invalid_values_name_their_key_in_both_forms(name):
    group = next(g for g, n in FIELDS if n == name)
    with pytest.raises(ValueError, match=name):
        GROUPS[group](**{name: BAD[name]})
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match=name):
        PDASOptions(**{name: BAD[name]})


def test_top_level_options_and_wrong_arguments():
    law = FrictionLaw("coulomb", coefficient=0.3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # friction and max_iterations stay top-level
        opts = PDASOptions(friction=law, max_iterations=7)
    assert opts.max_iterations == 7 and opts.frictions(2) == [law, law]
    assert opts.linear == LinearOptions() and opts.slip == SlipOptions()
    with pytest.raises(ValueError, match="max_iterations"):
        PDASOptions(max_iterations=0)
    with pytest.raises(TypeError, match="no_such_option"):
        PDASOptions(no_such_option=1)
    with pytest.raises(TypeError, match="LinearOptions"):
        PDASOptions(linear=SlipOptions())
    with pytest.raises(AttributeError):
        _ = PDASOptions().no_such_option
    with pytest.raises(dataclasses.FrozenInstanceError):
        PDASOptions().max_iterations = 3


@pytest.mark.parametrize(
    "fields",
    [
        {},
        {"strategy": "refactor"},
        {"strategy": "lowrank", "cold_start_fraction": 0.0, "slip_3d": "fixed_point"},
        {"loose_rtol": 0.0, "pc_reuse_rows": 0.5, "direction_tol": 1e-5},
    ],
)
def test_from_fields_groups_without_warning(fields):
    """Fields given by name land in their groups, equal to the grouped construction, and no
    DeprecationWarning is raised."""
    import warnings

    from bonecontact.contact.options import FLAT_NAMES, GROUPS

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = PDASOptions.from_fields(max_iterations=7, **fields)
        per_group = {g: {k: v for k, v in fields.items() if FLAT_NAMES[k] == g} for g in GROUPS}
        want = PDASOptions(max_iterations=7, **{g: GROUPS[g](**kw) for g, kw in per_group.items()})
    assert got == want
    for name, value in fields.items():
        assert getattr(getattr(got, FLAT_NAMES[name]), name) == value


def test_from_fields_refuses_an_unknown_name():
    with pytest.raises(TypeError, match="no option 'strateg'"):
        PDASOptions.from_fields(strateg="refactor")
