"""The SymPy/SymEngine -> CasADi translator: node by node, numbers equal to SymPy's, unknown functions refused."""

from __future__ import annotations

import math

import pytest
import symengine as se
import sympy as sp

ca = pytest.importorskip("casadi", reason="optimal motions need CasADi (the 'optimal' extra)")

from lagrangian.errors import ModelError  # noqa: E402
from lagrangian.optimal_control._casadi import KNOWN_FUNCTIONS, to_casadi  # noqa: E402

x, y = sp.symbols("x y")
X, Y = ca.SX.sym("x"), ca.SX.sym("y")


def evaluate(exprs, at=(0.3, 0.7)):
    out = to_casadi(exprs, {"x": X, "y": Y})
    f = ca.Function("f", [X, Y], out)
    got = f(*at)
    return [float(v) for v in (got if isinstance(got, tuple) else (got,))]


EXPRESSIONS = [
    sp.sin(x) ** 2 + sp.cos(y) * sp.tan(x) - sp.atan2(y, x) + sp.asin(x) * sp.acos(y) + sp.atan(x * y),
    sp.sqrt(y) * x / 3 + x ** -3 + y ** sp.Rational(3, 2) + 1 / sp.sqrt(x) + x ** 7,
    sp.exp(x) * sp.log(y) + sp.sinh(x) - sp.cosh(y) + sp.tanh(x * y) + sp.asinh(x) + sp.atanh(y / 2),
    sp.Abs(x - 1) * sp.sign(y - 1) + sp.Min(x, y, 0.5) + sp.Max(x, y) + sp.floor(3 * y) + sp.ceiling(x),
    sp.Piecewise((x, x > 0.5), (y ** 2, y > 0.6), (1, True)),
    sp.Piecewise((x, sp.And(x > 0.2, y < 0.8)), (y, True)) + sp.pi * sp.E,
    sp.sec(x) + sp.csc(y) + sp.cot(x),
]


@pytest.mark.parametrize("expr", EXPRESSIONS, ids=range(len(EXPRESSIONS)))
def test_numbers_equal_sympys(expr):
    for at in ((0.3, 0.7), (0.9, 0.65)):
        got = evaluate([expr], at)[0]
        want = float(expr.subs({x: at[0], y: at[1]}))
        assert got == pytest.approx(want, rel=1e-13, abs=1e-13)


def test_symengine_expressions_and_numbers():
    e = se.sin(se.Symbol("x")) * se.Symbol("y") ** 2 + se.Rational(1, 3)
    got = evaluate([e, 2.5, sp.Integer(4)])
    assert got[0] == pytest.approx(math.sin(0.3) * 0.49 + 1 / 3, rel=1e-14)
    assert got[1:] == [2.5, 4.0]


def test_parameters_as_numbers_and_shared_subtrees():
    common = sp.sin(x) * sp.cos(y)
    out = to_casadi([common + 1, common * 2, sp.Symbol("k") * x], {"x": X, "y": Y, "k": 3.0})
    f = ca.Function("f", [X, Y], out)
    assert [float(v) for v in f(0.3, 0.7)] == pytest.approx(
        [math.sin(0.3) * math.cos(0.7) + 1, 2 * math.sin(0.3) * math.cos(0.7), 0.9], rel=1e-14)


def test_deep_tree_without_recursion():
    e, want = x, 0.3
    for _ in range(3000):
        e, want = sp.sin(e, evaluate=False), math.sin(want)
    assert evaluate([e])[0] == pytest.approx(want, rel=1e-12)


def test_unknown_function_refused_by_name():
    with pytest.raises(ModelError, match=r"the function 'evil' cannot be used .* the known functions are Abs"):
        to_casadi([sp.Function("evil")(x)], {"x": X}, where="objective")
    with pytest.raises(ModelError, match="the function 'Derivative'"):
        to_casadi([sp.Derivative(sp.Function("f")(x), x)], {"x": X})
    assert "sin" in KNOWN_FUNCTIONS and "atan2" in KNOWN_FUNCTIONS


def test_unknown_symbol_named_with_the_known_ones():
    with pytest.raises(ModelError, match=r"objective: the name 'z' is not known here; .* may use x, y"):
        to_casadi([x + sp.Symbol("z")], {"x": X, "y": Y}, where="objective")


def test_not_an_expression():
    with pytest.raises(ModelError, match="expected a SymPy or SymEngine expression, got object"):
        to_casadi([object()], {"x": X})


def test_complex_numbers_refused():
    with pytest.raises(ModelError, match="is not real"):
        to_casadi([sp.I * x], {"x": X})
