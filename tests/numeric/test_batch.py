"""Batch runs: equal to single runs, parameter grids, failures that stop one run only, the Dask
path (a LocalCluster), the progress bar (off when stderr is not a terminal), and the errors."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian._progress import Progress, progress
from lagrangian.errors import ModelError


@pytest.fixture(scope="module")
def dp():
    return lg.derive(lg.load("double-pendulum"))


def forced():
    return lg.Model("forced", coordinates=["x"], parameters={"m": 1.0, "k": 4.0, "c": 0.3}, inputs=["F"],
                    T="m*x_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2", Q={"x": "F"})


def test_batch_equals_single_runs(dp):
    rng = np.random.default_rng(7)
    B = 12
    X0 = np.zeros((B, 4))
    X0[:, :2] = rng.uniform(-1.5, 1.5, (B, 2))
    l2 = rng.uniform(0.5, 1.5, B)
    batch = lg.simulate_batch(dp, 3.0, X0, params={"l2": l2}, dt=0.1, rtol=1e-8, atol=1e-8)
    assert batch.x.shape == (B, 31, 4) and batch.t.shape == (31,) and len(batch) == B
    assert np.all(batch.ok) and batch.backend == "numba"
    for i in range(B):
        single = lg.simulate(dp, 3.0, X0[i], params={"l2": float(l2[i])}, dt=0.1, rtol=1e-8, atol=1e-8)
        assert np.array_equal(single.t, batch.t)
        assert np.max(np.abs(single.x - batch.x[i])) <= 1e-13
        assert batch.nfev[i] == single.nfev
    assert np.array_equal(batch.parameters[:, batch.parameter_names.index("l2")], l2)
    assert np.array_equal(batch["theta2"], batch.x[:, :, 1])
    assert np.array_equal(batch.final, batch.x[:, -1])
    tr = batch.trajectory(3)
    assert tr.parameters["l2"] == l2[3] and np.array_equal(tr.x, batch.x[3])
    for arr in (batch.x, batch.t, batch.parameters, batch.status):
        assert not arr.flags.writeable


def test_batch_by_name_with_inputs_depending_on_parameters():
    grid = lg.grid({"k": [1.0, 4.0, 9.0], "c": [0.0, 0.2]})
    assert grid["k"].tolist() == [1, 1, 4, 4, 9, 9] and grid["c"].tolist() == [0, 0.2] * 3
    batch = lg.simulate_batch(forced(), 2.0, {"x": 1.0}, params=grid, inputs={"F": "0.1*k*sin(t)"}, dt=0.5)
    for i in range(6):
        single = lg.simulate(forced(), 2.0, {"x": 1.0}, params={"k": grid["k"][i], "c": grid["c"][i]},
                             inputs={"F": "0.1*k*sin(t)"}, dt=0.5)
        assert np.max(np.abs(single.x - batch.x[i])) <= 1e-13
    # undamped, unforced runs would follow cos(sqrt(k) t); the forcing makes them differ
    assert np.all(batch.x[:, 0, 0] == 1.0)


def test_a_failing_run_stops_alone():
    m = lg.Model("cart-pendulum-massless", coordinates=["q1", "q2"], parameters={"M": 0.5, "L": 1.0, "g": 9.81})
    q1, q2 = m.q
    M, L, g = (m.symbol(n) for n in ("M", "L", "g"))
    m.add_particle(M, (q1 + L * lg.cos(q2), L + L * lg.sin(q2)), name="pendulum")
    m.add_gravity(g)
    batch = lg.simulate_batch(m, 0.3, {"q2": [0.5, 0.5, 0.5]}, params={"g": [0.0, 9.81, 100.0]}, dt=0.01)
    t_star = math.sqrt(2 * (1 + math.sin(0.5)) / 100.0)  # under g = 100 the bob reaches the bottom at 0.19 s
    assert batch.status.tolist()[:2] == [0, 0] and batch.status[2] in (1, 2)
    assert batch.stop_time[2] == pytest.approx(t_star, abs=1e-6)
    assert "singular" in batch.messages[2] or "event" in batch.messages[2]
    k = int(t_star / 0.01) + 1
    assert np.all(np.isfinite(batch.x[2, :k])) and np.all(np.isnan(batch.x[2, k + 1:]))
    assert "2 reached the end" in repr(batch)


def test_dask_local_cluster_gives_the_same_arrays(dp):
    distributed = pytest.importorskip("dask.distributed")
    X0 = np.zeros((10, 4))
    X0[:, 0] = np.linspace(-1, 1, 10)
    local = lg.simulate_batch(dp, 2.0, X0, t_eval=[1.0, 2.0])
    # and in lanes: 40 runs, chunks of two blocks of 16 (the chunk size rounded up to whole blocks)
    X1 = np.zeros((40, 4))
    X1[:, 0] = np.linspace(-1, 1, 40)
    local_lanes = lg.simulate_batch(dp, 2.0, X1, t_eval=[1.0, 2.0], lanes=16)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = lg.simulate_batch(dp, 2.0, X0, t_eval=[1.0, 2.0], client=client, chunk_size=3)
        remote_lanes = lg.simulate_batch(dp, 2.0, X1, t_eval=[1.0, 2.0], client=client, chunk_size=20, lanes=16)
    assert np.array_equal(local.x, remote.x)
    assert np.array_equal(local.nfev, remote.nfev)
    assert np.array_equal(local_lanes.x, remote_lanes.x)
    assert np.array_equal(local_lanes.nfev, remote_lanes.nfev)


def test_progress_bar_is_silent_when_not_a_terminal(dp, capsys):
    lg.simulate_batch(dp, 1.0, np.zeros((4, 4)) + 0.1, t_eval=[1.0])
    assert capsys.readouterr().err == ""
    buf = io.StringIO()
    with progress(10, "simulating", stream=buf, delay=0.0) as bar:  # not a tty: nothing
        bar.update(10)
    assert buf.getvalue() == ""


def test_progress_bar_draws_when_enabled():
    buf = io.StringIO()
    with Progress(4, "simulating", stream=buf, delay=0.0, enabled=True, interval=0.0) as bar:
        bar.update(1)
        bar.set(4)
    text = buf.getvalue()
    assert text.startswith("\rsimulating [") and "4/4" in text and text.endswith("\n")
    assert "#" in text


def test_progress_bar_waits_for_slow_work():
    buf = io.StringIO()
    with Progress(4, "x", stream=buf, delay=60.0, enabled=True) as bar:
        bar.update(4)
    assert buf.getvalue() == ""  # done before the delay: nothing drawn


def test_batch_errors():
    with pytest.raises(ModelError, match=r"the per-run arrays have different lengths: initial.x: 3, params.k: 2"):
        lg.simulate_batch(forced(), 1.0, {"x": [0.1, 0.2, 0.3]}, params={"k": [1.0, 2.0]})
    with pytest.raises(ModelError, match=r"'kk' is not a parameter of the model \(did you mean 'k'\?\)"):
        lg.simulate_batch(forced(), 1.0, params={"kk": [1.0, 2.0]})
    with pytest.raises(ModelError, match=r"simulate_batch runs in compiled code, which cannot call a Python function"):
        lg.simulate_batch(forced(), 1.0, inputs={"F": lambda t: 0.0})
    with pytest.raises(ModelError, match=r"backend must be one of auto, numba, c, got 'scipy'"):
        lg.simulate_batch(forced(), 1.0, backend="scipy")
    with pytest.raises(ModelError, match=r"the initial states must have shape \(B, 2\)"):
        lg.simulate_batch(forced(), 1.0, np.zeros((3, 5)))
    with pytest.raises(ModelError, match=r"must be a finite number: not so in params row 1"):
        lg.simulate_batch(forced(), 1.0, params={"k": [1.0, np.nan]})


@pytest.mark.parametrize("initial", [[{"x": 0.1}], "abc", [[1.0, "x"]], [[1.0, 2.0], [3.0]], {1, 2}])
def test_batch_initial_states_that_are_not_numbers_are_one_error(initial):
    """A list of mappings, text, a ragged list: one error naming what initial must be (before: a TypeError or
    ValueError from NumPy's conversion, with a traceback)."""
    with pytest.raises(ModelError, match=r"\[initial\]: the initial states must be numbers: an array of shape \(B, 2\) "
                                         r"\(x, x_dot\), or a mapping of these names to a number or a 1-d array \(one "
                                         r"value per run\); got "):
        lg.simulate_batch(forced(), 1.0, initial)


@pytest.mark.parametrize("value", ["abc", [1.0, "x"], [[1.0], [2.0, 3.0]], None, {"a": 1}, True])
def test_batch_per_run_values_that_are_not_numbers_are_one_error(value):
    for what, kwargs in (("initial.x", {"initial": {"x": value}}), ("params.k", {"params": {"k": value}})):
        with pytest.raises(ModelError, match=rf"\[{what}\]: {what} must be a number or a 1-d array of numbers \(one "
                                             r"value per run\), got "):
            lg.simulate_batch(forced(), 1.0, **kwargs)


# ------------------------------------------------------------------ grid: hostile axes (FUZZ)
@pytest.mark.parametrize("axes", [3, "abc", [1, 2], None, b"k"])
def test_grid_of_something_that_is_not_a_mapping_is_one_error(axes):
    """Before: TypeError ('int' object is not iterable, string indices must be integers) or IndexError."""
    with pytest.raises(ModelError, match=r"\[axes\]: grid\(\) takes a mapping of names to the values of each axis, "
                                         r"such as grid\(\{'k': \[1, 2, 3\], 'c': \[0\.1, 0\.2\]\}\), got "):
        lg.grid(axes)


@pytest.mark.parametrize("values", ["abc", [1, [2]], [], [1.0, float("nan")], [1.0, float("inf")], {"a": 1},
                                    np.ones((2, 2)), object(), 1j])
def test_grid_axis_values_that_are_not_numbers_are_one_error(values):
    """Before: NumPy's ValueError (could not convert string to float, inhomogeneous shape) or TypeError."""
    with pytest.raises(ModelError, match=r"\[axes\.k\]: the values of axis 'k' must be one finite number or a "
                                         r"non-empty list of finite numbers, such as grid\("):
        lg.grid({"k": values, "c": [0.1]})


def test_a_grid_past_the_row_limit_is_one_error():
    """10^7 combinations: refused before itertools.product builds them (before: minutes and gigabytes)."""
    with pytest.raises(ModelError, match=r"\[axes\]: the grid has 1e\+07 combinations \(1000 x 1000 x 10\), more "
                                         r"than the limit of 1000000: use fewer values on an axis; "
                                         r".*LAGRANGIAN_MAX_ROWS"):
        lg.grid({"a": range(1000), "b": range(1000), "c": range(10)})


def test_grid_still_combines_numbers_and_ranges():
    out = lg.grid({"k": range(1, 3), "c": 0.5})
    assert out["k"].tolist() == [1.0, 2.0] and out["c"].tolist() == [0.5, 0.5]


@pytest.mark.parametrize("chunk_size", ["abc", 0, -4, 2.5, float("nan"), True, b"x"])
def test_a_chunk_size_that_is_not_a_positive_integer_is_one_error(chunk_size):
    """Before: TypeError ('str' object cannot be interpreted as an integer) or range()'s ValueError (0)."""
    model = lg.load("double-pendulum")
    with pytest.raises(ModelError, match=r"\[chunk_size\]: chunk_size must be a positive integer \(runs per chunk\), "
                                         r"such as chunk_size=64, got "):
        lg.simulate_batch(model, 0.1, {"theta1": [0.1, 0.2]}, chunk_size=chunk_size)


@pytest.mark.parametrize("backend", [np.ones((2, 2)), 3, None])
def test_a_backend_that_is_not_a_name_is_one_error(backend):
    model = lg.load("double-pendulum")
    with pytest.raises(ModelError, match=r"\[backend\]: simulate_batch runs in compiled code: backend must be one of "
                                         r"auto, numba, c, got "):
        lg.simulate_batch(model, 0.1, {"theta1": [0.1, 0.2]}, backend=backend)


@pytest.mark.parametrize("equations", ["double-pendulum", None, 3])
def test_compile_of_something_that_is_not_equations_says_what_it_expects(equations):
    """Before: TypeError 'cannot create weak reference to str object' from the cache."""
    with pytest.raises(TypeError, match=r"compile\(\) expects Equations \(lagrangian\.derive\(model\)\), got "):
        lg.compile(equations)


@pytest.mark.parametrize("backend", [np.ones(2), 3])
def test_compile_with_a_backend_that_is_not_text_is_one_error(dp, backend):
    with pytest.raises(ModelError, match=r"backend must be one of auto, numba, c, scipy \(text\), got "):
        lg.compile(dp, backend)
