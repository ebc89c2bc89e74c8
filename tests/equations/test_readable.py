"""The readable forms of the equations (issue 10: readable equations in well under a second):
compact (one cosine of the angle difference times a sum of masses), equal to the derivation for
every example, the identities one by one, the budget, and the shortcuts past SymPy's
constructors giving SymPy's own objects."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
import symengine as se
import sympy

import lagrangian as lg
from lagrangian.equations import _readable as R
from lagrangian.equations._singular import determinant, factored
from lagrangian.examples import example_names

S = sympy.Symbol


def chain(n: int) -> lg.Model:
    """An n-link pendulum chain with its own mass m_i and length l_i for every link."""
    model = lg.Model(f"chain-{n}")
    q = model.coordinate(*[f"q{i}" for i in range(1, n + 1)])
    q = (q,) if n == 1 else q
    m = [model.parameter(f"m{i}", 1.0) for i in range(1, n + 1)]
    l = [model.parameter(f"l{i}", 1.0) for i in range(1, n + 1)]  # noqa: E741
    x = y = 0
    for i in range(n):
        x, y = x + l[i] * lg.sin(q[i]), y - l[i] * lg.cos(q[i])
        model.add_particle(m[i], (x, y), name=f"bob{i + 1}")
    model.add_gravity(model.parameter("g", 9.81))
    return model


@pytest.fixture(scope="module")
def chain10():
    return lg.derive(chain(10))


# ------------------------------------------------------------------------ compact forms
def test_chain_entry_is_one_cosine_of_the_difference_times_a_sum_of_masses(chain10):
    m = [S(f"m{i}") for i in range(1, 11)]
    l1, l2, q1, q2 = S("l1"), S("l2"), S("q1"), S("q2")
    assert chain10.mass_matrix[0, 1] == l1 * l2 * sympy.Add(*m[1:]) * sympy.cos(q1 - q2)
    assert sympy.sstr(chain10.mass_matrix[0, 1]) == \
        "l1*l2*(m10 + m2 + m3 + m4 + m5 + m6 + m7 + m8 + m9)*cos(q1 - q2)"
    assert chain10.mass_matrix[0, 0] == l1**2 * sympy.Add(*m)
    # gravity and each other velocity once in the forcing: -g*l1*(m1 + ... + m10)*sin(q1), ...
    f1 = chain10.forcing[0]
    assert len(f1.args) == 10
    assert -S("g") * l1 * sympy.Add(*m) * sympy.sin(q1) in f1.args


def test_chain_entries_are_compact(chain10):
    qs = chain10.coordinates
    for i in range(10):
        for j in range(10):
            entry = chain10.mass_matrix[i, j]
            cosines = entry.atoms(sympy.cos)
            if i == j:
                assert not cosines
            else:  # one factor cos(q_i - q_j), one sum of masses
                assert cosines == {sympy.cos(qs[i] - qs[j])}
                assert entry.is_Mul and sum(1 for f in entry.args if f.is_Add) == (1 if max(i, j) < 9 else 0)
            assert sympy.count_ops(entry) <= 25
    for fi in chain10.forcing:  # one term for gravity and one for each other velocity
        assert len(fi.args) == 10 and sympy.count_ops(fi) <= 160
        assert all(len(t.atoms(sympy.sin, sympy.cos)) == 1 for t in fi.args)
    for Ei in chain10.equations:  # and one for each acceleration
        assert len(Ei.args) == 20


def test_example_chain_reads_as_before():
    eqs = lg.derive(lg.load("pendulum-chain-10"))
    l, m, th = S("l"), S("m"), [S(f"theta{i}") for i in range(1, 11)]
    assert eqs.mass_matrix[0, 1] == 9 * l**2 * m * sympy.cos(th[0] - th[1])
    assert eqs.mass_matrix[1, 9] == l**2 * m * sympy.cos(th[1] - th[9])
    energy = eqs.conserved_quantities["energy"]
    assert not [p for p in energy.atoms(sympy.Pow) if p.base.func in (sympy.sin, sympy.cos)]  # sin^2 + cos^2 = 1
    assert 3 * l**2 * m * S("theta1_dot") * S("theta8_dot") * sympy.cos(th[0] - th[7]) in energy.args


def test_textbook_forms_are_kept():
    cart = lg.derive(lg.load("cart-pendulum"))
    M1, M2, L, q2 = S("M1"), S("M2"), S("L"), S("q2")
    assert cart.mass_matrix == sympy.Matrix([[M1 + M2, -L * M2 * sympy.sin(q2)], [-L * M2 * sympy.sin(q2), L**2 * M2]])
    assert sympy.sstr(cart.equations[0]) == "-F - L*M2*q2_ddot*sin(q2) - L*M2*q2_dot**2*cos(q2) + q1_ddot*(M1 + M2)"
    mck = lg.derive(lg.load("mck"))  # a common factor is taken out with its sign
    assert sympy.sstr(mck.forcing[0]) == "c2*x2_dot + k2*x2 - x1*(k1 + k2) - x1_dot*(c1 + c2)"
    assert str(lg.singularities(cart).det_mass_matrix) == "L**2*M2*(M1 + M2*cos(q2)**2)"


# -------------------------------------------------------------------- equal to derived
def _examples():
    fixed = [n for n in example_names() if "<n>" not in n]
    return fixed + ["pendulum-chain-1", "pendulum-chain-2", "pendulum-chain-5", "spring-mass-damper-chain-3"]


# the bicycle takes 20 to 50 s on 2 cores, the other examples 0.4 s together: it is marked slow
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "whipple-bicycle" else n
                                  for n in _examples()])
def test_readable_forms_equal_the_derived_ones(name):
    """Every display form minus the derived expression is 0 at random points."""

    eqs = lg.derive(lg.load(name))
    core, n = eqs.core, eqs.n
    qdd = [se.Symbol(a.name) for a in eqs.accelerations]
    pairs = [(eqs.mass_matrix[i, j], core.M[i, j]) for i in range(n) for j in range(n)]
    pairs += [(eqs.forcing[i], core.f[i]) for i in range(n)]
    lam = [se.Symbol(m.name) for m in eqs.multipliers]
    pairs += [(eqs.equations[i], sum((core.M[i, j] * qdd[j] for j in range(n)), se.Integer(0)) - core.f[i]
               - sum((core.G[k, i] * lam[k] for k in range(len(lam))), se.Integer(0))) for i in range(n)]
    pairs += [(shown, derived) for shown, derived in zip(eqs.constraint_jacobian, core.G or ())]
    pairs += [(shown, derived) for shown, derived in zip(eqs.constraint_acceleration, core.c)]
    pairs += [(shown, derived) for shown, derived in zip(eqs.constraints.values(), core.g)]
    names = [c.name for c in eqs.coordinates]
    for key, value in eqs.conserved_quantities.items():
        raw = core.p[names.index(key[2:])] if key.startswith("p_") else eqs.jacobi_integral
        pairs.append((value, raw))
    shown = [se.sympify(sympy.sympify(a)) for a, _ in pairs]
    derived = [se.sympify(b) for _, b in pairs]
    symbols = sorted(set().union(*(e.free_symbols for e in shown + derived)), key=str)
    # evaluated by SymEngine (the bicycle's forcing is too large for SymPy's evalf)
    evaluate = [se.Lambdify(symbols, exprs, real=False, cse=True) for exprs in (shown, derived)]
    rng = np.random.default_rng(7)
    for _ in range(3):
        point = rng.uniform(0.3, 1.7, len(symbols)).astype(complex)
        got, want = (np.asarray(f(point), complex).ravel() for f in evaluate)
        assert np.all(np.isfinite(want))
        assert np.allclose(got, want, rtol=1e-10, atol=1e-10 * (1 + np.abs(want).max())), name


def test_readable_forms_equal_the_derived_ones_symbolically():
    """The same, exactly: M and f minus their derived forms vanish as trigonometric polynomials."""
    for eqs in (lg.derive(chain(3)), lg.derive(lg.load("double-pendulum")), lg.derive(lg.load("rotating-pendulum"))):
        for i in range(eqs.n):
            for j in range(eqs.n):
                assert _fourier_zero(se.sympify(eqs.mass_matrix[i, j]) - eqs.core.M[i, j])
            assert _fourier_zero(se.sympify(eqs.forcing[i]) - eqs.core.f[i])
        assert not _fourier_zero(se.sympify(eqs.forcing[0]))  # the check can fail


def _fourier_zero(expr) -> bool:
    """expr == 0 as a trigonometric polynomial: its Fourier form (products of sines and cosines
    written as sums, a unique form) has no term left."""
    terms = R._terms(se.expand(expr))
    return R._fourier(terms, 10**6) == {}


# ------------------------------------------------------------------------- identities
x, y, z, a, b = se.symbols("x y z a b")
SIN, COS = se.sin, se.cos


@pytest.mark.parametrize("expr, expected", [
    (a * SIN(x) * SIN(y) + a * COS(x) * COS(y), a * COS(x - y)),
    (COS(x) * COS(y) - SIN(x) * SIN(y), COS(x + y)),
    (SIN(x) * SIN(y) - COS(x) * COS(y), -COS(x + y)),
    (b * SIN(x) * COS(y) - b * COS(x) * SIN(y), b * SIN(x - y)),
    (SIN(x) * COS(y) + COS(x) * SIN(y), SIN(x + y)),
    (a * SIN(x) ** 2 + a * COS(x) ** 2, a),
    (a - a * SIN(x) ** 2, a * COS(x) ** 2),
    (2 - 2 * COS(x) ** 2, 2 * SIN(x) ** 2),
    (SIN(x) ** 3 + SIN(x) * COS(x) ** 2, SIN(x)),
    (SIN(z) * SIN(x - y) + COS(z) * (SIN(x) * SIN(y) + COS(x) * COS(y)), COS(x - y - z)),
    (se.sqrt(a ** 2 * SIN(x) ** 2 + a ** 2 * COS(x) ** 2), se.sqrt(a ** 2)),
    (a * SIN(x) * COS(x), a * SIN(x) * COS(x)),  # no double angle: as in the forcing
])
def test_identities(expr, expected):
    assert R.readable(expr) == sympy.sympify(expected._sympy_())


def test_no_rewrite_for_unequal_coefficients():
    expr = a * SIN(x) * SIN(y) + b * COS(x) * COS(y)
    assert R.readable(expr) == sympy.expand(expr._sympy_())


def test_determinant_in_the_shorter_form():
    eqs = lg.derive(lg.load("pendulum-chain-3"))
    raw = determinant(sympy.Matrix(eqs.mass_matrix))
    det = factored(raw)
    assert sympy.sstr(det) == "-l**6*m**3*(2*cos(2*theta1 - 2*theta2) + cos(2*theta2 - 2*theta3) - 5)/2"
    assert _fourier_zero(se.sympify(det) - raw)
    A = sympy.Matrix(4, 4, sympy.symbols("a0:16"))
    assert sympy.expand(determinant(A)._sympy_() - A.det()) == 0


# ----------------------------------------------------------------------------- budget
def test_budget_leaves_a_huge_expression_as_derived():
    xs = se.symbols("x1:31")
    huge = sum(xs, se.Integer(0)) ** 8  # expanded: C(37, 8) = 38,608,020 terms
    bound = R.expanded_terms_bound(huge)
    assert bound == math.comb(37, 8)
    assert R.expanded_terms_bound(huge, R.MAX_TERMS) > R.MAX_TERMS
    out = R.readable(huge)
    assert out == huge._sympy_() and out.is_Pow  # returned as it was, not expanded
    product = se.Mul(*(sum(xs[4 * k:4 * k + 4], se.Integer(0)) for k in range(7)))  # 4**7 = 16384 terms
    assert R.expanded_terms_bound(product) == 4 ** 7
    assert R.readable(product) == product._sympy_()
    small = R.readable(sum(xs[:3], se.Integer(0)) ** 2)  # under the budget: expanded
    assert small.is_Add and len(small.args) == 6


def test_budget_counts_shared_subexpressions_once():
    s = sum(se.symbols("x1:5"), se.Integer(0))
    t = sum(se.symbols("y1:4"), se.Integer(0))
    assert R.expanded_terms_bound(s * t + s) == 12 + 4
    assert R.expanded_terms_bound(s ** 2) == 10  # the monomials of degree 2 in 4 terms
    memo: dict = {}
    R.expanded_terms_bound(s * t, None, memo)
    assert memo[s] == 4 and memo[t] == 3  # reused by the next call with this memo


# ------------------------------------------------------------- SymPy's own objects
@pytest.mark.slow
def test_fast_constructors_give_sympys_canonical_objects():
    rng = random.Random(5)
    names = ["theta1", "theta2", "theta10", "q1", "x", "X", "x_1", "Omega", "b_c"]
    for _ in range(3000):
        k = rng.randint(1, 4)
        arg = sum((rng.choice([1, -1, 2, se.Rational(-3, 4)]) * se.Symbol(n) for n in rng.sample(names, k)),
                  se.Integer(0))
        for f, g in ((se.sin, sympy.sin), (se.cos, sympy.cos)):
            value = f(arg)
            if type(value) in (se.sin, se.cos):
                mine, theirs = R._to_sympy(value), g(arg._sympy_())
                assert mine == theirs and sympy.srepr(mine) == sympy.srepr(theirs)
                assert mine.atoms(sympy.Function).pop().nargs == theirs.atoms(sympy.Function).pop().nargs
    p, r, t = sympy.symbols("p r theta1")
    pool = [p, r ** 2, 1 / r, sympy.sin(t - p), -sympy.sin(t), sympy.cos(t) ** 2, p + r, sympy.sqrt(p), sympy.pi,
            sympy.exp(t), sympy.exp(p), sympy.Function("F")(t) ** 3]
    for _ in range(3000):
        factors = rng.sample(pool, rng.randint(1, 4))
        unsigned = [-f if f.could_extract_minus_sign() else f for f in factors]
        bases = [f.base if f.is_Pow else f for f in unsigned]
        if len(set(bases)) < len(bases):
            continue
        coef = rng.choice([sympy.S.One, sympy.Integer(-2), sympy.Rational(1, 2), sympy.Float(1.5)])
        mine, theirs = R._mul(coef, factors), sympy.Mul(coef, *factors)
        assert mine == theirs and sympy.srepr(mine) == sympy.srepr(theirs)
    terms = [sympy.Mul(c, f) for c in (1, -1, 2, sympy.Rational(-1, 3), sympy.Float(0.5)) for f in pool]
    for _ in range(3000):
        chosen = rng.sample(terms, rng.randint(1, 6))
        mine, theirs = R._add_sympy(chosen), sympy.Add(*chosen)
        assert mine == theirs and sympy.srepr(mine) == sympy.srepr(theirs)


def test_text_is_sympys_text():
    eqs = lg.derive(lg.load("pendulum-chain-4"))
    for e in (*eqs.mass_matrix, *eqs.forcing, *eqs.equations, *eqs.conserved_quantities.values()):
        assert R.text(e) == sympy.sstr(e)


@pytest.mark.parametrize("name", ["four-bar", "heavy-top", "rolling-disk", "robot-arm-3-joints", "mck", "kepler",
                                  "spherical-pendulum-3d", "pendulum-chain-10"])
def test_text_is_sympys_text_for_examples(name):
    """The printer's own paths for sums and products (issue 22: printing was most of `derive`) give
    sympy.sstr's string for every printed entry, JSON's included."""
    eqs = lg.derive(lg.load(name))
    exprs = [*eqs.mass_matrix, *eqs.forcing, *eqs.equations, *eqs.conserved_quantities.values()]
    if eqs.is_constrained:
        exprs += [*eqs.constraint_jacobian, *eqs.constraint_acceleration]
    for e in exprs:
        assert R.text(e) == sympy.sstr(e)


def _random_expression(rng: random.Random, depth: int) -> sympy.Expr:
    x, y, m, t1, t2 = sympy.symbols("x y m theta1 theta2")
    F = sympy.Function("F")
    atoms = [x, y, m, t1, t2, t1 - t2, sympy.pi, sympy.Integer(2), sympy.Rational(1, 3), sympy.Rational(-5, 7),
             sympy.Float(1.5), sympy.I, sympy.E, sympy.Integer(-1)]
    funcs = [sympy.sin, sympy.cos, sympy.exp, sympy.sqrt, lambda a: a ** 2, lambda a: 1 / a,
             lambda a: a ** sympy.Rational(3, 2), sympy.Abs, F, lambda a: sympy.Mod(a, 3), lambda a: a ** x]

    def build(d: int) -> sympy.Expr:
        r = rng.random()
        if d == 0 or r < 0.25:
            return rng.choice(atoms)
        if r < 0.45:
            return rng.choice(funcs)(build(d - 1))
        if r < 0.75:
            return sympy.Add(*[build(d - 1) for _ in range(rng.randint(2, 4))])
        return sympy.Mul(*[build(d - 1) for _ in range(rng.randint(2, 3))])

    return build(depth)


def test_text_is_sympys_text_for_any_expression():
    """Numbers among the factors, denominators, I, floats, unevaluated and non-commutative products,
    Mod (a function printed at a product's precedence), powers of sums: the same string as sstr."""
    rng = random.Random(22)
    A, B = sympy.symbols("A B", commutative=False)
    x, m = sympy.symbols("x m")
    special = [sympy.Mul(2, x, sympy.Integer(3), evaluate=False), sympy.Mul(1, x, evaluate=False) + m,
               -m * (x + 1) / 3, x * A * B + m, sympy.Add(x, m, evaluate=False) * 2, -(x + m), x ** -2 * m / 7]
    for e in special + [_random_expression(rng, 3) for _ in range(150)]:
        assert R.text(e) == sympy.sstr(e), e


@pytest.mark.parametrize("name", ["four-bar", "heavy-top", "cart-pendulum-extended", "mck", "spherical-pendulum-3d",
                                  "robot-arm-3-joints", "pendulum-chain-6", "slider-crank"])
def test_equations_and_energy_built_as_sympy_builds_them(name):
    """The residuals sum_j M_ij q_ddot_j - f_i - (G^T lambda)_i and the energy q_dot^T M q_dot / 2 - L0
    are built from the readable M and f without SymPy's flattening where it would only sort (issue 22):
    the same objects as sympy.Add and sympy.Mul build (equal, and the same tree)."""
    eqs = lg.derive(lg.load(name))
    assert eqs._mass_matrix_free_of_velocities
    M, f, qdd, R, v, n = (eqs.mass_matrix, eqs.forcing, eqs.accelerations, eqs.constraint_forces, eqs.velocities,
                          eqs.n)
    for i, e in enumerate(eqs.equations):
        expected = sympy.Add(*(M[i, j] * qdd[j] for j in range(n)), -f[i], -R[i])
        assert e == expected and sympy.srepr(e) == sympy.srepr(expected)
    if eqs.is_conservative:
        L0 = eqs.core.L.subs({qd: 0 for qd in eqs.core.qd})
        kinetic = [sympy.Mul(sympy.S.Half if i == j else 1, M[i, j], v[i], v[j]) for i in range(n) for j in range(i, n)]
        expected = sympy.Add(*kinetic, eqs.readable(-L0, v))
        h = eqs._readable_jacobi_integral()
        assert h == expected and sympy.srepr(h) == sympy.srepr(expected)


def test_times_and_plus_are_sympys_mul_and_add():
    x, y, m, v, w = sympy.symbols("x y m v w")
    cases = [(x + y, 1, [v]), (-3 * m * sympy.cos(x - y), sympy.S.Half, [v ** 2]), (sympy.S.Zero, 1, [v]),
             (2 * sympy.sqrt(2) * m, 1, [v, w]), (sympy.Rational(-1, 3) * (x + y), sympy.S.Half, [v]),
             (sympy.Float(1.5) * m, 1, [v]), (m, sympy.S.Half, [v ** 2])]
    for expr, coef, extra in cases:
        got, expected = R.times(expr, sympy.S(coef), extra), sympy.Mul(coef, expr, *extra)
        assert got == expected and sympy.srepr(got) == sympy.srepr(expected)
    for terms in ([x, -x], [x + y, -y, 2], [m * v, m * w, x * y], [], [sympy.S.Zero], [x * v, 2 * x * v]):
        got, expected = R.plus(list(terms)), sympy.Add(*terms)
        assert got == expected and sympy.srepr(got) == sympy.srepr(expected)
    assert R.negated(x - 2 * y) == [-x, 2 * y]


def _depends_on_reference(expr, var, samples=6):
    """_depends_on as it was before its memo (issue 22): the reference its decisions are checked against."""
    if var not in expr.free_symbols:
        return False
    d = expr.diff(var)
    if d == 0:
        return False
    symbols = sorted(d.free_symbols | expr.free_symbols, key=str)
    rng = np.random.default_rng(12345)
    for _ in range(samples):
        point = {s: se.Float(float(v)) for s, v in zip(symbols, rng.uniform(0.3, 1.7, len(symbols)))}
        value = complex(d.subs(point).n())
        scale = abs(complex(expr.subs(point).n())) + 1.0
        if not np.isfinite(value) or abs(value) > 1e-10 * scale:
            return True
    return False


@pytest.mark.parametrize("name", ["kepler", "heavy-top", "gyroscope", "rolling-disk", "spherical-pendulum-3d",
                                  "pendulum-chain-5", "sliding-disk-heavy-rod", "robot-arm-3-joints"])
def test_dependence_with_a_memo_decides_as_without(name):
    """cyclic_coordinates asks _depends_on(L, q_i) for every coordinate with one memo (L's free symbols,
    points and values found once): the same decisions as the reference, call by call."""
    from lagrangian.equations._equations import _depends_on

    eqs = lg.derive(lg.load(name))
    core = eqs.core
    memo: dict = {}
    for qi in (*core.q, *core.qd, core.t):
        assert _depends_on(core.L, qi, memo=memo) == _depends_on(core.L, qi) == _depends_on_reference(core.L, qi)
    assert {c.name for c in eqs.cyclic_coordinates} == {
        c.name for c, qi in zip(eqs.coordinates, core.q) if not _depends_on_reference(core.L, qi)
        and se.expand(core.Q[eqs.coordinates.index(c)] - core.D.diff(core.qd[eqs.coordinates.index(c)])) == 0
        and (core.G is None or all(se.expand(core.G[k, eqs.coordinates.index(c)]) == 0 for k in range(core.G.rows)))}


def test_dependence_that_cancels_is_not_counted():
    from lagrangian.equations._equations import _depends_on

    x, y, a = se.symbols("x y a")
    memo: dict = {}
    expr = a * (se.sin(x) ** 2 + se.cos(x) ** 2) + y ** 2
    assert not _depends_on(expr, x, memo=memo) and _depends_on(expr, y, memo=memo) and _depends_on(expr, a, memo=memo)
    assert not _depends_on(expr, se.Symbol("z"), memo=memo)
