"""Hostile arguments of the solver objects (lagrangian.numeric._solvers): each is one clear ModelError
that names the key and the fix, never a number computed with a step the user did not ask for, nor
SciPy's own ValueError."""

from __future__ import annotations

import pytest

import lagrangian as lg
from lagrangian.numeric import SciPyMethod, Variational


@pytest.fixture(scope="module")
def eqs():
    return lg.derive(lg.load("mck"))


@pytest.mark.parametrize("step, text", [
    (-1, "step must be a positive number, got -1 (Variational(step=...): the fixed step in seconds)"),
    (0.0, "step must be a positive number, got 0.0"),
    (float("inf"), "step must be a finite number, got inf"),
    ("a", "step must be a number, got 'a'"),
])
def test_a_variational_step_that_is_not_a_positive_number_is_refused(eqs, step, text):
    with pytest.raises(lg.ModelError, match=r"\[step\]") as info:
        lg.simulate(eqs, t_end=0.1, method=Variational(step=step))
    assert text in str(info.value)


def test_a_good_variational_step_is_taken(eqs):
    tr = lg.simulate(eqs, t_end=0.1, dt=0.01, method=Variational(step=0.005))
    assert tr.stats["method"] == "variational" and len(tr.t) == 11


@pytest.mark.parametrize("name, hint", [("nope", ""), ("radau", " (did you mean 'Radau'?)")])
def test_a_scipy_method_scipy_does_not_have_is_a_model_error(eqs, name, hint):
    with pytest.raises(lg.ModelError) as info:
        lg.simulate(eqs, t_end=0.1, method=SciPyMethod(name))
    assert (f"[method]: SciPyMethod('{name}') is not one of SciPy's solve_ivp methods{hint}; choose one of "
            "DOP853, RK45, RK23, Radau, BDF, LSODA") in str(info.value)
