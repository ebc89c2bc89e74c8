"""Constrained models simulate as unconstrained ones do: events (and stop_on), sampled inputs and
simulate_batch, on the compiled projected integration (DOP853 on the saddle-point right-hand side,
projected onto the constraints after every step).

Checked against independent paths: an event's crossing against the same crossing found on a dense
SciPy projected run (backend="scipy", interpolated by its states and velocities), a sampled
controller against a zero-order hold rolled by hand (one SciPy projected run per sample period, the
input held constant), a batch against its runs simulated one by one; and the refusals that remain
say why in terms of the mathematics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline

import lagrangian as lg
from lagrangian.numeric._cbackend import c_compiler
from lagrangian.numeric._simulate import _constrained_numbers


@pytest.fixture(scope="module")
def four_bar():
    return lg.derive(lg.load("four-bar"))


def _drift(eq, tr_t, X, p=None) -> float:
    """The largest |g| of the holonomic constraints over the rows (t, X)."""
    cm = _constrained_numbers(eq)
    p = np.array([float(v) for v in eq.parameters.values()]) if p is None else p
    return max(float(np.max(np.abs(cm.residuals(t, x, p)[0]))) for t, x in zip(tr_t, X))


def _crossings(tr, name: str, value: float) -> np.ndarray:
    """Where the column `name` crosses `value`, from a dense run: the cubic Hermite interpolant of
    the column and its velocity (error h^4/384 max|q''''|: below 1e-9 at h = 2e-3 here)."""
    return CubicHermiteSpline(tr.t, tr[name] - value, tr[f"{name}_dot"]).roots(extrapolate=False)


# ---------------------------------------------------------------------------------------- events
@pytest.mark.slow
def test_a_four_bar_event_is_located_where_the_dense_scipy_projected_run_crosses(four_bar):
    compiled = lg.simulate(four_bar, t_end=0.7, events={"up": "th3 - 2.0", "turn": "th3_dot"}, rtol=1e-11,
                           atol=1e-11)
    assert compiled.stats["backend"] == "numba"
    reference = lg.simulate(four_bar, t_end=0.7, dt=2e-3, rtol=1e-12, atol=1e-12, backend="scipy")
    expected = _crossings(reference, "th3", 2.0)
    up = compiled.events["up"]
    assert len(expected) == 2 and np.allclose(up["t"], expected, rtol=0, atol=1e-7)
    # the state recorded at each crossing: on the constraints, the rocker at th3 = 2 and turning where th3_dot = 0
    assert up["x"].shape == (2, 6) and np.allclose(up["x"][:, 2], 2.0, atol=1e-9)
    assert _drift(four_bar, up["t"], up["x"]) < 1e-12
    turn = compiled.events["turn"]
    th3 = CubicHermiteSpline(reference.t, reference["th3"], reference["th3_dot"])
    assert len(turn["t"]) == 1 and np.allclose(turn["x"][:, 5], 0.0, atol=1e-8)
    assert np.allclose(turn["x"][:, 2], th3(turn["t"]), atol=1e-8)  # the rocker's extreme angles, as SciPy's
    assert up["t"][0] < turn["t"][0] < up["t"][1]  # up to 2, over the top, back down through 2


def test_stop_on_ends_a_constrained_run_at_the_crossing(four_bar):
    full = lg.simulate(four_bar, t_end=1.0, events={"up": "th3 - 2.0"}, rtol=1e-11, atol=1e-11)
    stopped = lg.simulate(four_bar, t_end=1.0, events={"up": "th3 - 2.0"}, stop_on="up", rtol=1e-11, atol=1e-11)
    t_cross = full.events["up"]["t"][0]
    assert stopped.stats["stopped_by"] == "up" and stopped.stats["stop_time"] == pytest.approx(t_cross, abs=1e-12)
    assert stopped.t[-1] <= t_cross < stopped.t[-1] + 0.01 and len(stopped.t) == math.floor(t_cross / 0.01) + 1
    assert list(stopped.events["up"]["t"]) == pytest.approx([t_cross], abs=1e-12)
    # the rows of the stopping step come from its interpolant: projected onto the constraints as all others
    assert _drift(four_bar, stopped.t, stopped.x) < 1e-12 and stopped.stats["constraint_drift"]["position"] < 1e-12
    assert np.allclose(stopped.x, full.x[:len(stopped.t)], rtol=0, atol=1e-9)
    assert stopped.multipliers.shape == (len(stopped.t), 2) and np.all(np.isfinite(stopped.multipliers))


def test_events_of_a_constrained_model_where_they_are_not_watched(four_bar):
    with pytest.raises(lg.ModelError, match=r"events are watched by the compiled projected integration of a "
                                            r"constrained model: give the inputs as expression strings and use "
                                            r"method='DOP853' with a compiled backend \(backend='auto'\)"):
        lg.simulate(four_bar, t_end=0.1, events={"up": "th3 - 2.0"}, backend="scipy")
    with pytest.raises(lg.ModelError, match=r"events are not watched with constraints='eliminate': its right-hand "
                                            r"side finds the dependent coordinates by Newton on g\(q, t\) = 0 at every "
                                            r"evaluation, in SciPy's integrators, .*use constraints='project'"):
        lg.simulate(four_bar, t_end=0.1, events={"up": "th3 - 2.0"}, constraints="eliminate")
    with pytest.raises(lg.ModelError, match=r"method 'variational' does not integrate constrained models: use "
                                            r"method='DOP853' \(projected onto the constraints after every step\)\. "
                                            r"The midpoint rule's discrete Euler-Lagrange equations would need the "
                                            r"constraint forces G\^T lambda in them and g\(q\) = 0 imposed at every "
                                            r"step \(a RATTLE step"):
        lg.simulate(four_bar, t_end=0.1, method="variational")


# ------------------------------------------------------------------------------- sampled inputs
def test_a_sampled_controller_on_a_four_bar_is_the_zero_order_hold_rolled_by_hand(four_bar):
    Ts, law = 0.05, "0.5 - 0.3*th1_dot"
    tr = lg.simulate(four_bar, t_end=0.5, inputs={"tau": law}, sample_time=Ts, rtol=1e-12, atol=1e-12)
    assert tr.stats["backend"] == "numba" and tr.stats["samples"] == 11
    names = four_bar.state_names
    x = tr.x[0]
    for k in range(10):  # one SciPy projected run per period, the input held at its value at the sample instant
        held = 0.5 - 0.3 * x[names.index("th1_dot")]
        rows = (tr.t >= k * Ts - 1e-12) & (tr.t < (k + 1) * Ts - 1e-12)
        assert np.allclose(tr["tau"][rows], held, rtol=0, atol=1e-12)
        segment = lg.simulate(four_bar, t_end=Ts, dt=Ts, initial=dict(zip(names, x)), inputs={"tau": held},
                              backend="scipy", rtol=1e-12, atol=1e-12)
        x = segment.x[-1]
        assert np.allclose(tr.x[round((k + 1) * Ts / 0.01)], x, rtol=0, atol=1e-8)
    continuous = lg.simulate(four_bar, t_end=0.5, inputs={"tau": law}, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(continuous.x - tr.x)) > 1e-4  # the hold changes the motion: it is not ignored
    assert tr.stats["constraint_drift"]["position"] < 1e-12


def test_scipy_holds_the_sampled_inputs_of_a_constrained_model_as_the_compiled_run_does(four_bar):
    """One SciPy projected run per sample period; a sample instant at t_end too (its held value is the
    last row's input, as the compiled kernel records it)."""
    options = {"t_end": 0.5, "sample_time": 0.05, "rtol": 1e-12, "atol": 1e-12}
    compiled = lg.simulate(four_bar, inputs={"tau": "0.5 - 0.3*th1_dot"}, **options)
    scipy_run = lg.simulate(four_bar, inputs={"tau": "0.5 - 0.3*th1_dot"}, backend="scipy", **options)
    python_law = lg.simulate(four_bar, inputs={"tau": lambda t, x: 0.5 - 0.3 * x[3]}, **options)  # SciPy's path
    assert scipy_run.stats["backend"] == python_law.stats["backend"] == "scipy"
    assert scipy_run.stats["samples"] == compiled.stats["samples"] == 11
    assert np.max(np.abs(scipy_run.x - compiled.x)) < 1e-10 and np.array_equal(python_law.x, scipy_run.x)
    assert np.max(np.abs(scipy_run["tau"] - compiled["tau"])) < 1e-10
    assert scipy_run["tau"][-1] != scipy_run["tau"][-2]  # sampled again at t_end = 0.5
    assert np.max(np.abs(scipy_run.multipliers - compiled.multipliers)) < 1e-8
    assert scipy_run.stats["constraint_drift"]["position"] < 1e-12


def test_a_sampled_scipy_run_that_reaches_a_dead_point_keeps_the_rows_of_every_period():
    m = lg.Model("driven-rod", coordinates=["x", "y"], parameters={"g": 9.81})
    m.add_particle(1, ("x", "y"), name="bob")
    m.add_gravity("g")
    m.add_constraint("x**2 + y**2 - 1", name="rod")
    m.add_constraint("x - sin(t)", name="drive")
    m.input("F")
    m.add_generalized_force("y", "F")
    with pytest.raises(lg.SimulationError, match=r"the constraints' Jacobian G loses rank at t = 1\.5708") as caught:
        lg.simulate(lg.derive(m), t_end=3.0, initial={"x": 0.0, "y": -1.0}, inputs={"F": "-y_dot"},
                    sample_time=0.25, backend="scipy")
    partial = caught.value.partial
    assert len(partial.t) == 158 and partial.t[-1] == pytest.approx(1.57)
    assert np.allclose(partial["x"], np.sin(partial.t), atol=1e-7)
    # F held over each period at -y_dot of its sample instant 0, 0.25, ..., 1.5
    k = np.floor(partial.t / 0.25 + 1e-9).astype(int)
    samples = np.array([partial["y_dot"][round(0.25 * j / 0.01)] for j in range(7)])
    assert np.allclose(partial["F"], -samples[k], atol=1e-12)


def test_sampled_inputs_held_by_the_ode_in_the_independent_coordinates(four_bar):
    """constraints='eliminate' (th1 independent, th2 and th3 by Newton on g = 0): one run per period
    too, the same motion as the projected one."""
    options = {"t_end": 0.5, "inputs": {"tau": "0.5 - 0.3*th1_dot"}, "sample_time": 0.05, "rtol": 1e-12,
               "atol": 1e-12}
    eliminated = lg.simulate(four_bar, constraints="eliminate", **options)
    projected = lg.simulate(four_bar, **options)
    assert "elimination" in eliminated.stats and eliminated.stats["samples"] == 11
    assert np.max(np.abs(eliminated.x - projected.x)) < 1e-9
    assert np.max(np.abs(eliminated["tau"] - projected["tau"])) < 1e-9


# ---------------------------------------------------------------------------------------- batch
def test_a_batch_of_four_bars_is_its_runs_simulated_one_by_one(four_bar):
    grid = lg.grid({"a": [0.18, 0.2, 0.22], "mb": [1.0, 1.2]})
    batch = lg.simulate_batch(four_bar, 1.0, params=grid, inputs={"tau": "0.2*sin(3*t)"}, rtol=1e-10, atol=1e-10)
    assert batch.ok.all() and batch.x.shape == (6, 101, 6)
    for i in range(len(batch)):
        params = {k: float(v[i]) for k, v in grid.items()}
        one = lg.simulate(four_bar, 1.0, params=params, inputs={"tau": "0.2*sin(3*t)"}, rtol=1e-10, atol=1e-10)
        assert np.max(np.abs(one.x - batch.x[i])) < 1e-10
        p = np.array([params.get(k.name, v) for k, v in four_bar.parameters.items()], float)
        assert _drift(four_bar, batch.t, batch.x[i], p) < 1e-12  # projected onto its own constraints
    # the starts are assembled per run (th1 and th1_dot kept, th2 and th3 found for each crank length)
    assert np.all(batch.initial[:, 0] == 1.2) and np.ptp(batch.initial[:, 1]) > 0.01


@pytest.mark.slow
def test_a_constrained_batch_on_a_dask_cluster_gives_the_same_arrays(four_bar):
    distributed = pytest.importorskip("dask.distributed")
    params = {"a": np.linspace(0.18, 0.22, 5)}
    local = lg.simulate_batch(four_bar, 1.0, params=params, t_eval=[0.5, 1.0])
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = lg.simulate_batch(four_bar, 1.0, params=params, t_eval=[0.5, 1.0], client=client, chunk_size=2)
    assert local.ok.all() and np.array_equal(local.x, remote.x) and np.array_equal(local.nfev, remote.nfev)
    p = np.array([float(v) for v in four_bar.parameters.values()])
    p[0] = params["a"][-1]
    assert _drift(four_bar, remote.t, remote.x[-1], p) < 1e-12  # the workers projected too


def test_a_batch_run_that_reaches_a_dead_point_is_reported_alone():
    """A bob on a rod driven by x = A sin(t): with A = 1 the rod and the drive become dependent at t =
    pi/2 (y = 0); with A < 1 they never do."""
    m = lg.Model("driven-rod", coordinates=["x", "y"], parameters={"g": 9.81, "A": 1.0})
    m.add_particle(1, ("x", "y"), name="bob")
    m.add_gravity("g")
    m.add_constraint("x**2 + y**2 - 1", name="rod")
    m.add_constraint("x - A*sin(t)", name="drive")
    eq = lg.derive(m)
    batch = lg.simulate_batch(eq, 3.0, initial={"x": 0.0, "y": -1.0}, params={"A": [0.5, 1.0, 0.8]})
    assert list(batch.status) == [0, 6, 0] and list(batch.ok) == [True, False, True]
    assert batch.stop_time[1] == pytest.approx(np.pi / 2, abs=1e-6)
    assert "a dead point" in batch.messages[1]
    assert np.all(np.isnan(batch.x[1, 158:])) and np.all(np.isfinite(batch.x[1, :158]))
    assert np.allclose(batch["x"][1, :158], np.sin(batch.t[:158]), atol=1e-7)
    with pytest.raises(lg.SimulationError, match=r"the constraints' Jacobian G loses rank at t = 1\.5708"):
        lg.simulate(eq, 3.0, initial={"x": 0.0, "y": -1.0})  # alone, the same run raises
    for i in (0, 2):
        one = lg.simulate(eq, 3.0, initial={"x": 0.0, "y": -1.0}, params={"A": batch.parameters[i, 1]})
        assert np.max(np.abs(one.x - batch.x[i])) < 1e-10


def test_a_batch_run_whose_loop_cannot_close_names_the_run(four_bar):
    with pytest.raises(lg.ModelError, match=r"\[initial\]: run 1 of the batch \(a = 2, b = 0\.6, c = 0\.45, d = 0\.5, "
                                            r"ma = 0\.4, mb = 1\.2, mc = 0\.9, g = 9\.81\): the initial "
                                            r"coordinates do not meet constraint 'loop_x' .*give fewer coordinates"):
        lg.simulate_batch(four_bar, 0.1, params={"a": [0.2, 2.0]})  # a crank longer than b + c + d: no loop


# ------------------------------------------------------------------------------------ C backend
@pytest.mark.slow
@pytest.mark.subprocess  # cffi runs the C compiler
@pytest.mark.skipif(c_compiler() is None, reason="no C compiler ($CC, cc or gcc) for the C backend")
def test_the_c_backend_runs_events_sampled_inputs_and_batches_of_a_constrained_model_as_numba(four_bar):
    options = {"t_end": 0.7, "events": {"up": "th3 - 2.0"}, "stop_on": "up", "inputs": {"tau": "0.5 - 0.3*th1_dot"},
               "sample_time": 0.05, "rtol": 1e-11, "atol": 1e-11}
    numba_run = lg.simulate(four_bar, **options)
    c_run = lg.simulate(four_bar, backend="c", **options)
    assert c_run.stats["backend"] == "c" and c_run.stats["stopped_by"] == "up" and len(c_run.t) == len(numba_run.t)
    assert np.max(np.abs(c_run.x - numba_run.x)) < 1e-10
    assert c_run.events["up"]["t"] == pytest.approx(numba_run.events["up"]["t"], abs=1e-10)
    params = {"a": [0.18, 0.2, 0.22]}
    numba_batch = lg.simulate_batch(four_bar, 1.0, params=params)
    c_batch = lg.simulate_batch(four_bar, 1.0, params=params, backend="c")
    assert c_batch.backend == "c" and c_batch.ok.all() and np.max(np.abs(c_batch.x - numba_batch.x)) < 1e-10
