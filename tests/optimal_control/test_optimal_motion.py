"""Optimal motions against closed forms, an independent transcription and a conserved quantity."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

pytest.importorskip("casadi", reason="optimal motions need CasADi (the 'optimal' extra)")

import lagrangian as lg  # noqa: E402


@pytest.fixture(scope="module")
def double_integrator():
    """x'' = u."""
    return lg.derive(lg.Model(coordinates=["x"], T="x_dot**2/2", Q={"x": "u"}, inputs=["u"]))


CART_POLE = dict(m1=1.0, m2=0.3, l=0.5, g=9.81)


@pytest.fixture(scope="module")
def cart_pole():
    """Kelly (2017), 'An Introduction to Trajectory Optimization', section 6 and appendix E: a cart (m1)
    with a point mass m2 at the end of a massless pole of length l; th = 0 hanging, th = pi upright."""
    return lg.derive(lg.Model(
        coordinates=["x", "th"], parameters=CART_POLE, inputs=["F"], Q={"x": "F"},
        T="(m1 + m2)/2*x_dot**2 + m2*l*cos(th)*x_dot*th_dot + m2*l**2/2*th_dot**2", V="-m2*g*l*cos(th)"))


SWING_UP = dict(duration=2.0, objective="F**2", initial={"x": 0, "th": 0, "x_dot": 0, "th_dot": 0},
                final={"x": 1.0, "th": math.pi, "x_dot": 0, "th_dot": 0}, inputs={"F": (-20.0, 20.0)})


def switch_time(motion, name="u"):
    """The time where the input first changes sign (linear between the points)."""
    u, t = motion[name], motion.t
    k = int(np.flatnonzero(np.sign(u[:-1]) != np.sign(u[1:]))[0])
    return t[k] - u[k] * (t[k + 1] - t[k]) / (u[k + 1] - u[k])


@pytest.mark.parametrize("x0", [4.0, 2.5])
def test_minimum_time_double_integrator_bang_bang(double_integrator, x0):
    """From (x0, 0) to (0, 0) with |u| <= 1: T* = 2 sqrt(x0), u = -1 then +1, one switch at T*/2."""
    motion = lg.optimal_motion(double_integrator, duration=(0.5, 10.0), minimum_time=True,
                               initial={"x": x0, "x_dot": 0.0}, final={"x": 0.0, "x_dot": 0.0},
                               inputs={"u": (-1.0, 1.0)}, intervals=25)
    exact = 2 * math.sqrt(x0)
    h = motion.duration / 25
    assert motion.status == "Solve_Succeeded"
    assert motion.duration == pytest.approx(exact, rel=2e-3)  # the switch inside an interval costs O(h^2)
    assert motion.cost == pytest.approx(motion.duration, rel=1e-12)
    ts = switch_time(motion)
    assert abs(ts - exact / 2) < h
    far = np.abs(motion.t - ts) > h
    assert np.allclose(motion["u"][far & (motion.t < ts)], -1.0, atol=1e-6)
    assert np.allclose(motion["u"][far & (motion.t > ts)], 1.0, atol=1e-6)
    # the replay reaches the origin (the switch inside an interval: the quadratic law there)
    assert motion.replay_failure is None
    assert motion.max_replay_deviation < 5e-3


def test_minimum_time_with_a_speed_limit_path_constraint(double_integrator):
    """|x_dot| <= 1 from (4, 0) to (0, 0): accelerate 1 s, coast 3 s, brake 1 s: T* = 5."""
    motion = lg.optimal_motion(double_integrator, duration=(0.5, 20.0), minimum_time=True,
                               initial={"x": 4.0, "x_dot": 0.0}, final={"x": 0.0, "x_dot": 0.0},
                               inputs={"u": (-1.0, 1.0)}, path={"speed": {"expression": "-x_dot", "max": 1.0}},
                               intervals=20)
    assert motion.duration == pytest.approx(5.0, rel=1e-5)
    assert motion["x_dot"].min() >= -1.0 - 1e-8
    assert np.allclose(motion["x_dot"][(motion.t > 1.25) & (motion.t < 3.75)], -1.0, atol=1e-6)


def test_minimum_energy_rest_to_rest_closed_form(double_integrator):
    """min int u^2 dt, x from 0 to 1 in T = 1, at rest at both ends: u = 6 - 12 t, cost 12 (a cubic
    motion, which Hermite-Simpson represents exactly)."""
    motion = lg.optimal_motion(double_integrator, duration=1.0, objective="u**2", initial={"x": 0, "x_dot": 0},
                               final={"x": 1, "x_dot": 0}, intervals=10)
    assert motion.cost == pytest.approx(12.0, rel=1e-9)
    assert np.allclose(motion["u"], 6 - 12 * motion.t, atol=1e-7)
    assert np.allclose(motion["x"], 3 * motion.t**2 - 2 * motion.t**3, atol=1e-9)
    assert motion.collocation_error < 1e-9 and motion.converged
    assert motion.max_replay_deviation < 1e-8


def test_terminal_cost_with_a_free_final_position(double_integrator):
    """min int u^2 + 12 (x(1) - 1)^2 with x(1) free, at rest at both ends: reaching x_f costs 12 x_f^2,
    so x_f = 1/2 and the cost is 6."""
    motion = lg.optimal_motion(double_integrator, duration=1.0, objective="u**2", terminal_cost="12*(x - 1)**2",
                               initial={"x": 0, "x_dot": 0}, final={"x_dot": 0}, intervals=10)
    assert motion.cost == pytest.approx(6.0, rel=1e-9)
    assert motion["x"][-1] == pytest.approx(0.5, rel=1e-9)


def kelly_trapezoid(N, m1=1.0, m2=0.3, l=0.5, g=9.81, d=1.0, T=2.0, umax=20.0):
    """The cart-pole swing-up written by hand from Kelly's equations (appendix E), trapezoidal collocation
    (a different method, other equations, the same optimal motion): the optimal cost on N intervals."""
    ca = pytest.importorskip("casadi")
    X, U = ca.SX.sym("X", 4, N + 1), ca.SX.sym("U", 1, N + 1)

    def f(x, u):
        q2, dq1, dq2 = x[1], x[2], x[3]
        s, c = ca.sin(q2), ca.cos(q2)
        ddq1 = (l * m2 * s * dq2**2 + u + m2 * g * c * s) / (m1 + m2 * (1 - c**2))
        ddq2 = -(l * m2 * c * s * dq2**2 + u * c + (m1 + m2) * g * s) / (l * m1 + l * m2 * (1 - c**2))
        return ca.vertcat(dq1, dq2, ddq1, ddq2)

    h = T / N
    F = [f(X[:, k], U[0, k]) for k in range(N + 1)]
    defects = [X[:, k + 1] - X[:, k] - h / 2 * (F[k] + F[k + 1]) for k in range(N)]
    cost = sum(h / 2 * (U[0, k] ** 2 + U[0, k + 1] ** 2) for k in range(N))
    lbx, ubx = np.full((5, N + 1), -np.inf), np.full((5, N + 1), np.inf)
    lbx[4], ubx[4] = -umax, umax
    lbx[:4, 0] = ubx[:4, 0] = 0.0
    lbx[:4, -1] = ubx[:4, -1] = [d, np.pi, 0, 0]
    x0 = np.zeros((5, N + 1))
    x0[0], x0[1] = np.linspace(0, d, N + 1), np.linspace(0, np.pi, N + 1)
    solver = ca.nlpsol("kelly", "ipopt", {"x": ca.vec(ca.vertcat(X, U)), "f": cost, "g": ca.vertcat(*defects)},
                       {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes", "tol": 1e-10}})
    sol = solver(x0=x0.ravel(order="F"), lbx=lbx.ravel(order="F"), ubx=ubx.ravel(order="F"), lbg=0, ubg=0)
    assert solver.stats()["success"]
    return float(sol["f"])


@pytest.mark.slow
def test_cart_pole_swing_up_against_an_independent_transcription(cart_pole):
    motion = lg.optimal_motion(cart_pole, **SWING_UP, tolerance=1e-6)
    assert motion.converged and motion.collocation_error <= 1e-6
    # trapezoidal collocation converges as h^2: Richardson's extrapolation of N = 100 and 200
    c1, c2 = kelly_trapezoid(100), kelly_trapezoid(200)
    reference = c2 + (c2 - c1) / 3
    assert motion.cost == pytest.approx(reference, rel=1e-4)
    assert 58.7 < motion.cost < 58.9  # 58.8077 here
    assert np.abs(motion["F"]).max() <= 20.0 + 1e-9
    assert motion.max_replay_deviation < 1e-3


@pytest.mark.slow
def test_replay_deviation_small_and_decreasing_with_the_mesh(cart_pole):
    deviations, costs = [], []
    for n in (20, 40, 80):
        motion = lg.optimal_motion(cart_pole, **SWING_UP, intervals=n, max_refinements=0)
        deviations.append(motion.max_replay_deviation)
        costs.append(motion.cost)
    assert deviations[0] > 4 * deviations[1] > 16 * deviations[2]  # about h^4 (quadratic input law)
    assert deviations[2] < 5e-3
    assert abs(costs[2] - costs[1]) < abs(costs[1] - costs[0])


@pytest.mark.slow
def test_four_bar_crank_move_minimum_torque_squared():
    """A constrained mechanism: the crank from 1.2 to 2.0 rad in 1 s, at rest at both ends, min int tau^2.
    The multipliers are unknowns; the constraints hold along the motion; the motor's work equals the
    change of potential energy (it starts and ends at rest)."""
    eqs = lg.derive(lg.load("four-bar"))
    motion = lg.optimal_motion(eqs, duration=1.0, objective="tau**2", initial={"th1": 1.2, "th1_dot": 0.0},
                               final={"th1": 2.0, "th1_dot": 0.0}, inputs={"tau": (-50.0, 50.0)}, intervals=20)
    assert motion.converged
    assert motion.multipliers.shape == (len(motion.t), 2)
    assert motion.constraint_error < 1e-6
    assert motion["th1"][-1] == pytest.approx(2.0, abs=1e-12)
    # power tau * th1_dot integrated by Simpson's rule over each interval = V(end) - V(start)
    t, p = motion.t, motion["tau"] * motion["th1_dot"]
    h = t[2::2] - t[:-2:2]
    work = float(np.sum(h / 6 * (p[:-2:2] + 4 * p[1::2] + p[2::2])))
    V = eqs.V.subs({s: v for s, v in eqs.parameters.items()})
    q = [c for c in eqs.q]
    dV = float(V.subs(dict(zip(q, motion.x[-1, :3]))) - V.subs(dict(zip(q, motion.x[0, :3]))))
    assert work == pytest.approx(dV, rel=1e-5, abs=1e-7)
    assert motion.cost == pytest.approx(0.657363, rel=1e-5)
    assert motion.replay_failure is None and motion.max_replay_deviation < 1e-3


def test_input_law_is_the_collocations_quadratic(double_integrator):
    motion = lg.optimal_motion(double_integrator, duration=1.0, objective="u**2 + x**2",
                               initial={"x": 0, "x_dot": 0}, final={"x": 1, "x_dot": 0}, intervals=6, replay=False)
    law = motion.input_law["u"]
    t, u = motion.t, motion["u"]
    assert np.allclose(law(t), u, atol=1e-13)  # nodes and midpoints
    k = 2  # a quarter point of interval k: the quadratic through its three values
    s = t[2 * k] + 0.25 * (t[2 * k + 2] - t[2 * k])
    want = u[2 * k] * (2 * 0.25 - 1) * (0.25 - 1) + u[2 * k + 1] * 4 * 0.25 * 0.75 + u[2 * k + 2] * 0.25 * (-0.5)
    assert float(law(s)) == pytest.approx(want, abs=1e-13)
    assert motion.replay_deviation == {}


def test_result_outputs(double_integrator, tmp_path):
    motion = lg.optimal_motion(double_integrator, duration=1.0, objective="u**2", initial={"x": 0, "x_dot": 0},
                               final={"x": 1, "x_dot": 0}, intervals=4)
    assert motion.columns == ("t", "x", "x_dot", "u")
    text = motion.to_csv()
    assert text.splitlines()[0] == "t,x,x_dot,u" and len(text.splitlines()) == 1 + 9
    motion.to_csv(tmp_path / "m.csv")
    assert (tmp_path / "m.csv").read_text() == text
    d = motion.to_dict()
    assert d["cost"] == pytest.approx(12.0) and d["states"]["x"][-1] == pytest.approx(1.0)
    assert set(d) >= {"status", "duration", "iterations", "collocation_error", "replay_deviation", "meshes"}
    failed = dataclasses.replace(motion, replay_deviation={"x": math.nan, "x_dot": 1.0}, collocation_error=math.inf)
    strict = json.loads(json.dumps(failed.to_dict(), allow_nan=False))  # strict JSON: NaN and inf as null
    assert strict["replay_deviation"] == {"x": None, "x_dot": 1.0} and strict["collocation_error"] is None
    law = motion.input_law_csv(per_interval=4).splitlines()
    assert law[0] == "t,u" and len(law) == 1 + 4 * 4 + 1
    with pytest.raises(KeyError, match="no column 'y'"):
        motion["y"]
    with pytest.raises(Exception):
        motion.x[0, 0] = 1.0  # read-only
    assert "OptimalMotion(status='Solve_Succeeded'" in repr(motion)


def test_plot(double_integrator):
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    motion = lg.optimal_motion(double_integrator, duration=1.0, objective="u**2", initial={"x": 0, "x_dot": 0},
                               final={"x": 1, "x_dot": 0}, intervals=4, replay=False)
    fig = motion.plot()
    assert [ax.get_ylabel() for ax in fig.axes] == ["x", "u"]


def test_guess_from_a_previous_answer(double_integrator):
    kw = dict(duration=1.0, objective="u**2", initial={"x": 0, "x_dot": 0}, final={"x": 1, "x_dot": 0}, intervals=8)
    first = lg.optimal_motion(double_integrator, **kw)
    again = lg.optimal_motion(double_integrator, **kw, guess=first)
    assert again.cost == pytest.approx(first.cost, rel=1e-10)
    assert again.iterations <= first.iterations
