"""The compiled integrators: DOP853 against SciPy's in units of the tolerance, its convergence
order, work budgets (bounds on right-hand-side calls), the singular-mass-matrix event, and the
midpoint variational integrator's order and bounded energy error over 10^6 steps."""

from __future__ import annotations

import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.errors import ModelError


def oscillator(k=4.0):
    return lg.Model("oscillator", coordinates=["x"], parameters={"m": 1.0, "k": k},
                    T="m*x_dot**2/2", V="k*x**2/2")


def pendulum():
    return lg.Model("pendulum", coordinates=["theta"], parameters={"m": 1.0, "l": 1.0, "g": 9.81},
                    T="m*l**2*theta_dot**2/2", V="-m*g*l*cos(theta)")


@pytest.fixture(scope="module")
def double_pendulum():
    return lg.derive(lg.load("double-pendulum"))


# ------------------------------------------------------------------- DOP853 against SciPy
@pytest.mark.parametrize("name, t_end, initial", [
    ("double-pendulum", 5.0, {"theta1": 0.3, "theta2": -0.2}),
    ("mck", 3.0, None),
    ("rotating-pendulum", 4.0, {"theta": 0.4}),
    ("cart-pendulum", 3.0, {"q2": 0.5}),
])
@pytest.mark.parametrize("tol", [1e-6, 1e-9])
def test_dop853_agrees_with_scipy_in_units_of_the_tolerance(name, t_end, initial, tol):
    eqs = lg.derive(lg.load(name))
    ours = lg.simulate(eqs, t_end, initial, rtol=tol, atol=tol, backend="numba")
    ref = lg.simulate(eqs, t_end, initial, rtol=tol, atol=tol, backend="scipy")
    assert ours.stats["backend"] == "numba" and ref.stats["backend"] == "scipy"
    units = np.abs(ours.x - ref.x) / (tol + tol * np.abs(ref.x))
    # the same method, step-size control and dense output: the steps are the same and the
    # results differ by rounding only, far below the tolerance
    assert np.max(units) <= 1e-3
    # SciPy also builds the interpolant of a step whose only output is its end point
    assert ref.nfev - 3 * ours.stats["nstep"] <= ours.nfev <= ref.nfev


def test_dop853_convergence_order_from_a_log_log_slope():
    # error at t = 10 of x'' = -4 x against cos(2 t), for tolerances 1e-5 .. 1e-11: the error
    # falls as nfev^-p with p close to the method's order 8
    errors, work = [], []
    for tol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
        tr = lg.simulate(oscillator(), 10.0, {"x": 1.0}, t_eval=[0.0, 10.0], rtol=tol, atol=tol)
        errors.append(abs(tr["x"][-1] - math.cos(20.0)))
        work.append(tr.nfev)
    slope = np.polyfit(np.log(work), np.log(errors), 1)[0]
    assert -9.5 < slope < -6.5, slope
    assert errors[-1] < 1e-10


def test_work_budgets():
    # bounds on right-hand-side calls (regressions in the step-size control show here, not in time)
    tr = lg.simulate(oscillator(), 10.0, {"x": 1.0}, rtol=1e-9, atol=1e-9)
    assert tr.stats["backend"] == "numba"
    assert tr.nfev <= 1200 and tr.stats["nstep"] <= 70 and tr.stats["nreject"] <= 5
    dp = lg.load("double-pendulum")
    tr = lg.simulate(dp, 20.0, {"theta1": 1.0, "theta2": 0.5}, t_eval=[0.0, 20.0], rtol=1e-8, atol=1e-8)
    assert tr.nfev <= 6200  # 5822 measured
    # output every 0.01 s costs 3 more calls in each step (the interpolant), no more
    dense = lg.simulate(dp, 20.0, {"theta1": 1.0, "theta2": 0.5}, dt=0.01, rtol=1e-8, atol=1e-8)
    assert dense.stats["nstep"] == tr.stats["nstep"]
    assert dense.nfev <= tr.nfev + 3 * tr.stats["nstep"]


def test_dense_output_is_as_accurate_as_the_steps():
    tr = lg.simulate(oscillator(), 10.0, {"x": 1.0}, dt=0.001, rtol=1e-10, atol=1e-10)
    assert len(tr.t) == 10001
    assert np.max(np.abs(tr["x"] - np.cos(2 * tr.t))) <= 2e-9
    assert np.max(np.abs(tr["x_dot"] + 2 * np.sin(2 * tr.t))) <= 4e-9


def test_max_step_is_respected():
    tr = lg.simulate(oscillator(), 10.0, {"x": 1.0}, max_step=0.05, rtol=1e-6, atol=1e-6)
    assert tr.stats["nstep"] >= 200


def test_singular_event_agrees_between_backends():
    m = lg.Model("cart-pendulum-massless", coordinates=["q1", "q2"], parameters={"M": 0.5, "L": 1.0, "g": 9.81})
    q1, q2 = m.q
    M, L, g = (m.symbol(n) for n in ("M", "L", "g"))
    m.add_particle(M, (q1 + L * lg.cos(q2), L + L * lg.sin(q2)), name="pendulum")
    m.add_gravity(g)
    t_star = math.sqrt(2 * (1 + math.sin(0.5)) / 9.81)
    times = {}
    for backend in ("numba", "scipy"):
        with pytest.raises(lg.SingularMassMatrixError) as info:
            lg.simulate(m, 5.0, {"q2": 0.5}, backend=backend)
        times[backend] = info.value.time
        assert info.value.time == pytest.approx(t_star, abs=1e-6)
        assert "det M = L**2*M**2*cos(q2)**2" in info.value.diagnosis
    assert times["numba"] == pytest.approx(times["scipy"], abs=1e-9)


def test_step_size_underflow_is_a_simulation_error():
    # x'' = x^3 blows up in finite time
    m = lg.Model("blowup", coordinates=["x"], parameters={"m": 1.0}, T="m*x_dot**2/2", V="-x**4/4")
    with pytest.raises(lg.SimulationError, match=r"the integrator stopped at t = 1\.08\d*: Required step size is "
                                                  r"less than spacing between numbers\. \(state x = ") as info:
        lg.simulate(m, 10.0, {"x": 1.0, "x_dot": 2.0})
    assert info.value.status == -1


# ------------------------------------------------------------------------ variational
def test_variational_is_second_order():
    ref = lg.simulate(pendulum(), 5.0, {"theta": 1.0}, dt=0.1, rtol=1e-12, atol=1e-12)
    steps = (0.02, 0.01, 0.005, 0.0025)
    errors = [np.max(np.abs(lg.simulate(pendulum(), 5.0, {"theta": 1.0}, method="variational", dt=0.1,
                                        step=h).x - ref.x)) for h in steps]
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert 1.9 < slope < 2.1, slope


@pytest.mark.slow
def test_variational_energy_error_stays_bounded_over_a_million_steps():
    h = 0.05
    tr = lg.simulate(pendulum(), 5e4, {"theta": 1.0}, method="variational", dt=5.0, step=h)
    assert tr.stats["nstep"] == 1_000_000 and tr.stats["method"] == "variational"
    assert len(tr.t) == 10001
    err = np.abs(tr.energy - tr.energy[0])
    E = abs(tr.energy[0])
    # bounded, of order h^2, and no drift: the last tenth is no worse than the first
    assert np.max(err) <= 0.5 * h**2 * E
    tenth = len(err) // 10
    assert np.max(err[-tenth:]) <= 1.05 * np.max(err[:tenth])


def test_variational_with_damping_and_input_matches_dop853():
    model = lg.Model("forced", coordinates=["x"], parameters={"m": 1.0, "k": 4.0, "c": 0.3}, inputs=["F"],
                     T="m*x_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2", Q={"x": "F"})
    a = lg.simulate(model, 5.0, {"x": 1.0}, inputs={"F": "sin(3*t)"}, method="variational", dt=0.1, step=1e-3)
    b = lg.simulate(model, 5.0, {"x": 1.0}, inputs={"F": "sin(3*t)"}, dt=0.1, rtol=1e-11, atol=1e-11)
    assert np.max(np.abs(a.x - b.x)) <= 1e-5
    assert a.stats["nstep"] == 5000


def test_variational_step_divides_dt():
    tr = lg.simulate(oscillator(), 1.0, {"x": 1.0}, method="variational", dt=0.1, step=0.03)
    assert tr.stats["nstep"] == 40  # 4 steps of 0.025 per output interval
    assert tr.t.tolist() == lg.numeric.output_times(1.0, 0.1).tolist()


def test_variational_needs_quadratic_kinetic_energy():
    m = lg.Model("quartic", coordinates=["x"], T="x_dot**4/4 + x_dot**2/2", V="x**2/2")
    with pytest.raises(ModelError, match=r"method 'variational' needs T\* quadratic in the velocities"):
        lg.simulate(m, 1.0, {"x": 1.0}, method="variational")


# ----------------------------------------------------------------------------- events
def test_events_are_located_and_recorded():
    tr = lg.simulate(oscillator(), 10.0, {"x": 1.0}, events={"zero": "x", "turn": "x_dot", "late": "t - 7.3"},
                     rtol=1e-10, atol=1e-10)
    # x = cos 2t: zeros at pi/4 + k pi/2, turning points at k pi/2 (not t = 0, where it starts at 0)
    zeros = tr.events["zero"]["t"]
    assert len(zeros) == 6
    assert np.max(np.abs(zeros - (math.pi / 4 + np.arange(6) * math.pi / 2))) <= 1e-9
    assert np.max(np.abs(tr.events["zero"]["x"][:, 0])) <= 1e-9
    assert np.max(np.abs(tr.events["turn"]["t"] - np.arange(1, 7) * math.pi / 2)) <= 1e-9
    assert tr.events["late"]["t"].tolist() == pytest.approx([7.3], abs=1e-12)
    assert tr.events["late"]["x"][0, 0] == pytest.approx(math.cos(14.6), abs=1e-9)
    assert tr.t[-1] == 10.0 and "stopped_by" not in tr.stats
    assert not tr.events["zero"]["t"].flags.writeable


def test_a_terminal_event_stops_the_simulation():
    tr = lg.simulate(oscillator(), 10.0, {"x": 1.0}, events={"zero": "x", "turn": "x_dot"}, stop_on=["zero"],
                     dt=0.01)
    assert tr.stats["stopped_by"] == "zero"
    assert tr.stats["stop_time"] == pytest.approx(math.pi / 4, abs=1e-9)
    assert tr.t[-1] <= math.pi / 4 < tr.t[-1] + 0.01
    assert len(tr.events["zero"]["t"]) == 1 and len(tr.events["turn"]["t"]) == 0
    assert tr.message == "An event stopped the integration."


def test_events_may_use_inputs_and_parameters():
    model = lg.Model("forced", coordinates=["x"], parameters={"m": 1.0, "k": 4.0}, inputs=["F"],
                     T="m*x_dot**2/2", V="k*x**2/2", Q={"x": "F"})
    tr = lg.simulate(model, 3.0, inputs={"F": "t"}, events={"force": "F - k/2"}, rtol=1e-10, atol=1e-10)
    assert tr.events["force"]["t"].tolist() == pytest.approx([2.0], abs=1e-10)


def test_event_errors():
    with pytest.raises(ModelError) as info:
        lg.simulate(oscillator(), 1.0, events={"bad": "y + 1"}, stop_on=["zeros"])
    text = str(info.value)
    assert "event 'bad'" in text and "'y'" in text
    assert "stop_on names 'zeros', which is not one of the events" in text
    with pytest.raises(ModelError, match=r"events are watched by the compiled DOP853 only, not by method 'RK45'"):
        lg.simulate(oscillator(), 1.0, events={"zero": "x"}, method="RK45")
    with pytest.raises(ModelError, match=r"events are watched by the compiled integrators"):
        lg.simulate(oscillator(), 1.0, events={"zero": "x"}, backend="scipy")
