"""`lagrangian simulate --lqr` and `--controller` (a design saved by `lagrangian lqr --save`): the
loop closed from the command line, against the API's lqr + simulate with the law; the design
file's round trip and its refusals (another model, other parameters, hostile files)."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.cli import main
from cli_support import run_cli

QR = "Q=q1=1,q2=10,q1_dot=1,q2_dot=1;R=F=1"
START = "q2=pi/2+0.2"  # 0.2 rad from upright


def rows(text: str) -> tuple[list[str], np.ndarray]:
    lines = [ln for ln in io.StringIO(text).read().splitlines() if ln and not ln.startswith("#")]
    return lines[0].split(","), np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])


@pytest.fixture(scope="module")
def api_run():
    """The API's path: lqr on the linearization about upright, simulate with its law."""
    eqs = lg.derive(lg.load("cart-pendulum"))
    fb = lg.linearize(eqs, at={"q2": sympy.pi / 2}).lqr({"q1": 1, "q2": 10, "q1_dot": 1, "q2_dot": 1}, {"F": 1})
    traj = lg.simulate(eqs, 10.0, {"q2": math.pi / 2 + 0.2}, inputs=fb.inputs, dt=0.05)
    wrapped = lg.simulate(eqs, 10.0, {"q2": math.pi / 2 + 0.2}, inputs=fb.law(["q2"]), dt=0.05)
    return fb, traj, wrapped


@pytest.fixture(scope="module")
def design(tmp_path_factory, api_run):
    """A design saved by `lagrangian lqr --save` (q2 wrapped), as a dict and its path."""
    path = tmp_path_factory.mktemp("design") / "design.json"
    assert main(["lqr", "cart-pendulum", "--at", "q2=pi/2", "--Q", "q1=1,q2=10,q1_dot=1,q2_dot=1", "--R", "F=1",
                 "--wrap", "q2", "--save", str(path)]) == 0
    return json.loads(path.read_text()), path


def test_simulate_lqr_is_the_api_lqr_and_simulate_and_holds_upright(capsys, api_run):
    fb, traj, _ = api_run
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", 10, "--dt", 0.05, "--initial", START,
                           "--lqr", QR, "--at", "q2=pi/2")
    assert rc == 0, err
    header, data = rows(out)
    assert header[:6] == ["t", "q1", "q2", "q1_dot", "q2_dot", "F"]
    np.testing.assert_allclose(data[:, 0], traj.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(data[:, 1:5], traj.x, rtol=0, atol=1e-10)
    # the law: F = -K (x - x0), the first row from the start's error alone
    assert data[0, 5] == pytest.approx(-fb.K[0, 1] * 0.2, rel=1e-12)
    # stabilized: back near upright, at rest
    assert abs(data[-1, 2] - math.pi / 2) < 5e-3 and abs(data[-1, 4]) < 5e-3
    assert np.abs(data[:, 2] - math.pi / 2).max() <= 0.2 + 1e-12


def test_lqr_save_and_simulate_controller_round_trip(capsys, api_run, design):
    fb, _, wrapped = api_run
    d, path = design
    assert d["format"] == "lagrangian-state-feedback" and d["model"] == "cart-pendulum"
    assert d["state_names"] == ["q1", "q2", "q1_dot", "q2_dot"] and d["input_names"] == ["F"]
    np.testing.assert_array_equal(np.array(d["K"]), fb.K)  # to the last bit
    assert d["operating_point"]["q2"] == math.pi / 2 and d["inputs"] == {"F": 0.0} and d["wrap"] == ["q2"]
    assert d["parameters"] == {"M1": 1.0, "M2": 0.5, "L": 1.0, "g": 9.81} and len(d["fingerprint"]) == 32
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", 10, "--dt", 0.05, "--initial", START,
                           "--controller", path)
    assert rc == 0, err
    _, data = rows(out)
    np.testing.assert_allclose(data[:, 1:5], wrapped.x, rtol=0, atol=1e-10)


def test_a_discrete_design_is_simulated_sampled(capsys, tmp_path):
    path = tmp_path / "d.json"
    rc, _, err = run_cli(capsys, "lqr", "cart-pendulum", "--at", "q2=pi/2", "--Q", "1,10,1,1", "--sample-time", 0.02,
                         "--save", path)
    assert rc == 0, err
    fb = lg.control.lqr(lg.linearize(lg.derive(lg.load("cart-pendulum")), at={"q2": sympy.pi / 2}), [1, 10, 1, 1],
                        sample_time=0.02)
    ref = lg.simulate(lg.derive(lg.load("cart-pendulum")), 1.0, {"q2": math.pi / 2 + 0.2}, inputs=fb.inputs,
                      sample_time=0.02, dt=0.02)
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", 1, "--dt", 0.02, "--initial", START,
                           "--controller", path)
    assert rc == 0, err
    _, data = rows(out)
    np.testing.assert_allclose(data[:, 1:5], ref.x, rtol=0, atol=1e-10)
    assert np.unique(data[:, 5]).size == data.shape[0]  # held for a period, one value per sample
    rc, _, err = run_cli(capsys, "simulate", "cart-pendulum", "--controller", path, "--sample-time", 0.01)
    assert rc == 2 and "is a discrete design, sampled every 0.02 s" in err and "leave --sample-time out" in err


TWO_INPUTS = ('name = "two"\ncoordinates = ["x"]\ninputs = ["F", "G"]\n'
              '[energy]\nT = "x_dot**2/2"\n[forces]\nx = "F + G"\n')


def test_an_input_given_both_by_input_and_by_the_law_is_refused(capsys, tmp_path):
    model = tmp_path / "two.toml"
    model.write_text(TWO_INPUTS)
    rc, _, err = run_cli(capsys, "simulate", model, "--lqr", "Q=1;R=1", "--at", "x=0", "--input", "G=1")
    assert rc == 2
    assert "the input G given both by --input and by --lqr (whose law sets F, G)" in err and "drop its --input" in err
    rc, _, err = run_cli(capsys, "simulate", "cart-pendulum", "--lqr", QR, "--at", "q2=pi/2", "--input", "F=0")
    assert rc == 2 and "the input F given both by --input and by --lqr" in err


def test_a_design_of_some_inputs_combines_with_input_for_the_others(capsys, tmp_path):
    """x'' = F + G with the law on F only (K = [1, 2]: x'' = -x - 2 x' + G) and G = 1 by --input:
    x -> 1, and the run is the API's with the same law."""
    model = tmp_path / "two.toml"
    model.write_text(TWO_INPUTS)
    path = tmp_path / "d.json"
    assert main(["lqr", str(model), "--at", "x=0", "--save", str(path)]) == 0
    capsys.readouterr()
    d = json.loads(path.read_text())
    d.update(input_names=["F"], K=[[1.0, 2.0]], inputs={"F": 0.0}, R=[[1.0]])
    path.write_text(json.dumps(d))
    rc, out, err = run_cli(capsys, "simulate", model, "--t-end", 20, "--dt", 0.5, "--initial", "x=0.3",
                           "--controller", path, "--input", "G=1")
    assert rc == 0, err
    header, data = rows(out)
    assert header[:5] == ["t", "x", "x_dot", "F", "G"]
    eqs = lg.derive(lg.load(str(model)))
    ref = lg.simulate(eqs, 20.0, {"x": 0.3}, inputs={"F": "-x - 2*x_dot", "G": "1"}, dt=0.5)
    np.testing.assert_allclose(data[:, 1:3], ref.x, rtol=0, atol=1e-10)
    t = data[:, 0]  # closed form: x = 1 + (c1 + c2 t) e^-t, x(0) = 0.3, x'(0) = 0
    np.testing.assert_allclose(data[:, 1], 1 - 0.7 * (1 + t) * np.exp(-t), rtol=0, atol=1e-7)
    np.testing.assert_allclose(data[:, 4], 1.0)


@pytest.mark.parametrize("args, message", [
    (["--lqr", "Q=1;S=2"], "--lqr 'S=2': expected Q=WEIGHTS or R=WEIGHTS separated by ';'"),
    (["--lqr", "Q=1;Q=2"], "--lqr gives Q twice"),
    (["--lqr", "Q=1,2", "--at", "q2=pi/2"], "Q as a vector must have 4 weights"),
    (["--at", "q2=pi/2"], "--at is for a closed loop: give --lqr"),
    (["--wrap", "q2"], "--wrap is for a closed loop"),
    (["--lqr", QR, "--at", "q2=pi/2", "--wrap", "q9"], "wrap names q9, which is not a coordinate"),
    (["--lqr", QR, "--at", "q2=1"], "the operating point is not an equilibrium"),
])
def test_simulate_lqr_refusals(capsys, args, message):
    rc, _, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", 1, *args)
    assert rc == 2 and message in err, err


def _write(path, d):
    path.write_text(json.dumps(d))
    return path


@pytest.mark.parametrize("change, message", [
    (lambda d: d.update(K=[[1.0, 2.0]]), "\"K\" must be a 1 x 4 matrix"),
    (lambda d: d.update(K=[[1.0, 2.0, 3.0]] * 2), "\"K\" must be a 1 x 4 matrix (a list of 1 rows of 4 numbers), "
                                                  "got 2 rows"),
    (lambda d: d["K"][0].__setitem__(1, float("nan")), "an entry of \"K\" must be a finite number, got nan"),
    (lambda d: d["K"][0].__setitem__(1, 1e300), "an entry of \"K\" is 1e+300, too large: at most 1e+12"),
    (lambda d: d["K"][0].__setitem__(1, "41"), "an entry of \"K\" must be a finite number, got '41'"),
    (lambda d: d["operating_point"].__setitem__("q2", float("inf")), "\"operating_point\" of 'q2' must be a finite"),
    (lambda d: d.update(state_names=["q1", "q2", "q1_dot", "theta"]),
     "\"state_names\" names 'theta', not state of the model"),
    (lambda d: d.update(input_names=["Torque"]), "\"input_names\" names 'Torque', not input of the model"),
    (lambda d: d.update(wrap=["q1_dot"]), "\"wrap\" names 'q1_dot', not coordinate of the model"),
    (lambda d: d.update(inputs={"F": 0.0, "G": 1.0}), "\"inputs\" must give a number for each of F (and no other)"),
    (lambda d: d.update(sample_time=-0.1), "\"sample_time\" must be a positive number of seconds or null"),
    (lambda d: d.update(method="pid"), "\"method\" must be \"lqr\" or \"place\", got 'pid'"),
    (lambda d: d.update(format="other"), "it is JSON but not a state-feedback design"),
    (lambda d: d.update(model="double-pendulum"), "it was designed for the model 'double-pendulum', not "
                                                  "'cart-pendulum'"),
    (lambda d: d.update(fingerprint="0" * 32), "its fingerprint differs from the equations of 'cart-pendulum'"),
    (lambda d: d["parameters"].update(M2=0.6), "it was designed with other parameter values (M2 = 0.6 in the "
                                               "design, 0.5 now)"),
])
def test_hostile_design_files_are_refused_with_one_clear_message(capsys, tmp_path, design, change, message):
    d = json.loads(json.dumps(design[0]))
    change(d)
    path = _write(tmp_path / "bad.json", d)
    rc, _, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", 1, "--controller", path)
    assert rc == 2, err
    assert f"{path} is not a usable design: " in err and message in err, err
    assert "Traceback" not in err


def test_design_files_that_are_not_designs(capsys, tmp_path, design):
    from lagrangian.control._design import MAX_DESIGN_BYTES

    cases = {"text.json": (b"K = 1", "it is not JSON"), "binary.json": (b"\xff\xfe\x00", "not UTF-8"),
             "list.json": (b"[1, 2]", "it is JSON but not a state-feedback design"),
             "deep.json": (b"[" * 100000 + b"]" * 100000, "it is not JSON")}
    for name, (data, message) in cases.items():
        (tmp_path / name).write_bytes(data)
        rc, _, err = run_cli(capsys, "simulate", "cart-pendulum", "--controller", tmp_path / name)
        assert rc == 2 and message in err, (name, err)
    big = tmp_path / "big.json"
    with open(big, "wb") as fh:  # a sparse 1 GB file: refused by its size, never read
        fh.truncate(1 << 30)
    rc, _, err = run_cli(capsys, "simulate", "cart-pendulum", "--controller", big)
    assert rc == 2 and f"the file has {1 << 30} bytes, more than the {MAX_DESIGN_BYTES}" in err
    rc, _, err = run_cli(capsys, "simulate", "cart-pendulum", "--controller", tmp_path / "none.json")
    assert rc == 2 and "no such file; write one with `lagrangian lqr MODEL --at ... --save" in err
    rc, _, err = run_cli(capsys, "simulate", "cart-pendulum-energy", "--controller", design[1])
    assert rc == 2 and "designed for the model 'cart-pendulum', not 'cart-pendulum-energy'" in err
    rc, _, err = run_cli(capsys, "simulate", "cart-pendulum", "--controller", design[1], "--param", "M1=3")
    assert rc == 2 and "other parameter values (M1 = 1.0 in the design, 3.0 now)" in err
    rc, _, err = run_cli(capsys, "simulate", "cart-pendulum", "--controller", design[1], "--at", "q2=1")
    assert rc == 2 and "--at is for --lqr: a --controller design keeps its own operating point" in err


def test_a_changed_model_of_the_same_name_is_refused_by_the_fingerprint(capsys, tmp_path, design):
    assert main(["examples", "--show", "cart-pendulum"]) == 0
    text = capsys.readouterr().out
    changed = tmp_path / "cart.toml"
    changed.write_text(text.replace('force = ["F", "0"]', 'force = ["2*F", "0"]'))
    rc, _, err = run_cli(capsys, "simulate", changed, "--controller", design[1])
    assert rc == 2 and "its fingerprint differs from the equations of 'cart-pendulum'" in err, err


def test_save_to_a_folder_that_does_not_exist_is_refused_before_the_design(capsys, tmp_path):
    path = tmp_path / "none" / "d.json"
    rc, out, err = run_cli(capsys, "lqr", "cart-pendulum", "--at", "q2=pi/2", "--save", path)
    assert rc == 2 and f"--save {path}: the folder {path.parent} does not exist" in err and out == ""


def test_place_save_and_simulate_controller(capsys, tmp_path):
    path = tmp_path / "p.json"
    rc, _, err = run_cli(capsys, "place", "cart-pendulum", "--at", "q2=pi/2", "--poles=-1,-2,-3,-4", "--save", path)
    assert rc == 0, err
    fb = lg.linearize(lg.derive(lg.load("cart-pendulum")), at={"q2": sympy.pi / 2}).place([-1, -2, -3, -4])
    ref = lg.simulate(lg.derive(lg.load("cart-pendulum")), 2.0, {"q2": math.pi / 2 + 0.2}, inputs=fb.inputs, dt=0.1)
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", 2, "--dt", 0.1, "--initial", START,
                           "--controller", path)
    assert rc == 0, err
    np.testing.assert_allclose(rows(out)[1][:, 1:5], ref.x, rtol=0, atol=1e-10)


def test_animate_lqr_draws_the_closed_loop_motion(capsys, tmp_path, monkeypatch, api_run):
    """`animate --lqr` closes the loop as `simulate --lqr` does: the animated trajectory is the API's."""
    from lagrangian.plot import _animation

    drawn = []
    real = _animation.animate

    def spy(traj, **kw):
        drawn.append(traj)
        return real(traj, **kw)

    monkeypatch.setattr(_animation, "animate", spy)
    out = tmp_path / "held.html"
    rc, _, err = run_cli(capsys, "animate", "cart-pendulum", "--t-end", 10, "--dt", 0.05, "--initial", START,
                         "--lqr", QR, "--at", "q2=pi/2", "--fps", 0.5, "-o", out)
    assert rc == 0, err
    _, traj, _ = api_run
    np.testing.assert_allclose(drawn[0].x, traj.x, rtol=0, atol=1e-10)
    assert out.read_text().count("data:image/png;base64,") >= 5


def test_animate_at_without_a_loop_is_refused(capsys, tmp_path):
    rc, _, err = run_cli(capsys, "animate", "cart-pendulum", "--at", "q2=pi/2", "-o", tmp_path / "c.gif")
    assert rc != 0
    assert "--at is for a closed loop: give --lqr" in err
