"""Bounds with a message, never a hang or a traceback (issue 19, item 5): every input that crashed or
ran without bound is one clear error that says what is wrong, the limit and how to raise it; through
the library, the CLI (exit 2) and the playground's API (400 with a JSON body)."""

from __future__ import annotations

import json
import re

import pytest

import lagrangian as lg
from lagrangian._limits import LIMITS, MAX_COORDINATES, MAX_ROWS, MAX_TERMS, number_problem
from lagrangian.cli import main
from lagrangian.errors import ModelError, ModelFileError
from lagrangian.examples import example_source
from lagrangian.io import loads_model

OSCILLATOR = ('name = "osc"\ncoordinates = ["x"]\n[parameters]\nk = 4.0\n[energy]\nT = "x_dot**2/2"\n'
              'V = "k*x**2/2"\n')


def oscillator(**replace) -> str:
    text = OSCILLATOR
    for old, new in replace.items():
        text = text.replace(old, new)
    return text


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def assert_refused(code, out, err, message):
    assert code == 2, (code, err)
    assert message in err, err
    assert "Traceback" not in err and err.count("lagrangian") >= 1


# ------------------------------------------------------------------ model files
MODEL_FILES = [
    # (what, text, line, key, message)
    ("a 400-digit integer parameter", oscillator(**{"k = 4.0": "k = " + "9" * 400}), 4, "parameters.k",
     "expected a finite number, got an integer of 400 digits; write a number such as k = 1.5 (at most about 1.8e308)"),
    ("a 5000-digit integer", oscillator(**{"k = 4.0": "k = " + "9" * 5000}), 4, None,
     "invalid TOML: an integer too long to read (Exceeds the limit (4300 digits)"),
    ("a 400-digit integer in an expression", oscillator(**{'"k*x**2/2"': '"%s*x**2"' % ("9" * 400)}), 7, "energy.V",
     "number too large: the number 99999999999999999999... is beyond the largest floating-point number "
     "(about 1.8e308)"),
    ("a 400-digit integer as an expression", oscillator(**{'"k*x**2/2"': "9" * 400}), 7, "energy.V",
     "expected a finite number, got an integer of 400 digits; the largest a simulation can compute is about 1.8e308"),
    ("arrays nested 100k deep", OSCILLATOR + "[simulation]\nt_end = " + "[" * 100_000 + "]" * 100_000 + "\n", 9, None,
     "invalid TOML: arrays or tables nested too deeply for the reader"),
    ("x**(10**100)", oscillator(**{'"k*x**2/2"': '"x**(10**100)"'}), 7, "energy.V",
     "exponent too large: 1e+100 (in absolute value); the limit on the exponent of a power of a variable is 1,000; "
     "to raise it, set the environment variable LAGRANGIAN_MAX_EXPONENT"),
    ("exp(exp(exp(100)))", oscillator(**{'"k*x**2/2"': '"exp(exp(exp(100)))*x**2"'}), 7, "energy.V",
     "number too large: exp(2.68812e+43) is beyond the largest floating-point number (about 1.8e308), so no "
     "simulation can compute it"),
    ("sqrt(-1)", oscillator(**{'"k*x**2/2"': '"k*x**2*sqrt(-1)"'}), 7, "energy.V",
     "not a real number: sqrt(-1) has no real value (its argument is outside the domain of sqrt)"),
    ("a parent that is a table", example_source("heavy-top").replace('name = "body"\n', 'name = "body"\nparent = {}\n'),
     24, "frames[0].parent", "expected a frame's name, got a table; write parent = \"world\" or the name of a "
                             "[[frames]] table"),
]


@pytest.mark.parametrize("what, text, line, key, message", MODEL_FILES, ids=[m[0] for m in MODEL_FILES])
def test_a_bad_model_file_is_one_clear_error_at_its_line(what, text, line, key, message):
    with pytest.raises(ModelFileError) as info:
        loads_model(text, source="m.toml")
    (problem,) = info.value.problems
    assert (problem.line, problem.key) == (line, key)
    assert message in problem.message


@pytest.mark.parametrize("what, text, line, key, message", MODEL_FILES[:3] + MODEL_FILES[4:6] + MODEL_FILES[-1:],
                         ids=[m[0] for m in MODEL_FILES[:3] + MODEL_FILES[4:6] + MODEL_FILES[-1:]])
def test_the_cli_says_the_same_with_exit_2(tmp_path, capsys, what, text, line, key, message):
    path = tmp_path / "m.toml"
    path.write_text(text)
    code, out, err = run(capsys, "derive", str(path))
    assert_refused(code, out, err, message)
    assert f"m.toml:{line}" in err and out == ""


def test_an_initial_value_too_large_for_the_equations_is_refused_with_exit_2(tmp_path, capsys):
    path = tmp_path / "m.toml"
    path.write_text(OSCILLATOR + "[simulation]\nt_end = 1.0\ninitial = { x = 1e308 }\n")
    code, out, err = run(capsys, "simulate", str(path), "-o", str(tmp_path / "out.csv"))
    assert_refused(code, out, err, "[initial.x]: the value of 'x' is 1e+308, too large: at most 1e+150 in magnitude, "
                                   "so that the products of the equations stay finite in double precision")
    assert not (tmp_path / "out.csv").exists()
    code, out, err = run(capsys, "simulate", "cart-pendulum", "--param", "M1=-1e200")
    assert_refused(code, out, err, "[params.M1]: the value of 'M1' is -1e+200, too large: at most 1e+150")


# ------------------------------------------------------------------ derive's bounds
def test_an_expansion_past_the_limit_is_refused_before_any_work_with_how_to_raise_it(monkeypatch):
    text = ('name = "p"\ncoordinates = ["x", "y", "z", "w"]\n[energy]\n'
            'T = "(x_dot**2 + y_dot**2 + z_dot**2 + w_dot**2)/2"\nV = "(x + y + z + w)**200"\n')
    model = loads_model(text)
    with pytest.raises(ModelError) as info:
        lg.derive(model)
    (problem,) = info.value.problems
    assert problem.key == "energy.V"
    assert problem.message.startswith("V could expand to more than 100,000 terms")
    assert problem.message.endswith("the limit on terms of the expansion of an energy, dissipation function, "
                                    "generalized force or constraint is 100,000; to raise it, set the environment "
                                    "variable LAGRANGIAN_MAX_TERMS (e.g. LAGRANGIAN_MAX_TERMS=1000000)")
    # (x+y+z+w)**20 has 1771 terms: refused under a limit of 1000, derived over it
    small = loads_model(text.replace("**200", "**20"))
    monkeypatch.setenv("LAGRANGIAN_MAX_TERMS", "1000")
    with pytest.raises(ModelError, match=r"V could expand to more than 1,000 terms"):
        lg.derive(small)
    monkeypatch.setenv("LAGRANGIAN_MAX_TERMS", "2000")
    assert lg.derive(small).n == 4


def test_every_part_past_the_expansion_limit_is_reported_at_once(monkeypatch):
    monkeypatch.setenv("LAGRANGIAN_MAX_TERMS", "10")
    model = lg.Model(coordinates=["x", "y"], T="(x_dot + y_dot)**2/2 + x_dot**2", V="(x + y + 1)**5",
                     D="(x_dot + y_dot + 1)**6")
    with pytest.raises(ModelError) as info:
        lg.derive(model)
    assert [p.key for p in info.value.problems] == ["energy.V", "energy.D"]


def test_the_coordinates_are_bounded_with_how_to_raise_the_bound(monkeypatch):
    names = [f"q{i}" for i in range(5)]
    model = lg.Model(coordinates=names, T=" + ".join(f"{q}_dot**2/2" for q in names), V=" + ".join(names))
    monkeypatch.setenv("LAGRANGIAN_MAX_COORDINATES", "4")
    with pytest.raises(ModelError, match=re.escape(
            "has 5 coordinates, more than derive() takes: the limit on coordinates of a model is 4; to raise it, "
            "set the environment variable LAGRANGIAN_MAX_COORDINATES (e.g. LAGRANGIAN_MAX_COORDINATES=40)")):
        lg.derive(model)
    monkeypatch.setenv("LAGRANGIAN_MAX_COORDINATES", "5")
    assert lg.derive(model).n == 5


def test_the_examples_are_well_inside_the_bounds():
    # the largest expansion among the examples: the bicycle's T*, counted on its tree
    from lagrangian.equations._readable import expanded_terms_bound

    eqs = lg.derive(lg.load("whipple-bicycle"))
    assert 10_000 < expanded_terms_bound(eqs.core.T) < MAX_TERMS.default / 2
    assert eqs.n < MAX_COORDINATES.default / 10


@pytest.mark.parametrize("value", ["0", "-3", "many", "1.5"])
def test_a_malformed_limit_in_the_environment_is_one_clear_error(monkeypatch, value):
    monkeypatch.setenv("LAGRANGIAN_MAX_ROWS", value)
    with pytest.raises(ModelError, match=re.escape(f"the environment variable LAGRANGIAN_MAX_ROWS={value!r} must be a "
                                                   "whole number >= 1 (the limit on output rows and input samples of "
                                                   "a simulation; default 1,000,000)")):
        MAX_ROWS.value


def test_every_limit_is_documented_in_the_conventions():
    from pathlib import Path

    text = (Path(__file__).parents[1] / "docs" / "conventions.md").read_text()
    for limit in LIMITS.values():
        assert f"`{limit.variable}`" in text and f"{limit.default:,}" in text, limit.name


# ------------------------------------------------------------------ simulate's bounds
@pytest.mark.parametrize("options, message", [
    (["--t-end", "1e300"], "t_end = 1e+300 with dt = 0.01 asks for 1e+302 output rows, too many to keep: raise dt "
                           "(--dt 1e+294 or more) or give the times wanted as t_eval; the limit on output rows and "
                           "input samples of a simulation is 1,000,000; to raise it, set the environment variable "
                           "LAGRANGIAN_MAX_ROWS (e.g. LAGRANGIAN_MAX_ROWS=10000000)"),
    (["--dt", "1e-320"], "asks for inf output rows, too many to keep"),
    (["--t-end", "1e6", "--dt", "1e-12"], "t_end = 1e+06 with dt = 1e-12 asks for 1e+18 output rows"),
    (["--t-end", "10", "--dt", "1e-7"], "t_end = 10 with dt = 1e-07 asks for 1e+08 output rows, too many to keep: "
                                        "raise dt (--dt 1e-05 or more)"),
    (["--initial", "q2=sqrt(-1)"], "--initial q2: 'sqrt(-1)' is not a number (not a real number: sqrt(-1) has no "
                                   "real value"),
    (["--input", "F=acos(2)"], "[inputs.F]: not a real number: acos(2) has no real value (its argument is outside "
                               "the domain of acos)"),
    (["--param", "M1=1e999"], "--param M1: '1e999' is not a finite number; write e.g. 0.5 or pi/2"),
    (["--t-end", "1", "--method", "variational", "--step", "1e-300"],
     "t_end = 1 in fixed steps of 1e-300 is 1e+300 steps: use a larger step (--step) or a shorter t_end; the limit "
     "on fixed steps of a simulation is 100,000,000"),
    (["--t-end", "1", "--sample-time", "1e-300"],
     "sample time 1e-300 s over t_end = 1 s makes 1e+300 samples of input 'F': use a longer sample time"),
])
def test_simulate_refuses_with_exit_2_and_the_reason(capsys, tmp_path, options, message):
    out_file = tmp_path / "out.csv"
    code, out, err = run(capsys, "simulate", "cart-pendulum", *options, "-o", str(out_file))
    assert_refused(code, out, err, message)
    assert not out_file.exists()


def test_the_row_limit_applies_to_the_library_and_is_raised_by_its_variable(monkeypatch):
    eqs = lg.derive(lg.load("mck"))
    monkeypatch.setenv("LAGRANGIAN_MAX_ROWS", "100")
    with pytest.raises(ModelError, match=r"\[dt\]: t_end = 1 with dt = 0.001 asks for 1001 output rows"):
        lg.simulate(eqs, t_end=1.0, dt=1e-3)
    with pytest.raises(ModelError, match=r"\[t_eval\]: .* asks for 101 output rows, too many to keep: give fewer "
                                         r"times in t_eval"):
        lg.simulate(eqs, t_end=1.0, t_eval=[i / 100 for i in range(101)])
    monkeypatch.setenv("LAGRANGIAN_MAX_ROWS", "1001")
    assert len(lg.simulate(eqs, t_end=1.0, dt=1e-3).t) == 1001


def test_an_input_that_leaves_its_domain_during_a_run_is_a_failed_computation(capsys):
    code, out, err = run(capsys, "simulate", "cart-pendulum", "--t-end", "0.1", "--backend", "scipy",
                         "--input", "F=acos(2 + q1)")
    assert code == 1 and "Traceback" not in err
    assert ("input 'F' has no value at t = 0 (math domain error): its expression leaves the domain of a function "
            "there") in err


# ------------------------------------------------------------------ the CLI's numeric options
@pytest.mark.parametrize("argv, message", [
    (["simulate", "cart-pendulum", "--t-end", "-1"],
     "--t-end must be a positive number, got -1; for example --t-end 10"),
    (["simulate", "cart-pendulum", "--t-end", "inf"], "--t-end must be a finite number, got inf"),
    (["simulate", "cart-pendulum", "--t-end", "ten"], "--t-end must be a number, got 'ten'"),
    (["simulate", "cart-pendulum", "--dt", "nan"], "--dt must be a finite number, got nan; for example --dt 0.01"),
    (["simulate", "cart-pendulum", "--rtol", "2"], "--rtol must be at most 1, got 2; for example --rtol 1e-9"),
    (["simulate", "cart-pendulum", "--rtol", "0"], "--rtol must be a positive number, got 0"),
    (["simulate", "cart-pendulum", "--atol=-1e-9"], "--atol must be a positive number, got -1e-9"),
    (["simulate", "cart-pendulum", "--step", "0"], "--step must be a positive number, got 0"),
    (["animate", "cart-pendulum", "--fps", "1e9", "-o", "x.gif"], "--fps must be at most 1000, got 1e9"),
    (["animate", "cart-pendulum", "--speed", "-1", "-o", "x.gif"], "--speed must be a positive number, got -1"),
    (["animate", "cart-pendulum", "--dpi", "1e6", "-o", "x.gif"], "--dpi must be at most 1000, got 1e6"),
    (["sweep", "rotating-pendulum", "--param", "Omega", "--from", "0", "--to", "8", "--steps", "100000000"],
     "--steps must be at most 100000, got 100000000; for example --steps 200"),
    (["sweep", "rotating-pendulum", "--param", "Omega", "--from", "0", "--to", "8", "--steps", "2.5"],
     "--steps must be a whole number, got '2.5'"),
    (["sweep", "rotating-pendulum", "--param", "Omega", "--from=-inf", "--to", "8"],
     "--from must be a finite number, got -inf"),
    (["linearize", "cart-pendulum", "--t", "nan"], "--t must be a finite number, got nan"),
    (["lqr", "cart-pendulum", "--at", "q2=pi/2", "--sample-time", "-0.1"],
     "--sample-time must be a positive number, got -0.1"),
    (["serve", "--port", "70000"], "--port must be at most 65535, got 70000"),
    (["serve", "--workers", "0"], "--workers must be at least 1, got 0"),
    (["serve", "--time-limit", "inf"], "--time-limit must be a finite number, got inf"),
])
def test_each_numeric_option_is_checked_with_one_clear_error(capsys, argv, message):
    code, out, err = run(capsys, *argv)
    assert_refused(code, out, err, message)
    assert err.startswith(f"lagrangian {argv[0]}: error: ")


def test_every_bad_option_is_reported_at_once(capsys):
    code, _, err = run(capsys, "simulate", "cart-pendulum", "--t-end", "-1", "--dt", "0", "--rtol", "nan")
    assert code == 2
    assert err.startswith("lagrangian simulate: error: 3 problems:")
    for message in ("--t-end must be a positive number", "--dt must be a positive number",
                    "--rtol must be a finite number"):
        assert message in err


@pytest.mark.parametrize("value, bounds, message", [
    (float("nan"), {}, "x must be a finite number, got nan"),
    (True, {}, "x must be a number, got True"),
    ("1", {}, "x must be a number, got '1'"),
    (0, {"positive": True}, "x must be a positive number, got 0"),
    (3, {"maximum": 2}, "x must be at most 2, got 3"),
    (2.5, {"integer": True}, "x must be a whole number, got 2.5"),
    (-1, {"minimum": 0}, "x must be at least 0, got -1"),
])
def test_number_problem_says_what_is_wrong(value, bounds, message):
    assert number_problem(value, "x", **bounds) == message
    assert number_problem(1, "x") is None


def test_the_library_checks_its_tolerances_with_the_same_rule():
    eqs = lg.derive(lg.load("mck"))
    with pytest.raises(ModelError) as info:
        lg.simulate(eqs, t_end=1.0, rtol=float("inf"), atol=float("nan"))
    messages = [p.message for p in info.value.problems]
    assert messages[0] == "rtol must be a finite number, got inf; for example rtol=1e-9 (--rtol 1e-9)"
    assert messages[1].startswith("atol must be a finite number, got nan (with atol = 0")


# ------------------------------------------------------------------ the playground's API
@pytest.fixture(scope="module")
def server():
    from serve_support import Server

    s = Server(workers=2, time_limit=60)
    yield s
    code, out, err = s.stop()
    assert code == 0 and "Traceback" not in err, err


@pytest.mark.parametrize("fields, message", [
    ({"t_end": 1e300}, "the simulation would output 1e+302 rows (t_end / dt + 1), more than the limit of 100000"),
    ({"dt": 1e-320}, "the simulation would output inf rows (t_end / dt + 1)"),
    ({"t_end": 1e6, "dt": 1e-12}, "the simulation would output 1e+18 rows"),
    ({"t_end": 1, "initial": {"q2": "sqrt(-1)"}}, "initial.q2: 'sqrt(-1)' is not a number (not a real number"),
    ({"t_end": 1, "inputs": {"F": "acos(2)"}}, "not a real number: acos(2) has no real value"),
    ({"t_end": 1, "initial": {"q2": 1e308}}, "the value of 'q2' is 1e+308, too large: at most 1e+150 in magnitude"),
])
@pytest.mark.slow
@pytest.mark.subprocess
def test_the_api_answers_400_with_the_reason(server, fields, message):
    status, data = server.post_json("/api/simulate", json.dumps({"model": example_source("cart-pendulum"), **fields}),
                                    headers={"Content-Type": "application/json"})
    assert status == 400, data
    assert any(message in e["message"] for e in data["errors"]), data


@pytest.mark.parametrize("what, text, line, key, message", MODEL_FILES, ids=[m[0] for m in MODEL_FILES])
@pytest.mark.subprocess
def test_the_api_answers_400_for_each_bad_model_file(server, what, text, line, key, message):
    status, data = server.post_json("/api/derive", text)
    assert status == 400, data
    (error,) = data["errors"]
    assert (error["line"], error["key"]) == (line, key) and message in error["message"]


@pytest.mark.subprocess
def test_the_api_refuses_an_expansion_past_the_limit(server):
    text = ('name = "p"\ncoordinates = ["x", "y", "z", "w"]\n[energy]\n'
            'T = "(x_dot**2 + y_dot**2 + z_dot**2 + w_dot**2)/2"\nV = "(x + y + z + w)**200"\n')
    status, data = server.post_json("/api/derive", text)
    assert status == 400 and data["errors"][0]["key"] == "energy.V"
    assert data["errors"][0]["message"].startswith("V could expand to more than 100,000 terms")


def test_a_slow_motion_animation_takes_each_sample_once_without_an_array_of_wanted_times():
    # speed 1e-9 at 25 fps asked for 2.5e10 wanted times (186 GiB) for 1 s; every sample is a frame
    import numpy as np

    from lagrangian.plot._animation import _frame_indices

    t = np.linspace(0, 1, 101)
    assert _frame_indices(t, 25.0, 1e-9).tolist() == list(range(101))
    assert _frame_indices(t, 25.0, 1.0).tolist() == list(range(0, 101, 4))  # 25 fps of 100 samples per second


@pytest.mark.parametrize("max_step, message", [
    (float("nan"), "max_step must be a finite number, got nan (or math.inf: no limit)"),
    (0, "max_step must be a positive number, got 0 (or math.inf: no limit)"),
    ("x", "max_step must be a number, got 'x' (or math.inf: no limit)"),
])
def test_max_step_is_checked_by_the_same_rule(max_step, message):
    # it went through as NaN, or failed at t = 4.9e-323 (compiled) or with SciPy's ValueError
    with pytest.raises(ModelError, match=re.escape(f"[max_step]: {message}")):
        lg.simulate(lg.derive(lg.load("mck")), 0.1, max_step=max_step)


def test_a_batch_is_bounded_as_one_simulation_is():
    # simulate_batch(t_end=1e300) raised numpy's "Maximum allowed size exceeded"
    with pytest.raises(ModelError, match=re.escape("[dt]: t_end = 1e+300 with dt = 0.01 asks for 1e+302 output rows")):
        lg.simulate_batch(lg.derive(lg.load("mck")), 1e300, params={"k1": [1.0, 2.0]})


@pytest.mark.slow
def test_analysis_refuses_a_parameter_value_past_the_magnitude_limit():
    """equilibria with M1 = 1e300 answered 'singular mass matrix' (M1 + M2 overflowed in products);
    the analysis now refuses the value as simulate does."""
    eq = lg.derive(lg.load("cart-pendulum"))
    with pytest.raises(lg.ModelError, match=r"the value of 'M1' is 1e\+300, too large: at most 1e\+150 in magnitude"):
        lg.equilibria(eq, params={"M1": 1e300})
    with pytest.raises(lg.ModelError, match=r"the value of 'M1' must be a finite number, got inf"):
        lg.linearize(eq, at={"q2": 0.0}, params={"M1": float("inf")})
