"""A failed projection onto the constraints is never silent: the generated projection's result code
(SINGULAR, NOT_FINITE) stops the compiled DOP853 (numba and C backends) and the NumPy path alike,
with Status.PROJECTION_SINGULAR / PROJECTION_NOT_FINITE and a SimulationError that says where and why
(before, the kernels called the projection as void and went on from an unprojected state)."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.numeric import _kernels
from lagrangian.numeric._cbackend import c_compiler
from lagrangian.numeric._codegen_constrained import MET, NOT_FINITE, SINGULAR, compiled_projection, work_size
from lagrangian.numeric._compiled import compile_equations
from lagrangian.numeric._constrained import constrained_model, integrate
from lagrangian.numeric._fast import _address, run_dop853
from lagrangian.numeric._simulate import _compiled_failure, _input_programs

HAVE_C = importlib.util.find_spec("cffi") is not None and c_compiler() is not None
BACKENDS = ["numba"] + (["c"] if HAVE_C else [])


def test_the_kernels_statuses_are_the_enumerations_members():
    assert (_kernels.STATUS_PROJECTION_SINGULAR, _kernels.STATUS_PROJECTION_NOT_FINITE) == (
        lg.Status.PROJECTION_SINGULAR, lg.Status.PROJECTION_NOT_FINITE)
    assert (MET, SINGULAR, NOT_FINITE) == (_kernels.PROJECTION_MET, _kernels.PROJECTION_SINGULAR,
                                           _kernels.PROJECTION_NOT_FINITE)
    for status in (lg.Status.PROJECTION_SINGULAR, lg.Status.PROJECTION_NOT_FINITE):
        assert not status.ok and status.message.startswith("The projection onto the constraints") and status.fix


def _slider_crank():
    eq = lg.derive(lg.load("slider-crank"))
    p = np.array(list(eq.parameters.values()), float)
    p[[s.name for s in eq.parameters].index("r")] = 0.35  # crank = rod: a dead point at th = pi/2
    return eq, p


def test_numpy_numba_and_c_projections_return_the_same_code_at_a_dead_point_and_at_nan():
    """The slider-crank with crank = rod at its dead point (th = pi/2, the slider at the crank's
    pivot: G loses rank), with velocities off the constraints, and the same state with a NaN."""
    eq, p = _slider_crank()
    cm = constrained_model(eq, compile_equations(eq, "scipy"))
    dead = np.array([np.pi / 2, -np.pi / 2, 0.0, 3.0, -3.0, 0.5])
    nan = dead.copy()
    nan[1] = np.nan
    fine = np.array([0.3, -0.3, 0.7 * np.cos(0.3), 0.0, 0.0, 0.0])  # on the constraints (r = L), at rest
    for x, code in ((dead, SINGULAR), (nan, NOT_FINITE), (fine, MET)):
        y, got = cm.projection(0.0, x, p)
        assert got == code and np.array_equal(y, x, equal_nan=True)
        assert np.array_equal(cm.project(0.0, x, p), x, equal_nan=True)  # project: the state as it was left
        for backend in BACKENDS:
            yb, _, got = compiled_projection(compile_equations(eq, backend), 0.0, x, p)
            assert got == code, backend
            assert np.array_equal(yb, y, equal_nan=True), backend
    with pytest.raises(lg.SimulationError, match=r"the projection onto the constraints failed at t = 0: it met a "
                       r"singular system, and the state was left off the constraints; the constraints' Jacobian G "
                       r"loses rank at t = 0") as caught:
        cm.projected(0.0, dead, p)
    assert caught.value.status is lg.Status.PROJECTION_SINGULAR and caught.value.time == 0.0
    with pytest.raises(lg.SimulationError, match=r"failed at t = 0.5 in the state th = 1\.5708, ph = nan, .*: "
                       r"the state is not finite \(NaN or infinity\), so the state cannot be moved onto the "
                       r"constraints; check the model's parameters") as caught:
        cm.projected(0.5, nan, p)
    assert caught.value.status is lg.Status.PROJECTION_NOT_FINITE


def _skewed():
    """Two holonomic constraints whose rows [1, 0] and [1, 1e-13] are dependent to working precision
    in the identity metric of the projection's Gauss-Newton step, while the kinetic-energy metric of
    the saddle-point solve (y's inertia 1e-26) keeps them at 45 degrees: the solve goes on, the first
    projection that has to move the coordinates meets a singular system."""
    m = lg.Model("skewed", coordinates=["x", "y", "z"], parameters={"e": 1e-26, "b": 1e-13})
    m.add_energy(T="x_dot**2/2 + e*y_dot**2/2 + z_dot**2/2", V="z**2/2")
    m.add_constraint("x - sin(t)", name="c1")
    m.add_constraint("x + b*y - sin(t) - b*cos(t)", name="c2")
    return lg.derive(m)


@pytest.mark.parametrize("backend", [*BACKENDS, "scipy"])
def test_a_run_whose_projection_meets_a_singular_system_stops_with_its_status(backend):
    eq = _skewed()
    with pytest.raises(lg.SimulationError, match=r"^the projection onto the constraints failed at t = 0\.07: it met "
                       r"a singular system, and the state was left off the constraints; the constraints' Jacobian G "
                       r"loses rank at t = 0\.07 \(state x = 0\.0699428, .*\): the rows -0\.707\*c1 \+0\.707\*c2 "
                       r"combine to zero") as caught:
        lg.simulate(eq, 1.0, initial={"y": 1.0, "x_dot": 1.0, "z": 0.1}, backend=backend, rtol=1e-3, atol=1e-3)
    error = caught.value
    assert error.status is lg.Status.PROJECTION_SINGULAR and error.time == pytest.approx(0.07, abs=1e-12)
    assert "drive other coordinates" in str(error)  # the status's fix
    partial = error.partial  # the rows before the failed projection, on the constraints
    assert len(partial.t) == 7 and partial.stats["status"] is lg.Status.PROJECTION_SINGULAR
    assert np.allclose(partial["x"], np.sin(partial.t), atol=1e-12)
    assert np.allclose(partial["y"], np.cos(partial.t), atol=1e-3)


def _cartesian_pendulum_with_nan_length():
    """The rod's length l enters only g = l - sqrt(x**2 + y**2) (M, f, G and c do not read it): with
    l = NaN the saddle-point solve goes on and the first projection meets a g that is not finite."""
    eq = lg.derive(lg.load("cartesian-pendulum"))
    p = np.array(list(eq.parameters.values()), float)
    p[[s.name for s in eq.parameters].index("l")] = np.nan
    return eq, p, np.array([1.0, 0.0, 0.0, 0.0]), np.linspace(0.0, 1.0, 11)


_NOT_FINITE = (r"^the projection onto the constraints failed at t = 0\.046\d* in the state x = 0\.99994\d*, .*: "
               r"constraint 'rod' is not finite \(NaN or infinity\) there, so the state cannot be moved onto the "
               r"constraints; check the model's parameters, its constraints' expressions")


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_compiled_run_stops_where_the_projection_meets_nan(backend):
    eq, p, x0, times = _cartesian_pendulum_with_nan_length()
    fast = compile_equations(eq, backend)
    raw = run_dop853(fast, x0, times, p, _input_programs(eq, []), 1e-8, 1e-8, project=_address(fast.project_c),
                     nwork=work_size(eq.n, 1))
    assert raw.status == lg.Status.PROJECTION_NOT_FINITE and raw.stop_measure == NOT_FINITE
    assert len(raw.t) == 1 and 0.0 < raw.stop_t < 0.1  # the first step's end, before the first output after t = 0
    cm = constrained_model(eq, compile_equations(eq, "scipy"))
    error = _compiled_failure(fast, cm, raw, p, x0)
    assert isinstance(error, lg.SimulationError) and error.status is lg.Status.PROJECTION_NOT_FINITE
    assert error.time == raw.stop_t
    with pytest.raises(lg.SimulationError, match=_NOT_FINITE):
        raise error


def test_the_numpy_path_stops_where_the_projection_meets_nan_as_compiled():
    eq, p, x0, times = _cartesian_pendulum_with_nan_length()
    cm = constrained_model(eq, compile_equations(eq, "scipy"))
    with pytest.raises(lg.SimulationError, match=_NOT_FINITE) as caught:
        integrate(cm, x0, times, p, lambda t, x: np.zeros(0), 1e-8, 1e-8, np.inf)
    fast = compile_equations(eq, "numba")
    raw = run_dop853(fast, x0, times, p, _input_programs(eq, []), 1e-8, 1e-8, project=_address(fast.project_c),
                     nwork=work_size(eq.n, 1))
    assert caught.value.status is lg.Status.PROJECTION_NOT_FINITE
    assert caught.value.time == pytest.approx(raw.stop_t, rel=1e-9)  # the same first step as SciPy's DOP853
    assert len(caught.value.rows) == 1


def test_without_a_model_the_status_still_names_the_projection():
    """failure(), the one map from a status to an error, says what a projection status means even
    where no constrained model is at hand to diagnose it."""
    from lagrangian.numeric._simulate import failure

    eq = lg.derive(lg.load("cartesian-pendulum"))
    nm = compile_equations(eq, "scipy")
    error = failure(nm, 8, 0.25, np.array([1.0, 0.0, 0.0, 0.0]), 4.0, nm.parameter_values)
    assert error.status is lg.Status.PROJECTION_NOT_FINITE and error.time == 0.25
    assert str(error).startswith("the projection onto the constraints failed at t = 0.25 in the state x = 1, y = 0, "
                                 "x_dot = 0, y_dot = 0: the projection onto the constraints met values that are not "
                                 "finite")


def test_a_batch_run_whose_projection_fails_has_the_status_the_others_go_on():
    """simulate_batch: the runs whose projection meets the singular system stop with
    Status.PROJECTION_SINGULAR at the time simulate() stops; a run whose constraints stay regular
    (b = 1, e = 1: the rows at 45 degrees in both metrics) ends as asked."""
    eq = _skewed()
    batch = lg.simulate_batch(eq, 1.0, initial={"y": 1.0, "x_dot": 1.0, "z": 0.1}, params={"b": [1e-13, 1.0],
                                                                                          "e": [1e-26, 1.0]},
                              rtol=1e-3, atol=1e-3)
    assert batch.statuses == [lg.Status.PROJECTION_SINGULAR, lg.Status.SUCCESS]
    assert batch.stop_time[0] == pytest.approx(0.07, abs=1e-12) and batch.stop_time[1] == 1.0
    assert np.all(np.isnan(batch.x[0, 7:])) and np.all(np.isfinite(batch.x[1]))
