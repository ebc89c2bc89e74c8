"""The right message for each mistake, given once (issue 19, item 6): every problem of a model file in
one run, a mass matrix that becomes singular during a run said so with its diagnosis, the model's own
parameters usable in the CLI's expressions, and what the first run is doing while it compiles."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import lagrangian as lg

# ------------------------------------------------------------------ every problem in one run
ROUNDS = """\
name = "rounds"
coordinates = ["th", "ph"]
[parameters]
m = 1.0
l = 1.0
g = 9.81
[[frames]]
name = "rodframe"
rotation = [["w", "th"], ["q", "ph"]]
[[frames]]
name = "tip"
parent = "rodframes"
origin = ["0", "0"]
[[bodies]]
name = "rod"
mass = "m"
inertia = ["1", "1", "5"]
frame = "rodframe"
center = ["0", "0", "-l/2"]
[[bodies]]
name = "rod2"
mass = "-m"
inertia = ["1", "1", "1"]
frame = "rod_frame"
[[bodies]]
name = "tipmass"
mass = "-m"
inertia = ["1", "1", "5"]
frame = "tip"
[gravity]
g = "g"
"""


def test_frames_with_problems_and_the_bodies_in_them_are_reported_in_one_run(tmp_path):
    # before: a frame with a problem was left out, so the bodies in it were checked only in a later run
    # (3, then 1, then 2 problems); now every problem comes at once, with a did-you-mean over every frame
    path = tmp_path / "rounds.toml"
    path.write_text(ROUNDS)
    with pytest.raises(lg.ModelFileError) as info:
        lg.load(str(path))
    text = str(info.value)
    assert text.startswith(f"9 problems in {path}:")
    expected = [
        ":9 [frames[0].rotation[0][0]]: 'w' is not an axis",
        ":9 [frames[0].rotation[1][0]]: 'q' is not an axis",  # the second bad step too, not only the first
        ":12 [frames[1].parent]: no frame is named 'rodframes' (did you mean 'rodframe'?)",
        ":13 [frames[1].origin]: a frame's origin has 3 components (x, y, z), got 2",  # below an unknown parent
        ":17 [bodies[0].inertia]: the principal moments of inertia 1, 1, 5 break the triangle inequality",
        ":22 [bodies[1].mass]: mass is negative (-1)",  # a body whose frame is misnamed is still checked
        ":24 [bodies[1].frame]: no frame is named 'rod_frame' (did you mean 'rodframe'?); the frames are "
        "world, rodframe, tip",
        ":27 [bodies[2].mass]: mass is negative (-1)",
        ":28 [bodies[2].inertia]: the principal moments of inertia 1, 1, 5 break the triangle inequality",
    ]
    for item in expected:
        assert item in text, item


def test_the_issue_file_needs_one_run(tmp_path):
    path = tmp_path / "rod.toml"
    path.write_text('name = "rod"\ncoordinates = ["th"]\n[parameters]\nm = 1.0\nl = 1.0\n'
                    '[[frames]]\nname = "rodframe"\nrotation = [["w", "th"]]\n'
                    '[[bodies]]\nname = "rod"\nmass = "m"\ninertia = ["m*l**2/12", "m*l**2/12", "m*l**2"]\n'
                    'frame = "rod_frame"\ncenter = ["0", "0", "-l/2"]\n')
    with pytest.raises(lg.ModelFileError) as info:
        lg.load(str(path))
    assert [p.key for p in info.value.problems] == ["frames[0].rotation[0][0]", "bodies[0].inertia",
                                                    "bodies[0].frame"]
    assert "no frame is named 'rod_frame' (did you mean 'rodframe'?)" in str(info.value)
    assert "break the triangle inequality" in str(info.value)


# ------------------------------------------------------------------ a request's every problem
OSCILLATOR = ('name = "osc"\ncoordinates = ["x"]\ninputs = ["F"]\n[parameters]\nm = 1.0\nk = 4.0\n[energy]\n'
              'T = "m*x_dot**2/2"\nV = "k*x**2/2"\n[forces]\nx = "F"\n')


def _post_simulate(body) -> tuple[int, list]:
    import json

    from lagrangian.serve._tasks import run

    reply = run("simulate", json.dumps(body).encode())
    return reply.status, json.loads(reply.body)["errors"] if reply.status != 200 else []


def test_a_simulation_request_reports_its_fields_and_the_names_the_model_lacks_at_once():
    # before: only t_end was reported, and the unknown coordinate y only after t_end was fixed
    status, errors = _post_simulate({"model": OSCILLATOR, "t_end": -1, "initial": {"y": 1, "x_dot": "pi"},
                                     "params": {"kk": 2}, "inputs": {"G": "1"}})
    assert status == 400
    assert [(e["key"], e["message"]) for e in errors] == [
        (None, "t_end: expected a positive number, got -1.0"),
        ("initial.y", "'y' is not a coordinate or velocity; the choices are x, x_dot"),
        ("params.kk", "'kk' is not a parameter of the model (did you mean 'k'?); the choices are m, k"),
        ("inputs.G", "'G' is not an input of the model; the choices are F")]


def test_too_many_rows_and_an_unknown_name_are_reported_together():
    status, errors = _post_simulate({"model": OSCILLATOR, "t_end": 1000, "dt": 0.001, "initial": {"y": 1}})
    assert status == 400
    assert len(errors) == 2
    assert errors[0]["message"].startswith("the simulation would output ")
    assert errors[0]["message"].endswith(" rows (t_end / dt + 1), more than the limit of 100000 per request: "
                                         "raise dt or shorten t_end")
    assert errors[1]["message"] == "'y' is not a coordinate or velocity; the choices are x, x_dot"


def test_a_bad_request_with_a_bad_model_reports_both():
    status, errors = _post_simulate({"model": OSCILLATOR.replace('V = "k*x**2/2"', 'V = "kk*x**2/2"'),
                                     "t_end": -1})
    assert status == 400
    assert errors[0]["message"] == "t_end: expected a positive number, got -1.0"
    assert errors[1]["key"] == "energy.V" and "unknown name 'kk' (did you mean 'k'?)" in errors[1]["message"]


def test_a_good_request_still_simulates():
    status, errors = _post_simulate({"model": OSCILLATOR, "t_end": 0.5, "initial": {"x": 1}, "inputs": {"F": "0"}})
    assert status == 200 and errors == []


# ------------------------------------------------------------------ a mass matrix that becomes singular
COLLAPSE = ('name = "collapse"\ncoordinates = ["x"]\n[energy]\nT = "x**2*x_dot**2/2"\nV = "0"\n'
            '[simulation]\nt_end = 3.0\ninitial = { x = 1.0, x_dot = -1.0 }\n')


@pytest.mark.parametrize("backend", ["auto", "scipy"])
def test_a_mass_matrix_that_loses_its_inertia_during_a_run_is_said_so_with_the_diagnosis(backend):
    # x x_dot = -1 along the motion, so x**2 = 1 - 2 t reaches 0 (where M = x**2 vanishes) at t = 0.5; the
    # scale-free inertia measure of a 1x1 M stays 1, and the integrator's step size collapses there: before,
    # a step-size failure with the advice to use Radau, which fails there too
    from lagrangian.io import loads_model

    eqs = lg.derive(loads_model(COLLAPSE))
    with pytest.raises(lg.SingularMassMatrixError) as info:
        lg.simulate(eqs, backend=backend)
    err = info.value
    assert err.time == pytest.approx(0.5, abs=1e-6)
    assert abs(err.state["x"]) < 1e-4
    text = str(err)
    assert text.startswith("the mass matrix became singular at t = 0.5 (its least inertia is ")
    assert "of that at the start) in the state x = " in text
    assert "Radau" not in text
    assert err.diagnosis.startswith("det M = x**2\ndet M vanishes where x = 0.")
    assert "Fix: give the body that x moves a mass" in err.diagnosis


@pytest.mark.parametrize("backend", ["auto", "scipy"])
def test_a_step_size_failure_away_from_a_singular_mass_matrix_keeps_its_message(backend):
    # x'' = x**3 runs away to infinity at t = 1.854 with M = 1 all along: not a singular mass matrix
    eqs = lg.derive(lg.Model(coordinates=["x"], T="x_dot**2/2", V="-x**4/4"))
    with pytest.raises(lg.SimulationError) as info:
        lg.simulate(eqs, t_end=5.0, initial={"x": 1.0}, backend=backend)
    assert not isinstance(info.value, lg.SingularMassMatrixError)
    assert str(info.value).startswith("the integrator stopped at t = 1.85")
    assert "Required step size is less than spacing between numbers" in str(info.value)


@pytest.mark.parametrize("backend", ["auto", "scipy"])
def test_the_diagnosis_of_a_singular_run_uses_the_parameter_values_it_ran_with(backend):
    # before: "became singular" and then "The mass matrix is regular" (the diagnosis took the model's M2 = 1)
    eqs = lg.derive(lg.load("cart-pendulum"))
    with pytest.raises(lg.SingularMassMatrixError) as info:
        lg.simulate(eqs, t_end=1.0, params={"M2": 0}, backend=backend)
    text = str(info.value)
    assert "The mass matrix is regular" not in text
    assert ("det M vanishes at every configuration for the parameter values: the mass matrix is always singular"
            in text)
    assert "only massless parts move: particle 'pendulum' (mass M2 = 0)" in text


def test_linearize_at_a_singular_mass_matrix_diagnoses_it_with_the_parameter_values_given():
    eqs = lg.derive(lg.load("cart-pendulum"))
    with pytest.raises(lg.SingularMassMatrixError) as info:
        lg.linearize(eqs, {"q2": 1.0}, params={"M2": 0})
    assert str(info.value).startswith("the mass matrix is singular at the operating point (q1 = 0, q2 = 1)")
    assert "the mass matrix is always singular" in info.value.diagnosis
    assert "is regular" not in info.value.diagnosis


def test_singularities_takes_parameter_values():
    eqs = lg.derive(lg.load("cart-pendulum"))
    assert not lg.singularities(eqs).singular
    report = lg.singularities(eqs, parameters={"M1": 0})
    assert report.singular and not report.everywhere
    assert [c.condition for c in report.configurations] == ["q2 = -pi/2", "q2 = pi/2"]
    assert lg.singularities(eqs, parameters={"M2": 0}).everywhere
    with pytest.raises(lg.ModelError, match=r"'LL' is not a parameter of the model \(did you mean 'L'\?\); "
                                            r"its parameters are M1, M2, L, g"):
        lg.singularities(eqs, parameters={"LL": 0})


@pytest.mark.slow
@pytest.mark.subprocess
def test_the_cli_gives_one_answer_for_a_massless_pendulum(tmp_path):
    import subprocess
    import sys

    p = subprocess.run([sys.executable, "-m", "lagrangian", "simulate", "cart-pendulum", "--param", "M2=0",
                        "--t-end", "1", "-o", str(tmp_path / "x.csv")], capture_output=True, text=True, timeout=600)
    assert p.returncode == 1
    assert "the mass matrix became singular at t = 0" in p.stderr
    assert "the mass matrix is always singular" in p.stderr and "is regular" not in p.stderr


# ------------------------------------------------------------------ the model's parameters in options
ARM2 = (Path(__file__).parent / "models" / "arm2.toml").read_text()
#: the torques that hold the arm straight out at th1 = 1, th2 = 0, in the model's own parameters
HOLD = "tau1=g*cos(1)*(m1*l1/2 + m2*(l1 + l2/2)),tau2=m2*g*l2/2*cos(1)"


def _cli(capsys, *args):
    from lagrangian.cli import main

    try:
        rc = main([str(a) for a in args])
    except SystemExit as exc:
        rc = exc.code
    out, err = capsys.readouterr()
    return rc, out, err


def test_lqr_inputs_may_use_the_model_s_parameters(tmp_path, capsys):
    # before: "unknown names 'g', 'l1'" for the model's own parameters
    path = tmp_path / "arm2.toml"
    path.write_text(ARM2)
    rc, out, err = _cli(capsys, "lqr", path, "--at", "th1=1,th2=0", "--input", HOLD, "--json")
    assert rc == 0, err
    data = json.loads(out)
    assert data["inputs"] == pytest.approx({"tau1": 9.81 * math.cos(1) * (2 * 0.5 / 2 + 1 * (0.5 + 0.2)),
                                                  "tau2": 1 * 9.81 * 0.2 * math.cos(1)}, rel=1e-12)
    # --param overrides the value the expressions use: g = 1 needs torques 9.81 times smaller
    rc, out, err = _cli(capsys, "lqr", path, "--at", "th1=1,th2=0", "--input", HOLD, "--param", "g=1", "--json")
    assert rc == 0, err
    assert json.loads(out)["inputs"]["tau2"] == pytest.approx(0.2 * math.cos(1), rel=1e-12)


def test_an_unknown_name_in_an_option_lists_the_parameters(tmp_path, capsys):
    path = tmp_path / "arm2.toml"
    path.write_text(ARM2)
    rc, out, err = _cli(capsys, "linearize", path, "--at", "th1=1", "--input", "tau1=gg*l1")
    assert rc == 2 and out == ""
    assert err.strip() == ("lagrangian linearize: error: --input tau1: 'gg*l1' is not a number (unknown name 'gg' "
                           "(did you mean 'g'?)); write e.g. 0.5 or pi/2, or an expression of the parameters m1, "
                           "m2, l1, l2, g")


def test_at_and_initial_may_use_the_model_s_parameters(tmp_path, capsys):
    rc, out, err = _cli(capsys, "linearize", "cart-pendulum", "--at", "q1=L/4,q2=pi/2", "--param", "L=2", "--json")
    assert rc == 0, err
    assert json.loads(out)["operating_point"]["q1"] == 0.5
    out_csv = tmp_path / "x.csv"
    rc, out, err = _cli(capsys, "simulate", "cart-pendulum", "--initial", "q1=L/4,q2=pi/2", "--param", "L=2",
                        "--t-end", "0.01", "-o", out_csv)
    assert rc == 0, err
    first = out_csv.read_text().splitlines()[1].split(",")
    assert float(first[1]) == 0.5 and float(first[2]) == pytest.approx(math.pi / 2)
    rc, out, err = _cli(capsys, "export", "cart-pendulum", "--modelica", tmp_path / "m.mo", "--initial", "q1=-L")
    assert rc == 0, err
    assert "q1(start = -1" in (tmp_path / "m.mo").read_text()


def test_simulate_inputs_use_the_parameter_values_after_overrides():
    # the library: an input expression's parameters take the values of params=..., as the CLI's --param
    eqs = lg.derive(lg.load("cart-pendulum"))
    traj = lg.simulate(eqs, t_end=0.1, initial={"q2": math.pi / 2}, inputs={"F": "(M1 + M2)*g/10"},
                       params={"M1": 3.0})
    force = (3.0 + 0.5) * 9.81 / 10  # M2 = 0.5, the model's
    assert traj["F"] == pytest.approx(np.full(len(traj.t), force), rel=1e-15)
    given = lg.simulate(eqs, t_end=0.1, initial={"q2": math.pi / 2}, inputs={"F": force}, params={"M1": 3.0})
    assert np.allclose(traj.x, given.x, rtol=1e-12, atol=1e-15) and traj.x[-1, 0] > 1e-3


# ------------------------------------------------------------------ the first run compiles
def test_the_progress_bar_says_what_it_waits_for_until_the_count_moves():
    import io

    from lagrangian._progress import Progress

    stream = io.StringIO()
    bar = Progress(100, "simulating", stream=stream, enabled=True, delay=0.0, interval=0.0)
    bar.wait("compiling the integrators, once per machine")
    bar.set(0)
    shown = stream.getvalue()
    assert shown.startswith("\rcompiling the integrators, once per machine... 0 s")
    assert "simulating" not in shown and "0/100" not in shown
    bar.set(1)  # the counted work has begun: the bar from now on
    assert stream.getvalue()[len(shown):].startswith("\rsimulating [")
    bar.set(0)
    assert "compiling" not in stream.getvalue()[len(shown):]
    bar.close()


def test_the_integrators_compiled_are_told_from_those_still_to_compile():
    import numba

    from lagrangian.numeric._fast import compiled, kernels

    fresh = numba.njit(lambda x: x + 1)  # no cache on disk, not compiled yet
    assert not compiled(fresh)
    assert fresh(1) == 2 and compiled(fresh)
    lg.simulate(lg.derive(lg.load("cart-pendulum")), t_end=0.01)
    assert compiled(kernels().dop853)  # compiled in this process, or found in numba's cache on disk


@pytest.mark.slow
def test_a_first_run_says_it_compiles_the_integrators_before_the_bar(capsys):
    import time

    import numpy as np

    from lagrangian.numeric._fast import COMPILING, _with_progress

    assert COMPILING == "compiling the integrators, once per machine"
    stats = np.zeros(5, dtype=np.int64)

    def call():  # what the kernel's first call does: compile (no output yet), then integrate
        time.sleep(1.5)
        stats[3] = 1
        time.sleep(0.3)
        stats[3] = 10
        return 0

    assert _with_progress(call, stats, 10, True, compiling=True) == 0
    err = capsys.readouterr().err
    assert "\rcompiling the integrators, once per machine... 1 s" in err
    assert err.index("compiling the integrators") < err.index("simulating [")
    assert err.split("\r")[-1].startswith("simulating [") and "] 10/10" in err.split("\r")[-1]
    # a later run (compiled) shows the bar only
    stats[:] = 0
    _with_progress(call, stats, 10, True, compiling=False)
    assert "compiling" not in capsys.readouterr().err
