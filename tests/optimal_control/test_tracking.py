"""The time-varying LQR along an optimal motion holds it on the nonlinear model under a perturbation."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("casadi", reason="optimal motions need CasADi (the 'optimal' extra)")

import lagrangian as lg  # noqa: E402
from lagrangian.errors import ModelError  # noqa: E402


@pytest.fixture(scope="module")
def swing_up():
    eqs = lg.derive(lg.Model(
        coordinates=["x", "th"], parameters=dict(m1=1.0, m2=0.3, l=0.5, g=9.81), inputs=["F"], Q={"x": "F"},
        T="(m1 + m2)/2*x_dot**2 + m2*l*cos(th)*x_dot*th_dot + m2*l**2/2*th_dot**2", V="-m2*g*l*cos(th)"))
    motion = lg.optimal_motion(eqs, duration=2.0, objective="F**2", initial={"x": 0, "th": 0, "x_dot": 0, "th_dot": 0},
                               final={"x": 1.0, "th": math.pi, "x_dot": 0, "th_dot": 0}, inputs={"F": (-20, 20)},
                               intervals=40, max_refinements=0, replay=False)
    return eqs, motion


def test_linearization_against_finite_differences(swing_up):
    eqs, motion = swing_up
    tr = motion._transcription
    for p in (0, 17, 60):
        A, B = tr.linear(motion.x[p], motion.u[p], motion.t[p])
        eps = 1e-6
        for j in range(4):
            dx = np.zeros(4)
            dx[j] = eps
            x, u = motion.x[p], motion.u[p]
            fd = (tr.rates(x + dx, u, 0.0) - tr.rates(x - dx, u, 0.0)) / (2 * eps)
            assert np.allclose(A[:, j], fd, atol=1e-7)
        du = (tr.rates(motion.x[p], motion.u[p] + eps, 0.0) - tr.rates(motion.x[p], motion.u[p] - eps, 0.0)) / (2 * eps)
        assert np.allclose(B[:, 0], du, atol=1e-7)


def test_state_at_interpolates_the_points(swing_up):
    _, motion = swing_up
    for p in (0, 5, 6, len(motion.t) - 1):
        assert np.allclose(motion.state_at(motion.t[p]), motion.x[p], atol=1e-12)


@pytest.mark.slow
def test_tracking_lqr_holds_the_motion_under_a_perturbation(swing_up):
    eqs, motion = swing_up
    law = motion.tracking_lqr(Q={"x": 10, "th": 10, "x_dot": 1, "th_dot": 1}, R={"F": 0.1},
                              Qf=np.diag([100.0, 100.0, 10.0, 10.0]))
    assert law.gains.shape == (len(motion.t), 1, 4) and law.input_names == ("F",)
    # S(T) = Qf and K(T) = R^-1 B^T Qf
    assert np.allclose(law.riccati[-1], np.diag([100.0, 100.0, 10.0, 10.0]))
    x0 = dict(zip(motion.state_names, motion.x[0]))
    x0["th"] += 0.1
    x0["x"] += 0.05
    open_loop = lg.simulate(eqs, t_end=2.0, initial=x0, inputs=motion.input_law, t_eval=motion.t)
    closed = lg.simulate(eqs, t_end=2.0, initial=x0, inputs=law.inputs(), t_eval=motion.t, rtol=1e-8, atol=1e-8)
    assert abs(open_loop["th"][-1] - math.pi) > 1.0  # the open-loop law misses upright by far
    assert abs(closed["th"][-1] - math.pi) < 0.01 and abs(closed["x"][-1] - 1.0) < 0.01
    assert np.max(np.abs(closed.x - motion.x)[:, 1]) <= 0.1 + 1e-9  # never further than the initial kick


def test_tracking_lqr_refusals(swing_up):
    _, motion = swing_up
    with pytest.raises(ModelError, match="Q: 'thh' is not one of x, th, x_dot, th_dot"):
        motion.tracking_lqr(Q={"thh": 1.0})
    with pytest.raises(ModelError, match="R must be positive definite"):
        motion.tracking_lqr(R={"F": 0.0})
    with pytest.raises(ModelError, match="expected a finite 4 x 4 matrix"):
        motion.tracking_lqr(Q=np.eye(3))
    eqs = lg.derive(lg.load("four-bar"))
    bar = lg.optimal_motion(eqs, duration=1.0, objective="tau**2", initial={"th1": 1.2, "th1_dot": 0.0},
                            final={"th1": 1.3, "th1_dot": 0.0}, intervals=6, max_refinements=0, replay=False)
    with pytest.raises(ModelError, match="does not handle constrained models yet"):
        bar.tracking_lqr()
