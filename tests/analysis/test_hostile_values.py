"""Hostile values given to the analysis functions (linearize, equilibria, steady_motions, continuation): text,
bytes, NaN, huge numbers, ragged lists, objects where a mapping, a number or a sequence of numbers belongs are one
ModelError that names the argument, what it must be and an example, never NumPy's or Python's exception with a
traceback."""

from __future__ import annotations

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.errors import ModelError


class _Thing:
    pass


NOT_A_MAPPING = ["abc", b"x", float("nan"), 1e308, -1, True, [1, [2]], [("m1", 2.0)], 1j, _Thing(), np.ones((2, 2))]


@pytest.fixture(scope="module")
def pendulum():
    return lg.derive(lg.load("double-pendulum"))


@pytest.fixture(scope="module")
def spherical():
    return lg.derive(lg.load("spherical-pendulum"))


@pytest.mark.parametrize("params", NOT_A_MAPPING)
@pytest.mark.parametrize("call", ["linearize", "equilibria"])
def test_params_that_are_not_a_mapping_are_one_error(pendulum, params, call):
    """params=1e308, "abc", a list of pairs...: before, AttributeError ('float' object has no attribute 'items')
    or NumPy's ambiguous truth value."""
    fn = getattr(lg, call)
    with pytest.raises(ModelError, match=r"\[params\]: params must be a mapping of names to numbers, such as "
                                         r"\{'m1': 1\.0\}, got \w+ .*; give the values by name"):
        fn(pendulum, params=params)


@pytest.mark.parametrize("inputs", ["F=1", 2.0, [1.0]])
def test_inputs_that_are_not_a_mapping_are_one_error(inputs):
    eq = lg.derive(lg.load("cart-pendulum"))
    with pytest.raises(ModelError, match=r"\[inputs\]: inputs must be a mapping of names to numbers, such as "
                                         r"\{'F': 1\.0\}, got "):
        lg.linearize(eq, inputs=inputs)


def test_a_long_value_is_cut_in_the_message(pendulum):
    with pytest.raises(ModelError) as info:
        lg.linearize(pendulum, params="x" * 20000)
    assert len(str(info.value)) < 300
    assert "got str 'xxxxxxxxx" in str(info.value) and "...;" in str(info.value)


@pytest.mark.parametrize("at", ["abc", b"x", [1, [2]], 1j, _Thing(), [0.0, "x"]])
def test_an_operating_point_that_is_not_numbers_is_one_error(pendulum, at):
    """Before: NumPy's ValueError/TypeError from converting the text or the ragged list."""
    with pytest.raises(ModelError, match=r"\[at\]: the operating point must give 2 coordinates or 4 state values "
                                         r"\(theta1, theta2, theta1_dot, theta2_dot\), got "):
        lg.linearize(pendulum, at)


def test_an_operating_point_as_numbers_still_works(pendulum):
    lin = lg.linearize(pendulum, [np.pi, np.pi])
    assert lin.operating_point["theta1"] == pytest.approx(np.pi)


@pytest.mark.parametrize("starts, text", [
    ("abc", r"starts must be a whole number, got 'abc'; for example starts=48"),
    (2.5, r"starts must be a whole number, got 2\.5; for example starts=48"),
    (-1, r"starts must be at least 0, got -1; for example starts=48"),
    (float("nan"), r"starts must be a finite number, got nan; for example starts=48"),
    (True, r"starts must be a whole number, got True; for example starts=48"),
    ([], r"starts must be a whole number, got \[\]; for example starts=48"),
    (np.ones((2, 2)), r"starts must be a whole number, got array"),
])
@pytest.mark.parametrize("fn", ["equilibria", "steady_motions"])
def test_bad_starts_are_one_error(pendulum, spherical, starts, text, fn):
    eq = pendulum if fn == "equilibria" else spherical
    with pytest.raises(ModelError, match=r"\[starts\]: " + text):
        getattr(lg, fn)(eq, starts=starts, exact=False)


@pytest.mark.parametrize("seed, text", [
    ("abc", r"seed must be a whole number, got 'abc'; for example seed=0"),
    (-3, r"seed must be at least 0, got -3; for example seed=0"),
    ({}, r"seed must be a whole number, got \{\}; for example seed=0"),
    (1e308, r"seed must be a whole number, got 1e\+308; for example seed=0"),
])
def test_bad_seeds_are_one_error(pendulum, seed, text):
    """Before: NumPy's SeedSequence TypeError or ValueError."""
    with pytest.raises(ModelError, match=r"\[seed\]: " + text):
        lg.equilibria(pendulum, seed=seed, exact=False)


@pytest.mark.parametrize("exact", ["yes", np.ones((2, 2)), None])
def test_exact_that_is_not_true_or_false_is_one_error(pendulum, exact):
    with pytest.raises(ModelError, match=r"\[exact\]: exact must be True or False, got "):
        lg.equilibria(pendulum, exact=exact)


def test_whole_numbers_of_numpy_are_starts_and_seeds(pendulum):
    found = lg.equilibria(pendulum, exact=False, starts=np.int64(8), seed=np.int32(1))
    assert len(found) == 4  # both rods down or up, in each combination


@pytest.mark.parametrize("which", ["velocities", "momenta"])
@pytest.mark.parametrize("value", ["abc", 1.5, [1.0], _Thing()])
def test_steady_velocities_or_momenta_not_a_mapping_are_one_error(spherical, which, value):
    """Before: AttributeError ('str' object has no attribute 'items')."""
    name = "phi_dot" if which == "velocities" else "p_phi"
    with pytest.raises(ModelError, match=rf"\[{which}\]: the {which} must be a mapping of names to numbers, such as "
                                         rf"\{{'{name}': 1\.0\}}, got "):
        lg.steady_motions(spherical, **{which: value})


@pytest.mark.parametrize("values", ["abc", b"x", [1.0, "x"], [1, [2]], {"a": 1}, _Thing(), 1j, [1.0, 1j]])
def test_continuation_values_that_are_not_numbers_are_one_error(pendulum, values):
    """Before: NumPy's ValueError (could not convert string to float) or TypeError."""
    with pytest.raises(ModelError, match=r"the values of g must be at least 2 finite numbers in increasing \(or "
                                         r"decreasing\) order, e\.g\. numpy\.linspace\(0, 8, 201\); got "):
        lg.continuation(pendulum, "g", values)


@pytest.mark.parametrize("values", [[1.0, 1e308], [-1e308, 0.0]])
def test_continuation_values_too_large_are_one_error(pendulum, values):
    """Before: NumPy's LinAlgError (SVD did not converge)."""
    with pytest.raises(ModelError, match=r"the values of g reach 1e\+308, too large: at most 1e\+150 in magnitude"):
        lg.continuation(pendulum, "g", values)


@pytest.mark.parametrize("parameter", [np.ones((2, 2)), 3, None, b"g"])
def test_continuation_parameter_that_is_not_a_name_is_one_error(pendulum, parameter):
    with pytest.raises(ModelError, match=r"the parameter to vary must be its name \(text\), one of m1, m2, l1, l2, "
                                         r"g; got "):
        lg.continuation(pendulum, parameter, [1.0, 2.0])


def test_continuation_params_not_a_mapping_is_one_error(pendulum):
    with pytest.raises(ModelError, match=r"\[params\]: params must be a mapping of names to numbers"):
        lg.continuation(pendulum, "g", [1.0, 2.0], params=2.0)


@pytest.mark.parametrize("q, text", [
    ([1.0, [2.0]], r"q: expected numbers, got \[1\.0, \[2\.0\]\]"),
    ({"theta1": [1.0, [2.0]], "theta2": 0.0}, r"q\.theta1: expected numbers, got \[1\.0, \[2\.0\]\]"),
    ({"theta1": np.ones((2, 2)), "theta2": 0.0}, r"q\.theta1: expected one number or a sequence of numbers \(one per "
                                                 r"state\), got an array of shape \(2, 2\)"),
    ("ab", r"q: expected numbers, got 'ab'"),
    ([0.1, "x"], r"q: expected numbers, got \[0\.1, 'x'\]"),
])
def test_inverse_dynamics_states_that_are_not_numbers_are_one_error(pendulum, q, text):
    """Before: NumPy's ValueError (inhomogeneous shape, operand has more dimensions) with a traceback."""
    with pytest.raises(ModelError, match=text):
        lg.inverse_dynamics(pendulum, q)


@pytest.mark.parametrize("inputs", ["F", 1.5, [1.0], np.ones((2, 2)), True])
def test_inverse_dynamics_inputs_not_a_mapping_are_one_error(inputs):
    """Before: AttributeError ('str' object has no attribute 'items') or NumPy's ambiguous truth value."""
    eq = lg.derive(lg.load("cart-pendulum"))
    with pytest.raises(ModelError, match=r"\[inputs\]: inputs must be a mapping of names to numbers or arrays \(one "
                                         r"value per state\), such as \{'F': 1\.0\}, got "):
        lg.inverse_dynamics(eq, [0.0, 0.0], inputs=inputs)


def test_inverse_dynamics_of_a_pose_still_works(pendulum):
    out = lg.inverse_dynamics(pendulum, {"theta1": [0.5, 0.0], "theta2": 0.0})
    assert out.torques[0, 0] == pytest.approx(2 * 9.81 * np.sin(0.5))  # g l1 (m1 + m2) sin(theta1)
    assert out.torques[1, 0] == pytest.approx(0.0)


@pytest.mark.parametrize("actuated, text", [
    ("theta1", r"actuated: model 'double-pendulum' has no constraints, so every coordinate is actuated and tau has "
               r"one force per coordinate \(theta1, theta2\); leave actuated out"),
    (["zz"], r"\[actuated\.zz\]: 'zz' is not a coordinate; the coordinates are theta1, theta2"),
    (3, r"actuated must be a list of coordinate names, e.g\. actuated=\['theta1'\], got 3; the coordinates are "
        r"theta1, theta2"),
    ([1], r"actuated must be a list of coordinate names, e.g\. actuated=\['theta1'\], got \[1\]"),
])
def test_inverse_dynamics_actuated_of_a_model_without_constraints(pendulum, actuated, text):
    """Before: ignored without a word (a wrong name, or a subset that the model cannot be driven by)."""
    with pytest.raises(ModelError, match=text):
        lg.inverse_dynamics(pendulum, [0.5, 0.0], actuated=actuated)


def test_inverse_dynamics_every_coordinate_actuated_is_the_default(pendulum):
    both = lg.inverse_dynamics(pendulum, [0.5, 0.0], actuated=["theta2", "theta1"])
    assert both.torques.tolist() == lg.inverse_dynamics(pendulum, [0.5, 0.0]).torques.tolist()
