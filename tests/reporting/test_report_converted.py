"""The report's conversion of derived expressions to SymPy (reporting._build._converted): the same SymPy
expressions as SymEngine's own ``_sympy_()``, structurally (srepr), with subexpressions shared across
expressions converted once."""

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
