"""The report's conversion of derived expressions to SymPy (reporting._build._converted): the same SymPy
expressions as SymEngine's own ``_sympy_()``, structurally (srepr), with subexpressions shared across
expressions converted once."""

import pytest
import symengine as se
import sympy

import lagrangian as lg
from lagrangian.reporting._build import _converted


def test_the_conversion_of_derived_expressions_is_symengines_own():
    eqs = lg.derive(lg.load("rolling-disk"))
    core = eqs.core
    x, y = se.symbols("x y")
    exprs = [*core.M, *core.f, *core.G, *core.c, core.L, se.sqrt(x ** 2 + y ** 2) / (1 + se.exp(-x)),
             se.atan(x) * se.log(y) - se.tanh(x * y) + se.Rational(3, 7) * x ** se.Rational(-1, 2), se.Abs(x) + 2.5]
    memo: dict = {}
    for e in exprs:
        got = _converted(e, memo)
        want = e._sympy_()
        assert sympy.srepr(got) == sympy.srepr(want)
    assert len(memo) > len(exprs)  # subexpressions kept, for the next expression



def _check(exprs) -> None:
    memo: dict = {}
    for e in exprs:
        got = _converted(e, memo)
        want = e._sympy_()
        assert sympy.srepr(got) == sympy.srepr(want), e
        assert got == want and got.args == want.args


def test_the_conversion_builds_sums_and_products_as_sympy_does():
    # (_converted builds sums and products without SymPy's flattening where that would only sort them)
    x, y, z = se.symbols("x y z")
    _check([2 * x * (x + y), 3 * (x + y), -se.cos(x - y) * se.sin(y - x),
            x ** 2 / y + 1 - se.sin(z) ** 2 * se.cos(z) ** -2, se.Rational(-1, 2) * x * se.sin(2 * x) * (y + z) ** 2,
            x * se.exp(x) * se.exp(y), 2.0 * x * y + x,
            se.sin(-x) * y - se.cos(-y) * x * z + x * y * z])


@pytest.mark.slow
def test_the_conversion_of_the_bicycles_derived_forms_is_symengines_own():
    core = lg.derive(lg.load("whipple-bicycle")).core  # the largest example's
    _check([*core.M, *core.f[:3], *core.G, *core.c[:2]])
