"""Hostile values given to singularities() and constraint_singularities(): a parameter value that is text, None,
True, a list, NaN or past the magnitude limit, parameters that are not a mapping, drivers that are not names are one
ModelError naming the key and what is expected, never SymPy's or Python's exception with a traceback."""

from __future__ import annotations

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.errors import ModelError


@pytest.fixture(scope="module")
def pendulum():
    return lg.derive(lg.load("double-pendulum"))


@pytest.fixture(scope="module")
def slider_crank():
    return lg.derive(lg.load("slider-crank"))


@pytest.mark.parametrize("value, text", [
    ("abc", r"must be a finite number, got 'abc'"),
    (None, r"must be a finite number, got None"),
    (True, r"must be a finite number, got True"),
    ([1, 2], r"must be a finite number, got \[1, 2\]"),
    ({"a": {"b": 1}}, r"must be a finite number, got \{'a': \{'b': 1\}\}"),
    (float("nan"), r"must be a finite number, got nan"),
    (1j, r"must be a finite number, got 1j"),
    ("__import__('os')", r"must be a finite number, got \"__import__\('os'\)\""),
    ("x" * 10000, r"must be a finite number, got 'x{36}\.\.\.$"),
    (1e308, r"is 1e\+308, too large: at most 1e\+150 in magnitude"),
])
def test_a_parameter_value_that_is_not_a_number_is_one_error(pendulum, value, text):
    """Before: SymPy's TypeError (Cannot convert expression to float), AttributeError ('list' object has no
    attribute 'xreplace'), SympifyError; "__import__('os')" was even read by sympify."""
    with pytest.raises(ModelError, match=r"\[parameters\.m1\]: the value of 'm1' " + text):
        lg.singularities(pendulum, {"m1": value})


@pytest.mark.parametrize("value", [2, 2.5, np.float64(0.5), lg.pi / 2])
def test_numbers_are_still_parameter_values(pendulum, value):
    report = lg.singularities(pendulum, {"m1": value})
    assert not report.singular  # det M = l1^2 l2^2 m2 (m1 + m2 sin^2(theta1 - theta2)) > 0


@pytest.mark.parametrize("parameters", ["m1", 1.0, [("m1", 2.0)], np.ones(3)])
def test_parameters_that_are_not_a_mapping_are_one_error(pendulum, parameters):
    with pytest.raises(ModelError, match=r"\[parameters\]: parameters must be a mapping of names to numbers, such as "
                                         r"\{'m1': 1\.0\}, got "):
        lg.singularities(pendulum, parameters)


@pytest.mark.parametrize("drivers", [3, 1.5, [1], b"x", {"th": 1}, [("th", 2)], object()])
def test_drivers_that_are_not_names_are_one_error(slider_crank, drivers):
    """Before: TypeError ('int' object is not iterable)."""
    with pytest.raises(ModelError, match=r"drivers must be a coordinate's name, a list of names or a list of sets of "
                                         r"names, such as drivers='th' or drivers=\[\('th',\)\], got .*; the "
                                         r"coordinates are th, ph, s"):
        lg.constraint_singularities(slider_crank, drivers)


@pytest.mark.parametrize("drivers", ["th", ["th"], ("th",), {"th"}, [{"th"}]])
def test_names_are_still_drivers(slider_crank, drivers):
    report = lg.constraint_singularities(slider_crank, drivers)
    assert report.dead_points[0].drivers == ("th",)
