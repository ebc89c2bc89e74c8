"""The floor's helpers (lagrangian/_util.py): did-you-mean, read-only arrays and named values, which
every layer's messages and results go through."""

import math

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian._util import closest, did_you_mean, named_values, read_only, real_number


def test_did_you_mean_names_the_closest_candidate_in_either_form():
    assert closest("thta", ["q1", "theta"]) == "theta"
    assert did_you_mean("thta", ["q1", "theta"]) == " (did you mean 'theta'?)"
    assert did_you_mean("pendulm", ["pendulum", "kepler"], 0.5, sentence=True) == " Did you mean 'pendulum'?"
    assert did_you_mean("zzz", ["theta"]) == ""
    assert closest("zzz", ["theta"]) is None


def test_the_cutoff_decides_how_far_a_hint_may_be():
    # difflib's ratio of 'ab' and 'ax' (and of 'q3' and 'q2') is 0.5: close enough at 0.5, not at the default 0.6
    assert did_you_mean("ab", ["ax"], 0.5) == " (did you mean 'ax'?)"
    assert did_you_mean("ab", ["ax"]) == ""
    assert closest("q3", ["q2", "theta"], 0.5) == "q2" and closest("q3", ["q2", "theta"]) is None


def test_a_name_that_is_not_text_still_gets_its_hint():
    assert did_you_mean(sympy.Symbol("thta"), ["theta"]) == " (did you mean 'theta'?)"
    assert did_you_mean(12, ["q12"]) == " (did you mean 'q12'?)"


def test_read_only_copies_and_cannot_be_written():
    source = [1, 2, 3]
    a = read_only(source, float)
    assert a.dtype == float and a.tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match="read-only"):
        a[0] = 5.0
    b = np.arange(3)
    c = read_only(b)
    b[0] = 7
    assert c.dtype == b.dtype and c.tolist() == [0, 1, 2]  # a copy: the caller's array stays its own


@pytest.mark.parametrize("value, expected", [
    (0.5, 0.5), (2, 2.0), (np.float32(0.25), 0.25), (sympy.pi / 2, math.pi / 2), (sympy.Rational(1, 3), 1 / 3),
    (True, None), ("0.5", None), (math.nan, None), (math.inf, None), (sympy.oo, None), (sympy.Symbol("x"), None),
])
def test_real_number(value, expected):
    assert real_number(value) == expected


def test_named_values_reports_every_problem_with_its_key():
    problems = []
    out = named_values({"g": 9.81, sympy.Symbol("L"): sympy.Rational(1, 2), "gg": 1, "M1": math.nan, "M2": 1e200},
                       ("M1", "M2", "L", "g"), "a parameter of the model", "params", problems)
    assert out == {"g": 9.81, "L": 0.5}
    assert [(p.key, p.message) for p in problems] == [
        ("params.gg", "'gg' is not a parameter of the model (did you mean 'g'?); the choices are M1, M2, L, g"),
        ("params.M1", "the value of 'M1' must be a finite number, got nan"),
        ("params.M2", "the value of 'M2' is 1e+200, too large: at most 1e+150 in magnitude, so that the products of "
                      "the equations stay finite in double precision"),
    ]


def test_no_names_are_said_as_none():
    problems = []
    assert named_values({"F": 1.0}, (), "an input of the model", "inputs", problems) == {}
    assert problems[0].message == "'F' is not an input of the model; the choices are none"


def test_simulate_and_the_analysis_take_the_same_named_values():
    """One rule for a value given by name: simulate takes a SymPy number (g = pi**2) as linearize
    does, and gives the float's result."""
    eqs = lg.derive(lg.load("cart-pendulum"))
    exact = lg.simulate(eqs, t_end=0.5, params={"g": sympy.pi ** 2}, initial={"q2": 0.3})
    floating = lg.simulate(eqs, t_end=0.5, params={"g": math.pi ** 2}, initial={"q2": 0.3})
    assert np.array_equal(exact.x, floating.x) and exact.x[-1, 1] != 0.3
    with pytest.raises(lg.ModelError, match=r"\[params\.gg\]: 'gg' is not a parameter of the model \(did you mean "
                                            r"'g'\?\); the choices are M1, M2, L, g"):
        lg.simulate(eqs, t_end=0.5, params={"gg": sympy.pi})
    lin = lg.linearize(eqs, params={"g": sympy.pi ** 2})
    assert lin.parameter_values["g"] == pytest.approx(math.pi ** 2)
