"""The pure-UFL forms compile ahead of time with ``ffcx`` into valid C.

``forms/kelvin_voigt.py`` ends with a concrete instance (``a``, ``L``: the time-discrete
Kelvin–Voigt operator and right-hand side of docs/theory/mechanics.md#time-discretisation on P1
triangles).  Compiling it
with the ``ffcx`` command must give one bilinear form with the coefficients ρ, C, C_v and
one linear form with ρ, C_v, uⁿ, uⁿ⁻¹, f, both depending on the constant Δt — and the C
must compile.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.serial

ROOT = Path(__file__).resolve().parents[3]


def _forms(c_source: str) -> list[tuple[int, list[str], list[str]]]:
    """(rank, coefficient names, constant names) of each form in an ffcx C file."""
    coeffs = dict(re.findall(r"coefficient_names_(form_\w+)\[\d+\] = \{([^}]*)\}", c_source))
    consts = dict(re.findall(r"constant_names_(form_\w+)\[\d+\] = \{([^}]*)\}", c_source))
    ranks = re.findall(r"ufcx_form (form_\w+) =\s*\{[^;]*?\.rank = (\d+)", c_source, flags=re.S)
    names = lambda s: re.findall(r'"(\w+)"', s or "")  # noqa: E731
    return [(int(r), names(coeffs.get(f)), names(consts.get(f))) for f, r in ranks]


def test_kelvin_voigt_compiles_ahead_of_time(tmp_path):
    ffcx = Path(sys.executable).parent / "ffcx"
    res = subprocess.run(
        [str(ffcx), str(ROOT / "forms" / "kelvin_voigt.py"), "-d", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert res.returncode == 0, res.stderr
    c_file, h_file = tmp_path / "kelvin_voigt.c", tmp_path / "kelvin_voigt.h"
    assert c_file.is_file() and h_file.is_file()
    forms = sorted(_forms(c_file.read_text()))
    assert forms == [
        (1, ["_rho", "_Cv", "_un", "_unm1", "_f"], ["_dt"]),
        (2, ["_rho", "_C", "_Cv"], ["_dt"]),
    ], forms
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc is not None, "a C compiler (cc) is needed to check that the generated code compiles"
    import ffcx.codegeneration

    res = subprocess.run(
        [
            cc,
            "-std=c17",
            "-O0",
            "-c",
            "-Wall",
            "-Werror=implicit-function-declaration",
            f"-I{ffcx.codegeneration.get_include_path()}",
            str(c_file),
            "-o",
            str(tmp_path / "kv.o"),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "kv.o").stat().st_size > 1000
