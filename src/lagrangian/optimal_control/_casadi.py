"""A safe translator from SymPy (or SymEngine) expressions to CasADi SX.

The tree is walked node by node (post-order, without recursion, so deep trees are fine); each node
type maps to one CasADi operation. Nothing goes through text: no string is built, parsed or
evaluated. A function this module does not know is refused by name (:class:`ModelError`), never
guessed. Shared subtrees are translated once (a memo keyed by the node), so the SX graph keeps the
sharing of the symbolic expressions.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import sympy

from ..errors import ModelError
from ..model._kinematics import to_sympy

__all__ = ["import_casadi", "to_casadi", "KNOWN_FUNCTIONS"]

_MISSING = "optimal motions need CasADi's IPOPT: pip install 'lagrangian[optimal]'"


def import_casadi():
    """The casadi module, or a ModelError that says how to install it."""
    try:
        import casadi
    except ImportError:  # pragma: no cover - casadi is in the test extra
        raise ModelError(_MISSING + " (CasADi brings IPOPT and MUMPS in its wheel; it is an extra "
                                    "because that wheel is about 93 MB)") from None
    return casadi


def _unary(name: str):
    def make(ca):
        return getattr(ca, name)
    return make


#: SymPy function name -> a maker taking the casadi module and returning the n-ary operation.
_FUNCTIONS: dict[str, Any] = {
    "sin": _unary("sin"), "cos": _unary("cos"), "tan": _unary("tan"),
    "asin": _unary("asin"), "acos": _unary("acos"), "atan": _unary("atan"),
    "sinh": _unary("sinh"), "cosh": _unary("cosh"), "tanh": _unary("tanh"),
    "asinh": _unary("asinh"), "acosh": _unary("acosh"), "atanh": _unary("atanh"),
    "exp": _unary("exp"), "log": _unary("log"), "Abs": _unary("fabs"), "sign": _unary("sign"),
    "floor": _unary("floor"), "ceiling": _unary("ceil"),
    "atan2": lambda ca: ca.atan2,
    "sec": lambda ca: (lambda x: 1 / ca.cos(x)), "csc": lambda ca: (lambda x: 1 / ca.sin(x)),
    "cot": lambda ca: (lambda x: 1 / ca.tan(x)),
    "Heaviside": lambda ca: (lambda x, *_: ca.if_else(x > 0, 1, ca.if_else(x < 0, 0, 0.5))),
}
#: The names of the functions the translator knows (for messages and tests).
KNOWN_FUNCTIONS: tuple[str, ...] = tuple(sorted(
    [*_FUNCTIONS, "Min", "Max", "Piecewise", "sqrt (Pow)"]))

_RELATIONS = {"StrictLessThan": "__lt__", "LessThan": "__le__", "StrictGreaterThan": "__gt__",
              "GreaterThan": "__ge__", "Equality": "__eq__", "Unequality": "__ne__"}


def _node(expr: sympy.Basic, where: str) -> sympy.Basic:
    if not isinstance(expr, sympy.Basic):
        try:
            expr = to_sympy(expr)
        except Exception:  # noqa: BLE001 - anything that is not an expression
            raise ModelError(f"{where}: expected a SymPy or SymEngine expression, got {type(expr).__name__}; "
                             "give an expression such as F**2") from None
    return expr


def to_casadi(exprs: Iterable, symbols: Mapping[str, Any], *, where: str = "expression") -> list:
    """Translate expressions into CasADi SX, node by node.

    Parameters
    ----------
    exprs : iterable of sympy.Expr or symengine.Basic (or numbers)
    symbols : mapping of str to casadi.SX or float
        What each free symbol (by name) stands for: an SX variable or a number (a parameter's value).
    where : str
        Named in errors ("objective", "the forcing f").

    Returns
    -------
    list of casadi.SX (scalars), one per expression.

    Raises
    ------
    ModelError
        A symbol not in `symbols`, or a function the translator does not know (named, with the list
        of known ones).
    """
    ca = import_casadi()
    memo: dict[sympy.Basic, Any] = {}
    out = []
    for raw in exprs:
        if isinstance(raw, (int, float)) and not isinstance(raw, bool):
            out.append(ca.SX(float(raw)))
            continue
        root = _node(raw, where)
        stack: list[tuple[sympy.Basic, bool]] = [(root, False)]
        while stack:
            e, ready = stack.pop()
            if e in memo:
                continue
            if not ready and e.args and not (e.is_Number or e.is_NumberSymbol):
                _check_known(e, where)  # before its arguments: the outermost unknown function is named
                stack.append((e, True))
                stack.extend((a, False) for a in e.args if a not in memo)
                continue
            memo[e] = _translate(ca, e, memo, symbols, where)
        out.append(ca.SX(memo[root]) if not isinstance(memo[root], ca.SX) else memo[root])
    return out


_OPERATIONS = frozenset({"Add", "Mul", "Pow", "Min", "Max", "Piecewise", "ExprCondPair", "And", "Or", "Not",
                         *_RELATIONS, *_FUNCTIONS})


def _check_known(e: sympy.Basic, where: str) -> None:
    name = type(e).__name__
    if name not in _OPERATIONS:
        raise ModelError(f"{where}: the function '{name}' cannot be used in an optimal control problem (the "
                         f"translator to CasADi does not know it); the known functions are "
                         f"{', '.join(KNOWN_FUNCTIONS)}: write the expression with those")


def _translate(ca, e: sympy.Basic, memo, symbols, where):
    if e.is_Symbol:
        if e.name not in symbols:
            known = ", ".join(sorted(symbols)) or "(none)"
            raise ModelError(f"{where}: the name '{e.name}' is not known here; an expression of the optimal "
                             f"control problem may use {known}")
        return symbols[e.name]
    if e.is_Number or e.is_NumberSymbol or (e.is_Atom and e.is_number):
        value = complex(e)
        if value.imag != 0:
            raise ModelError(f"{where}: the number {e} is not real; use real expressions")
        return float(value.real)
    if e is sympy.true or e is sympy.false:
        return 1.0 if e is sympy.true else 0.0
    args = [memo[a] for a in e.args]
    name = type(e).__name__
    if e.is_Add:
        total = args[0]
        for a in args[1:]:
            total = total + a
        return total
    if e.is_Mul:
        prod = args[0]
        for a in args[1:]:
            prod = prod * a
        return prod
    if e.is_Pow:
        base, power = args
        exponent = e.args[1]
        if exponent == sympy.Rational(1, 2):
            return ca.sqrt(base)
        if exponent == sympy.Rational(-1, 2):
            return 1 / ca.sqrt(base)
        if exponent.is_Integer:
            k = int(exponent)
            if k == 2:
                return base * base
            if k == -1:
                return 1 / base
            return ca.constpow(base, float(k))
        return ca.power(base, power)
    if name in ("Min", "Max"):
        op = ca.fmin if name == "Min" else ca.fmax
        value = args[0]
        for a in args[1:]:
            value = op(value, a)
        return value
    if name == "Piecewise":
        # the pieces in order: the first condition that holds wins
        value: Any = float("nan")  # no piece holds: NaN, as SymPy leaves it undefined
        for pair in reversed(e.args):
            v, c = memo[pair.args[0]], memo[pair.args[1]]
            value = v if pair.args[1] == sympy.true else ca.if_else(c, v, value)
        return value
    if name == "ExprCondPair":  # Piecewise's (value, condition) pairs: read by Piecewise
        return None
    if name in _RELATIONS:
        return getattr(ca.SX(args[0]), _RELATIONS[name])(args[1])
    if name in ("And", "Or"):
        op = ca.logic_and if name == "And" else ca.logic_or
        value = args[0]
        for a in args[1:]:
            value = op(value, a)
        return value
    if name == "Not":
        return ca.logic_not(args[0])
    if name in _FUNCTIONS:
        return _FUNCTIONS[name](ca)(*args)
    _check_known(e, where)  # an atom of another kind (a symbol-like object, a set): refused by name
    raise ModelError(f"{where}: '{e}' ({name}) cannot be translated to CasADi")  # pragma: no cover
