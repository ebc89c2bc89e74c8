"""The named form of M and f (issue 22: readable equations of spatial systems): equations too large
to expand are printed with named quantities in Kane's form; substituted back, they are the derived
M, f (and G, c, g); `derive` shows them by default for such models and in full with --expanded."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import symengine as se
import sympy

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.equations import _readable as R

MODELS = Path(__file__).resolve().parents[1] / "models"
CHAIN3 = MODELS / "spatial-chain-3.toml"


@pytest.fixture(scope="module")
def chain3():
    return lg.derive(lg.load(str(CHAIN3)))


def assert_same(pairs, points: int = 3, seed: int = 5):
    """Each (a, b) of SymEngine expressions equal at random points (all symbols in 0.3 .. 1.7)."""
    a = [se.sympify(x) for x, _ in pairs]
    b = [se.sympify(y) for _, y in pairs]
    symbols = sorted(set().union(*(e.free_symbols for e in a + b)), key=str)
    fa, fb = (se.Lambdify(symbols, exprs, real=False, cse=True) for exprs in (a, b))
    rng = np.random.default_rng(seed)
    for _ in range(points):
        x = rng.uniform(0.3, 1.7, len(symbols)).astype(complex)
        got, want = (np.asarray(f(x), complex).ravel() for f in (fa, fb))
        assert np.all(np.isfinite(want))
        assert np.allclose(got, want, rtol=1e-11, atol=1e-11 * (1 + np.abs(want).max()))


def derived_pairs(eqs):
    back = eqs.named_form.substituted()
    core, n = eqs.core, eqs.n
    pairs = [(back["M"][i][j], core.M[i, j]) for i in range(n) for j in range(n)]
    pairs += [(back["f"][i], core.f[i]) for i in range(n)]
    m = len(core.c)
    pairs += [(back["G"][k][j], core.G[k, j]) for k in range(m) for j in range(n)]
    pairs += [(back["c"][k], core.c[k]) for k in range(m)] + [(back["g"][k], core.g[k]) for k in range(m)]
    return pairs


# ----------------------------------------------------------------- equal to the derived equations
def test_the_spatial_chain_derives_within_the_bounds_and_its_named_form_is_the_derived_one(chain3):
    assert chain3.n == 9 and chain3.too_large_to_expand
    form = chain3.named_form
    names = [name for name, _, _ in form.quantities]
    assert len(names) == len(set(names))
    # each rod's angular velocity and joint velocity in its own axes, from the rod above's (PyDy's way)
    assert {"w_rod1_x", "w_rod2_y", "w_rod3_z", "v_rod2_x", "v_rod3_z"} <= set(names)
    defined = dict((name, expr) for name, expr, _ in form.quantities)
    assert {s.name for s in defined["w_rod1_x"].free_symbols} <= {"qx1", "qy1", "qz1", "qx1_dot", "qy1_dot",
                                                                   "qz1_dot"} | set(names)
    def uses(name):  # the named quantities that `name` is written with, through common subexpressions
        out, todo = set(), [name]
        while todo:
            for s in defined[todo.pop()].free_symbols:
                if s.name in defined and s.name not in out:
                    out.add(s.name)
                    if not s.name.startswith(("w_", "v_")):
                        todo.append(s.name)
        return {u for u in out if u.startswith(("w_", "v_"))}

    assert uses("w_rod2_x") == {"w_rod1_x", "w_rod1_y", "w_rod1_z"}
    assert uses("v_rod3_x") <= {"w_rod2_x", "w_rod2_y", "w_rod2_z", "v_rod2_x", "v_rod2_y", "v_rod2_z"}
    assert form.size() < 35_000  # KanesMethod's mass_matrix_full and forcing_full: 45 KB
    assert_same(derived_pairs(chain3))
    # M symmetric as printed
    assert all(form.M[i][j] == form.M[j][i] for i in range(9) for j in range(9))


def test_each_quantity_uses_only_the_model_and_the_quantities_before_it(chain3):
    model = chain3.model
    allowed = {s.name for s in (*model.q, *model.q_dot, *model.parameters)} | {"t"}
    for name, expr, _ in chain3.named_form.quantities:
        assert {s.name for s in expr.free_symbols} <= allowed, name
        allowed.add(name)
    used = set().union(*(e.free_symbols for row in chain3.named_form.M for e in row),
                       *(e.free_symbols for e in chain3.named_form.f))
    assert {s.name for s in used} <= allowed


def test_a_planar_chain_named_form_equals_the_readable_one_exactly():
    eqs = lg.derive(lg.load("pendulum-chain-3"))
    assert not eqs.too_large_to_expand
    back = eqs.named_form.substituted()
    for i in range(3):
        assert R.trigonometric_polynomial(se.sympify(back["f"][i]) - eqs.core.f[i]) == 0
        for j in range(3):
            assert R.readable(back["M"][i][j] - se.sympify(eqs.mass_matrix[i, j])) == 0


@pytest.mark.parametrize("name", ["heavy-top", "gyroscope", "rolling-disk", "double-pendulum", "cart-pendulum",
                                  "slider-crank", "robot-arm-3", "sliding-disk-heavy-rod"])
def test_the_named_form_of_examples_with_bodies_loads_and_constraints_is_the_derived_one(name):
    assert_same(derived_pairs(lg.derive(lg.load(name))))


@pytest.mark.slow
def test_the_bicycle_prints_with_named_quantities_equal_to_the_derived_ones():
    eqs = lg.derive(lg.load("whipple-bicycle"))
    assert eqs.too_large_to_expand
    assert_same(derived_pairs(eqs), points=2)
    text = eqs.text()
    assert "Named quantities" in text and "Constraints (5;" in text and len(text) < 200_000


def test_a_mass_that_varies_and_an_energy_written_out_go_through_lagrange_s_operator():
    model = lg.Model(coordinates=["x", "th"], T="J*th_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2",
                     Q={"x": "F*cos(th)"}, parameters={"J": 0.3, "k": 2.0, "c": 0.1, "F": 1.0, "m": 1.0})
    m, x, th = sympy.symbols("m x th")
    model.add_particle(m * (1 + x**2), (x * sympy.cos(th), x * sympy.sin(th)), name="bead")
    model.add_particle(m, (sympy.cos(th), x), name="slider")
    assert_same(derived_pairs(lg.derive(model)))


def test_the_temporaries_are_named_apart_from_the_model_s_symbols():
    text = CHAIN3.read_text().replace("iXX = 0.9", "iXX = 0.9\nx1 = 2.0").replace('"iXX", "iYY"', '"iXX*x1", "iYY"')
    path = Path(__file__).parent / "_tmp_named_x1.toml"
    try:
        path.write_text(text)
        eqs = lg.derive(lg.load(str(path)))
    finally:
        path.unlink()
    names = [name for name, _, _ in eqs.named_form.quantities]
    assert "x1" not in names and names[0].startswith("z")
    assert_same(derived_pairs(eqs), points=1)


# --------------------------------------------------------------------------------- printing
def test_derive_prints_the_spatial_chain_small_with_named_quantities(capsys, chain3):
    assert main(["derive", str(CHAIN3)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("Lagrange's equations of spatial-chain-3 (9 coordinates: qx1, qy1, qz1, qx2")
    assert "Named quantities (" in out and "in Kane's form" in out and "--expanded" in out
    assert "energy = q_dot^T M q_dot / 2 + V" in out
    assert len(out) < 40_000  # the expanded form: 15 MB
    assert out.strip() == chain3.text()


@pytest.mark.parametrize("name", ["cart-pendulum", "double-pendulum", "heavy-top", "slider-crank"])
def test_small_models_print_as_before_and_expanded_changes_nothing(capsys, name):
    eqs = lg.derive(lg.load(name))
    assert not eqs.too_large_to_expand
    assert eqs.text() == eqs.text(expanded=True)
    assert main(["derive", name, "--expanded"]) == 0
    assert capsys.readouterr().out.strip() == eqs.text()
    assert "Named quantities" not in eqs.text()


def test_expanded_is_in_the_help(capsys):
    with pytest.raises(SystemExit):
        main(["derive", "--help"])
    assert "--expanded" in capsys.readouterr().out


# ------------------------------------------------------------------------- quasi-velocities
def _quasi_rhs(eqs):
    """(rhs(t, y) of y = [q, u], W(q) as a function, n) of the quasi-velocity form, numerically."""
    form = eqs.quasi_velocities()
    values: dict = {}
    for name, expr, _ in form.quantities:
        values[se.Symbol(name)] = se.DenseMatrix([expr]).xreplace(values)[0] if values else expr
    n = eqs.n
    Mu = [se.DenseMatrix([x]).xreplace(values)[0] for row in form.M for x in row]
    fu = [se.DenseMatrix([x]).xreplace(values)[0] for x in form.f]
    params = {se.Symbol(p.name): v for p, v in eqs.parameters.items()}
    q = [se.Symbol(c.name) for c in eqs.coordinates]
    u = [se.Symbol(s) for s in form.speeds]
    W = [x for row in form.W for x in row]
    args = q + u
    sub = [se.sympify(e).xreplace(params) for e in Mu + fu + W]
    fn = se.Lambdify(args, sub, cse=True)
    Wfn = se.Lambdify(q, [se.sympify(x).xreplace(params) for x in W], cse=True)

    def rhs(_t, y):
        out = np.asarray(fn(np.array(y, float)), float).ravel()
        M = out[:n * n].reshape(n, n)
        f = out[n * n:n * n + n]
        Wq = out[n * n + n:].reshape(n, n)
        return np.concatenate((Wq @ y[n:], np.linalg.solve(M, f)))

    return rhs, (lambda qv: np.asarray(Wfn(np.array(qv, float)), float).reshape(n, n)), n, form


@pytest.mark.parametrize("name, initial, t_end", [
    ("heavy-top", {"theta": 1.0, "phi_dot": 2.0, "psi_dot": 20.0}, 0.5),
    pytest.param(str(CHAIN3), None, 0.3, marks=pytest.mark.slow),  # minutes on 2 shared cores
])
def test_the_quasi_velocity_form_gives_the_same_motion_as_the_equations_in_q_dot(name, initial, t_end):
    from scipy.integrate import solve_ivp

    eqs = lg.derive(lg.load(name))
    reference = lg.simulate(eqs, t_end=t_end, initial=initial, rtol=1e-11, atol=1e-11)
    rhs, W, n, form = _quasi_rhs(eqs)
    x0 = np.array(reference.x[0], float)  # shape (N, 2n): the model's initial state (a writable copy)
    q0, qd0 = x0[:n], x0[n:]
    u0 = np.linalg.solve(W(q0), qd0)  # q_dot = W u
    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate((q0, u0)), method="DOP853", rtol=1e-11, atol=1e-11)
    assert sol.success
    q_end, u_end = sol.y[:n, -1], sol.y[n:, -1]
    ref_end = np.asarray(reference.x[-1], float)
    assert np.allclose(q_end, ref_end[:n], rtol=0, atol=1e-7)
    assert np.allclose(W(q_end) @ u_end, ref_end[n:], rtol=0, atol=1e-6)
    # the kinematic equations are stated, one per coordinate, in the speeds
    assert [k for k, _ in form.kinematic] == [f"{c.name}_dot" for c in eqs.coordinates]


def test_the_kinematic_equations_of_a_spherical_joint_read_as_the_textbook_s(chain3):
    form = chain3.quasi_velocities()
    assert form.speeds[:3] == ("u_rod1_x", "u_rod1_y", "u_rod1_z")
    kin = dict(form.kinematic)
    qy, qz, ux, uy = sympy.symbols("qy1 qz1 u_rod1_x u_rod1_y")
    # body-fixed x, y, z angles: qy_dot = sin(qz) u_x + cos(qz) u_y
    assert sympy.simplify(sympy.sympify(str(kin["qy1_dot"])) - (sympy.sin(qz) * ux + sympy.cos(qz) * uy)) == 0
    assert "cos(qy1)" in str(kin["qx1_dot"])  # singular at qy1 = pi/2, as every Euler angle set is somewhere


def test_derive_prints_the_quasi_velocities_on_request_and_says_when_there_are_none(capsys):
    assert main(["derive", "heavy-top", "--quasi-velocities"]) == 0
    out = capsys.readouterr().out
    assert "in quasi-velocities" in out and "Kinematic equations (q_dot = W(q) u):" in out
    assert "  theta_dot = -sin(psi)*u_body_y + cos(psi)*u_body_x" in out
    assert main(["derive", "cart-pendulum", "--quasi-velocities"]) == 2
    err = capsys.readouterr().err
    assert ("quasi-velocities: no frame of model 'cart-pendulum' is turned by three coordinates of its own (a "
            "spherical joint: three angles), so its speeds are its velocities; derive it without "
            "--quasi-velocities") in err
    assert main(["derive", "rolling-disk", "--quasi-velocities"]) == 2
    assert "the quasi-velocity form is for unconstrained models" in capsys.readouterr().err


def test_a_kinetic_energy_too_large_to_expand_is_differentiated_in_kane_s_form_equal_to_lagrange_s(chain3):
    from lagrangian.equations import _derive
    from lagrangian.equations._readable import expanded_terms_bound

    core = chain3.core
    assert expanded_terms_bound(core.T, _derive.KANE_ABOVE) > _derive.KANE_ABOVE
    kin = lg.model._kinematics.Kinematics(chain3.model.q, [])
    M, f = _derive._lagrange_core(core.L, core.D, core.Q, core.p, kin)
    n = chain3.n
    pairs = [(core.M[i, j], M[i, j]) for i in range(n) for j in range(n)] + [(core.f[i], f[i]) for i in range(n)]
    assert_same(pairs, points=2)
    # the small models keep Lagrange's operator (their printed forms are pinned)
    small = lg.derive(lg.load("heavy-top"))
    assert expanded_terms_bound(small.core.T, _derive.KANE_ABOVE) <= _derive.KANE_ABOVE
