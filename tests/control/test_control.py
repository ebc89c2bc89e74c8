"""Controller design on the linearization (LQR, pole placement, continuous and discrete), the
laws as inputs of the nonlinear model, and the lqr and place commands."""

import json
import math

import numpy as np
import pytest
import sympy
from scipy.linalg import expm

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.control import DesignError, discretize

Q_CART = {"q1": 1.0, "q2": 10.0, "q1_dot": 1.0, "q2_dot": 1.0}


@pytest.fixture(scope="module")
def cart():
    return lg.derive(lg.load("cart-pendulum"))


@pytest.fixture(scope="module")
def upright(cart):
    return lg.linearize(cart, at={"q2": sympy.pi / 2})


def _closed_loop_jacobian(eqs, law: dict, x0: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """The Jacobian at x0 of x' = f(x, u(x)) with the law's expressions (read by the parser and
    evaluated by SymPy), by central differences."""
    from lagrangian.model._expr import parse_expression

    nm = lg.compile(eqs)
    syms = [*eqs.coordinates, *eqs.velocities]
    names = {"t": eqs.t, **{s.name: s for s in syms}, **{p.name: p for p in eqs.parameters}}
    funcs = [sympy.lambdify([syms], parse_expression(law[u], names, feedback=True).subs(
        {p: v for p, v in eqs.parameters.items()})) for u in nm.input_names]
    p = nm.parameter_values

    def f(x):
        return nm.rhs(0.0, x, np.array([g(list(x)) for g in funcs]), p)

    J = np.zeros((len(x0), len(x0)))
    for j in range(len(x0)):
        d = np.zeros(len(x0))
        d[j] = eps
        J[:, j] = (f(x0 + d) - f(x0 - d)) / (2 * eps)
    return J


def _sorted(z):
    z = np.asarray(z, complex)
    return z[np.lexsort((np.round(z.imag, 6), np.round(z.real, 6)))]


def test_lqr_gain_is_python_control_s_and_its_law_realizes_the_eigenvalues(cart, upright):
    control = pytest.importorskip("control")
    fb = upright.lqr(Q_CART, {"F": 1.0})
    K, _, E = control.lqr(upright.A, upright.B, np.diag([1.0, 10.0, 1.0, 1.0]), np.eye(1))
    np.testing.assert_allclose(fb.K, K, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(_sorted(fb.eigenvalues), _sorted(E), rtol=1e-9)
    assert fb.stable and fb.state_names == ("q1", "q2", "q1_dot", "q2_dot") and fb.input_names == ("F",)
    assert fb.gains["F"]["q2"] == pytest.approx(K[0, 1], rel=1e-12)
    # the law's text, parsed and linearized with the nonlinear model, has the designed eigenvalues
    J = _closed_loop_jacobian(cart, fb.inputs, np.array([0.0, math.pi / 2, 0.0, 0.0]))
    np.testing.assert_allclose(_sorted(np.linalg.eigvals(J)), _sorted(fb.eigenvalues), rtol=1e-6, atol=1e-6)
    assert "(q2 - pi/2)" in fb.inputs["F"]


@pytest.mark.slow
def test_closed_loop_settles_with_the_designed_eigenvalues(cart, upright):
    """The nonlinear cart-pendulum under the LQR law, from a small tilt, follows
    exp((A - B K) t) dx0 to second order in dx0, and settles upright."""
    fb = upright.lqr(Q_CART, {"F": 1.0})
    dx0 = np.array([0.0, 1e-3, 0.0, 0.0])
    tr = lg.simulate(cart, 15.0, {"q2": math.pi / 2 + 1e-3}, inputs=fb.inputs, dt=0.1, rtol=1e-12, atol=1e-14)
    Acl = upright.A - upright.B @ fb.K
    linear = np.array([expm(Acl * t) @ dx0 for t in tr.t])
    dx = tr.x - np.array([0.0, math.pi / 2, 0.0, 0.0])
    assert np.max(np.abs(dx - linear)) < 1e-3 * 1e-3 * 10  # O(dx0^2), dx0 = 1e-3
    assert np.max(np.abs(dx[-1])) < 1e-6  # the slowest mode, Re = -0.657, decays as e^-9.9
    # and from 0.3 rad off (far from linear) it still settles
    tr = lg.simulate(cart, 15.0, {"q2": math.pi / 2 - 0.3}, inputs=fb.inputs, rtol=1e-10, atol=1e-10)
    assert np.max(np.abs(tr.x[-1] - [0.0, math.pi / 2, 0.0, 0.0])) < 1e-3


def test_pole_placement_realizes_the_poles(cart, upright):
    poles = [-1.0, -2.0, -1.5 + 1j, -1.5 - 1j]
    fb = upright.place(poles)
    np.testing.assert_allclose(_sorted(fb.eigenvalues), _sorted(poles), atol=1e-9)
    J = _closed_loop_jacobian(cart, fb.inputs, np.array([0.0, math.pi / 2, 0.0, 0.0]))
    np.testing.assert_allclose(_sorted(np.linalg.eigvals(J)), _sorted(poles), atol=1e-5)
    assert fb.method == "place" and fb.Q is None


def test_saturated_law_still_settles(cart, upright):
    """The LQR law clipped to |F| <= 6 N, from a 0.35 rad tilt: the force saturates for 0.6 s and
    the pendulum is still brought upright (clipped to 4 N it falls: the limit matters)."""
    fb = upright.lqr(Q_CART, {"F": 1.0})
    runs = {}
    for limit in (6, 4):
        law = f"clip({fb.inputs['F']}, -{limit}, {limit})"
        runs[limit] = lg.simulate(cart, 20.0, {"q2": math.pi / 2 + 0.35}, inputs={"F": law}, rtol=1e-10, atol=1e-10)
    tr = runs[6]
    saturated = np.abs(tr["F"]) >= 6 - 1e-12
    assert saturated.sum() * 0.01 > 0.5  # at the limit for more than 0.5 s
    assert np.max(np.abs(tr["F"])) <= 6 + 1e-12
    assert np.max(np.abs(tr.x[-1] - [0.0, math.pi / 2, 0.0, 0.0])) < 1e-4
    assert abs(runs[4]["q2"][-1] - math.pi / 2) > 0.3


def swing_up_law(upright) -> str:
    """The energy swing-up of the pendulum (Astrom and Furuta) handing over to an LQR near the top:
    E = M2 L^2 q2_dot^2 / 2 + M2 g L (sin q2 - 1) is 0 upright at rest; dE/dt = M2 L q2_dot sin(q2)
    q1_ddot, so pushing the cart with F ~ -E q2_dot sin(q2) pumps E to 0; the cart is kept near 0."""
    fb = upright.lqr(Q_CART, {"F": 1.0})
    catch = fb.law(wrap=["q2"])["F"]
    energy = "(M2*L**2*q2_dot**2/2 + M2*g*L*(sin(q2) - 1))"
    swing = f"clip(-8*{energy}*q2_dot*sin(q2) - 0.5*q1 - q1_dot, -8, 8)"
    return f"where(sin(q2) > 0.9, {catch}, {swing})"


@pytest.mark.slow
def test_swing_up_reaches_the_top_and_stays(cart, upright):
    law = swing_up_law(upright)
    tr = lg.simulate(cart, 20.0, {"q2": -math.pi / 2 + 0.1}, inputs={"F": law}, rtol=1e-10, atol=1e-10)
    top = np.nonzero(np.sin(tr["q2"]) > 0.9)[0]
    assert len(top) and tr.t[top[0]] < 8.0  # caught within 8 s
    assert tr.stats["switches"] >= 1
    assert math.sin(tr["q2"][-1]) > 1 - 1e-9 and abs(tr["q2_dot"][-1]) < 1e-4 and abs(tr["q1"][-1]) < 1e-3
    assert np.all(np.abs(tr["F"]) <= 8 + 1e-9) or np.all(np.sin(tr["q2"][np.abs(tr["F"]) > 8]) > 0.9)
    slow = lg.simulate(cart, 20.0, {"q2": -math.pi / 2 + 0.1}, inputs={"F": law}, rtol=1e-10, atol=1e-10,
                       backend="scipy")
    np.testing.assert_allclose(tr.x, slow.x, atol=1e-6)


def test_discrete_lqr_is_dlqr_and_the_sampled_loop_follows_it(cart, upright):
    control = pytest.importorskip("control")
    Ts = 0.02
    fb = upright.lqr(Q_CART, 1.0, sample_time=Ts)
    Ad, Bd = discretize(upright.A, upright.B, Ts)
    K, _, E = control.dlqr(Ad, Bd, np.diag([1.0, 10.0, 1.0, 1.0]), np.eye(1))
    np.testing.assert_allclose(fb.K, K, rtol=1e-9)
    assert fb.sample_time == Ts and fb.stable and np.all(np.abs(fb.eigenvalues) < 1)
    dx0 = np.array([0.0, 1e-3, 0.0, 0.0])
    tr = lg.simulate(cart, 4.0, {"q2": math.pi / 2 + 1e-3}, inputs=fb.inputs, sample_time=fb.sample_time, dt=Ts,
                     rtol=1e-12, atol=1e-14)
    Acl = Ad - Bd @ fb.K
    dx = dx0.copy()
    for k in range(len(tr.t)):
        assert np.max(np.abs(tr.x[k] - [0, math.pi / 2, 0, 0] - dx)) < 1e-5, k
        dx = Acl @ dx
    assert fb.input_options()[-2:] == ["--sample-time", "0.02"]


def test_design_errors(cart, upright):
    with pytest.raises(lg.ModelError, match=r"\[Q.q3\]: 'q3' is not one of q1, q2, q1_dot, q2_dot \(did you mean "
                                            r"'q2'\?\)"):
        upright.lqr({"q3": 1.0})
    with pytest.raises(lg.ModelError, match=r"R must give every one of F a weight; missing F"):
        upright.lqr(R={})
    with pytest.raises(lg.ModelError, match=r"Q must be positive semi-definite \(weights >= 0\), but its smallest "
                                            r"eigenvalue is -1"):
        upright.lqr(-np.eye(4))
    with pytest.raises(lg.ModelError, match=r"R must be positive definite"):
        upright.lqr(R=0.0)
    with pytest.raises(lg.ModelError, match=r"Q as a vector must have 4 weights"):
        upright.lqr([1, 2, 3])
    with pytest.raises(lg.ModelError, match=r"4 poles are needed \(one for each state: q1, q2, q1_dot, q2_dot\), "
                                            r"got 3"):
        upright.place([-1, -2, -3])
    with pytest.raises(lg.ModelError, match=r"the complex pole -1\+1j needs its conjugate -1-1j too"):
        upright.place([-1 + 1j, -2, -3, -4])
    with pytest.raises(lg.ModelError, match=r"the pole -2 is repeated 2 times, but with 1 input a pole may be "
                                            r"placed at most 1 time"):
        upright.place([-2, -2, -3, -4])
    with pytest.raises(lg.ModelError, match=r"the operating point is not an equilibrium \(q1_ddot = .*, q2_ddot = "
                                            r".*\): a state feedback holds the system at an equilibrium"):
        lg.linearize(cart, at={"q2": 1.0}).lqr()
    with pytest.raises(lg.ModelError, match=r"has no inputs, so there is nothing to feed back"):
        lg.linearize(lg.derive(lg.load("double-pendulum"))).lqr()
    saddle = lg.derive(lg.Model("saddle", coordinates=["x", "y"], inputs=["F"], T="(x_dot**2 + y_dot**2)/2",
                                V="-(x**2 + y**2)/2", Q={"x": "F"}))
    with pytest.raises(DesignError, match=r"no state feedback stabilizes saddle here: the unstable eigenvalue\(s\) "
                                          r"1 of A cannot be moved by the inputs F"):
        lg.linearize(saddle).lqr()
    with pytest.raises(lg.ModelError, match=r"wrap names q3, which is not a coordinate"):
        upright.lqr().law(wrap=["q3"])


# ------------------------------------------------------------------------------ the commands


def test_lqr_command_text_and_json(capsys, upright):
    assert main(["lqr", "cart-pendulum", "--at", "q2=pi/2", "--Q", "q1=1,q2=10,q1_dot=1,q2_dot=1", "--R", "F=1"]) == 0
    text = capsys.readouterr().out
    fb = upright.lqr(Q_CART, {"F": 1.0})
    assert "LQR for cart-pendulum at q1 = 0, q2 = pi/2" in text
    assert f'--input "F={fb.inputs["F"]}"' in text
    assert "closed-loop eigenvalues (A - B K): -4.25965, -3.58374, -0.657173-0.459077j, -0.657173+0.459077j" in text
    assert main(["lqr", "cart-pendulum", "--at", "q2=pi/2", "--Q", "1,10,1,1", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["method"] == "lqr" and data["state_names"] == ["q1", "q2", "q1_dot", "q2_dot"]
    np.testing.assert_allclose(data["K"], fb.K, rtol=1e-12)
    assert data["law"] == fb.inputs and data["input_options"] == ["--input", f"F={fb.inputs['F']}"]
    np.testing.assert_allclose([complex(*z) for z in data["closed_loop_eigenvalues"]], fb.eigenvalues, rtol=1e-12)
    assert data["stable"] is True and data["sample_time"] is None and len(data["Q"]) == 4
    assert set(data) >= {"gains", "open_loop_eigenvalues", "operating_point", "inputs", "R", "P", "model"}


def test_lqr_law_from_the_command_simulates_upright(capsys, tmp_path):
    assert main(["lqr", "cart-pendulum", "--at", "q2=pi/2", "--Q", "1,10,1,1", "--wrap", "q2", "--json"]) == 0
    options = json.loads(capsys.readouterr().out)["input_options"]
    assert "atan2(sin(q2 - pi/2), cos(q2 - pi/2))" in options[1]
    out = tmp_path / "up.csv"
    assert main(["simulate", "cart-pendulum", "--t-end", "12", "--initial", "q2=1.3", *options, "-o", str(out)]) == 0
    last = np.loadtxt(out, delimiter=",", skiprows=1)[-1]
    assert abs(last[2] - math.pi / 2) < 1e-3 and abs(last[1]) < 1e-2


def test_place_command_and_errors(capsys):
    assert main(["place", "cart-pendulum", "--at", "q2=pi/2", "--poles=-2+1j,-2-1j,-3,-4", "--sample-time", "0.01",
                 "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    z = [complex(*e) for e in data["closed_loop_eigenvalues"]]
    expected = np.exp(np.array([-2 + 1j, -2 - 1j, -3, -4]) * 0.01)
    np.testing.assert_allclose(_sorted(z), _sorted(expected), atol=1e-9)
    assert data["sample_time"] == 0.01 and data["input_options"][-2:] == ["--sample-time", "0.01"]
    assert main(["place", "cart-pendulum", "--at", "q2=pi/2", "--poles=-1,-2"]) == 2
    assert "4 poles are needed" in capsys.readouterr().err
    assert main(["place", "cart-pendulum", "--at", "q2=pi/2", "--poles=-1,x,-2,-3"]) == 2
    assert "--poles 'x': expected a number such as -2 or a complex number such as -1+2j" in capsys.readouterr().err
    assert main(["lqr", "cart-pendulum", "--at", "q2=1"]) == 2
    assert "the operating point is not an equilibrium" in capsys.readouterr().err
    assert main(["lqr", "cart-pendulum", "--at", "q2=pi/2", "--Q", "q7=1"]) == 2
    assert "'q7' is not one of q1, q2, q1_dot, q2_dot" in capsys.readouterr().err


def test_simulate_command_with_a_feedback_law_and_sample_time(capsys, tmp_path):
    out = tmp_path / "held.csv"
    law = "F=1.0*q1 - 41.9*(q2 - pi/2) + 2.56*q1_dot - 11.7*q2_dot"
    assert main(["simulate", "cart-pendulum", "--t-end", "1", "--initial", "q2=1.5", "--input", law,
                 "--sample-time", "0.1", "-o", str(out)]) == 0
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    F = data[:, 5]
    assert np.all(F[:10] == F[0]) and F[10] != F[0]  # held from t = 0 to 0.09, new at 0.1
    assert main(["simulate", "cart-pendulum", "--t-end", "1", "--sample-time", "F=-1"]) == 2
    assert "a sample time must be a positive number of seconds, got -1.0" in capsys.readouterr().err
    assert main(["simulate", "cart-pendulum", "--t-end", "1", "--input", "F=5*(q1 > 0)"]) == 2
    assert "the condition 'q1 > 0' is true or false, not a number" in capsys.readouterr().err
