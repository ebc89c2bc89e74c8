"""simulate()'s output stage (issue 20): a call made again with the same plain arguments takes the
options, the checks and the compiled model of the first (numeric/_simulate.py, _checked_key), and a
compiled run hands its own arrays to the Trajectory without copies. Nothing a call sees may change:
the same numbers as the whole path, every check still made for a call that differs in anything (a
value's type or sign included), the model's [simulation] table and the limits read as they are now."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.numeric import SimulationOptions, _simulate
from lagrangian.numeric._cache import per_equations


@pytest.fixture()
def eqs():
    """A fresh snapshot each test (the kept calls live with the Equations object)."""
    return lg.derive(lg.load("double-pendulum"))


def count_prepares(monkeypatch) -> list:
    calls = []
    prepare = _simulate._prepare

    def counting(nm, opts):
        calls.append(opts)
        return prepare(nm, opts)

    monkeypatch.setattr(_simulate, "_prepare", counting)
    return calls


def test_a_call_made_again_skips_the_checks_and_gives_the_whole_paths_numbers(eqs, monkeypatch):
    calls = count_prepares(monkeypatch)
    first = lg.simulate(eqs, 2.0, {"theta2": 0.5}, rtol=1e-8, atol=1e-8)
    again = lg.simulate(eqs, 2.0, {"theta2": 0.5}, rtol=1e-8, atol=1e-8)
    assert len(calls) == 1  # the second call was checked before
    # options= always takes the whole path: merged with the model file's, checked, compiled model looked up
    whole = lg.simulate(eqs, 2.0, {"theta2": 0.5}, rtol=1e-8, atol=1e-8,
                        options=SimulationOptions.from_model(eqs.model))
    assert len(calls) == 2
    for tr in (again, whole):
        np.testing.assert_array_equal(tr.t, first.t)
        np.testing.assert_array_equal(tr.x, first.x)
        np.testing.assert_array_equal(tr.energy, first.energy)
        assert tr.stats == first.stats and tr.parameters == first.parameters and tr.message == first.message
    assert first.x[0].tolist() == [2.0, 0.5, 0.0, 0.0] and len(first.t) == 201
    assert first.stats["status"] == lg.Status.SUCCESS and first.stats["nstep"] > 0
    # the energy of the undamped pendulum is conserved to the tolerance
    assert np.max(np.abs(first.energy - first.energy[0])) < 1e-6


def test_each_runs_arrays_are_its_own_and_read_only(eqs):
    a = lg.simulate(eqs, 1.0, rtol=1e-8, atol=1e-8)
    b = lg.simulate(eqs, 1.0, rtol=1e-8, atol=1e-8)
    for name in ("t", "x", "u", "energy"):
        x, y = getattr(a, name), getattr(b, name)
        assert not x.flags.writeable and not y.flags.writeable
        assert x.dtype == np.float64 and x.flags.c_contiguous
        assert x.size == 0 or not np.shares_memory(x, y), name
    with pytest.raises(ValueError, match="read-only"):
        a.x[0, 0] = 1.0
    assert a.u.shape == (len(a.t), 0) and a.x.shape == (len(a.t), 4)


def test_a_trajectory_built_by_hand_still_copies_what_it_is_given():
    x = np.zeros((3, 2))
    frozen = np.ones(3)
    frozen.setflags(write=False)
    tr = lg.Trajectory(t=np.arange(3.0), x=x, state_names=("q", "q_dot"), energy=frozen, energy_name="energy")
    x[0, 0] = 5.0
    assert tr.x[0, 0] == 0.0 and not np.shares_memory(tr.energy, frozen) and not tr.x.flags.writeable


@pytest.mark.parametrize("good, bad, message", [
    ({"initial": {"theta1": 1}}, {"initial": {"theta1": True}},
     "the value of 'theta1' must be a finite number, got True"),
    ({"initial": {"theta1": 1.0}}, {"initial": {"theta1": math.nan}},
     "the value of 'theta1' must be a finite number, got nan"),
    ({"rtol": 1e-8}, {"rtol": -1e-8}, "rtol must be a positive number, got -1e-08"),
    ({"params": {"m1": 1.0}}, {"params": {"m1": math.inf}}, "the value of 'm1' must be a finite number, got inf"),
    ({"t_end": 1}, {"t_end": True}, "t_end must be a number, got True"),
    ({"inputs": None}, {"inputs": {"F": 1.0}}, "'F' is not an input of the model"),
    ({"initial": {"theta1": 1.0}}, {"initial": {"theta_1": 1.0}}, "'theta_1' is not a coordinate or velocity"),
])
def test_a_call_that_differs_in_anything_is_checked_again(eqs, good, bad, message):
    lg.simulate(eqs, **{"t_end": 0.5, **good})
    lg.simulate(eqs, **{"t_end": 0.5, **good})  # kept
    with pytest.raises(lg.ModelError, match=message.replace("(", r"\(").replace(")", r"\)")):
        lg.simulate(eqs, **{"t_end": 0.5, **bad})


def test_minus_zero_is_not_zero(eqs):
    plus = lg.simulate(eqs, 0.1, {"theta1_dot": 0.0})
    minus = lg.simulate(eqs, 0.1, {"theta1_dot": -0.0})
    assert not np.signbit(plus.x[0, 2]) and np.signbit(minus.x[0, 2])


def test_the_models_simulation_table_is_read_as_it_is_now(eqs):
    assert len(lg.simulate(eqs, dt=0.5).t) == 41  # the model file's t_end = 20
    eqs.model.simulation["t_end"] = 1.0
    assert len(lg.simulate(eqs, dt=0.5).t) == 3
    eqs.model.simulation["initial"]["theta1"] = 0.25
    assert lg.simulate(eqs, dt=0.5).x[0, 0] == 0.25


def test_the_limits_are_read_as_they_are_now(eqs, monkeypatch):
    assert len(lg.simulate(eqs, 1.0, dt=0.01).t) == 101
    monkeypatch.setenv("LAGRANGIAN_MAX_ROWS", "100")
    with pytest.raises(lg.ModelError, match="asks for 101 output rows, too many to keep"):
        lg.simulate(eqs, 1.0, dt=0.01)
    monkeypatch.setenv("LAGRANGIAN_MAX_EXPONENT", "2")
    monkeypatch.setenv("LAGRANGIAN_MAX_ROWS", "1000")
    model = lg.Model("forced", coordinates=["x"], parameters={"k": 4.0}, inputs=["F"], T="x_dot**2/2",
                     V="k*x**2/2", Q={"x": "F"})
    forced = lg.derive(model)
    lg.simulate(forced, 1.0, inputs={"F": "t**2"})
    monkeypatch.setenv("LAGRANGIAN_MAX_EXPONENT", "1")
    with pytest.raises(lg.ModelError, match="exponent too large"):
        lg.simulate(forced, 1.0, inputs={"F": "t**2"})


def test_a_compiled_model_and_its_equations_keep_their_own_calls(eqs):
    cm = lg.compile(eqs, backend="numba")
    a = lg.simulate(eqs, 0.5)
    b = lg.simulate(cm, 0.5)
    c = lg.simulate(eqs, 0.5)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.x, c.x)
    kept = per_equations(eqs)["simulate.checked"]
    assert [entry[0] for entry in kept.values()].count(cm) == 1


def test_the_calls_kept_are_the_newest_few(eqs):
    for k in range(_simulate._CHECKED_CALLS + 5):
        lg.simulate(eqs, 0.01 * (k + 1), dt=0.01)
    kept = per_equations(eqs)["simulate.checked"]
    assert len(kept) == _simulate._CHECKED_CALLS
    newest = lg.simulate(eqs, 0.01 * (_simulate._CHECKED_CALLS + 5), dt=0.01)
    assert len(newest.t) == _simulate._CHECKED_CALLS + 6


def test_calls_the_key_cannot_hold_take_the_whole_path(eqs, monkeypatch):
    calls = count_prepares(monkeypatch)
    state = np.array([1.0, 0.0, 0.0, 0.0])
    for _ in range(2):
        lg.simulate(eqs, 0.1, state)  # an array
        lg.simulate(eqs, 0.1, {"theta1": np.float32(1.0)})  # a NumPy number
        lg.simulate(eqs, 0.1, events={"up": "theta1"})  # events, t_eval, stop_on, sample_time, options
        lg.simulate(eqs, 0.1, t_eval=[0.0, 0.05, 0.1])
    assert len(calls) == 8
    # a SciPy run is checked every time
    lg.simulate(eqs, 0.1, backend="scipy")
    lg.simulate(eqs, 0.1, backend="scipy")
    assert len(calls) == 10


def test_a_table_the_key_cannot_hold_is_read_every_time(eqs, monkeypatch):
    calls = count_prepares(monkeypatch)
    eqs.model.simulation["initial"] = {"theta1": np.float64(0.5)}  # a NumPy number
    assert lg.simulate(eqs, 0.1).x[0, 0] == 0.5
    eqs.model.simulation["initial"]["theta1"] = np.float64(0.75)
    assert lg.simulate(eqs, 0.1).x[0, 0] == 0.75
    assert len(calls) == 2
    eqs.model.simulation["initial"] = {"theta1": 0.75}  # plain again
    again = lg.simulate(eqs, 0.1, [0.75, 0.0, 0.0, 0.0])  # a list is a plain value: kept
    assert lg.simulate(eqs, 0.1, [0.75, 0.0, 0.0, 0.0]).x.tolist() == again.x.tolist()
    assert len(calls) == 3


def test_merged_options_are_the_dataclass_replace_of_the_model_files():
    import dataclasses

    base = SimulationOptions.from_model(lg.load("double-pendulum"))
    merged = base.merged(rtol=1e-6, initial={"theta2": 0.5}, t_end=3)
    expected = dataclasses.replace(base, rtol=1e-6, t_end=3, initial={"theta1": 2.0, "theta2": 0.5},
                                   given={"theta2": 0.5})
    assert merged == expected and type(merged) is SimulationOptions and hash(merged.stop_on) == hash(())
    assert dict(merged.initial) == {"theta1": 2.0, "theta2": 0.5} and base.rtol == 1e-9 and base.t_end == 20.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        merged.rtol = 1.0
    assert base.merged(rtol=None) is base


@pytest.mark.parametrize("kind", ["variational", "c", "inputs"])
def test_every_compiled_run_kept_gives_the_whole_paths_numbers(kind, monkeypatch):
    """The variational integrator, the C backend and inputs given as expressions (their programs kept
    with the run) take the kept call as DOP853 in numba does."""
    if kind == "c":
        from lagrangian.numeric._cbackend import c_compiler

        if c_compiler() is None or importlib.util.find_spec("cffi") is None:
            pytest.skip("no C compiler or cffi for the C backend")
    model = lg.Model("forced", coordinates=["x"], parameters={"m": 1.0, "k": 4.0}, inputs=["F"],
                     T="m*x_dot**2/2", V="k*x**2/2", Q={"x": "F"})
    eqs = lg.derive(model)
    args = {"variational": {"method": "variational", "initial": {"x": 1.0}},
            "c": {"backend": "c", "initial": {"x": 1.0}},
            "inputs": {"inputs": {"F": "cos(3*t)"}}}[kind]
    calls = count_prepares(monkeypatch)
    first = lg.simulate(eqs, 2.0, **args)
    again = lg.simulate(eqs, 2.0, **args)
    whole = lg.simulate(eqs, 2.0, **args, options=SimulationOptions.from_model(eqs.model))
    assert len(calls) == 2
    for tr in (again, whole):
        np.testing.assert_array_equal(tr.x, first.x)
        np.testing.assert_array_equal(tr.u, first.u)
        np.testing.assert_array_equal(tr.energy, first.energy)
        assert tr.stats == first.stats
    t = first.t
    if kind == "inputs":  # x'' + 4 x = cos(3 t) from rest: x = (cos(2 t) - cos(3 t)) / 5
        np.testing.assert_allclose(first.x[:, 0], (np.cos(2 * t) - np.cos(3 * t)) / 5, atol=1e-7)
        np.testing.assert_allclose(first.u[:, 0], np.cos(3 * t), atol=1e-12)
    else:  # x = cos(2 t)
        np.testing.assert_allclose(first.x[:, 0], np.cos(2 * t), atol=2e-4 if kind == "variational" else 1e-7)


def test_the_progress_bar_shows_a_run_that_ended_before_its_first_look(monkeypatch):
    """The compiled run draws its bar from the main thread while the kernel runs in another: a run
    that ends before the main thread first looks still shows its last count (it did not: a race
    that made test_progress_bar_on_a_terminal_and_the_same_results fail now and then)."""
    import io
    import threading

    import lagrangian._progress as P
    from lagrangian.numeric._fast import _with_progress

    stream = io.StringIO()

    class Immediate(P.Progress):  # no 1 s delay, drawn into `stream`
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **{**kwargs, "delay": 0.0, "stream": stream})

    start = threading.Thread.start

    def start_and_finish(self):  # the worker ends before the main thread looks
        start(self)
        self.join()

    monkeypatch.setattr(P, "Progress", Immediate)
    monkeypatch.setattr(threading.Thread, "start", start_and_finish)
    stats = np.array([0, 0, 0, 7, 0], np.int64)
    assert _with_progress(lambda: 0, stats, 7, True) == 0
    shown = stream.getvalue()
    assert shown.startswith("\rsimulating [") and " 7/7 " in shown and shown.endswith(" s\n")


def _fields(tr) -> dict:
    import dataclasses

    return {f.name: getattr(tr, f.name) for f in dataclasses.fields(tr)}


def _same_trajectory(a, b) -> None:
    """Every field of `a` equal to `b`'s (arrays bit for bit, with their dtype, shape and flags), in
    the same order, the stats' keys in the same order."""
    fa, fb = _fields(a), _fields(b)
    assert list(a.__dict__) == list(b.__dict__)
    for name, value in fa.items():
        other = fb[name]
        if isinstance(value, np.ndarray):
            assert type(other) is np.ndarray and value.dtype == other.dtype and value.shape == other.shape, name
            assert value.tobytes() == other.tobytes() and not value.flags.writeable and value.flags.c_contiguous, name
            assert not other.flags.writeable and (value.size == 0 or not np.shares_memory(value, other)), name
        elif name == "model":
            assert value is other
        elif name == "outputs":
            assert list(value) == list(other) and value is not other
            for key in value:
                assert value[key].tobytes() == other[key].tobytes() and not value[key].flags.writeable
        else:
            assert type(value) is type(other) and value == other, name
    assert list(a.stats) == list(b.stats) and type(a.stats["status"]) is lg.Status
    assert a.parameters is not b.parameters and a.stats is not b.stats and a.events is not b.events


def test_a_repeated_run_is_the_whole_paths_trajectory_field_by_field(eqs, monkeypatch):
    """The same call again runs the kept, prepared kernel call (_simulate._Repeat) and builds its
    Trajectory from a template (_trajectory.RunTemplate): the same object as run_trajectory's."""
    import dataclasses

    first = lg.simulate(eqs, 3.0, {"theta2": 0.5}, rtol=1e-8, atol=1e-8)
    kept = per_equations(eqs)["simulate.checked"]
    assert all(isinstance(entry[5], _simulate._Repeat) for entry in kept.values())
    again = lg.simulate(eqs, 3.0, {"theta2": 0.5}, rtol=1e-8, atol=1e-8)
    whole = lg.simulate(eqs, 3.0, {"theta2": 0.5}, rtol=1e-8, atol=1e-8,
                        options=SimulationOptions.from_model(eqs.model))
    _same_trajectory(again, first)
    _same_trajectory(again, whole)
    assert again.stats["nstep"] > 0 and again.message == lg.Status.SUCCESS.message and again.outputs == {}
    # frozen and immutable as any Trajectory; what a user changes in one is not in the next
    with pytest.raises(dataclasses.FrozenInstanceError):
        again.x = first.x
    with pytest.raises(ValueError, match="read-only"):
        again.t[0] = 1.0
    again.parameters["m1"] = 99.0
    again.stats["nstep"] = -1
    third = lg.simulate(eqs, 3.0, {"theta2": 0.5}, rtol=1e-8, atol=1e-8)
    _same_trajectory(third, first)
    assert third.conserved_drift()["energy"] < 1e-5 and third.to_csv() == first.to_csv()
    # pickled and copied as any Trajectory
    import copy
    import pickle

    np.testing.assert_array_equal(pickle.loads(pickle.dumps(third)).x, first.x)
    assert copy.copy(third).x is third.x


def test_a_repeated_run_that_fails_raises_the_whole_paths_error_and_partial_rows():
    """x'' = 4 x^3 from rest at x = 1 leaves to infinity at t = K(1/sqrt(2))/2 = 0.9270373 (the energy
    x_dot^2/2 - x^4 = -1: t = int_1^inf dx / sqrt(2 (x^4 - 1))): the kept call's run fails as the first
    did, through the same map (the error, its status, the finite rows before it)."""
    model = lg.Model("escape", coordinates=["x"], T="x_dot**2/2", V="-x**4")
    eqs = lg.derive(model)
    errors = []
    for _ in range(3):
        with pytest.raises(lg.SimulationError) as info:
            lg.simulate(eqs, 2.0, {"x": 1.0}, rtol=1e-8, atol=1e-8)
        errors.append(info.value)
    kept = per_equations(eqs)["simulate.checked"]
    assert len(kept) == 1 and isinstance(next(iter(kept.values()))[5], _simulate._Repeat)
    first = errors[0]
    blow_up = 1.8540746773013719 / 2  # K(1/sqrt(2))
    assert abs(first.time - blow_up) < 1e-4 and first.partial.t[-1] == 0.92 and first.status == lg.Status.STEP_TOO_SMALL
    for error in errors[1:]:
        assert str(error) == str(first) and error.status == first.status and error.time == first.time
        _same_trajectory(error.partial, first.partial)


def test_what_the_repeated_run_does_not_take_goes_the_whole_way(monkeypatch):
    """Inputs that switch (`where`), named outputs, the variational integrator and events: the kept
    call runs as _run_compiled (no _Repeat, or its run handed on), with the same numbers."""
    model = lg.Model("switched", coordinates=["x"], parameters={"k": 4.0}, inputs=["F"], T="x_dot**2/2",
                     V="k*x**2/2", Q={"x": "F"})
    model.add_output("twice", "2*x")
    eqs = lg.derive(model)
    cases = [{"inputs": {"F": "where(x > 0, -1, 1)"}}, {}, {"method": "variational"}]
    for args in cases:
        first = lg.simulate(eqs, 2.0, {"x": 1.0}, **args)
        again = lg.simulate(eqs, 2.0, {"x": 1.0}, **args)
        _same_trajectory(again, first)
        np.testing.assert_array_equal(again.outputs["twice"], 2 * again.x[:, 0])
    assert all(entry[5] is None for entry in per_equations(eqs)["simulate.checked"].values())
    with pytest.raises(lg.ModelError, match="cannot change"):  # (so _keep_checked asks for outputs once)
        eqs.model.add_output("thrice", "3*x")
    plain = lg.derive(lg.Model("switched", coordinates=["x"], parameters={"k": 4.0}, inputs=["F"],
                               T="x_dot**2/2", V="k*x**2/2", Q={"x": "F"}))
    first = lg.simulate(plain, 2.0, {"x": 1.0}, inputs={"F": "where(x > 0, -1, 1)"})
    assert first.stats["switches"] > 0
    again = lg.simulate(plain, 2.0, {"x": 1.0}, inputs={"F": "where(x > 0, -1, 1)"})
    assert isinstance(next(iter(per_equations(plain)["simulate.checked"].values()))[5], _simulate._Repeat)
    _same_trajectory(again, first)



def test_the_keys_tell_apart_what_simulate_treats_differently():
    """_argument_key keys the floats inside a dict, list or tuple in place (the repeated call's key):
    still by their exact bits and type."""
    key = _simulate._argument_key
    values = [0.0, -0.0, 1, 1.0, True, "1.0", None, float.fromhex("0x1.0000000000001p+0")]
    for wrap in (lambda v: v, lambda v: [v], lambda v: (v,), lambda v: {"a": v}, lambda v: {"a": [v]}):
        keys = [key(wrap(v)) for v in values]
        assert len(set(keys)) == len(values) and keys == [key(wrap(v)) for v in values]
    assert key([1.0]) != key((1.0,))
    for bad in ({1: 2.0}, {"a": np.float64(1.0)}, [np.array([1.0])], {"a": {"b": {2}}}, (lambda t: t,)):
        with pytest.raises(_simulate._Uncheckable):
            key(bad)
    assert _simulate._checked_key(None, None, 1e-8, {"x": -0.0}) != _simulate._checked_key(None, None, 1e-8, {"x": 0.0})
    assert _simulate._checked_key(None, np.float64(1.0)) is None
