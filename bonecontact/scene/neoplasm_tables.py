"""Reading ``[neoplasm]``, ``[neoplasm.tumour]`` and ``[neoplasm.cyst]`` (docs/neoplasm_format.md).

The keys are declared in :mod:`bonecontact.scene.spec` (:data:`NEOPLASM_TABLE`,
:data:`TUMOUR_TABLE`, :data:`CYST_TABLE`); the parameters are validated by their physics
dataclasses (:class:`~bonecontact.neoplasm.tumour.TumourParameters`,
:class:`~bonecontact.neoplasm.cyst.CystParameters`), whose errors are reported as a
:class:`~bonecontact.scene.errors.SceneError` naming the table and the key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import fields
from typing import Any

from bonecontact.common.errors import ParameterError
from bonecontact.neoplasm.cyst import CystParameters
from bonecontact.neoplasm.tumour import TumourParameters
from bonecontact.scene.errors import SceneError, describe_value
from bonecontact.scene.expressions import ExpressionError, RateExpression, parse_rate
from bonecontact.scene.spec import (
    CYST_TABLE,
    NEOPLASM_TABLE,
    TUMOUR_TABLE,
    CystSpec,
    NeoplasmSpec,
)
from bonecontact.scene.tables import MISSING, TableReader, table_of

__all__ = ["read_neoplasm"]


def _sub_table(tab: TableReader, key: str) -> TableReader | None:
    """``[neoplasm.<key>]`` as a table, or ``None`` when absent."""
    if not tab.has(key):
        return None
    value = tab.data[key]
    if not isinstance(value, dict):
        raise tab.error(key, f"must be a table [neoplasm.{key}], got {describe_value(value)}")
    return TableReader(value, f"[neoplasm.{key}]")


def _read_rate(tab: TableReader, key: str, default: float, u_c1: float) -> float | RateExpression:
    """A tumour rate: a number, or an expression string of ``u_c`` (checked at ``u_c = u_c1``)."""
    value = tab.raw(key, False)
    if value is MISSING:
        return default
    if isinstance(value, str):
        try:
            expr = parse_rate(value)
            probe = expr(u_c1)
        except ExpressionError as exc:
            raise tab.error(key, f"invalid expression of u_c: {exc}") from None
        except (ArithmeticError, ValueError) as exc:
            raise tab.error(
                key, f'expression "{value}" cannot be evaluated at u_c = u_c1 = {u_c1!r} ({exc})'
            ) from None
        if not math.isfinite(probe):
            raise tab.error(key, f'expression "{value}" is not finite at u_c = u_c1 = {u_c1!r}')
        return expr
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise tab.error(
            key,
            f"must be a number (1/s) or an expression string of u_c such as "
            f'"2.0*(u_c - 0.7)", got {describe_value(value)}',
        )
    return tab.as_number(key, value)


def _tumour_parameters(tab: TableReader, values: dict[str, Any]) -> TumourParameters:
    """``TumourParameters(**values)``, its range errors reported on ``tab``."""
    params = TumourParameters(**values)
    try:
        params.validate()
    except ParameterError as exc:
        raise tab.error(exc.key, exc.message) from None
    return params


def _read_tumour(tab: TableReader) -> TumourParameters:
    """``[neoplasm.tumour]``: numbers (ranges checked by TumourParameters), then the rates."""
    tab.check_keys(TUMOUR_TABLE)
    names = (f.name for f in fields(TumourParameters))
    numbers = {
        name: tab.get(TUMOUR_TABLE[key])
        for name, key in zip(names, TUMOUR_TABLE.names, strict=True)
        if name in TumourParameters.NUMBERS
    }
    _tumour_parameters(tab, numbers)  # ranges first: the rates are probed at u_c1
    rates = {
        k: _read_rate(tab, k, TUMOUR_TABLE.default(k), numbers["u_c1"])
        for k in TumourParameters.RATES
    }
    return _tumour_parameters(tab, {**numbers, **rates})


def _read_cyst(tab: TableReader) -> CystSpec:
    """``[neoplasm.cyst]``: the scene's ``model`` and the CystParameters (ranges checked there)."""
    tab.check_keys(CYST_TABLE)
    model = tab.get(CYST_TABLE["model"])
    strain = tab.get(CYST_TABLE["strain"])
    beta = tab.get(CYST_TABLE["beta"], why=" (osmotic supply rate, mol m-2 s-1)")
    C_minus = tab.get(CYST_TABLE["C_minus"], why=" (outside osmolarity, mol/m3)")
    others = {k: tab.get(CYST_TABLE[k]) for k in ("temperature", "E", "viscosity", "f0")}
    try:
        params = CystParameters(beta=beta, C_minus=C_minus, strain=strain, **others)
    except ParameterError as exc:
        raise tab.error(exc.key, exc.message) from None
    return CystSpec(model=model, parameters=params)


def _read_region(tab: TableReader, has_mesh: bool) -> str | None:
    """``region`` with a mesh (required; ``radius`` refused), none without one."""
    if has_mesh:
        if not tab.has("region"):
            raise tab.error(
                "region",
                "missing required key (the cell group of the mesh holding the neoplasm at t = 0)",
            )
        region = tab.get(NEOPLASM_TABLE["region"], required=True)
        if tab.has("radius"):
            raise tab.error(
                "radius",
                "is only for scenes without a mesh; with a mesh the initial "
                'neoplasm is the cell group named by "region"',
            )
        return region
    if tab.has("region"):
        raise tab.error(
            "region",
            "names a cell group of the mesh, but [scene] has no mesh; "
            "give the initial size with radius = ... (m) instead",
        )
    return None


def _read_host(tab: TableReader, has_mesh: bool, region: str | None) -> tuple[str, ...]:
    """``host``: cell groups the neoplasm may grow into (may be empty; none without a mesh)."""
    raw_host = tab.raw("host", False)
    if raw_host is MISSING or (isinstance(raw_host, list) and not raw_host):
        return ()
    host = tab.names("host")
    if not has_mesh:
        raise tab.error(
            "host",
            "names cell groups of the mesh, but [scene] has no mesh; "
            "write host = [] or leave it out",
        )
    if region is not None and region in host:
        raise tab.error("host", f'must not contain the neoplasm region "{region}" itself')
    return host


def _read_model(tab: TableReader, kind: str) -> tuple[TumourParameters | None, CystSpec | None]:
    """The sub-table of ``kind`` (the other kind's sub-table is an error)."""
    tumour_tab, cyst_tab = _sub_table(tab, "tumour"), _sub_table(tab, "cyst")
    other = "tumour" if kind == "cyst" else "cyst"
    if (cyst_tab if kind == "tumour" else tumour_tab) is not None:
        raise tab.error(
            other,
            f'[neoplasm.{other}] is given but kind = "{kind}"; '
            f"write the parameters under [neoplasm.{kind}]",
        )
    if kind == "tumour":
        return _read_tumour(tumour_tab or TableReader({}, "[neoplasm.tumour]")), None
    if cyst_tab is None:
        raise SceneError(
            None,
            "[neoplasm.cyst]",
            None,
            'missing required table (kind = "cyst" needs at least beta and C_minus)',
        )
    return None, _read_cyst(cyst_tab)


def _read_times(tab: TableReader, has_analysis: bool) -> dict[str, Any]:
    """``t_end``, ``dt``, ``remesh_every`` and ``mechanics_every``."""
    t_end = tab.get(NEOPLASM_TABLE["t_end"], why=" (growth time, s)")
    dt = tab.get(NEOPLASM_TABLE["dt"], why=" (growth step, s)")
    if dt > t_end * (1.0 + 1e-12):
        raise tab.error("dt", f"must be <= t_end = {t_end!r}, got {dt!r}")
    remesh_every = tab.get(NEOPLASM_TABLE["remesh_every"])
    mechanics_every = tab.get(NEOPLASM_TABLE["mechanics_every"])
    if mechanics_every > 0 and not has_analysis:
        raise tab.error(
            "mechanics_every",
            f"is {mechanics_every} but the scene has no [analysis] to run; "
            "a growth-only scene needs mechanics_every = 0",
        )
    return {
        "t_end": t_end,
        "dt": dt,
        "remesh_every": remesh_every,
        "mechanics_every": mechanics_every,
    }


def read_neoplasm(
    doc: Mapping[str, Any], has_mesh: bool, has_analysis: bool
) -> NeoplasmSpec | None:
    """``[neoplasm]`` and its sub-table; ``None`` without one.

    Parameters
    ----------
    doc
        The scene document.
    has_mesh
        The scene has a mesh: the initial neoplasm is its cell group ``region``;
        without one (extension) it is a disc or ball of ``radius``.
    has_analysis
        The scene has an ``[analysis]`` (a coupled scene); else ``mechanics_every``
        must be 0.
    """
    tab = table_of(doc, "neoplasm", required=False)
    if tab is None:
        return None
    tab.check_keys(NEOPLASM_TABLE)
    kind = tab.get(NEOPLASM_TABLE["kind"])
    region = _read_region(tab, has_mesh)
    radius = tab.get(
        NEOPLASM_TABLE["radius"],
        required=not has_mesh,
        why=" (initial radius in m of a scene without a mesh: a disc in 2D, a ball in 3D)",
    )
    h = tab.get(NEOPLASM_TABLE["h"])
    if h is not None and kind == "cyst":
        raise tab.error("h", 'is the tumour mesh size; the cyst model "sphere" has no mesh')
    host = _read_host(tab, has_mesh, region)
    times = _read_times(tab, has_analysis)
    tumour, cyst = _read_model(tab, kind)
    return NeoplasmSpec(
        kind=kind, region=region, host=host, radius=radius, h=h, tumour=tumour, cyst=cyst, **times
    )
