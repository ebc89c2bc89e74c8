"""A relative tolerance below what double precision can meet (100 machine epsilons, as SciPy's
solve_ivp) is refused with the bound, by simulate, simulate_batch and the CLI alike: the integrators
used to raise it to that bound silently."""

from __future__ import annotations

import pytest

import lagrangian as lg
from lagrangian.cli import main

TEXT = ("rtol = 1e-16 is smaller than a relative error double precision can meet: at least 100 machine epsilons, "
        "2.22e-14; use rtol=2.22e-14 or larger (--rtol 2.22e-14)")


@pytest.fixture(scope="module")
def eqs():
    return lg.derive(lg.load("mck"))


def test_simulate_refuses_a_tolerance_below_double_precision(eqs):
    with pytest.raises(lg.ModelError, match=r"\[rtol\]") as info:
        lg.simulate(eqs, t_end=0.1, rtol=1e-16)
    assert TEXT in str(info.value)


def test_simulate_batch_refuses_it_with_the_same_words(eqs):
    with pytest.raises(lg.ModelError) as info:
        lg.simulate_batch(eqs, 0.1, {"x1": [0.1, 0.2]}, rtol=1e-16)
    assert TEXT in str(info.value)


def test_the_bound_itself_is_taken(eqs):
    tr = lg.simulate(eqs, t_end=0.1, rtol=2.23e-14, atol=1e-14)
    assert tr.t[-1] == pytest.approx(0.1)


def test_the_cli_says_the_bound(capsys):
    assert main(["simulate", "mck", "--t-end", "0.1", "--rtol", "1e-16"]) == 2
    assert TEXT in capsys.readouterr().err
