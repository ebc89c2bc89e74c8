"""State feedback: inputs that read the state (expressions, switches, Python functions), their
location as events, sampled controllers, and the compiled programs against SymPy."""

import math

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.errors import ExpressionError
from lagrangian.model._expr import parse_expression


@pytest.fixture(scope="module")
def double_integrator():
    """x'' = F: T = x_dot**2/2, Q = F (every closed form below is exact)."""
    return lg.derive(lg.Model("double-integrator", coordinates=["x"], inputs=["F"], T="x_dot**2/2", Q={"x": "F"}))


@pytest.fixture(scope="module")
def two_inputs():
    """x'' = F + G."""
    return lg.derive(lg.Model("two-inputs", coordinates=["x"], inputs=["F", "G"], T="x_dot**2/2",
                              Q={"x": "F + G"}))


@pytest.fixture(scope="module")
def cart():
    return lg.derive(lg.load("cart-pendulum"))


# ------------------------------------------------------------------------------ the language


def _names():
    x, v, k = sympy.symbols("x x_dot k")
    return {"x": x, "x_dot": v, "k": k}


@pytest.mark.parametrize("text, expected", [
    ("where(x > 0, -1, 1)", lambda x, v, k: sympy.Piecewise((-1, x > 0), (1, True))),
    ("clip(-k*x, -2, 2)", lambda x, v, k: sympy.Min(sympy.Max(-k * x, -2), 2)),
    ("min(x, x_dot, 3) + max(x, 0)", lambda x, v, k: sympy.Min(x, v, 3) + sympy.Max(x, 0)),
    ("where(-1 < x <= 1 and not x_dot > 0, x, 0)",
     lambda x, v, k: sympy.Piecewise((x, (x > -1) & (x <= 1) & (v <= 0)), (0, True))),
    ("where(x > 0 or x_dot < 0, 1, 2)", lambda x, v, k: sympy.Piecewise((1, (x > 0) | (v < 0)), (2, True))),
])
def test_feedback_language(text, expected):
    names = _names()
    assert parse_expression(text, names, feedback=True) == expected(names["x"], names["x_dot"], names["k"])


@pytest.mark.parametrize("text, position, pattern", [
    ("10*(x > 0)", 6, r"the condition 'x > 0' is true or false, not a number: use it as the condition of "
                      r"where\(x > 0, a, b\), as in where\(x > 0, 1, 0\) for 1 where it holds and 0 elsewhere"),
    ("x >= 0", 2, r"the condition 'x >= 0' is true or false, not a number"),
    ("where(x, 1, 2)", 0, r"the first argument of where\(condition, a, b\) must be a condition such as q1 > 0"),
    ("where(x > 0, x_dot < 0, 1)", 19, r"the condition 'x_dot < 0' is true or false"),
    ("x == 0", 2, r"unexpected '==': a simulated value meets an exact equality almost never, so '==' and "
                  r"'!=' are not allowed; compare with <, <=, > or >="),
    ("x != 0", 2, r"unexpected '!='"),
    ("where(x > 0 & x_dot > 0, 1, 2)", 12, r"unexpected '&': write 'and' to join two conditions"),
    ("where(x > 0 and x_dot, 1, 2)", 12, r"'and' joins conditions such as q1 > 0, but 'x_dot' is a number; "
                                         r"compare it with something, as in x_dot > 0"),
    ("clip(x, 2, -2)", 0, r"clip\(x, lo, hi\) needs lo <= hi, got lo = 2 > hi = -2; swap them"),
    ("min(x)", 0, r"wrong number of arguments: min takes two or more arguments"),
    ("saturate(x, 1)", 0, r"unknown function 'saturate' \(did you mean 'clip'\?\)"),
    ("1 if x > 0 else 2", 2, r"'if' is not allowed: write a switch as where\(condition, a, b\)"),
])
def test_feedback_language_errors(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse_expression(text, _names(), feedback=True)
    assert info.value.position == position


def test_model_expressions_keep_the_smooth_language():
    with pytest.raises(ExpressionError, match=r"'where' may only be used in an input or an event"):
        parse_expression("where(1, 2, 3)", _names())
    with pytest.raises(ExpressionError, match=r"unexpected '<': comparisons are not allowed.*where\(condition, "
                                              r"a, b\), belongs in an input or an event"):
        parse_expression("x < 1", _names())
    with pytest.raises(lg.ModelError, match=r"'clip' may only be used in an input or an event"):
        lg.Model("m", coordinates=["x"], T="x_dot**2/2", V="clip(x, 0, 1)")


# ------------------------------------------------------------------------------ feedback laws


def test_compiled_programs_equal_sympy_on_a_switching_law(double_integrator):
    """Every construct of the language, compiled (with switches) and lambdified (SciPy), gives
    the same trajectory."""
    law = ("where(x > 0.2 and x_dot < 0 or x < -0.5, clip(-4*x - x_dot, -1.5, 1.5), "
           "min(max(-2*x, -1), 1) - 0.1*sign(x_dot)) + 0.05*abs(sin(3*t))")
    fast = lg.simulate(double_integrator, 6.0, {"x": 1.0}, inputs={"F": law}, rtol=1e-11, atol=1e-11)
    slow = lg.simulate(double_integrator, 6.0, {"x": 1.0}, inputs={"F": law}, rtol=1e-11, atol=1e-11,
                       backend="scipy")
    assert fast.stats["backend"] == "numba" and fast.stats["switches"] >= 3
    np.testing.assert_allclose(fast.x, slow.x, atol=2e-6)
    x, v, t = sympy.symbols("x x_dot t")
    f = sympy.lambdify([t, x, v], parse_expression(law, {"x": x, "x_dot": v, "t": t}, feedback=True))
    recorded = [f(*row) for row in zip(fast.t, fast["x"], fast["x_dot"])]
    np.testing.assert_allclose(fast["F"], recorded, atol=1e-13, rtol=0,
                               err_msg="the inputs recorded at the output times are the law's values there")


@pytest.mark.parametrize("law", ["where(x > 0, -1, 1)", "-sign(x)"])
def test_bang_bang_switches_are_located_exactly(double_integrator, law):
    """x'' = -1 for x > 0, +1 otherwise, from x = 1 at rest: piecewise parabolas crossing 0 at
    t = sqrt(2), 3 sqrt(2), 5 sqrt(2), ... with speed sqrt(2); the compiled DOP853 locates each
    switch (a where's condition, or sign's) and follows the closed form to rounding, where
    SciPy's solve_ivp crawls through them."""
    t_end = 10.0
    tr = lg.simulate(double_integrator, t_end, {"x": 1.0}, inputs={"F": law}, dt=0.05, rtol=1e-10, atol=1e-10)
    r2 = math.sqrt(2)

    def exact(t):
        k = np.floor((t + r2) / (2 * r2))  # the k-th arc is centred on the turning point at 2 k sqrt(2)
        s = t - 2 * r2 * k
        sign = np.where(k % 2 == 0, 1.0, -1.0)
        return sign * (1 - s ** 2 / 2), sign * (-s)

    x, v = exact(tr.t)
    assert np.max(np.abs(tr["x"] - x)) < 1e-9 and np.max(np.abs(tr["x_dot"] - v)) < 1e-9
    crossings = int(np.floor((t_end / r2 + 1) / 2))  # sqrt(2), 3 sqrt(2), ... <= t_end
    assert tr.stats["switches"] == crossings == 4
    slow = lg.simulate(double_integrator, t_end, {"x": 1.0}, inputs={"F": law}, dt=0.05, rtol=1e-10, atol=1e-10,
                       backend="scipy")
    assert tr.stats["nfev"] * 3 < slow.stats["nfev"], (tr.stats, slow.stats)


def test_a_sliding_mode_is_refused_with_the_fix_and_the_boundary_layer_works(double_integrator):
    """x'' = -sign(x_dot + x) reaches the surface x_dot + x = 0 and would slide on it (Filippov),
    switching infinitely fast: the integrator says so at once instead of crawling. With a
    boundary layer, clip(s/0.01, -1, 1), the motion reaches the layer and decays as exp(-1.0102 t)."""
    with pytest.raises(lg.SimulationError, match=r"the inputs switch at every step near t = 0\.\d+.*a sliding mode.*"
                                                 r"boundary layer, e\.g\. clip\(s/0\.01, -1, 1\) instead of sign\(s\)"):
        lg.simulate(double_integrator, 4.0, {"x": 0.5}, inputs={"F": "-sign(x_dot + x)"}, rtol=1e-8, atol=1e-8)
    tr = lg.simulate(double_integrator, 6.0, {"x": 0.5}, inputs={"F": "-clip((x_dot + x)/0.01, -1, 1)"},
                     rtol=1e-10, atol=1e-10)
    s = tr["x_dot"] + tr["x"]
    k = np.nonzero(np.abs(s) < 0.01)[0][0]  # in the layer: s' = -s/0.01 + x_dot, s ~ 0.01 x_dot
    assert tr.t[k] < 1.5
    late = tr.t > tr.t[k] + 0.5
    slow = (-1 + math.sqrt(1 - 4 * 0.01)) / (2 * 0.01)  # 0.01 x'' + x' + x = 0: the slow root, -1.0102
    expected = tr["x"][late][0] * np.exp(slow * (tr.t[late] - tr.t[late][0]))
    assert np.max(np.abs(tr["x"][late] - expected)) < 1e-8


def test_a_branch_undefined_outside_its_region_is_handled(double_integrator):
    """where(x > 0, -sqrt(x), 0): a frozen step evaluates sqrt a little below 0 (NaN); the step
    is taken again with the switch live, and the result is SciPy's."""
    law = "where(x > 0, -sqrt(x), 0.5)"
    fast = lg.simulate(double_integrator, 3.0, {"x": 0.3}, inputs={"F": law}, rtol=1e-10, atol=1e-10)
    slow = lg.simulate(double_integrator, 3.0, {"x": 0.3}, inputs={"F": law}, rtol=1e-10, atol=1e-10,
                       backend="scipy")
    np.testing.assert_allclose(fast.x, slow.x, atol=1e-6)


def test_python_function_of_the_state_equals_the_expression(cart):
    K = np.array([-1.0, 40.0, -2.5, 11.0])
    x0 = np.array([0.0, np.pi / 2, 0.0, 0.0])
    text = "1.0*q1 - 40.0*(q2 - pi/2) + 2.5*q1_dot - 11.0*q2_dot"
    a = lg.simulate(cart, 3.0, {"q2": 1.45}, inputs={"F": lambda t, x: -K @ (x - x0)}, rtol=1e-10, atol=1e-10)
    b = lg.simulate(cart, 3.0, {"q2": 1.45}, inputs={"F": text}, rtol=1e-10, atol=1e-10)
    assert a.stats["backend"] == "scipy" and b.stats["backend"] == "numba"
    np.testing.assert_allclose(a.x, b.x, atol=1e-8)
    np.testing.assert_allclose(a["F"], b["F"], atol=1e-7)
    with pytest.raises(lg.ModelError, match=r"input 'F': a function must take \(t\) or \(t, x\), the time and the "
                                            r"state \[q, q_dot\], but it takes 3 arguments"):
        lg.simulate(cart, 1.0, inputs={"F": lambda t, x, p: 0.0})
    with pytest.raises(lg.ModelError, match=r"backend 'numba' cannot run this model: an input is a Python function"):
        lg.simulate(cart, 1.0, inputs={"F": lambda t, x: 0.0}, backend="numba")


def test_a_new_law_compiles_nothing(cart):
    """Laws are programs that the compiled integrator interprets: a new law, with switches,
    saturations and sampling, runs on the kernels and the model already compiled (numba adds no
    specialization) and in milliseconds (benchmarks/feedback.py measures it)."""
    from lagrangian.numeric._fast import kernels

    lg.simulate(cart, 1.0, {"q2": 1.4}, inputs={"F": "1.0*q1 - 40.0*(q2 - pi/2)"})
    compiled = lg.compile(cart)

    def signatures():
        return {name: list(f.signatures) for name, f in vars(kernels()).items() if hasattr(f, "signatures")}

    before = signatures()
    assert sum(map(len, before.values())) >= 1
    for kw in ({"inputs": {"F": "where(q1 > 0, clip(-3*q1_dot, -1, 1), 2.5*sign(sin(t))) - 41*(q2 - pi/2)"}},
               {"inputs": {"F": "max(-5, min(5, -20*(q2 - pi/2) - 5*q2_dot))"}, "sample_time": 0.05}):
        tr = lg.simulate(cart, 1.0, {"q2": 1.4}, **kw)
        assert tr.stats["backend"] == "numba"
    assert signatures() == before and lg.compile(cart) is compiled


def test_input_expression_errors(cart):
    with pytest.raises(lg.ModelError, match=r"\[inputs.F\]: unknown name 'q2_ddot'"):
        lg.simulate(cart, 1.0, inputs={"F": "q2_ddot"})
    with pytest.raises(lg.ModelError, match=r"the condition 'q2 > 1' is true or false, not a number"):
        lg.simulate(cart, 1.0, inputs={"F": "2*(q2 > 1)"})


def test_variational_integrator_with_a_damping_law(double_integrator):
    """x'' = -x - 0.4 x_dot as a law of the state, through the variational integrator (inputs
    evaluated at each midpoint iterate): second order, against the closed form."""
    law = "-x - 0.4*x_dot"
    w = math.sqrt(1 - 0.04)
    t = np.linspace(0, 5, 51)
    exact = np.exp(-0.2 * t) * (np.cos(w * t) + 0.2 / w * np.sin(w * t))
    errors = []
    for step in (0.01, 0.005):
        tr = lg.simulate(double_integrator, 5.0, {"x": 1.0}, inputs={"F": law}, method="variational", dt=0.1,
                         step=step)
        errors.append(np.max(np.abs(tr["x"] - exact)))
    assert errors[0] < 1e-4 and 3.5 < errors[0] / errors[1] < 4.5


def test_feedback_laws_in_a_batch_equal_single_runs(cart):
    law = "1.0*q1 - 40.0*(q2 - pi/2) + 2.5*q1_dot - 11.0*q2_dot + where(q1 > 0, -0.5, 0.5)"
    X0 = np.zeros((3, 4))
    X0[:, 1] = [1.5, 1.55, 1.62]
    batch = lg.simulate_batch(cart, 2.0, X0, inputs={"F": law}, rtol=1e-10, atol=1e-10, dt=0.5)
    for i in range(3):
        alone = lg.simulate(cart, 2.0, X0[i], inputs={"F": law}, rtol=1e-10, atol=1e-10, dt=0.5)
        np.testing.assert_allclose(batch.x[i], alone.x, atol=1e-12)


# ------------------------------------------------------------------------------ sampled laws


def test_sampled_law_is_the_exact_discretization(double_integrator):
    """x'' = u, u = -k1 x - k2 x_dot sampled every Ts and held: the states at the sample times
    follow x_{k+1} = (Ad - Bd K) x_k exactly, and the recorded input is the held value."""
    from lagrangian.control import discretize

    Ts, K = 0.1, np.array([[2.0, 1.5]])
    tr = lg.simulate(double_integrator, 3.0, {"x": 1.0}, inputs={"F": "-2*x - 1.5*x_dot"}, sample_time=Ts,
                     dt=0.05, rtol=1e-12, atol=1e-12)
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0]])
    Ad, Bd = discretize(A, B, Ts)
    xk = np.array([1.0, 0.0])
    for k in range(30):
        j = 2 * k
        assert abs(tr.t[j] - k * Ts) < 1e-12
        np.testing.assert_allclose(tr.x[j], xk, atol=1e-10)
        held = float((-K @ xk)[0])
        assert tr["F"][j] == pytest.approx(held, abs=1e-10) and tr["F"][j + 1] == pytest.approx(held, abs=1e-10)
        xk = (Ad - Bd @ K) @ xk
    assert tr.stats["samples"] == 31
    slow = lg.simulate(double_integrator, 3.0, {"x": 1.0}, inputs={"F": "-2*x - 1.5*x_dot"}, sample_time=Ts,
                       dt=0.05, rtol=1e-12, atol=1e-12, backend="scipy")
    np.testing.assert_allclose(slow.x, tr.x, atol=1e-10)
    np.testing.assert_allclose(slow["F"], tr["F"], atol=1e-10)


def test_sample_time_of_named_inputs_only(two_inputs):
    """F sampled every 0.25 s, G continuous: x'' = F + G with F = -x (held) and G = sin(t)."""
    tr = lg.simulate(two_inputs, 1.0, {"x": 1.0}, inputs={"F": "-x", "G": "sin(t)"}, sample_time={"F": 0.25},
                     dt=0.125, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(tr["G"], np.sin(tr.t), atol=1e-14)
    F = tr["F"]
    assert np.all(F[0:8:2] == F[1:8:2])  # held over each 0.25 s
    # x at 0.25: x(0) = 1, v(0) = 0 under x'' = -1 + sin(t): x = 1 - t^2/2 + t - sin(t)
    assert tr["x"][2] == pytest.approx(1 - 0.25 ** 2 / 2 + 0.25 - math.sin(0.25), abs=1e-12)
    assert F[2] == pytest.approx(-tr["x"][2], abs=1e-12)


def test_sample_time_errors(cart):
    with pytest.raises(lg.ModelError, match=r"\[sample_time\]: a sample time must be a positive number of seconds"):
        lg.simulate(cart, 1.0, sample_time=-0.1)
    with pytest.raises(lg.ModelError, match=r"\[sample_time.G\]: 'G' is not an input of the model"):
        lg.simulate(cart, 1.0, sample_time={"G": 0.1})
    with pytest.raises(lg.ModelError, match=r"method 'variational' does not sample inputs"):
        lg.simulate(cart, 1.0, sample_time=0.1, method="variational")


def test_model_file_feedback_law_and_sample_time(tmp_path):
    path = tmp_path / "held.toml"
    path.write_text('coordinates = ["x"]\ninputs = ["F"]\n[parameters]\nk = 2.0\n[energy]\nT = "x_dot**2/2"\n'
                    '[forces]\nx = "F"\n[simulation]\nt_end = 1.0\ndt = 0.1\ninitial = { x = 1.0 }\n'
                    'inputs = { F = "-k*x - 1.5*x_dot" }\nsample_time = 0.1\n')
    model = lg.load(str(path))
    assert model.simulation["sample_time"] == 0.1
    tr = lg.simulate(lg.derive(model), rtol=1e-12, atol=1e-12)
    assert tr.stats["samples"] == 11
    assert tr["F"][1] == pytest.approx(-2 * tr["x"][1] - 1.5 * tr["x_dot"][1], abs=1e-12)
