"""The one simulation pipeline (issue 20 items 3 and 6): the status enumeration, the frozen options
and their one merge rule, the solver objects, and one meaning of --initial everywhere."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.numeric import DOP853, SciPyMethod, SimulationOptions, Variational
from lagrangian.numeric._kernels import STATUS


def run_cli(capsys, *args):
    rc = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return rc, out, err


def oscillator(**kw):
    return lg.Model("forced", coordinates=["x"], parameters={"m": 1.0, "k": 4.0, "c": 0.3}, inputs=["F", "G"],
                    T="m*x_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2", Q={"x": "F + G"}, **kw)


# ------------------------------------------------------------------------- item 6: one rule
def test_initial_by_name_is_one_rule_for_the_api_the_cli_the_export_and_the_playground(capsys, tmp_path):
    """double-pendulum's [simulation] initial is theta1 = 2.0, theta2 = 2.5: giving theta2 = 0.5
    keeps theta1 = 2.0 through every path."""
    expected = [2.0, 0.5, 0.0, 0.0]
    api = lg.simulate(lg.load("double-pendulum"), 0.1, {"theta2": 0.5}, dt=0.1)
    assert api.x[0].tolist() == expected

    rc, out, err = run_cli(capsys, "simulate", "double-pendulum", "--t-end", "0.1", "--dt", "0.1",
                           "--initial", "theta2=0.5")
    assert rc == 0, err
    assert [float(v) for v in out.splitlines()[1].split(",")[1:5]] == expected

    mo = tmp_path / "dp.mo"
    rc, out, err = run_cli(capsys, "export", "double-pendulum", "--modelica", mo, "--initial", "theta2=0.5")
    assert rc == 0, err
    text = mo.read_text()
    assert "theta1(start = 2.0," in text and "theta2(start = 0.5," in text

    from lagrangian.examples import example_source
    from lagrangian.serve._tasks import run

    reply = run("simulate", json.dumps({"model": example_source("double-pendulum"), "t_end": 0.1, "dt": 0.1,
                                        "initial": {"theta2": 0.5}}).encode())
    assert reply.status == 200, reply.body
    columns = json.loads(reply.body)["columns"]
    assert [columns[n][0] for n in ("theta1", "theta2", "theta1_dot", "theta2_dot")] == expected


def test_inputs_given_update_the_models_by_name():
    model = oscillator()
    model.simulation = {"inputs": {"F": "1", "G": "2"}, "initial": {"x": 0.5}}
    traj = lg.simulate(model, 0.1, inputs={"G": "3"}, dt=0.1)
    assert traj["F"].tolist() == [1.0, 1.0] and traj["G"].tolist() == [3.0, 3.0]
    assert traj.x[0].tolist() == [0.5, 0.0]
    assert lg.simulate(model, 0.1, [0.0, 1.0], dt=0.1).x[0].tolist() == [0.0, 1.0]  # an array replaces all


def test_the_merge_rule_of_simulation_options():
    model = oscillator()
    model.simulation = {"t_end": 2.0, "dt": 0.5, "initial": {"x": 0.5}, "inputs": {"F": "1"},
                        "sample_time": {"F": 0.1}}
    base = SimulationOptions.from_model(model)
    assert (base.t_end, base.dt, base.rtol, base.atol) == (2.0, 0.5, 1e-9, 1e-9)
    merged = base.merged(t_end=3.0, dt=None, initial={"x_dot": 1.0}, inputs={"G": "t"},
                         sample_time={"G": 0.2}, params={"k": 5.0})
    assert (merged.t_end, merged.dt) == (3.0, 0.5)  # a value replaces, None keeps
    assert dict(merged.initial) == {"x": 0.5, "x_dot": 1.0} and dict(merged.given) == {"x_dot": 1.0}
    assert dict(merged.inputs) == {"F": "1", "G": "t"} and dict(merged.params) == {"k": 5.0}
    assert dict(merged.sample_time) == {"F": 0.1, "G": 0.2}
    assert base.merged(sample_time=0.3).sample_time == 0.3  # a number replaces the mapping
    assert base.merged(stop_on="hit").stop_on == ("hit",)
    assert dict(base.initial) == {"x": 0.5}  # frozen: merging makes a new object
    with pytest.raises(dataclasses.FrozenInstanceError):
        base.t_end = 1.0
    with pytest.raises(TypeError):
        base.initial["x"] = 1.0
    with pytest.raises(TypeError, match=r"^unknown simulation option tend; the options are atol, backend, "):
        base.merged(tend=1.0)


def test_options_object_given_to_simulate():
    model = oscillator()
    options = SimulationOptions(t_end=1.0, dt=0.5, initial={"x": 1.0}, method="variational", step=0.01)
    traj = lg.simulate(model, options=options, inputs={"F": "0"})
    assert traj.t.tolist() == [0.0, 0.5, 1.0] and traj.stats["method"] == "variational"
    same = lg.simulate(model, 1.0, {"x": 1.0}, dt=0.5, method="variational", step=0.01)
    assert np.array_equal(traj.x, same.x)


def test_every_problem_of_the_options_at_once():
    with pytest.raises(lg.ModelError) as info:
        lg.simulate(oscillator(), -1.0, dt=0.0, rtol=2.0, method="DOP854")
    keys = [p.key for p in info.value.problems]
    assert keys == ["t_end", "dt", "rtol", "method"]
    assert "unknown method 'DOP854' (did you mean 'DOP853'?)" in str(info.value)


# --------------------------------------------------------------------------------- status
def test_status_members_carry_their_message_and_fix():
    assert lg.Status.SUCCESS == 0 and lg.Status.STEP_TOO_SMALL == -1 and lg.Status(5) is lg.Status.CHATTERING
    assert lg.Status.STEP_TOO_SMALL.message == "Required step size is less than spacing between numbers."
    assert "method='Radau'" in lg.Status.STEP_TOO_SMALL.fix
    assert lg.Status.CHATTERING.fix.startswith("smooth the switch with a boundary layer")
    assert lg.Status.SUCCESS.ok and lg.Status.EVENT_STOP.ok and not lg.Status.SINGULAR_MASS_MATRIX.ok
    assert lg.Status.of(99) == 99 and not isinstance(lg.Status.of(99), lg.Status)
    # the kernels' table is the enumeration's (one source)
    assert {code: lg.Status(code).message for code in (0, 1, 2, 3, -1, -3, 4, 5)}.items() <= STATUS.items()


def test_status_of_a_trajectory_and_of_a_failed_run():
    model = oscillator()
    for backend in ("numba", "scipy"):
        traj = lg.simulate(model, 0.5, {"x": 1.0}, backend=backend)
        assert traj.stats["status"] is lg.Status.SUCCESS and traj.message == lg.Status.SUCCESS.message
    blowup = lg.Model("blowup", coordinates=["x"], parameters={"m": 1.0}, T="m*x_dot**2/2", V="-x**4/4")
    for backend in ("numba", "scipy"):
        with pytest.raises(lg.SimulationError, match=r"; try a smaller rtol/atol, a stiff method") as info:
            lg.simulate(blowup, 10.0, {"x": 1.0, "x_dot": 2.0}, backend=backend)
        assert info.value.status is lg.Status.STEP_TOO_SMALL and info.value.status == -1
        assert info.value.partial.stats["status"] is lg.Status.STEP_TOO_SMALL
    stopped = lg.simulate(lg.load("double-pendulum"), 5.0, events={"down": "theta1"}, stop_on="down")
    assert stopped.stats["status"] is lg.Status.EVENT_STOP


def test_forcing_not_finite_is_its_status():
    model = lg.Model("sqrt", coordinates=["x"], parameters={"m": 1.0}, T="m*x_dot**2/2", V="sqrt(x)")
    for backend in ("numba", "scipy"):  # (the status was -1 before issue 20, the kernel's code 3 now)
        with pytest.raises(lg.SimulationError, match=r"the forcing f is not finite \(NaN or infinity\) at t = 0 in "
                                                     r"the state x = -1, x_dot = 0: check the model's") as info:
            lg.simulate(model, 1.0, {"x": -1.0}, backend=backend)
        assert info.value.status is lg.Status.FORCING_NOT_FINITE


def test_batch_statuses_are_members():
    model = oscillator()
    batch = lg.simulate_batch(model, 0.5, {"x": [1.0, 2.0]})
    assert batch.statuses == [lg.Status.SUCCESS, lg.Status.SUCCESS]
    assert batch.messages == [lg.Status.SUCCESS.message] * 2


# -------------------------------------------------------------------------------- solvers
def test_solver_objects_are_the_methods():
    model = lg.load("double-pendulum")
    by_name = lg.simulate(model, 1.0, method="variational", step=0.01)
    by_object = lg.simulate(model, 1.0, method=Variational(step=0.01))
    assert np.array_equal(by_name.x, by_object.x) and by_object.stats["method"] == "variational"
    assert np.array_equal(lg.simulate(model, 1.0, method=DOP853()).x, lg.simulate(model, 1.0).x)
    radau = lg.simulate(model, 1.0, method=SciPyMethod("Radau"), rtol=1e-10, atol=1e-10)
    assert radau.stats["backend"] == "scipy" and radau.stats["method"] == "Radau"
    assert np.max(np.abs(radau.x[-1] - lg.simulate(model, 1.0, rtol=1e-10, atol=1e-10).x[-1])) < 1e-6


def test_solvers_say_what_they_support_and_refuse_with_the_fix():
    assert (DOP853().events, DOP853().compiled, DOP853().scipy) == (True, True, True)
    assert not Variational().scipy and not Variational().sampled_inputs and not Variational().constraints
    assert not SciPyMethod("RK45").events and SciPyMethod("RK45").constraints
    with pytest.raises(lg.ModelError, match=r"method 'variational' runs in compiled code only: use backend='auto'"):
        lg.simulate(oscillator(), 1.0, method=Variational(), backend="scipy")
    with pytest.raises(lg.ModelError, match=r"events are watched by the compiled DOP853 only, not by method 'BDF'"):
        lg.simulate(oscillator(), 1.0, method=SciPyMethod("BDF"), events={"zero": "x"})
    with pytest.raises(lg.ModelError, match=r"t_end = 10 in fixed steps of 1e-09 is 1e\+10 steps: use a larger step"):
        lg.simulate(oscillator(), 10.0, method=Variational(step=1e-9), inputs={"F": "0"})  # the object's step
    assert Variational().callable_inputs is False and DOP853().callable_inputs is True


# ------------------------------------------------------------------------ energy's name
def test_energy_name_comes_from_the_equations():
    assert lg.derive(lg.load("double-pendulum")).energy_name == "energy"
    rotating = lg.Model("bead", coordinates=["r"], parameters={"m": 1.0, "w": 2.0}, T="m*(r_dot**2 + w**2*r**2)/2")
    assert lg.derive(rotating).energy_name == "jacobi_integral"
    driven = lg.Model("driven", coordinates=["x"], parameters={"m": 1.0}, T="m*x_dot**2/2", V="x*cos(t)")
    assert lg.derive(driven).energy_name is None
    traj = lg.simulate(rotating, 1.0, {"r": 1.0})
    assert traj.energy_name == "jacobi_integral" and math.isclose(traj.energy[-1], traj.energy[0], rel_tol=1e-7)
