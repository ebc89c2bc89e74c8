"""Measured signals as inputs (lagrangian.Signal): a table of times and values, interpolated in
compiled code (the opcode ``table`` of the input programs), on numba, C and SciPy alike, in
simulate, simulate_batch and the CLI (--input F=@data.csv:column); tables that do not cover the
run and hostile CSV files get one clear error."""

from __future__ import annotations

import math
import re
import shutil

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.errors import ModelError

W, WN = 3.0, 2.0  # the drive's and the spring-mass's angular frequencies (m = 1, k = 4)


def spring_mass():
    return lg.Model("spring-mass", coordinates=["x"], parameters={"m": 1.0, "k": 4.0}, inputs=["F"],
                    T="m*x_dot**2/2", V="k*x**2/2", Q={"x": "F"})


@pytest.fixture(scope="module")
def eqs():
    return lg.derive(spring_mass())


def forced_response(t):
    """x'' + 4 x = sin(3 t) from rest: the particular solution and the free oscillation that cancels it."""
    return (np.sin(W * t) - W / WN * np.sin(WN * t)) / (WN**2 - W**2)


def sampled(h, t_end=2.0, **kw):
    ts = np.arange(0.0, t_end + h / 2, h)
    return lg.Signal(ts, np.sin(W * ts), **kw)


def test_linear_table_matches_the_closed_form_to_second_order(eqs):
    errors = []
    for h in (2e-3, 1e-3):
        traj = lg.simulate(eqs, 2.0, inputs={"F": sampled(h)}, rtol=1e-12, atol=1e-13)
        assert np.max(np.abs(traj["F"] - np.sin(W * traj.t))) < 1e-14  # the samples at the output times
        errors.append(np.max(np.abs(traj["x"] - forced_response(traj.t))))
    # linear interpolation of sin(3t): |error| <= h^2/8 * 9, integrated over the run
    assert errors[1] < 9 * 1e-6 / 8 * 2.0
    order = math.log2(errors[0] / errors[1])
    assert 1.9 < order < 2.1


def test_cubic_table_is_fourth_order(eqs):
    errors = [np.max(np.abs(lg.simulate(eqs, 2.0, inputs={"F": sampled(h, interpolation="cubic")}, rtol=1e-13,
                                        atol=1e-14)["x"] - forced_response(np.arange(0, 2.005, 0.01))))
              for h in (0.04, 0.02)]
    assert errors[1] < 1e-7
    assert 3.5 < math.log2(errors[0] / errors[1]) < 4.5


@pytest.mark.parametrize("interpolation", ["linear", "cubic"])
def test_numba_c_and_scipy_agree(eqs, interpolation):
    sig = sampled(0.05, interpolation=interpolation)
    backends = ["numba", "scipy"] + (["c"] if shutil.which("cc") or shutil.which("gcc") else [])
    runs = {b: lg.simulate(eqs, 2.0, inputs={"F": sig}, rtol=1e-12, atol=1e-13, backend=b, method="DOP853")
            for b in backends}
    for b in backends[1:]:
        assert np.max(np.abs(runs[b].x - runs["numba"].x)) < 1e-9, b
        assert np.max(np.abs(runs[b]["F"] - runs["numba"]["F"])) < 1e-14, b


def test_values_and_expressions_of_a_signal(eqs):
    sig = lg.Signal([0.0, 1.0, 3.0], [0.0, 2.0, -2.0])
    assert np.allclose(sig(np.array([0.0, 0.5, 1.0, 2.0, 3.0])), [0.0, 1.0, 2.0, 0.0, -2.0])
    cubic = lg.Signal(np.linspace(0, 1, 6), np.linspace(0, 1, 6) ** 3, interpolation="cubic")
    assert abs(float(cubic(0.37)) - 0.37**3) < 1e-14  # not-a-knot reproduces a cubic exactly
    # an expression of the signal (2*F(t) + 1) runs compiled and on SciPy, the same numbers
    held = lg.Signal([0.0, 1.0], [1.0, 3.0], extrapolation="hold")
    for backend in ("numba", "scipy"):
        traj = lg.simulate(eqs, 2.0, inputs={"F": 2 * held(eqs.t) + 1}, dt=0.5, backend=backend)
        assert np.allclose(traj["F"], [3.0, 5.0, 7.0, 7.0, 7.0], rtol=0, atol=1e-14)


def test_a_batch_with_a_signal(eqs):
    sig = sampled(0.01)
    k = np.array([4.0, 9.0, 16.0])
    batch = lg.simulate_batch(eqs, 2.0, {"x": [0.0, 0.0, 0.0]}, params={"k": k}, inputs={"F": sig}, dt=0.1,
                              rtol=1e-10, atol=1e-12)
    assert np.all(batch.ok)
    for i, ki in enumerate(k):
        single = lg.simulate(eqs, 2.0, inputs={"F": sig}, params={"k": float(ki)}, dt=0.1, rtol=1e-10, atol=1e-12)
        assert np.max(np.abs(batch.x[i] - single.x)) < 1e-12


def test_outside_the_table_is_refused_before_the_run_unless_held(eqs):
    sig = sampled(0.01, t_end=1.0)
    with pytest.raises(ModelError, match=r"covers t = 0 \.\. 1, but the run needs it on 0 \.\. 2; shorten t_end, "
                                         r"give a longer table, or give extrapolation='hold'"):
        lg.simulate(eqs, 2.0, inputs={"F": sig})
    with pytest.raises(ModelError, match="covers t = 0 .. 1"):
        lg.simulate_batch(eqs, 2.0, {"x": [0.0, 0.1]}, inputs={"F": sig})
    with pytest.raises(ModelError, match="not t plus a constant"):
        lg.simulate(eqs, 1.0, inputs={"F": sig(eqs.coordinates[0])})
    held = lg.Signal(sig.times, sig.values, extrapolation="hold")
    traj = lg.simulate(eqs, 2.0, inputs={"F": held}, dt=0.5)
    assert np.allclose(traj["F"][-2:], sig.values[-1], atol=1e-15)


@pytest.mark.parametrize("args, message", [
    (([0, 1, 1, 2], [0, 1, 2, 3]), r"time at index 2 \(1\) is repeated after 1; sort the samples"),
    (([0, 2, 1], [0, 1, 2]), r"time at index 2 \(1\) is not increasing after 2"),
    (([0, 1, 2], [0, np.nan, 2]), r"1 value\(s\) not finite \(NaN or inf\), the first at index 1"),
    (([0.0], [1.0]), r"1 samples, but linear interpolation needs at least 2"),
    (([0, 1, 2], [0, 1]), r"3 times but 2 values"),
])
def test_bad_tables(args, message):
    with pytest.raises(ModelError, match=message):
        lg.Signal(*args)


def test_bad_options():
    with pytest.raises(ModelError, match="needs at least 4; give more samples"):
        lg.Signal([0, 1, 2], [0, 1, 2], interpolation="cubic")
    with pytest.raises(ModelError, match="unknown interpolation 'spline'; choose 'linear' or 'cubic'"):
        lg.Signal([0, 1], [0, 1], interpolation="spline")
    with pytest.raises(ModelError, match="unknown extrapolation 'clamp'; choose 'error'"):
        lg.Signal([0, 1], [0, 1], extrapolation="clamp")


# ------------------------------------------------------------------------------------------- CSV


def write(tmp_path, text, name="data.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_csv_column(tmp_path):
    path = write(tmp_path, "time,acc,other\n0,0,5\n0.5,1,5\n1.0,4,5\n")
    sig = lg.Signal.from_csv(path, "acc")
    assert np.array_equal(sig.times, [0.0, 0.5, 1.0]) and np.array_equal(sig.values, [0.0, 1.0, 4.0])
    assert sig.name == "data.csv:acc"


@pytest.mark.parametrize("text, column, message", [
    ("t,acc\n0,1\n0.1,nan\n", "acc", r"row 3, column 'acc': 'nan' is not a finite number"),
    ("t,acc\n0,1\n0.1,abc\n", "acc", r"row 3, column 'acc': 'abc' is not a finite number"),
    ("t,acc\n0,1\n0.1,\n", "acc", r"row 3, column 'acc': 'empty' is not a finite number"),
    ("t,acc\n0,1\n0.2,2\n0.1,3\n", "acc", r"row 4, column 't': time 0.1 is earlier than the time 0.2 of row 3; "
                                         r"times must increase strictly"),
    ("t,acc\n0,1\n0,2\n", "acc", r"row 3, column 't': time 0 repeats the time 0 of row 2"),
    ("t,acc\n0,1\n", "acc", r"1 data row\(s\); a signal needs at least 2"),
    ("t,acc\n0,1\n1,2\n", "acx", r"no column 'acx' \(did you mean 'acc'\?\); its header row has t, acc"),
    ("t,acc\n0,1\n1,2\n", "t", r"column 't' is the time column"),
    ("", "acc", r"the file is empty"),
])
def test_hostile_csv(tmp_path, text, column, message):
    path = write(tmp_path, text)
    with pytest.raises(ModelError, match=str(path).replace("\\", "\\\\").replace(".", r"\.") + ": " + message):
        lg.Signal.from_csv(path, column)


def test_binary_file_and_non_numbers(tmp_path):
    path = tmp_path / "data.csv"
    path.write_bytes(b"t,acc\n\xff\xfe\x00\x81\n")
    with pytest.raises(ModelError, match=r"data\.csv: not a text CSV file \(not UTF-8\); save it as CSV text"):
        lg.Signal.from_csv(path, "acc")
    with pytest.raises(ModelError, match="signal 'signal': times and values must be arrays of numbers"):
        lg.Signal(["a", "b"], [1, 2])


def test_missing_csv(tmp_path):
    with pytest.raises(ModelError, match="cannot read the signal file .*nope.csv: .*; check the path"):
        lg.Signal.from_csv(tmp_path / "nope.csv", "acc")


# ------------------------------------------------------------------------------------------- CLI


def run_cli(capsys, *args):
    try:
        rc = main([str(a) for a in args])
    except SystemExit as exc:
        rc = exc.code if isinstance(exc.code, int) else 1
    out, err = capsys.readouterr()
    return rc, out, err


def model_file(tmp_path):
    path = tmp_path / "spring-mass.toml"
    path.write_text('name = "spring-mass"\ncoordinates = ["x"]\ninputs = ["F"]\n[parameters]\nm = 1.0\nk = 4.0\n'
                    '[energy]\nT = "1/2*m*x_dot**2"\nV = "1/2*k*x**2"\n[forces]\nx = "F"\n')
    return path


def test_cli_input_from_csv(tmp_path, capsys):
    ts = np.arange(0.0, 2.0005, 1e-3)
    rows = "\n".join(f"{float(t)!r},{math.sin(W * t)!r}" for t in ts)
    data = write(tmp_path, "t,acc\n" + rows + "\n")
    out = tmp_path / "out.csv"
    rc, _, err = run_cli(capsys, "simulate", model_file(tmp_path), "--t-end", "2", "--dt", "0.1",
                         "--input", f"F=@{data}:acc", "--rtol", "1e-12", "--atol", "1e-13", "--output", out)
    assert rc == 0, err
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert np.max(np.abs(table["x"] - forced_response(table["t"]))) < 5e-7
    assert np.max(np.abs(table["F"] - np.sin(W * table["t"]))) < 1e-12
    # cubic, and the column named as the input by default
    write(tmp_path, "t,F\n" + rows + "\n", "f.csv")
    rc, _, err = run_cli(capsys, "simulate", model_file(tmp_path), "--t-end", "2", "--dt", "0.1",
                         "--input", f"F=@{tmp_path / 'f.csv'}:cubic", "--output", out)
    assert rc == 0, err


def test_cli_bad_csv_and_span(tmp_path, capsys):
    data = write(tmp_path, "t,acc\n0,1\n0.5,x\n")
    rc, _, err = run_cli(capsys, "simulate", model_file(tmp_path), "--t-end", "1", "--input", f"F=@{data}:acc")
    assert rc != 0 and "row 3, column 'acc': 'x' is not a finite number" in err
    data = write(tmp_path, "t,acc\n0,1\n0.5,2\n")
    rc, _, err = run_cli(capsys, "simulate", model_file(tmp_path), "--t-end", "1", "--input", f"F=@{data}:acc")
    assert rc != 0 and "covers t = 0 .. 0.5, but the run needs it on 0 .. 1" in err
    rc, _, err = run_cli(capsys, "simulate", model_file(tmp_path), "--t-end", "1", "--input",
                         f"F=@{data}:acc:hold", "--output", tmp_path / "o.csv")
    assert rc == 0, err
    rc, _, err = run_cli(capsys, "simulate", model_file(tmp_path), "--t-end", "1", "--input", "F=@")
    assert rc != 0 and "expected a CSV file after '@'" in err


def test_a_signal_from_its_polynomials_is_run_exactly_by_the_compiled_loop():
    """Signal.from_polynomials: s**2 given as one quadratic per interval, in powers of (s - t_k); the
    compiled run of x'' = F from rest gives x = t**4/12 (the integrator's accuracy), SciPy's the same."""
    sig = lg.Signal.from_polynomials([0.0, 1.0, 2.0], [[1.0, 0.0, 0.0], [1.0, 2.0, 1.0]], name="F",
                                     interpolation="quadratic")
    s = np.linspace(0.0, 2.0, 9)
    np.testing.assert_allclose(sig(s), s**2, rtol=0, atol=1e-15)
    assert sig.interpolation == "quadratic" and sig.values.tolist() == [0.0, 1.0, 4.0]
    model = lg.Model("push", coordinates=["x"], inputs=["F"], T="x_dot**2/2", Q={"x": "F"})
    eqs = lg.derive(model)
    for backend in ("numba", "scipy"):
        traj = lg.simulate(eqs, 2.0, {}, inputs={"F": sig}, dt=0.5, backend=backend, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(traj["x"], traj.t**4 / 12, rtol=0, atol=1e-9)


@pytest.mark.parametrize("times, coefficients, message", [
    ([0, 1, 2], [[1, 0, 0]], "coefficients must have shape (2, d + 1) with degree d <= 3"),
    ([0, 1], [[1, 0, 0, 0, 0]], "coefficients must have shape (1, d + 1) with degree d <= 3"),
    ([0, 1], [[float("nan"), 0]], "a coefficient is not finite (NaN or inf)"),
    ([1, 0], [[1, 0]], "times must increase strictly"),
    ([0, 1], "ab", "times and coefficients must be arrays of numbers"),
])
def test_bad_polynomials_are_refused(times, coefficients, message):
    with pytest.raises(lg.ModelError, match=re.escape(message)):
        lg.Signal.from_polynomials(times, coefficients, name="u")


# ------------------------------------------------------------------ hostile arguments (FUZZ)
@pytest.mark.parametrize("at", ["abc", {"t": 1}, [0.1, [0.2]], object()])
def test_a_signal_evaluated_at_something_that_is_not_a_time_is_one_error(at):
    """Before: NumPy's ValueError (could not convert string to float) or TypeError."""
    sig = lg.Signal([0.0, 1.0], [1.0, 3.0], name="acc")
    with pytest.raises(ModelError, match=r"signal 'acc': a signal is evaluated at a time \(a number\), an array of "
                                         r"times or a sympy expression of t, got "):
        sig(at)
    assert sig(0.5) == pytest.approx(2.0) and sig([0.0, 0.25]).tolist() == pytest.approx([1.0, 1.5])


@pytest.mark.parametrize("kwargs, text", [
    (dict(name=np.ones(2)), r"a signal's name must be text, such as name='acc', got ndarray"),
    (dict(name=3), r"a signal's name must be text, such as name='acc', got int"),
    (dict(interpolation=np.ones(2)), r"interpolation and extrapolation are names \(text\): interpolation 'linear' or "
                                     r"'cubic', extrapolation 'error' or 'hold'"),
    (dict(extrapolation=3), r"interpolation and extrapolation are names \(text\)"),
])
def test_signal_options_that_are_not_text_are_one_error(kwargs, text):
    """Before: NumPy's ambiguous truth value (an array as the name or the interpolation)."""
    with pytest.raises(ModelError, match=text):
        lg.Signal([0.0, 1.0], [1.0, 3.0], **kwargs)
