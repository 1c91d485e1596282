"""Tests of bonecontact.scene.expressions: the safe rate-expression parser of ``u_c``.

Exact values with Python numbers, UFL expressions for a UFL argument, and every kind of
input the grammar refuses (attribute access, imports, unknown names and functions, dunder
names, ...) with the message that says why.  Pure Python: also runs under mpiexec.
"""

from __future__ import annotations

import math

import pytest
import ufl
from basix.ufl import element
from ufl.core.expr import Expr

from bonecontact.scene.expressions import (
    ALLOWED_FUNCTIONS,
    MAX_LENGTH,
    ExpressionError,
    RateExpression,
    parse_rate,
)


# --------------------------------------------------------------------------------------
# what it evaluates
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "text, u_c, expected",
    [
        ("3", 0.0, 3.0),
        ("u_c", 0.25, 0.25),
        ("2.0*(u_c - 0.5)", 1.0, 1.0),
        ("1 + 2*3 - 4/8", 0.0, 6.5),
        ("u_c**2", 3.0, 9.0),
        ("2**3**2", 0.0, 512.0),  # ** is right-associative
        ("-u_c", 2.0, -2.0),
        ("+u_c", 2.0, 2.0),
        ("-(u_c - 4)", 1.0, 3.0),
        ("pos(0.4 - u_c)", 0.25, 0.4 - 0.25),
        ("pos(0.4 - u_c)", 0.5, 0.0),
        ("max(u_c, 0.3)", 0.5, 0.5),
        ("max(u_c, 0.3)", 0.1, 0.3),
        ("min(u_c, 0.3)", 0.5, 0.3),
        ("abs(-u_c)", 0.75, 0.75),
        ("sqrt(u_c)", 0.25, 0.5),
        ("exp(u_c)", 0.0, 1.0),
        ("log(e)", 0.0, 1.0),
        ("sin(pi/2)", 0.0, 1.0),
        ("cos(0)", 0.0, 1.0),
        ("tan(0)", 0.0, 0.0),
        ("tanh(0)", 0.0, 0.0),
        ("pi", 0.0, math.pi),
        ("e", 0.0, math.e),
    ],
)
def test_exact_values(text, u_c, expected):
    value = parse_rate(text)(u_c)
    assert isinstance(value, float)
    assert value == expected


def test_values_to_rounding():
    assert parse_rate("2.0*(u_c - 0.7)")(1.0) == pytest.approx(0.6, rel=1e-15)
    assert parse_rate("exp(-u_c**2)")(0.5) == pytest.approx(math.exp(-0.25), rel=1e-15)
    assert parse_rate("1.1574074e-6*(u_c - 0.5)")(1.0) == pytest.approx(
        0.5 * 1.1574074e-6, rel=1e-15
    )


def test_integers_are_floats():
    """Integers are read as floats: integer division is true division and huge powers
    overflow (OverflowError) instead of building a huge integer."""
    assert parse_rate("1/2")(0.0) == 0.5
    with pytest.raises(OverflowError):
        parse_rate("9**9**9")(0.0)


def test_whitespace_is_stripped():
    assert parse_rate("  u_c + 1  ")(1.0) == 2.0


def test_rate_expression_object():
    K = parse_rate("2*u_c")
    assert isinstance(K, RateExpression)
    assert K.text == "2*u_c"
    assert K == RateExpression("2*u_c")  # the tree does not take part in ==
    assert RateExpression("2*u_c")(1.5) == 3.0  # built from the text alone
    assert repr(K) == "RateExpression(text='2*u_c')"


def test_depends_on_u_c():
    assert parse_rate("2*u_c").depends_on_u_c
    assert parse_rate("pos(0.4 - u_c)").depends_on_u_c
    assert not parse_rate("3").depends_on_u_c
    assert not parse_rate("2*pi + e").depends_on_u_c


def test_ufl_argument_gives_ufl_expression():
    x = ufl.SpatialCoordinate(ufl.Mesh(element("Lagrange", "triangle", 1, shape=(2,))))[0]
    for text in [
        "2.0*(u_c - 0.7)",
        "pos(0.4 - u_c)",
        "max(u_c, 0.3)",
        "min(u_c, 0.3)",
        "abs(u_c)",
        "log(u_c)",
        "exp(u_c)",
        "sqrt(u_c)",
        "tanh(u_c)",
    ]:
        assert isinstance(parse_rate(text)(x), Expr), text
    # a function of a number only stays a float even with a UFL argument elsewhere
    assert isinstance(parse_rate("exp(1.0) * u_c")(x), Expr)


# --------------------------------------------------------------------------------------
# what it refuses
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "text, words",
    [
        # attribute access and dunder names
        ("u_c.__class__", ["Attribute is not allowed"]),
        ("u_c.real", ["Attribute is not allowed"]),
        ("(1).__class__.__bases__", ["Attribute is not allowed"]),
        ("__builtins__", ['unknown name "__builtins__"']),
        ("__import__", ['unknown name "__import__"']),
        # imports and calls of unknown names
        (
            "__import__('os').system('true')",
            ["function \"__import__('os').system\" is not allowed"],
        ),
        ("__import__('os')", ['function "__import__" is not allowed']),
        ("import os", ["cannot parse"]),
        ("open('x')", ['function "open" is not allowed']),
        ("eval('1')", ['function "eval" is not allowed']),
        ("exec('1')", ['function "exec" is not allowed']),
        ("math.exp(u_c)", ['function "math.exp" is not allowed']),
        ("ln(u_c)", ['function "ln" is not allowed']),
        ("f(u_c)", ['function "f" is not allowed']),
        # unknown variables
        ("2*c", ['unknown name "c"', "u_c"]),
        ("x + u_c", ['unknown name "x"']),
        # operators and constructs outside the grammar
        ("u_c^2", ["BitXor", "**"]),
        ("u_c % 2", ["Mod is not allowed"]),
        ("u_c // 2", ["FloorDiv is not allowed"]),
        ("~1", ["Invert is not allowed"]),
        ("not u_c", ["Not is not allowed"]),
        ("u_c < 1", ["Compare is not allowed"]),
        ("u_c if u_c else 1", ["IfExp is not allowed"]),
        ("u_c and 1", ["BoolOp is not allowed"]),
        ("[u_c]", ["List is not allowed"]),
        ("(u_c, 1)", ["Tuple is not allowed"]),
        ("{1: 2}", ["Dict is not allowed"]),
        ("lambda: 1", ["Lambda is not allowed"]),
        ("(y := 1)", ["NamedExpr is not allowed"]),
        ("[x for x in (1,)]", ["ListComp is not allowed"]),
        ("u_c[0]", ["Subscript is not allowed"]),
        ("'1'", ["constant '1' is not a number"]),
        ("True", ["constant True is not a number"]),
        ("None", ["constant None is not a number"]),
        ("1j", ["constant 1j is not a number"]),
        # syntax, arity, arguments
        ("u_c; 1", ["cannot parse"]),
        ("2*(u_c", ["cannot parse"]),
        ("max(u_c)", ["max() takes 2 arguments, got 1"]),
        ("exp(u_c, 1)", ["exp() takes 1 argument, got 2"]),
        ("exp(x=u_c)", ["keyword or starred arguments are not allowed"]),
        ("max(*[u_c, 1])", ["keyword or starred arguments are not allowed"]),
        # empty and too long
        ("", ["non-empty"]),
        ("   ", ["non-empty"]),
        ("u_c+" * 200 + "1", [f"longer than {MAX_LENGTH} characters"]),
    ],
)
def test_refused(text, words):
    with pytest.raises(ExpressionError) as info:
        parse_rate(text)
    for w in words:
        assert w in str(info.value), str(info.value)


def test_refused_lists_the_grammar():
    with pytest.raises(ExpressionError) as info:
        parse_rate("open('x')")
    text = str(info.value)
    assert "allowed: numbers, u_c, pi, e, + - * / **" in text
    for name, n in ALLOWED_FUNCTIONS.items():
        assert (f"{name}(x)" if n == 1 else f"{name}(x, y)") in text


def test_expression_error_is_value_error():
    assert issubclass(ExpressionError, ValueError)
    with pytest.raises(ExpressionError):
        RateExpression("u_c.__class__")


def test_not_a_string():
    with pytest.raises(ExpressionError, match="non-empty expression string"):
        parse_rate(1.0)  # type: ignore[arg-type]


def test_domain_errors_surface_when_evaluated():
    """Parsing accepts log/sqrt of anything; evaluating outside the domain raises ValueError."""
    K = parse_rate("log(u_c - 1)")
    with pytest.raises(ValueError):
        K(1.0)
    with pytest.raises(ZeroDivisionError):
        parse_rate("1/u_c")(0.0)
