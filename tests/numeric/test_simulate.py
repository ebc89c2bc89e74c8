"""simulate(): accuracy against closed forms, conserved quantities, inputs, parameters, output
times, CSV, immutability, and every error it raises."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.errors import LagrangianError, ModelError

TIGHT = dict(rtol=1e-10, atol=1e-10)


# ------------------------------------------------------------------------------ models
def oscillator(m=1.0, k=4.0, c=None, force=False):
    """m x'' + c x' + k x = F."""
    model = lg.Model("oscillator", coordinates=["x"], parameters={"m": m, "k": k},
                     T="m*x_dot**2/2", V="k*x**2/2")
    if c is not None:
        model.add_damper(model.parameter("c", c), length=model.symbol("x"))
    if force:
        model.add_generalized_force("x", model.input("F"))
    return model


def double_pendulum():
    m = lg.Model("double-pendulum", coordinates=["q1", "q2"],
                 parameters={"m1": 1.0, "m2": 0.7, "l1": 1.0, "l2": 0.8, "g": 9.81})
    q1, q2 = m.q
    m1, m2, l1, l2, g = (m.symbol(n) for n in ("m1", "m2", "l1", "l2", "g"))
    m.add_particle(m1, (l1 * lg.sin(q1), -l1 * lg.cos(q1)), name="a")
    m.add_particle(m2, (l1 * lg.sin(q1) + l2 * lg.sin(q2), -l1 * lg.cos(q1) - l2 * lg.cos(q2)), name="b")
    m.add_gravity(g)
    return m


def rotating_pendulum_from_elements():
    m = lg.Model("rotating-pendulum", coordinates=["theta"],
                 parameters={"m": 1.0, "l": 0.5, "g": 9.81, "Omega": 3.0})
    (th,) = m.q
    mass, l, g, W = (m.symbol(n) for n in ("m", "l", "g", "Omega"))
    t = lg.t
    m.add_particle(mass, (l * lg.sin(th) * lg.cos(W * t), l * lg.sin(th) * lg.sin(W * t), -l * lg.cos(th)),
                   name="bob")
    m.add_gravity(g)
    return m


def rotating_pendulum_from_energies():
    return lg.Model("rotating-pendulum-energy", coordinates=["theta"],
                    parameters={"m": 1.0, "l": 0.5, "g": 9.81, "Omega": 3.0},
                    T="m/2*((l*theta_dot)**2 + (l*Omega*sin(theta))**2)", V="-g*m*l*cos(theta)")


def massless_cart():
    """The seed's cart with an inverted pendulum whose cart has no mass."""
    m = lg.Model("cart-pendulum-massless", coordinates=["q1", "q2"],
                 parameters={"M": 0.5, "L": 1.0, "g": 9.81})
    q1, q2 = m.q
    M, L, g = (m.symbol(n) for n in ("M", "L", "g"))
    m.add_particle(M, (q1 + L * lg.cos(q2), L + L * lg.sin(q2)), name="pendulum")
    m.add_gravity(g)
    return m


# ------------------------------------------------------------------ accuracy, closed forms
def test_harmonic_oscillator_closed_form():
    tr = lg.simulate(oscillator(m=1.0, k=4.0), 10.0, {"x": 1.0, "x_dot": 0.5}, dt=0.01, **TIGHT)
    w = 2.0
    x = np.cos(w * tr.t) + 0.5 / w * np.sin(w * tr.t)
    v = -w * np.sin(w * tr.t) + 0.5 * np.cos(w * tr.t)
    assert len(tr.t) == 1001
    assert np.max(np.abs(tr["x"] - x)) <= 1e-9
    assert np.max(np.abs(tr["x_dot"] - v)) <= 2e-9
    assert tr.energy_name == "energy" and tr.conservative
    assert tr.energy[0] == pytest.approx(0.5 * 0.25 + 0.5 * 4.0, rel=1e-14)
    assert tr.energy_drift <= 1e-8


def test_default_tolerances_are_tight():
    # the documented defaults are rtol = atol = 1e-9
    tr = lg.simulate(oscillator(), 10.0, {"x": 1.0})
    assert np.max(np.abs(tr["x"] - np.cos(2 * tr.t))) <= 1e-8


def test_damped_oscillator_closed_form():
    m, k, c = 1.5, 6.0, 0.6
    tr = lg.simulate(oscillator(m=m, k=k, c=c), 8.0, {"x": 1.0, "x_dot": -0.3}, dt=0.02, **TIGHT)
    w0 = math.sqrt(k / m)
    zeta = c / (2 * math.sqrt(k * m))
    wd = w0 * math.sqrt(1 - zeta**2)
    x0, v0 = 1.0, -0.3
    expected = np.exp(-zeta * w0 * tr.t) * (x0 * np.cos(wd * tr.t) + (v0 + zeta * w0 * x0) / wd * np.sin(wd * tr.t))
    assert np.max(np.abs(tr["x"] - expected)) <= 1e-9
    # dissipative: the energy decreases and is not flagged conservative
    assert not tr.conservative
    assert np.all(np.diff(tr.energy) <= 1e-12)
    assert tr.energy[-1] < 0.2 * tr.energy[0]


def test_double_pendulum_conserves_energy():
    tr = lg.simulate(double_pendulum(), 10.0, {"q1": 1.2, "q2": -0.6, "q2_dot": 1.0}, **TIGHT)
    assert tr.energy_name == "energy" and tr.conservative
    E0 = tr.energy[0]
    assert tr.energy_drift <= 1e-8 * abs(E0)
    # and it is chaotic enough to move: the second link swings far
    assert np.ptp(tr["q2"]) > 1.0


@pytest.mark.parametrize("build", [rotating_pendulum_from_elements, rotating_pendulum_from_energies])
def test_rotating_pendulum_conserves_its_jacobi_integral(build):
    tr = lg.simulate(build(), 5.0, {"theta": 0.3}, **TIGHT)
    assert tr.energy_name == "jacobi_integral"
    assert tr.conservative
    m, l, g, W = 1.0, 0.5, 9.81, 3.0
    th, thd = tr["theta"], tr["theta_dot"]
    h = m / 2 * (l * thd) ** 2 - m / 2 * (l * W * np.sin(th)) ** 2 - g * m * l * np.cos(th)
    assert np.allclose(tr.energy, h, rtol=0, atol=1e-12)
    assert tr.energy_drift <= 1e-8
    assert "jacobi_integral" in tr.columns and tr["jacobi_integral"] is tr.energy


def test_both_rotating_pendulums_move_alike():
    a = lg.simulate(rotating_pendulum_from_elements(), 3.0, {"theta": 0.3}, **TIGHT)
    b = lg.simulate(rotating_pendulum_from_energies(), 3.0, {"theta": 0.3}, **TIGHT)
    assert np.max(np.abs(a.x - b.x)) <= 1e-8


def test_explicitly_time_dependent_lagrangian_has_no_energy():
    m = lg.Model("shaken", coordinates=["theta"], parameters={"m": 1.0, "l": 1.0, "g": 9.81, "A": 0.1, "w": 5.0})
    (th,) = m.q
    mass, l, g, A, w = (m.symbol(n) for n in ("m", "l", "g", "A", "w"))
    m.add_particle(mass, (A * lg.sin(w * lg.t) + l * lg.sin(th), -l * lg.cos(th)), name="bob")
    m.add_gravity(g)
    tr = lg.simulate(m, 1.0, {"theta": 0.1})
    assert tr.energy is None and tr.energy_name is None and tr.energy_drift is None
    assert not tr.conservative
    assert tr.columns == ("t", "theta", "theta_dot")


# ------------------------------------------------------------------------------- inputs
def test_input_string_and_callable_agree_and_match_closed_form():
    m, k, F0, w = 2.0, 8.0, 1.5, 3.0
    model = oscillator(m=m, k=k, force=True)
    a = lg.simulate(model, 5.0, inputs={"F": "1.5*sin(3*t)"}, **TIGHT)
    b = lg.simulate(model, 5.0, inputs={"F": lambda t: 1.5 * math.sin(3 * t)}, **TIGHT)
    assert np.array_equal(a.t, b.t)
    assert np.max(np.abs(a.x - b.x)) <= 1e-12
    assert np.allclose(a["F"], F0 * np.sin(w * a.t), rtol=0, atol=1e-14)
    assert a.input_names == ("F",) and a.u.shape == (len(a.t), 1)
    w0 = math.sqrt(k / m)
    x = F0 / (m * (w0**2 - w**2)) * (np.sin(w * a.t) - (w / w0) * np.sin(w0 * a.t))
    assert np.max(np.abs(a["x"] - x)) <= 1e-9
    assert not a.conservative


def test_input_expression_may_use_parameters_and_constant_inputs():
    model = oscillator(m=1.0, k=4.0, force=True)
    a = lg.simulate(model, 2.0, inputs={"F": "k*0.25"}, **TIGHT)  # constant F = 1
    b = lg.simulate(model, 2.0, inputs={"F": 1.0}, **TIGHT)
    # x'' + 4 x = 1 from rest: x = (1 - cos 2t)/4
    for tr in (a, b):
        assert np.max(np.abs(tr["x"] - (1 - np.cos(2 * tr.t)) / 4)) <= 1e-9
        assert np.all(tr["F"] == 1.0)


def test_inputs_not_given_are_zero():
    tr = lg.simulate(oscillator(force=True), 1.0, {"x": 1.0}, **TIGHT)
    assert np.all(tr["F"] == 0.0)
    assert np.max(np.abs(tr["x"] - np.cos(2 * tr.t))) <= 1e-9


# --------------------------------------------------------------------------- parameters
def test_parameter_override_changes_frequency():
    model = oscillator(m=1.0, k=1.0)
    base = lg.simulate(model, 6.0, {"x": 1.0}, **TIGHT)
    stiff = lg.simulate(model, 6.0, {"x": 1.0}, params={"k": 4.0}, **TIGHT)
    assert np.max(np.abs(base["x"] - np.cos(base.t))) <= 1e-9
    assert np.max(np.abs(stiff["x"] - np.cos(2.0 * stiff.t))) <= 1e-9
    assert stiff.parameters == {"m": 1.0, "k": 4.0}
    assert base.parameters == {"m": 1.0, "k": 1.0}
    # the model itself keeps its value
    assert model.parameters[model.symbol("k")] == 1.0


def test_parameter_override_by_symbol_and_missing_value_given():
    model = lg.Model("osc", coordinates=["x"])
    k = model.parameter("k")
    model.add_energy(T="x_dot**2/2", V="k*x**2/2")
    tr = lg.simulate(model, 3.0, {"x": 1.0}, params={k: 9.0}, **TIGHT)
    assert np.max(np.abs(tr["x"] - np.cos(3.0 * tr.t))) <= 1e-9


# ------------------------------------------------------------------------- output times
def test_output_times_are_multiples_of_dt():
    tr = lg.simulate(oscillator(), 1.0, {"x": 1.0}, dt=0.3)
    assert len(tr.t) == 4
    assert np.allclose(tr.t, [0.0, 0.3, 0.6, 0.9], rtol=0, atol=1e-15)
    assert tr.t[0] == 0.0 and tr.t[-1] <= 1.0
    tr = lg.simulate(oscillator(), 1.0, {"x": 1.0}, dt=0.1)
    assert len(tr.t) == 11 and tr.t[-1] == pytest.approx(1.0, abs=1e-15)
    # 0.3 / 0.1 = 2.9999999999999996 in floating point: t_end is still reached
    tr = lg.simulate(oscillator(), 0.3, {"x": 1.0}, dt=0.1)
    assert len(tr.t) == 4 and tr.t[-1] == pytest.approx(0.3, abs=1e-15)
    assert lg.numeric.output_times(0.7, 0.1).size == 8
    tr = lg.simulate(oscillator(), 2.5, {"x": 1.0}, dt=1.0)
    assert tr.t.tolist() == [0.0, 1.0, 2.0]
    # the states are those at the output times, not at the integrator's steps
    assert np.max(np.abs(tr["x"] - np.cos(2 * tr.t))) <= 1e-8


def test_output_times_are_the_decimal_multiples():
    tr = lg.simulate(oscillator(), 1.0, {"x": 1.0}, dt=0.3)
    assert tr.t.tolist() == [0.0, 0.3, 0.6, 0.9]
    assert [row.split(",")[0] for row in tr.to_csv().splitlines()[1:]] == ["0.0", "0.3", "0.6", "0.9"]
    assert lg.simulate(oscillator(), 0.3, {"x": 1.0}, dt=0.1).t[-1] <= 0.3


def test_explicit_t_eval():
    tr = lg.simulate(oscillator(), 2.0, {"x": 1.0}, t_eval=[0.0, 0.5, 1.25, 2.0], **TIGHT)
    assert tr.t.tolist() == [0.0, 0.5, 1.25, 2.0]
    assert np.max(np.abs(tr["x"] - np.cos(2 * tr.t))) <= 1e-9


# -------------------------------------------------------------------------------- CSV
def test_csv_header_and_round_trip(tmp_path):
    model = lg.Model("2d", coordinates=["x", "y"], parameters={"m": 1.0, "k": 2.0}, inputs=["F"],
                     T="m/2*(x_dot**2 + y_dot**2)", V="k/2*(x**2 + y**2)", Q={"y": "F"})
    tr = lg.simulate(model, 1.0, {"x": 0.1, "y_dot": -0.2}, inputs={"F": "sin(t)"}, dt=0.1)
    text = tr.to_csv()
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[0] == ["t", "x", "y", "x_dot", "y_dot", "F", "energy"]
    assert rows[0][:5] == ["t", *tr.state_names]
    assert list(tr.columns) == rows[0]
    data = np.array(rows[1:], dtype=float)
    assert data.shape == (11, 7)
    assert np.array_equal(data, tr.table())  # exact: the CSV writes every digit
    assert np.array_equal(data[:, 0], tr.t)
    assert np.array_equal(data[:, 1:5], tr.x)
    assert np.array_equal(data[:, 5], tr["F"])
    assert np.array_equal(data[:, 6], tr.energy)
    path = tmp_path / "out.csv"
    assert tr.to_csv(path) is None
    assert path.read_text() == text


def test_csv_without_energy_or_inputs():
    m = lg.Model("shaken", coordinates=["theta"], parameters={"A": 0.1},
                 T="theta_dot**2/2 + A*cos(t)*theta_dot", V="theta**2/2")
    tr = lg.simulate(m, 0.5, dt=0.25)
    assert tr.to_csv().splitlines()[0] == "t,theta,theta_dot"


# ------------------------------------------------------------------------- immutability
def test_trajectory_arrays_are_read_only():
    tr = lg.simulate(oscillator(force=True), 1.0, {"x": 1.0}, dt=0.5)
    for arr in (tr.t, tr.x, tr.u, tr.energy, tr.q, tr.q_dot, tr["x"], tr["F"]):
        assert not arr.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 1.0
    with pytest.raises(AttributeError):
        tr.t = np.zeros(3)
    with pytest.raises(KeyError, match="no column 'z'"):
        tr["z"]


# ------------------------------------------------------------------------ numeric model
def test_compiled_rhs():
    nm = lg.compile(lg.derive(oscillator(m=2.0, k=8.0, c=1.0, force=True)))
    assert nm.state_names == ("x", "x_dot")
    assert nm.input_names == ("F",)
    p = nm.parameter_values
    assert dict(zip(nm.parameter_names, p)) == {"m": 2.0, "k": 8.0, "c": 1.0}
    # x'' = (F - c x' - k x)/m
    out = nm.rhs(0.0, [0.5, -1.0], [3.0], p)
    assert np.allclose(out, [-1.0, (3.0 + 1.0 - 4.0) / 2.0], rtol=1e-14, atol=0)
    assert nm.energy(0.0, [0.5, -1.0], np.array([3.0]), p) == pytest.approx(2.0 / 2 + 8.0 * 0.25 / 2)
    assert lg.compile(nm.equations) is nm  # cached


# ------------------------------------------------------------------------------- errors
def test_error_unknown_initial_name():
    with pytest.raises(ModelError, match=r"'xx' is not a coordinate or velocity \(did you mean 'x'\?\)"):
        lg.simulate(oscillator(), 1.0, {"xx": 1.0})


def test_error_unknown_parameter():
    with pytest.raises(ModelError, match=r"'kk' is not a parameter of the model \(did you mean 'k'\?\)"):
        lg.simulate(oscillator(), 1.0, params={"kk": 2.0})


def test_error_parameter_without_value():
    model = lg.Model("osc", coordinates=["x"])
    model.parameter("k")
    model.add_energy(T="x_dot**2/2", V="k*x**2/2")
    with pytest.raises(ModelError, match=r"parameter 'k' has no value.*params=\{'k': \.\.\.\}"):
        lg.simulate(model, 1.0, {"x": 1.0})


def test_error_unknown_input():
    with pytest.raises(ModelError, match=r"'G' is not an input of the model; its inputs are F"):
        lg.simulate(oscillator(force=True), 1.0, inputs={"G": 1.0})
    with pytest.raises(ModelError, match=r"'F' is not an input of the model; its inputs are none"):
        lg.simulate(oscillator(), 1.0, inputs={"F": 1.0})


def test_error_bad_method():
    with pytest.raises(ModelError, match=r"unknown method 'RK44' \(did you mean 'RK45'\?\); choose one of DOP853"):
        lg.simulate(oscillator(), 1.0, method="RK44")


@pytest.mark.parametrize("t_end, message", [(0, "a positive number, got 0"), (-1.0, "a positive number, got -1.0"),
                                             (float("nan"), "a finite number, got nan"),
                                             (float("inf"), "a finite number, got inf")])
def test_error_non_positive_t_end(t_end, message):
    with pytest.raises(ModelError, match=rf"\[t_end\]: t_end must be {message}$"):
        lg.simulate(oscillator(), t_end)


@pytest.mark.parametrize("dt, message", [(0, "a positive number, got 0"), (-0.1, "a positive number, got -0.1"),
                                         (float("nan"), "a finite number, got nan")])
def test_error_non_positive_dt(dt, message):
    with pytest.raises(ModelError, match=rf"\[dt\]: dt must be {message}$"):
        lg.simulate(oscillator(), 1.0, dt=dt)


def test_errors_are_reported_together():
    with pytest.raises(ModelError) as info:
        lg.simulate(oscillator(), -1.0, {"xx": 1.0}, params={"kk": 1.0}, method="nope")
    keys = {p.key for p in info.value.problems}
    assert keys == {"t_end", "initial.xx", "params.kk", "method"}
    assert str(info.value).startswith("4 problems:")
    assert isinstance(info.value, ValueError) and isinstance(info.value, LagrangianError)


def test_error_bad_initial_array_shape():
    with pytest.raises(ModelError, match=r"the initial state must have 2 values \(x, x_dot\)"):
        lg.simulate(oscillator(), 1.0, [1.0, 2.0, 3.0])


@pytest.mark.parametrize("initial", ["abc", [1.0, "x"], [[1.0], [2.0, 3.0]], object(), b"x"])
def test_an_initial_state_that_is_not_numbers_is_one_error(initial):
    """Text, bytes, a ragged list, an object: one error that says what initial must be (before: NumPy's ValueError
    or TypeError with a traceback)."""
    with pytest.raises(ModelError, match=r"\[initial\]: the initial state must be 2 numbers \(x, x_dot\) or a "
                                         r"mapping of these names to numbers, got "):
        lg.simulate(oscillator(), 1.0, initial)


@pytest.mark.parametrize("t_eval", ["abc", [0.0, "x"], {"a": 1}, [[0.0], [0.5, 1.0]]])
def test_output_times_that_are_not_numbers_are_one_error(t_eval):
    with pytest.raises(ModelError, match=r"t_eval must be a non-empty increasing sequence of times \(numbers\) in "
                                         r"\[0, t_end = 1\], got "):
        lg.simulate(oscillator(), 1.0, {"x": 1.0}, t_eval=t_eval)


# ------------------------------------------------------------------ singular mass matrix
def test_massless_cart_raises_singular_mass_matrix_error():
    with pytest.raises(lg.SingularMassMatrixError) as info:
        lg.simulate(massless_cart(), 5.0, {"q2": 0.5})
    err = info.value
    assert isinstance(err, LagrangianError) and isinstance(err, ArithmeticError)
    # The cart has no mass, so no horizontal force acts on the bob: it falls straight down from
    # height L (1 + sin 0.5) and reaches q2 = -pi/2 (height 0, det M = M^2 L^2 cos(q2)^2 = 0) at
    # t* = sqrt(2 L (1 + sin 0.5) / g).
    t_star = math.sqrt(2 * 1.0 * (1 + math.sin(0.5)) / 9.81)
    assert err.time == pytest.approx(t_star, abs=1e-6)
    assert set(err.state) == {"q1", "q2", "q1_dot", "q2_dot"}
    assert err.state["q2"] == pytest.approx(-math.pi / 2, abs=1e-3)
    assert err.state["q1"] + math.cos(err.state["q2"]) == pytest.approx(math.cos(0.5), abs=1e-6)  # bob's x
    msg = str(err)
    assert f"t = {err.time:.6g}" in msg
    assert "q2 = -1.5707" in msg and "q1_dot = " in msg
    for text in ("det M", "no inertia", "Fix:"):
        assert text in err.diagnosis
        assert text in msg
    assert "det M = L**2*M**2*cos(q2)**2" in err.diagnosis
    assert "q2 = -pi/2" in err.diagnosis
    assert err.diagnosis in msg


def test_massless_cart_runs_until_just_before_the_singularity():
    t_star = math.sqrt(2 * (1 + math.sin(0.5)) / 9.81)
    tr = lg.simulate(massless_cart(), 0.99 * t_star, {"q2": 0.5}, dt=0.99 * t_star / 50)
    height = 1.0 + np.sin(tr["q2"])
    assert np.allclose(height, 1 + math.sin(0.5) - 9.81 * tr.t**2 / 2, rtol=0, atol=1e-7)
    assert np.all(np.diff(tr["q2"]) < 0)


def test_singular_at_the_initial_state():
    with pytest.raises(lg.SingularMassMatrixError, match=r"singular at t = 0 .*q2 = -1\.5708") as info:
        lg.simulate(massless_cart(), 1.0, {"q2": -math.pi / 2})
    assert info.value.time == 0.0
    assert info.value.state == {"q1": 0.0, "q2": -math.pi / 2, "q1_dot": 0.0, "q2_dot": 0.0}


def test_mass_matrix_singular_everywhere():
    model = lg.Model("no-mass-on-y", coordinates=["x", "y"], T="x_dot**2/2", V="x**2/2 + y**2/2")
    with pytest.raises(lg.SingularMassMatrixError) as info:
        lg.simulate(model, 1.0, {"x": 1.0})
    assert "det M = 0" in info.value.diagnosis
    assert "always singular" in info.value.diagnosis
    assert "y_dot alone" in info.value.diagnosis
    assert info.value.time == 0.0


def test_t_end_shorter_than_dt():
    try:
        tr = lg.simulate(oscillator(), 0.5, {"x": 1.0}, dt=1.0)
    except ModelError as exc:  # an explicit refusal would be fine too
        assert "dt" in str(exc)
        return
    assert tr.t.tolist() == [0.0]
    assert tr.x.tolist() == [[1.0, 0.0]]


def test_empty_t_eval_is_refused_clearly():
    with pytest.raises(ModelError, match="t_eval"):
        lg.simulate(oscillator(), 1.0, {"x": 1.0}, t_eval=[])


def test_unsorted_t_eval_is_refused_clearly():
    with pytest.raises(ModelError, match="t_eval must be a non-empty increasing sequence"):
        lg.simulate(oscillator(), 1.0, {"x": 1.0}, t_eval=[0.5, 0.2])
    with pytest.raises(ModelError, match=r"in \[0, t_end = 1\]"):
        lg.simulate(oscillator(), 1.0, {"x": 1.0}, t_eval=[0.0, 2.0])


def test_input_function_returning_an_array_is_refused_clearly():
    model = lg.Model("forced", coordinates=["x"], parameters={"m": 1.0, "k": 1.0}, inputs=["F"],
                     T="m*x_dot**2/2", V="k*x**2/2", Q={"x": "F"})
    with pytest.raises(ModelError, match="input 'F': its function returned .* expected a number"):
        lg.simulate(model, 1.0, inputs={"F": lambda t: np.array([1.0, 2.0])})


def test_non_finite_forcing_is_a_simulation_error_not_a_singular_mass_matrix():
    # V = sqrt(x) has dV/dx = 1/(2 sqrt(x)): not finite at x = -1
    model = lg.Model("sqrt", coordinates=["x"], parameters={"m": 1.0}, T="m*x_dot**2/2", V="sqrt(x)")
    with pytest.raises(lg.SimulationError, match=r"the forcing f is not finite \(NaN or infinity\) at t = 0 "
                                                 r"in the state x = -1, x_dot = 0: check the model's parameters"):
        lg.simulate(model, 1.0, {"x": -1.0})


def test_progress_bar_on_a_terminal_and_the_same_results(monkeypatch):
    import io

    import lagrangian._progress as P

    stream = io.StringIO()

    class Immediate(P.Progress):  # no 1 s delay, drawn into `stream`
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **{**kwargs, "delay": 0.0, "stream": stream})

    monkeypatch.setattr(P, "Progress", Immediate)
    eqs = lg.derive(lg.load("double-pendulum"))
    for backend in ("numba", "scipy"):
        # compiled first: a run that compiles (a new generator version, cold caches) says "compiling..."
        # before its bar, which is right, but not the line this test reads
        lg.simulate(eqs, 0.1, {"theta1": 1.0}, backend=backend, progress=False)
        stream.seek(0)
        stream.truncate()
        shown = lg.simulate(eqs, 2.0, {"theta1": 1.0}, backend=backend, progress=True)
        assert stream.getvalue().startswith("\rsimulating [") and stream.getvalue().endswith("\n")
        assert ("201/201" if backend == "numba" else "1000/1000") in stream.getvalue()
        stream.seek(0)
        stream.truncate()
        quiet = lg.simulate(eqs, 2.0, {"theta1": 1.0}, backend=backend, progress=False)
        assert stream.getvalue() == ""
        np.testing.assert_array_equal(shown.x, quiet.x)


# ------------------------------------------------------------------ hostile arguments (FUZZ)
@pytest.mark.parametrize("key, value, text", [
    ("inputs", "F", r"\[inputs\]: inputs must be a mapping of names to values, such as inputs=\{'F': 1\.0\}, got str "
                    r"'F'"),
    ("inputs", 2.0, r"\[inputs\]: inputs must be a mapping of names to values, such as inputs=\{'F': 1\.0\}, got float "
                    r"2\.0"),
    ("params", [1.0], r"\[params\]: params must be a mapping of names to values, such as params=\{'m': 2\.0\}, got "
                      r"list \[1\.0\]"),
    ("events", 3, r"\[events\]: events must be a mapping of names to values, such as events=\{'ground': 'y'\}, got "
                  r"int 3"),
    ("events", "x", r"\[events\]: events must be a mapping of names to values"),
    ("stop_on", 3, r"\[stop_on\]: stop_on must be the name of an event or a list of names, such as stop_on='ground' "
                   r"or stop_on=\['ground', 'wall'\], got 3"),
    ("stop_on", [1], r"\[stop_on\]: stop_on must be the name of an event or a list of names"),
    ("options", {}, r"\[options\]: options must be a SimulationOptions \(lagrangian\.numeric\."
                    r"SimulationOptions\(\.\.\.\)\), got dict \{\}; or pass each option as its own argument"),
    ("options", "fast", r"\[options\]: options must be a SimulationOptions"),
])
def test_arguments_of_the_wrong_kind_are_one_error(key, value, text):
    """Before: AttributeError ('str' object has no attribute 'values'), TypeError ('int' object is not iterable),
    ValueError (dictionary update sequence) with a traceback."""
    with pytest.raises(ModelError, match=text):
        lg.simulate(oscillator(force=True), 0.1, {"x": 1.0}, **{key: value})


@pytest.mark.parametrize("value, text", [
    (float("nan"), r"\[inputs\.F\]: input 'F' must be a finite number, got nan"),
    (float("inf"), r"\[inputs\.F\]: input 'F' must be a finite number, got inf"),
    (1e308, r"\[inputs\.F\]: input 'F' is 1e\+308, too large: at most 1e\+150 in magnitude"),
    (np.float64(-1e200), r"\[inputs\.F\]: input 'F' is -1e\+200, too large: at most 1e\+150 in magnitude"),
])
def test_a_constant_input_that_is_not_a_finite_number_is_one_error(value, text):
    """Before: 1e308 raised ZeroDivisionError from the compiled integrator, NaN a SimulationError after the run
    started that blamed the model's expressions."""
    with pytest.raises(ModelError, match=text):
        lg.simulate(oscillator(force=True), 0.1, {"x": 1.0}, inputs={"F": value})


def test_a_constant_input_within_the_limit_still_runs():
    traj = lg.simulate(oscillator(force=True), 1.0, {"x": 0.0}, inputs={"F": 4.0}, **TIGHT)
    assert traj.x[-1, 0] == pytest.approx(1.0 - math.cos(2.0), rel=1e-7)  # x = F/k (1 - cos 2t)


@pytest.mark.parametrize("spec, text", [
    ("1e308", r"\[inputs\.F\]: the input is 1e\+308, too large: at most 1e\+150 in magnitude"),
    ("-2e200", r"\[inputs\.F\]: the input is -2e\+200, too large: at most 1e\+150 in magnitude"),
    (lg.pi * 1e300, r"\[inputs\.F\]: the input is 3\.14159e\+300, too large: at most 1e\+150 in magnitude"),
])
def test_a_constant_input_expression_past_the_limit_is_one_error(spec, text):
    """The command line's --input F=1e308 is the expression '1e308': checked as the number is (before:
    ZeroDivisionError inside the compiled integrator)."""
    with pytest.raises(ModelError, match=text):
        lg.simulate(oscillator(force=True), 0.1, {"x": 1.0}, inputs={"F": spec})


def test_a_constant_input_expression_within_the_limit_still_runs():
    traj = lg.simulate(oscillator(force=True), 1.0, {"x": 0.0}, inputs={"F": "2*2"}, **TIGHT)
    assert traj.x[-1, 0] == pytest.approx(1.0 - math.cos(2.0), rel=1e-7)
