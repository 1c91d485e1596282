"""Safe rate expressions of the nutrient ``u_c`` (``[neoplasm.tumour]`` K_B ... K_D).

A scene may give a tumour rate as a string such as ``"2.0*(u_c - 0.7)"`` or
``"0.5*pos(0.4 - u_c)"``.  The string is parsed with :mod:`ast` and only this grammar is
accepted (anything else is an :class:`ExpressionError`; nothing is ever passed to
``eval``):

* numbers (integers are read as floats, so ``9**9**9`` overflows instead of hanging);
* the variable ``u_c`` and the constants ``pi`` and ``e``;
* ``+ - * / **`` and unary ``+ -`` (``^`` is rejected with a hint to write ``**``);
* the functions ``exp log sqrt sin cos tan tanh abs`` (one argument), ``max min`` (two
  arguments) and ``pos`` (positive part, ``pos(x) = max(x, 0)``).

:class:`RateExpression` is callable: ``K(u_c)`` with a Python number returns a float
(``math`` functions); with a UFL expression (the nutrient field) it returns the UFL
expression, built with ``ufl.exp``, ``ufl.ln``, ``ufl.max_value`` ... - the form
:class:`bonecontact.neoplasm.tumour.TumourParameters` expects.  This module imports UFL only when it
is called with a UFL argument, so the scene reader stays free of DOLFINx.
"""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass, field
from typing import Any

from bonecontact.common.errors import InputError

__all__ = ["ALLOWED_FUNCTIONS", "VARIABLE", "ExpressionError", "RateExpression", "parse_rate"]

#: The only free variable.
VARIABLE = "u_c"
#: Named constants.
CONSTANTS = {"pi": math.pi, "e": math.e}
#: Function name -> number of arguments.
ALLOWED_FUNCTIONS: dict[str, int] = {
    "exp": 1,
    "log": 1,
    "sqrt": 1,
    "sin": 1,
    "cos": 1,
    "tan": 1,
    "tanh": 1,
    "abs": 1,
    "pos": 1,
    "max": 2,
    "min": 2,
}
#: Longest accepted expression (characters).
MAX_LENGTH = 500

_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_UNARY = {ast.UAdd: "+", ast.USub: "-"}


class ExpressionError(InputError):
    """A rate expression that is not in the accepted grammar (the message says why)."""


def _describe_allowed() -> str:
    funcs = ", ".join(f"{n}(x)" if a == 1 else f"{n}(x, y)" for n, a in ALLOWED_FUNCTIONS.items())
    return f"allowed: numbers, {VARIABLE}, pi, e, + - * / **, and {funcs}"


def _check(node: ast.AST) -> None:
    """Reject every node outside the grammar (recursively)."""
    if isinstance(node, ast.Expression):
        _check(node.body)
    elif isinstance(node, ast.BinOp):
        if type(node.op) not in _BINOPS:
            hint = " (write ** for a power)" if isinstance(node.op, ast.BitXor) else ""
            raise ExpressionError(
                f"operator {type(node.op).__name__} is not allowed{hint}; {_describe_allowed()}"
            )
        _check(node.left)
        _check(node.right)
    elif isinstance(node, ast.UnaryOp):
        if type(node.op) not in _UNARY:
            raise ExpressionError(
                f"operator {type(node.op).__name__} is not allowed; {_describe_allowed()}"
            )
        _check(node.operand)
    elif isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise ExpressionError(f"constant {node.value!r} is not a number; {_describe_allowed()}")
    elif isinstance(node, ast.Name):
        if node.id != VARIABLE and node.id not in CONSTANTS:
            raise ExpressionError(
                f'unknown name "{node.id}"; the only variable is {VARIABLE} (constants: pi, e)'
            )
    elif isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in ALLOWED_FUNCTIONS:
            name = node.func.id if isinstance(node.func, ast.Name) else ast.unparse(node.func)
            raise ExpressionError(f'function "{name}" is not allowed; {_describe_allowed()}')
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise ExpressionError(f"{node.func.id}(): keyword or starred arguments are not allowed")
        n = ALLOWED_FUNCTIONS[node.func.id]
        if len(node.args) != n:
            raise ExpressionError(
                f"{node.func.id}() takes {n} argument{'s' if n > 1 else ''}, got {len(node.args)}"
            )
        for a in node.args:
            _check(a)
    else:
        raise ExpressionError(
            f"{type(node).__name__} is not allowed in a rate expression; {_describe_allowed()}"
        )


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _math_call(name: str, args: list[float]) -> float:
    if name == "pos":
        return max(args[0], 0.0)
    if name in ("max", "min", "abs"):
        return float({"max": max, "min": min, "abs": abs}[name](*args))
    return getattr(math, name)(*args)


def _ufl_call(name: str, args: list[Any]) -> Any:
    import ufl

    if name == "pos":
        return ufl.max_value(args[0], 0.0)
    if name == "max":
        return ufl.max_value(args[0], args[1])
    if name == "min":
        return ufl.min_value(args[0], args[1])
    if name == "abs":
        return abs(args[0])
    if name == "log":
        return ufl.ln(args[0])
    return getattr(ufl, name)(args[0])


def _evaluate(node: ast.AST, u_c: Any) -> Any:
    if isinstance(node, ast.Expression):
        return _evaluate(node.body, u_c)
    if isinstance(node, ast.Constant):
        return float(node.value)
    if isinstance(node, ast.Name):
        return u_c if node.id == VARIABLE else CONSTANTS[node.id]
    if isinstance(node, ast.UnaryOp):
        x = _evaluate(node.operand, u_c)
        return -x if isinstance(node.op, ast.USub) else +x
    if isinstance(node, ast.BinOp):
        a, b = _evaluate(node.left, u_c), _evaluate(node.right, u_c)
        op = _BINOPS[type(node.op)]
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if op == "/":
            return a / b
        return a**b
    if isinstance(node, ast.Call):
        args = [_evaluate(a, u_c) for a in node.args]
        name = node.func.id  # type: ignore[attr-defined]
        return _math_call(name, args) if all(_is_number(a) for a in args) else _ufl_call(name, args)
    raise ExpressionError(f"{type(node).__name__} is not allowed")  # unreachable after _check


@dataclass(frozen=True)
class RateExpression:
    """A validated rate expression of ``u_c``; call it with a number or a UFL expression.

    Parameters
    ----------
    text
        The expression as written in the scene.

    Examples
    --------
    >>> K = parse_rate("2.0*(u_c - 0.7)")
    >>> K(1.0)
    0.6000000000000001
    >>> parse_rate("0.5*pos(0.4 - u_c)")(0.2)
    0.1
    """

    text: str
    _tree: ast.Expression = field(repr=False, compare=False, default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self._tree is None:
            object.__setattr__(self, "_tree", _parse(self.text))

    def __call__(self, u_c: Any) -> Any:
        """The rate at ``u_c`` (a float for a number, a UFL expression for a UFL argument)."""
        return _evaluate(self._tree, u_c)

    @property
    def depends_on_u_c(self) -> bool:
        """Whether the expression contains ``u_c``."""
        return any(isinstance(n, ast.Name) and n.id == VARIABLE for n in ast.walk(self._tree))


def _parse(text: str) -> ast.Expression:
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError("must be a non-empty expression string")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"is longer than {MAX_LENGTH} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f'cannot parse "{text}": {exc.msg}') from None
    _check(tree)
    return tree


def parse_rate(text: str) -> RateExpression:
    """Parse and validate a rate expression of ``u_c``.

    Raises
    ------
    ExpressionError
        The text is not in the grammar of the module docstring.
    """
    return RateExpression(text, _parse(text))
