"""lqr(): weights past the magnitude limit and a sample time so long that e^(A Ts) overflows are one ModelError
naming the weight or the sample time and the fix, never NumPy's LinAlgError with a traceback."""

from __future__ import annotations

import math

import pytest

import lagrangian as lg
from lagrangian.control import lqr
from lagrangian.errors import ModelError


@pytest.fixture(scope="module")
def upright():
    return lg.linearize(lg.derive(lg.load("cart-pendulum")), {"q2": math.pi / 2})


@pytest.mark.parametrize("key", ["Q", "R"])
@pytest.mark.parametrize("value", [1e308, -1e200])
def test_a_weight_past_the_limit_is_one_error(upright, key, value):
    """Before: LinAlgError (Eigenvalues did not converge) from `lagrangian lqr --Q 1e308`."""
    with pytest.raises(ModelError, match=rf"\[{key}\]: {key} has a weight of 1e\+(308|200), too large: at most "
                                         r"1e\+150 in magnitude; scale the weights down \(only their ratios matter\)"):
        lqr(upright, **{key: value})


def test_a_weight_by_name_past_the_limit_is_one_error(upright):
    with pytest.raises(ModelError, match=r"\[Q\.q1\]: the weight of 'q1' must be a finite number of magnitude at "
                                         r"most 1e\+150, got 1e\+200"):
        lqr(upright, Q={"q1": 1e200, "q2": 1.0, "q1_dot": 1.0, "q2_dot": 1.0})


@pytest.mark.parametrize("sample_time", [1e308, 1e3])
def test_a_sample_time_whose_discretization_overflows_is_one_error(upright, sample_time):
    """Before: LinAlgError (Array must not contain infs or NaNs) from `lagrangian lqr --sample-time 1e308`."""
    with pytest.raises(ModelError, match=r"sample_time 1e\+308 s|sample_time 1000 s"):
        lqr(upright, sample_time=sample_time)
    with pytest.raises(ModelError, match=r"is too long for cart-pendulum: e\^\(A Ts\) of its unstable modes overflows "
                                         r"double precision; choose a sample time shorter"):
        lqr(upright, sample_time=sample_time)


def test_large_weights_within_the_limit_give_the_same_gain_as_their_ratios(upright):
    """Only the ratio Q/R matters: Q = R = 1e6 I gives the gain of Q = R = I."""
    import numpy as np

    big = lqr(upright, Q=1e6, R=1e6)
    unit = lqr(upright)
    assert np.allclose(big.K, unit.K, rtol=1e-6)
