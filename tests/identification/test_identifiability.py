"""Structural identifiability (identification._identifiability): which parameters the data determine.

Every expected answer is derived by hand in the test's docstring from the closed-form equations; the
numeric confirmation is checked against an independent path (finite differences of simulate).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.examples import example_source
from lagrangian.identification import identifiability, numeric_rank
from lagrangian.io import loads_model

m, l, g, c, k = sympy.symbols("m l g c k")
m1, m2, l1, l2 = sympy.symbols("m1 m2 l1 l2")

PENDULUM = """
name = "pend"
coordinates = ["th"]
[parameters]
m = 1.0
l = 0.8
g = 9.81
c = 0.1
[[particles]]
name = "bob"
mass = "m"
position = ["l*sin(th)", "-l*cos(th)"]
[gravity]
g = "g"
[[dampers]]
coefficient = "c"
length = "th"
"""


def pendulum(damped=True):
    """m l^2 th'' + c th' + m g l sin(th) = 0 (a point mass on a massless rod, a damper on the angle)."""
    return lg.derive(lg.Model(coordinates=["th"], T="m*l**2*th_dot**2/2", V="-m*g*l*cos(th)",
                              D="c*th_dot**2/2" if damped else "0",
                              parameters={"m": 1.0, "l": 0.8, "g": 9.81, "c": 0.1}))


def test_pendulum_determines_g_over_l_and_c_over_m_l2():
    """th'' = -(c/(m l^2)) th' - (g/l) sin(th): the data fix exactly the two coefficients g/l and
    c/(m l^2); the scalings (m, c) -> s (m, c) and (l, g, c) -> (s l, s g, s^2 c) leave them unchanged,
    so no parameter is determined alone."""
    r = identifiability(pendulum(), ["m", "l", "g", "c"])
    assert r.rank == 2
    assert r.identifiable == ()
    assert r.not_identifiable == ("m", "l", "g", "c")
    assert r.symmetry == "scaling"
    assert set(r.combinations) == {g / l, c / (m * l**2)}
    # the null directions are the two scalings (exponents), in echelon form
    assert [dict(d) for d in r.null_directions] == [{"m": 1.0, "c": 1.0}, {"l": 1.0, "g": 1.0, "c": 2.0}]
    s = sympy.Symbol("s", positive=True)
    for d in r.null_directions:
        scaled = {sympy.Symbol(n): sympy.Symbol(n) * s**sympy.Rational(v).limit_denominator(24) for n, v in d.items()}
        for combo in r.combinations:
            assert sympy.simplify(combo.xreplace(scaled) - combo) == 0
    assert "m -> m*s, c -> c*s" in r.reasons["m"]
    assert "c/(l**2*m)" in r.reasons["m"]
    assert r.method.startswith("exact") and "confirmed numerically" in r.method
    assert r.singular_values[1] > 1e-3 and r.singular_values[2] < 1e-12


def test_undamped_pendulum_mass_cancels():
    """th'' = -(g/l) sin(th) holds for every m: m cancels from M^-1 f, and nothing determines it."""
    r = identifiability(pendulum(damped=False), ["m"])
    assert r.rank == 0 and r.not_identifiable == ("m",) and r.combinations == ()
    assert r.reasons["m"] == "m cancels from the accelerations M^-1 f (scaling m alone leaves the motion unchanged)"


def test_constrained_models_without_motor_and_many_parameters_stay_bounded():
    """The rolling disk: its mass cancels (every force is its weight or a constraint's), v (the speed
    linearize is about) is not in the equations, r and g are determined."""
    r = identifiability(lg.derive(lg.load("rolling-disk")), ["m", "r", "g", "v"])
    assert r.identifiable == ("r", "g") and r.not_identifiable == ("m", "v") and r.rank == 2
    assert "m cancels from the accelerations" in r.reasons["m"]
    assert "v does not appear in the equations of motion" in r.reasons["v"]


def test_damped_pendulum_known_damper_fixes_the_mass():
    """With c known, c/(m l^2) and g/l (g known) determine l, then m."""
    r = identifiability(pendulum(), ["m", "l"])
    assert r.identifiable == ("m", "l") and r.rank == 2 and r.symmetry == "none"


def test_parameter_absent_from_the_equations():
    e = lg.derive(lg.Model(coordinates=["x"], T="m*x_dot**2/2", V="k*x**2/2", Q={"x": "F"}, inputs=["F"],
                           parameters={"m": 1.0, "k": 2.0, "unused": 3.0}))
    r = identifiability(e, ["m", "k", "unused"])
    assert r.identifiable == ("m", "k") and r.not_identifiable == ("unused",)
    assert "does not appear in the equations" in r.reasons["unused"]


def test_mck_with_known_force_all_identifiable():
    """mck (Preumont): M x'' + C x' + K x = [0, f] with f known. The force's column of M^-1 fixes the
    scale of M, then C and K follow: all six parameters are determined."""
    r = identifiability(lg.derive(lg.load("mck")), ["m1", "m2", "k1", "k2", "c1", "c2"])
    assert r.all_identifiable and r.rank == 6 and r.combinations == ()
    assert "rank 6 of 6" in r.text()


def test_mck_without_input_only_ratios():
    """m x'' + c x' + k x = 0: x'' = -(c/m) x' - (k/m) x; scaling m, c, k together changes nothing."""
    e = lg.derive(lg.Model(coordinates=["x"], T="m*x_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2",
                           parameters={"m": 1.0, "c": 0.3, "k": 4.0}))
    r = identifiability(e, ["m", "c", "k"])
    assert r.rank == 2 and r.identifiable == ()
    assert set(r.combinations) == {c / m, k / m}
    assert [dict(d) for d in r.null_directions] == [{"m": 1.0, "c": 1.0, "k": 1.0}]


def test_damper_and_mass_trade_off():
    """A mass on a damper, no spring, no input: m x'' + c x' = 0 decays as exp(-c/m t): m and c trade off."""
    e = lg.derive(lg.Model(coordinates=["x"], T="m*x_dot**2/2", D="c*x_dot**2/2", parameters={"m": 2.0, "c": 0.5}))
    r = identifiability(e, ["m", "c"])
    assert r.combinations == (c / m,) and r.not_identifiable == ("m", "c")
    assert "m -> m*s, c -> c*s" in r.reasons["c"]


def test_masses_that_enter_only_as_a_sum_translation():
    """(m1 + m2) x'' + k x = F: with F known, k and m1 + m2 are determined, m1 and m2 not alone (the
    change m1 + s, m2 - s is a translation, not a scaling)."""
    e = lg.derive(lg.Model(coordinates=["x"], T="(m1 + m2)*x_dot**2/2", V="k*x**2/2", Q={"x": "F"}, inputs=["F"],
                           parameters={"m1": 1.0, "m2": 0.5, "k": 3.0}))
    r = identifiability(e, ["m1", "m2", "k"])
    assert r.symmetry == "translation" and r.identifiable == ("k",) and r.combinations == (m1 + m2,)
    assert "m1 -> m1 + s, m2 -> m2 - s" in r.reasons["m1"]


def test_translation_found_on_the_numeric_path_too(monkeypatch):
    from lagrangian.identification import _identifiability

    monkeypatch.setattr(_identifiability, "EXACT_MAX_N", 0)
    e = lg.derive(lg.Model(coordinates=["x"], T="(m1 + m2)*x_dot**2/2", V="k*x**2/2", Q={"x": "F"}, inputs=["F"],
                           parameters={"m1": 1.0, "m2": 0.5, "k": 3.0}))
    r = identifiability(e, ["m1", "m2", "k"])
    assert r.method.startswith("numeric")
    assert r.symmetry == "translation" and r.identifiable == ("k",) and r.combinations == (m1 + m2,)


def test_neither_scaling_nor_translation():
    """(m1 + m2) x'' + k x = 0: only k/(m1 + m2) is determined (rank 1); the null directions change with
    the parameters' values, so the parameters are named without combinations."""
    e = lg.derive(lg.Model(coordinates=["x"], T="(m1 + m2)*x_dot**2/2", V="k*x**2/2",
                           parameters={"m1": 1.0, "m2": 0.5, "k": 3.0}))
    r = identifiability(e, ["m1", "m2", "k"])
    assert r.symmetry == "other" and r.rank == 1 and r.combinations == ()
    assert r.not_identifiable == ("m1", "m2", "k")
    assert "neither a scaling nor a translation" in r.reasons["k"]


def test_double_pendulum_masses_only_in_ratio():
    """Double pendulum, g known. Dividing the first equation by (m1 + m2) l1^2 and the second by m2 l2^2:
        th1'' + mu (l2/l1) [cos(th1 - th2) th2'' + sin(th1 - th2) th2'^2] + (g/l1) sin th1 = 0,
        th2'' + (l1/l2) [cos(th1 - th2) th1'' - sin(th1 - th2) th1'^2] + (g/l2) sin th2 = 0,
    with mu = m2/(m1 + m2). With g known, g/l1 and g/l2 give l1 and l2; mu gives m2/m1; scaling both
    masses together changes nothing. So: l1, l2 determined, m1 and m2 only as m2/m1 (rank 3)."""
    r = identifiability(lg.derive(lg.load("double-pendulum")), ["m1", "m2", "l1", "l2"])
    assert r.identifiable == ("l1", "l2") and r.not_identifiable == ("m1", "m2")
    assert r.rank == 3 and r.combinations == (m2 / m1,)
    assert [dict(d) for d in r.null_directions] == [{"m1": 1.0, "m2": 1.0}]


def four_bar(without_input: bool):
    text = example_source("four-bar")
    if without_input:
        text = text.replace('inputs = ["tau"]\n', "")
        start = text.index("[[loads]]")
        text = text[:start] + text[text.index("[gravity]"):]
    return lg.derive(loads_model(text))


def test_four_bar_with_motor_torque_all_identifiable():
    """The closed chain: the measured angles satisfy the loop equations, which fix the lengths a, b, c
    (d known); the known motor torque fixes the masses' scale, gravity (known) the rest."""
    r = identifiability(four_bar(False), ["a", "b", "c", "ma", "mb", "mc"])
    assert r.all_identifiable and r.rank == 6
    assert r.method.startswith("numeric") and "consistent states" in r.method


def test_four_bar_without_input_masses_in_ratios():
    """Without the motor every term of the saddle-point equations (M q'' - f - G^T lambda, gravity
    included) is linear in the masses: scaling ma, mb, mc together changes the multipliers only, so
    the masses are determined as two ratios; the lengths still by the loop."""
    r = identifiability(four_bar(True), ["a", "b", "ma", "mb", "mc"])
    assert r.identifiable == ("a", "b") and r.not_identifiable == ("ma", "mb", "mc")
    assert r.rank == 4 and r.symmetry == "scaling"
    assert [dict(d) for d in r.null_directions] == [{"ma": 1.0, "mb": 1.0, "mc": 1.0}]
    ma, mb, mc = sympy.symbols("ma mb mc")
    assert r.combinations == (mb / ma, mc / ma)
    scaled = {ma: 3 * ma, mb: 3 * mb, mc: 3 * mc}
    assert all(sympy.simplify(combo.subs(scaled) - combo) == 0 for combo in r.combinations)


def test_double_pendulum_written_with_cos_of_a_difference_stays_exact():
    """The energies written with cos(th1 - th2): sin and cos of an integer combination of coordinates
    are evaluated exactly from the coordinates' points on the unit circle (no relaxation)."""
    e = lg.derive(lg.Model(coordinates=["th1", "th2"],
                           T="(m1 + m2)*l1**2*th1_dot**2/2 + m2*l2**2*th2_dot**2/2 "
                             "+ m2*l1*l2*cos(th1 - th2)*th1_dot*th2_dot",
                           V="-(m1 + m2)*g*l1*cos(th1) - m2*g*l2*cos(th2)",
                           parameters={"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 0.7, "g": 9.81}))
    r = identifiability(e, ["m1", "m2", "l1", "l2"])
    assert r.identifiable == ("l1", "l2") and r.combinations == (m2 / m1,)
    assert r.method.startswith("exact") and "confirmed numerically" in r.method


def test_parameter_inside_a_function_takes_the_numeric_path():
    """m x'' + k x = F0 sin(w t): x'' = (F0/m) sin(w t) - (k/m) x; w is determined by the forcing's
    frequency, m, k, F0 scale together. The numeric null direction is recognized as the scaling."""
    e = lg.derive(lg.Model(coordinates=["x"], T="m*x_dot**2/2", V="k*x**2/2", Q={"x": "F0*sin(w*t)"},
                           parameters={"m": 1.0, "k": 2.0, "F0": 0.5, "w": 3.0}))
    r = identifiability(e, ["m", "k", "F0", "w"])
    F0 = sympy.Symbol("F0")
    assert r.identifiable == ("w",) and set(r.combinations) == {k / m, F0 / m} and r.symmetry == "scaling"
    assert r.method.startswith("numeric") and "a parameter asked about is inside sin(t*w)" in r.method


def test_irrational_constant_takes_the_numeric_path():
    e = lg.derive(lg.Model(coordinates=["x"], T="m*x_dot**2/2", V="k*x**2/2 + sqrt(2)*x",
                           parameters={"m": 1.0, "k": 2.0}))
    r = identifiability(e, ["m", "k"])
    assert r.all_identifiable and "an expression holds an irrational constant" in r.method


def test_past_the_exact_bound_the_numeric_path_gives_the_same_answer(monkeypatch):
    from lagrangian.identification import _identifiability

    monkeypatch.setattr(_identifiability, "EXACT_MAX_N", 1)
    r = identifiability(lg.derive(lg.load("double-pendulum")), ["m1", "m2", "l1", "l2"])
    assert r.method.startswith("numeric") and "more than 1 coordinates" in r.method
    assert r.identifiable == ("l1", "l2") and r.combinations == (m2 / m1,) and r.symmetry == "scaling"


@pytest.mark.slow
def test_four_bar_only_the_crank_angle_measured():
    """An encoder on the crank alone (th1), the initial crank angle and speed unknown: the same answer
    as with every angle measured, from simulated sensitivities (the dependent angles follow the loop)."""
    r = identifiability(four_bar(True), ["a", "b", "ma", "mb", "mc"], measured=["th1"])
    ma, mb, mc = sympy.symbols("ma mb mc")
    assert r.identifiable == ("a", "b") and r.combinations == (mb / ma, mc / ma) and r.symmetry == "scaling"
    assert "the 2 initial values of each experiment unknown too" in r.method
    assert r.singular_values[3] > 1e3 * r.singular_values[4]


def _simulated_sensitivities(e, names, values, h=1e-5):
    """d th(t_k) / d log p by central differences of simulate (the independent path)."""
    nm = lg.compile(e)
    times = np.linspace(0, 3, 61)

    def run(p):
        return lg.simulate(nm, t_end=3.0, initial={"th": 1.0, "th_dot": -0.5}, params=p, t_eval=times,
                           rtol=1e-12, atol=1e-12)["th"]

    cols = []
    for n in names:
        up, down = dict(values), dict(values)
        up[n] *= 1 + h
        down[n] *= 1 - h
        cols.append((run(up) - run(down)) / (2 * h))
    return np.array(cols).T


@pytest.mark.slow
def test_numeric_rank_of_simulated_sensitivities_agrees_with_the_symbolic_rank():
    e = pendulum()
    names = ["m", "l", "g", "c"]
    S = _simulated_sensitivities(e, names, {"m": 1.0, "l": 0.8, "g": 9.81, "c": 0.1})
    rank, null = numeric_rank(S, names, rtol=1e-6)
    symbolic = identifiability(e, names)
    assert rank == symbolic.rank == 2
    # the same scalings, in the columns' (log) coordinates
    assert len(null) == 2
    for found, expected in zip(null, symbolic.null_directions):
        assert set(found) == set(expected)
        assert all(abs(found[n] - expected[n]) < 1e-3 for n in expected)


def test_numeric_rank_zero_column_and_full_rank():
    S = np.array([[1.0, 0.0, 2.0], [0.0, 0.0, 1.0], [3.0, 0.0, 0.5]])
    rank, null = numeric_rank(S, ["a", "b", "c"])
    assert rank == 2 and null == ({"b": 1.0},)
    rank, null = numeric_rank(np.eye(3), ["a", "b", "c"])
    assert rank == 3 and null == ()


def test_only_the_bob_x_measured():
    """Only the bob's horizontal position l sin(th) is measured (a camera), the initial state unknown:
    l is fixed by the amplitude against the angle's dynamics (g known), c/m by the decay."""
    e = lg.derive(loads_model(PENDULUM))
    r = identifiability(e, ["m", "l", "c"], measured=["bob.x"])
    assert r.measured == ("bob.x",)
    assert r.identifiable == ("l",) and r.combinations == (c / m,)
    assert r.method.startswith("numeric") and "central differences of simulations" in r.method
    assert r.to_dict()["measured"] == ["bob.x"]
    # every coordinate measured is the whole state: the exact path
    assert identifiability(e, ["m", "l", "c"], measured=["th"]).measured is None


def test_text_and_json():
    r = identifiability(pendulum(), "m, l, g, c")
    d = json.loads(json.dumps(r.to_dict()))
    assert d["combinations"] == ["g/l", "c/(l**2*m)"] and d["rank"] == 2 and d["symmetry"] == "scaling"
    text = r.text()
    assert "rank 2 of 4" in text and "determined only in combination: g/l, c/(l**2*m)" in text
    assert "not determined alone (a fit reports no value for them): m, l, g, c" in text
    assert str(r) == text
    assert lg.identifiability is identifiability


# ------------------------------------------------------------------------------------ hostile
@pytest.mark.parametrize("params, message", [
    (["m", "ll"], "'ll' is not a parameter of model 'model' (did you mean 'l'?); its parameters are: m, l, g, c"),
    (["m", "m"], "parameter 'm' is named twice: name each parameter once"),
    ([], "params is empty: name the parameters to be determined"),
    ("", "params is empty"),
    ([3], "a parameter name must be a string, got 3"),
    (["__import__('os')"], "'__import__('os')' is not a parameter of model 'model'"),
    (["m\nl"], "is not a parameter of model 'model'"),
    (["x" * 500], "...' is not a parameter"),
    (None, "params must be a list of parameter names, got None"),
    ({"m": 1}, "params must be a list of parameter names, got {'m': 1}"),
    (["m"] * 201, "params names 201 parameters, more than 200"),
])
def test_bad_params(params, message):
    with pytest.raises(ModelError) as info:
        identifiability(pendulum(), params)
    assert message in str(info.value)


def test_known_parameter_without_value():
    model = lg.Model(coordinates=["x"], T="m*x_dot**2/2", V="k*x**2/2", parameters={"m": 1.0, "k": None})
    with pytest.raises(ModelError, match=r"parameter 'k' is known \(not in params\) but has no finite value \(None\): "
                                         "give it a value in the model, or add it to params"):
        identifiability(model, ["m"])


def test_bad_measured_and_inputs():
    e = lg.derive(loads_model(PENDULUM))
    with pytest.raises(ModelError, match=r"'bob\.q' is not a coordinate, velocity, output or '<point>\.x'"):
        identifiability(e, ["m"], measured=["bob.q"])
    with pytest.raises(ModelError, match=r"'bobb' is not a point, particle or body \(did you mean 'bob'\?\)"):
        identifiability(e, ["m"], measured=["bobb.x"])
    with pytest.raises(ModelError, match="'th_dot' is measured twice"):
        identifiability(e, ["m"], measured=["th_dot", "th_dot"])
    with pytest.raises(ModelError, match="measured must be a non-empty list"):
        identifiability(e, ["m"], measured=[])
    with pytest.raises(ModelError, match="does not handle velocity constraints yet, and model 'rolling-disk' has"):
        identifiability(lg.derive(lg.load("rolling-disk")), ["m"], measured=["x"])
    text = example_source("four-bar").replace('independent = ["th1"]\n', "")
    with pytest.raises(ModelError, match=r"needs the independent coordinates of the constrained model 'four-bar' .*"
                                         r"add independent = \[\.\.\.\] to its \[simulation\] table"):
        identifiability(lg.derive(loads_model(text)), ["a"], measured=["th1"])
    with pytest.raises(ModelError, match="equations must be the Equations of a model"):
        identifiability("pendulum", ["m"])


def test_numeric_rank_hostile():
    with pytest.raises(ModelError, match=r"one column per name, shape \(rows, 2\); got shape \(3,\)"):
        numeric_rank(np.ones(3), ["a", "b"])
    with pytest.raises(ModelError, match="not finite"):
        numeric_rank(np.array([[1.0, np.nan]]), ["a", "b"])
    with pytest.raises(ModelError, match="rtol must be a number between 0 and 1, got 2"):
        numeric_rank(np.eye(2), ["a", "b"], rtol=2)
