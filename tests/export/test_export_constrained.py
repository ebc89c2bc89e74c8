"""Export of constrained models (M q_ddot = f + G^T lambda, G q_ddot = c): the C sources (the
saddle-point solve, the multipliers, the residuals and the projection) against lagrangian's own
numbers and trajectories, the FMU run by fmpy (Model Exchange's drift measured, Co-Simulation
projected), and the Modelica DAE compiled and simulated by rumoca."""

import importlib
import subprocess
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.export import export_c, export_fmu, export_modelica
from lagrangian.numeric._cbackend import c_compiler
from lagrangian.numeric._compiled import compile_equations
from lagrangian.numeric._constrained import consistent_state, constrained_model

needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler ($CC, cc or gcc) to build the C export")
WERROR = ["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2"]


def _fmpy():
    fmpy = pytest.importorskip("fmpy", reason="fmpy (pip install 'lagrangian[fmu]') runs the FMUs")
    importlib.import_module("fmpy.validation")  # the validation the tests call, a submodule

    return fmpy


def _rumoca():
    return pytest.importorskip("rumoca", reason="rumoca (pip install rumoca), a Modelica compiler, checks the model")


_EQS: dict = {}


def _eq(name):
    if name not in _EQS:
        _EQS[name] = lg.derive(lg.load(name))
    return _EQS[name]


def _cm(eq):
    return constrained_model(eq, compile_equations(eq))


def _p(eq, **changed):
    return np.array([changed.get(p.name, v) for p, v in eq.parameters.items()], float)


def _drift(eq, times, X, p):
    """The largest |g| and |G q_dot + b| along a trajectory."""
    cm = _cm(eq)
    res = [cm.residuals(t, x, p) for t, x in zip(times, X)]
    return (max(float(np.max(np.abs(g), initial=0.0)) for g, _ in res),
            max(float(np.max(np.abs(w), initial=0.0)) for _, w in res))


def _columns(result, names, prefix=""):
    return np.column_stack([result[prefix + n] for n in names])


def _pendulum(name, constraint="l - sqrt(x**2 + y**2)", **extra):
    """The Cartesian pendulum built in Python, with another constraint or generalized forces."""
    m = lg.Model(name, coordinates=["x", "y"], parameters={"l": 1.0, "g": 9.81}, T="(x_dot**2 + y_dot**2)/2",
                 V="g*y", **extra)
    m.add_constraint(constraint, name="rod")
    return m


#: a residual that overflows after t = 4.78 while its derivatives stay finite (log(exp(s)) = s):
#: the projection, the only part that evaluates g, meets a residual that is not finite
LATE = "l - sqrt(x**2 + y**2) + log(exp(t + 705)) - t - 705"


# ------------------------------------------------------------------------------------------ C

_CHECK = r"""#include <stdio.h>
#include "@ID@.h"
#define K 6
int main(void) {
    const double X[K][@UP@_NX] = {@X@};
    const double U[@NU1@] = {@U@};
    double dx[@UP@_NX], lambda[@UP@_NC], lam2[@UP@_NC], g[@UP@_NH + 1], w[@UP@_NC], G[@UP@_NC * @UP@_N];
    double c[@UP@_NC], x[@UP@_NX];
    int k, i, s;
    for (k = 0; k < K; k++) {
        double r = @ID@_rhs_multipliers(0.3, X[k], U, @ID@_parameter_values, dx, lambda);
        double r2 = @ID@_multipliers(0.3, X[k], U, @ID@_parameter_values, lam2);
        printf("%.17g %.17g", r, r2);
        for (i = 0; i < @UP@_NX; i++) printf(" %.17g", dx[i]);
        for (i = 0; i < @UP@_NC; i++) printf(" %.17g %.17g", lambda[i], lam2[i]);
        @ID@_constraint_residuals(0.3, X[k], @ID@_parameter_values, g, w);
        for (i = 0; i < @UP@_NH; i++) printf(" %.17g", g[i]);
        for (i = 0; i < @UP@_NC; i++) printf(" %.17g", w[i]);
        @ID@_constraint_jacobian(0.3, X[k], @ID@_parameter_values, G, c);
        for (i = 0; i < @UP@_NC * @UP@_N; i++) printf(" %.17g", G[i]);
        for (i = 0; i < @UP@_NC; i++) printf(" %.17g", c[i]);
        for (i = 0; i < @UP@_NX; i++) x[i] = X[k][i];
        s = @ID@_project(0.3, x, @ID@_parameter_values);
        printf(" %d", s);
        for (i = 0; i < @UP@_NX; i++) printf(" %.17g", x[i]);
        for (i = 0; i < @UP@_NX; i++) x[i] = X[k][i];
        s = @ID@_consistent_state(0.0, x, @ID@_parameter_values, @ID@_independent);
        printf(" %d", s);
        for (i = 0; i < @UP@_NX; i++) printf(" %.17g", x[i]);
        printf("\n");
    }
    return 0;
}
"""


def _build(folder, ident, *extra):
    build = subprocess.run([*c_compiler().split(), *WERROR, "-o", str(folder / "run"), *map(str, extra),
                            str(folder / f"{ident}.c"), "-lm"], capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    return folder / "run"


@needs_cc
@pytest.mark.parametrize("name", ["cartesian-pendulum", "four-bar", "rolling-disk"])
@pytest.mark.subprocess
def test_c_of_a_constrained_model_gives_lagrangian_s_numbers(name, tmp_path):
    """Built with -Wall -Wextra -pedantic -Werror: at states 1e-3 off the constraints (and random
    inputs), the saddle-point solve gives numeric._constrained's q_ddot and lambda (np.linalg.solve
    of the unscaled system) to 1e-12 relative (measured: 1e-15), the residuals, G and c to
    rounding; the projection gives ConstrainedModel.project's state to 1e-13 and the consistent
    state (the independent coordinates and speeds held) consistent_state's to 1e-12 (measured:
    9e-16 and 2.5e-16)."""
    eq = _eq(name)
    ident, n, nc = name.replace("-", "_"), eq.n, len(eq.multipliers)
    nh = sum(c.kind == "holonomic" for c in eq.model.constraints)
    folder = tmp_path / ident
    export_c(eq, folder)
    cm, p = _cm(eq), _p(eq)
    x0 = np.array([float(v) for v in (folder / f"{ident}.c").read_text().split(f"{ident}_initial_state[] = {{")[1]
                   .split("}")[0].split(",")])
    rng = np.random.default_rng(7)
    X = x0 + 1e-3 * rng.standard_normal((6, 2 * n))
    U = rng.uniform(-1, 1, max(1, len(eq.inputs)))
    rows = ", ".join("{" + ", ".join(repr(float(v)) for v in x) + "}" for x in X)
    (folder / "check.c").write_text(
        _CHECK.replace("@ID@", ident).replace("@UP@", ident.upper()).replace("@X@", rows)
        .replace("@U@", ", ".join(map(repr, map(float, U)))).replace("@NU1@", str(len(U))))
    out = subprocess.run([str(_build(folder, ident, folder / "check.c"))], capture_output=True, text=True,
                         check=True).stdout
    sim = eq.model.simulation
    held = {str(q) for q in sim.get("independent", ())}
    held |= {str(v) for v in sim.get("independent_speeds", ())} or {f"{q}_dot" for q in held}
    u = U[:len(eq.inputs)]
    for line, x in zip(out.splitlines(), X):
        v = np.array([float(s) for s in line.split()])
        r, r2, dx = v[0], v[1], v[2:2 + 2 * n]
        lam = v[2 + 2 * n:2 + 2 * n + 2 * nc:2]
        lam2 = v[3 + 2 * n:2 + 2 * n + 2 * nc:2]
        k = 2 + 2 * n + 2 * nc
        g, w = v[k:k + nh], v[k + nh:k + nh + nc]
        k += nh + nc
        G, c = v[k:k + nc * n].reshape(nc, n), v[k + nc * n:k + nc * n + nc]
        k += nc * n + nc
        status, projected = v[k], v[k + 1:k + 1 + 2 * n]
        k += 1 + 2 * n
        status2, consistent = v[k], v[k + 1:k + 1 + 2 * n]
        qdd, lam_py = cm.solve(0.3, x, u, p)
        assert 0 < r <= 1 and r == r2
        np.testing.assert_array_equal(dx[:n], x[n:])
        np.testing.assert_allclose(dx[n:], qdd, rtol=1e-12, atol=1e-12 * np.max(np.abs(qdd)))
        np.testing.assert_allclose(lam, lam_py, rtol=1e-12, atol=1e-12 * np.max(np.abs(lam_py)))
        np.testing.assert_array_equal(lam, lam2)
        g_py, w_py = cm.residuals(0.3, x, p)
        np.testing.assert_allclose(g, g_py, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(w, w_py, rtol=1e-13, atol=1e-15)
        _, G_py, _ = cm._velocity_parts(0.3, x, p)
        np.testing.assert_allclose(G, G_py, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(c, cm._parts(np.concatenate(([0.3], x, u, p)))[-nc:].ravel(), rtol=1e-12,
                                   atol=1e-14)
        assert status == 0 and np.max(np.abs(projected - cm.project(0.3, x, p))) < 1e-13
        assert status2 == 0
        assert np.max(np.abs(consistent - consistent_state(cm, x, held, p))) < 1e-12
        assert all(consistent[eq.state_names.index(h)] == x[eq.state_names.index(h)] for h in held)


@needs_cc
@pytest.mark.parametrize("name, step, states, multipliers", [("cartesian-pendulum", 2.5e-4, 1e-11, 1e-10),
                                                             ("four-bar", 2.5e-4, 2e-8, 5e-7)])
@pytest.mark.subprocess
def test_c_example_projects_after_every_step_and_follows_lagrangian(name, step, states, multipliers, tmp_path):
    """The example (RK4 with a fixed step, the state projected after every step), built with
    -Werror, follows lagrangian.simulate (DOP853 at rtol 1e-13, projected after every step) over 2 s:
    RK4's error at h = 2.5e-4 (h^4 ~ 4e-15 per unit of the model's time scale to the fourth; the
    four-bar's crank turns at 4 rad/s and its multipliers are large, measured 4.1e-9 in the states
    and 6.9e-8 in lambda; the pendulum 7e-13 and 3e-12). Its constraints stay at round-off."""
    eq = _eq(name)
    ident, n = name.replace("-", "_"), eq.n
    folder = tmp_path / ident
    export_c(eq, folder)
    run = _build(folder, ident, folder / "main.c")
    every = round(0.1 / step)
    out = subprocess.run([str(run), "2", repr(step), str(every)], capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out[0] == ",".join(["t", *eq.state_names, "energy", *(m.name for m in eq.multipliers)])
    data = np.array([[float(v) for v in line.split(",")] for line in out[1:]])
    assert len(data) == 21
    ours = lg.simulate(eq, 2.0, dt=0.1, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(data[:, 0], ours.t, atol=1e-12)
    X = data[:, 1:1 + 2 * n]
    assert np.max(np.abs(X - ours.x)) < states
    assert np.max(np.abs(data[:, 2 + 2 * n:] - ours.multipliers)) < multipliers
    assert max(_drift(eq, ours.t, X, _p(eq))) < 1e-12


@needs_cc
@pytest.mark.slow
@pytest.mark.subprocess
def test_c_reports_a_singular_saddle_point_system_and_a_failed_projection(tmp_path):
    """Two constraints that say the same (the rod's length twice) make [M G^T; G 0] singular: the
    C right-hand side returns at most 1e-12 and sets nothing; a state that is not finite makes the
    projection return <ID>_NOT_FINITE. The example says each failure: the singular system, a
    forcing that is not finite, a residual that is not finite at a projection, a start state whose
    constraints cannot be met."""
    m = lg.Model("twice", coordinates=["x", "y"], parameters={"l": 1.0, "g": 9.81})
    m.add_particle(1, ("x", "y"), name="bob")
    m.add_gravity("g")
    m.add_constraint("l - sqrt(x**2 + y**2)", name="rod")
    m.add_constraint("x**2 + y**2 - l**2", name="rope")
    folder = tmp_path / "twice"
    export_c(lg.derive(m), folder, initial={"x": 1.0, "y": 0.0})
    (folder / "check.c").write_text("""#include <math.h>
#include <stdio.h>
#include "twice.h"
int main(void) {
    double x[4] = {0.6, -0.8, 0.4, 0.3}, dx[4] = {7, 7, 7, 7}, lambda[2] = {7, 7}, nan[4] = {NAN, 0, 0, 0};
    double r = twice_rhs_multipliers(0.0, x, 0, twice_parameter_values, dx, lambda);
    printf("%.3g %g %g %d %d\\n", r, dx[2], lambda[0], twice_project(0.0, nan, twice_parameter_values),
           TWICE_NOT_FINITE);
    return 0;
}
""")
    r, dx, lam, status, expected = subprocess.run([str(_build(folder, "twice", folder / "check.c"))],
                                                  capture_output=True, text=True, check=True).stdout.split()
    assert float(r) <= 1e-12 and dx == "7" and lam == "7" and status == expected == "4"
    run = _build(folder, "twice", folder / "main.c")
    example = subprocess.run([str(run), "1", "0.01", "10"], capture_output=True, text=True)
    assert example.returncode == 1
    assert example.stderr == ("at t = 0: the system [M G^T; G 0] is singular (M singular, or the constraints "
                              "dependent: a dead point)\n")
    folder = tmp_path / "four"
    export_c(_eq("four-bar"), folder)
    source = (folder / "four_bar.c").read_text()
    line = "four_bar_parameter_values[] = {0.2, 0.6, 0.45, 0.5,"
    assert line in source  # a, b, c, d: with a rocker of 0.01 the loop cannot close
    (folder / "four_bar.c").write_text(source.replace(line, line.replace("0.45", "0.01")))
    example = subprocess.run([str(_build(folder, "four_bar", folder / "main.c"))], capture_output=True, text=True)
    assert example.returncode == 1
    assert example.stderr == "the initial state: the coordinates cannot meet the holonomic constraints\n"
    for name, model, args, said in [
            ("kick", _pendulum("kick", Q={"y": "1/(t - 0.5)"}), ["1", "0.125", "1"],
             "at t = 0.5: M, f, G or c is not finite\n"),
            ("late", _pendulum("late", LATE), ["5", "0.01", "100"],
             "at t = 4.79: the projection onto the constraints failed: a residual or a Jacobian entry is not "
             "finite\n")]:
        folder = tmp_path / name
        export_c(lg.derive(model), folder, initial={"x": 1.0, "y": 0.0})
        example = subprocess.run([str(_build(folder, name, folder / "main.c")), *args], capture_output=True,
                                 text=True)
        assert example.returncode == 1 and example.stderr == said


# ---------------------------------------------------------------------------------------- FMU


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """The FMUs of the Cartesian pendulum and the four-bar, built once for the module."""
    if c_compiler() is None:
        pytest.skip("no C compiler ($CC, cc or gcc) to build the FMU's binary")
    folder = tmp_path_factory.mktemp("fmu")
    out = {}
    for name in ("cartesian-pendulum", "four-bar"):
        result = export_fmu(_eq(name), folder / f"{name}.fmu")
        assert result.warnings == () and result.binary is not None
        out[name] = str(folder / f"{name}.fmu")
    return out


@pytest.mark.slow
def test_constrained_fmu_validates_and_has_the_multipliers_as_outputs(fmus):
    """fmpy's validation reports nothing; the multipliers follow the energy as calculated outputs;
    the states are initial="approx" (the FMU makes them consistent), their start values the
    consistent state lagrangian.simulate starts from."""
    fmpy = _fmpy()
    path = fmus["four-bar"]
    assert fmpy.validation.validate_fmu(path) == []
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    variables = list(root.find("ModelVariables"))
    names = [v.get("name") for v in variables]
    eq = _eq("four-bar")
    k = names.index("energy")
    assert names[k + 1:k + 4] == ["lambda_loop_x", "lambda_loop_y", "solver.rtol"]
    lam = variables[k + 1]
    assert (lam.get("causality"), lam.get("variability"), lam.get("initial")) == ("output", "continuous",
                                                                                 "calculated")
    assert "holonomic constraint loop_x: a*cos(th1) + b*cos(th2) - c*cos(th3) - d = 0" in lam.get("description")
    starts = [float(v.find("Real").get("start")) for v in variables[:6]]
    assert all(v.get("initial") == "approx" for v in variables[:6])
    np.testing.assert_allclose(starts, lg.simulate(eq, 0.01, dt=0.01).x[0], atol=1e-15)
    outputs = [int(u.get("index")) for u in root.find("ModelStructure").find("Outputs")]
    initial = [int(u.get("index")) for u in root.find("ModelStructure").find("InitialUnknowns")]
    assert outputs == [1, 2, 3, 4, 5, 6, k + 1, k + 2, k + 3] and initial[:6] == [1, 2, 3, 4, 5, 6]


@pytest.mark.subprocess
def test_constrained_model_exchange_matches_lagrangian_and_drifts(fmus):
    """Model Exchange gives the index-1 form to fmpy's CVode, which integrates it without
    projection: at rtol 1e-12 the Cartesian pendulum follows lagrangian over 2 s to 1e-8
    (measured 6.4e-10, lambda 3.7e-9) and the four-bar over 0.5 s to 1e-8 (measured 1.9e-9); over
    10 s at rtol 1e-8 the pendulum's rod length drifts (measured |g| 5e-7 in the first second,
    9.8e-7 at most, |w| 1e-6), where Co-Simulation, projected after every step, stays at round-off."""
    fmpy = _fmpy()
    eq = _eq("cartesian-pendulum")
    names, lam = list(eq.state_names), [m.name for m in eq.multipliers]
    ours = lg.simulate(eq, 2.0, dt=0.1, rtol=1e-13, atol=1e-13)
    me = fmpy.simulate_fmu(fmus["cartesian-pendulum"], fmi_type="ModelExchange", stop_time=2.0, output_interval=0.1,
                           relative_tolerance=1e-12, output=names + lam)
    np.testing.assert_allclose(me["time"], ours.t, atol=1e-12)
    assert np.max(np.abs(_columns(me, names) - ours.x)) < 1e-8
    assert np.max(np.abs(me["lambda_rod"] - ours["lambda_rod"])) < 1e-7
    four = _eq("four-bar")
    ours4 = lg.simulate(four, 0.5, dt=0.01, rtol=1e-13, atol=1e-13)
    me4 = fmpy.simulate_fmu(fmus["four-bar"], fmi_type="ModelExchange", stop_time=0.5, output_interval=0.01,
                            relative_tolerance=1e-12, output=list(four.state_names))
    assert np.max(np.abs(_columns(me4, four.state_names) - ours4.x)) < 1e-8
    p = _p(eq)
    long_me = fmpy.simulate_fmu(fmus["cartesian-pendulum"], fmi_type="ModelExchange", stop_time=10.0,
                                output_interval=0.01, relative_tolerance=1e-8, output=names)
    g_me, w_me = _drift(eq, long_me["time"], _columns(long_me, names), p)
    assert 1e-8 < g_me < 1e-5 and 1e-8 < w_me < 1e-5
    first = long_me["time"] <= 1.0
    assert _drift(eq, long_me["time"][first], _columns(long_me, names)[first], p)[0] < g_me
    long_cs = fmpy.simulate_fmu(fmus["cartesian-pendulum"], fmi_type="CoSimulation", stop_time=10.0,
                                output_interval=0.01, start_values={"solver.rtol": 1e-8, "solver.atol": 1e-8},
                                output=names)
    assert max(_drift(eq, long_cs["time"], _columns(long_cs, names), p)) < 1e-14


def test_constrained_co_simulation_projects_and_matches_lagrangian(fmus):
    """Co-Simulation (DOP853 at solver.rtol 1e-12, projected after every step) follows lagrangian:
    the four-bar from th1 = 2 (a changed start value: held, the others made consistent as
    lagrangian does), driven by tau = 0.5 with a heavier coupler, to 1e-9 in the states (measured
    2.7e-11) and 1e-8 in the multipliers (1.3e-10); the pendulum to 1e-10 (2.4e-12). Its
    constraints stay at round-off over 10 s at the default tolerance (|g| <= 1e-14 (1 + max|q|),
    the projection's own stopping rule, with the crank's angle growing to 70 rad: measured 5.1e-13)."""
    fmpy = _fmpy()
    eq = _eq("four-bar")
    names, lam = list(eq.state_names), [m.name for m in eq.multipliers]
    ours = lg.simulate(eq, 1.0, {"th1": 2.0, "th1_dot": 4.0}, inputs={"tau": 0.5}, params={"mb": 1.5}, dt=0.1,
                       rtol=1e-13, atol=1e-13)
    tight = {"solver.rtol": 1e-12, "solver.atol": 1e-12}
    cs = fmpy.simulate_fmu(fmus["four-bar"], fmi_type="CoSimulation", stop_time=1.0, output_interval=0.1,
                           start_values={"th1": 2.0, "tau": 0.5, "mb": 1.5, **tight}, output=names + lam)
    assert np.max(np.abs(_columns(cs, names) - ours.x)) < 1e-9
    assert np.max(np.abs(_columns(cs, lam) - ours.multipliers)) < 1e-8
    me = fmpy.simulate_fmu(fmus["four-bar"], fmi_type="ModelExchange", stop_time=0.1, output_interval=0.1,
                           relative_tolerance=1e-12, start_values={"th1": 2.0, "tau": 0.5, "mb": 1.5}, output=names)
    np.testing.assert_allclose(_columns(me, names)[0], ours.x[0], atol=1e-13)
    pendulum = _eq("cartesian-pendulum")
    ours = lg.simulate(pendulum, 2.0, dt=0.1, rtol=1e-13, atol=1e-13)
    cs = fmpy.simulate_fmu(fmus["cartesian-pendulum"], fmi_type="CoSimulation", stop_time=2.0, output_interval=0.1,
                           start_values=tight, output=list(pendulum.state_names))
    assert np.max(np.abs(_columns(cs, pendulum.state_names) - ours.x)) < 1e-10
    long_cs = fmpy.simulate_fmu(fmus["four-bar"], fmi_type="CoSimulation", stop_time=10.0, output_interval=0.01,
                                output=names)
    X = _columns(long_cs, names)
    g, w = _drift(eq, long_cs["time"], X, _p(eq))
    assert g <= 1e-14 * (1 + np.max(np.abs(X[:, :3]))) and w < 1e-14


def _fails(fmpy, path, messages, **kwargs):
    def logger(component, instance, status, category, text):
        messages.append(text.decode())

    with pytest.raises(Exception, match="failed"):
        fmpy.simulate_fmu(path, logger=logger, **kwargs)


@pytest.mark.slow
def test_constrained_fmu_errors_are_said_through_the_logger(fmus, tmp_path):
    """Start values that cannot be made consistent (every coordinate of the four-bar changed, so
    held; the pendulum's x_dot changed where only y_dot is free, and the rod leaves y_dot free at
    y = 0); two constraints that say the same (a singular saddle-point system); a projection that
    meets a residual that is not finite (LATE); a forcing that is not finite (1/(t - 0.5) at
    t = 0.5)."""
    fmpy = _fmpy()
    messages: list = []
    _fails(fmpy, fmus["four-bar"], messages, fmi_type="CoSimulation", stop_time=1.0,
           start_values={"th1": 2.0, "th2": 5.0, "th3": 0.1})
    assert ("at t = 0: the start state cannot be made consistent with the constraints: the coordinates that may "
            "change cannot meet the holonomic constraints (held: the independent coordinates and speeds, and the "
            "start values that were changed); give start values that meet them, or change fewer") in messages
    twice = lg.Model("twice", coordinates=["x", "y"], parameters={"l": 1.0, "g": 9.81})
    twice.add_particle(1, ("x", "y"), name="bob")
    twice.add_gravity("g")
    twice.add_constraint("l - sqrt(x**2 + y**2)", name="rod")
    twice.add_constraint("x**2 + y**2 - l**2", name="rope")
    export_fmu(lg.derive(twice), tmp_path / "twice.fmu", initial={"x": 1.0, "y": 0.0})
    messages.clear()
    _fails(fmpy, str(tmp_path / "twice.fmu"), messages, fmi_type="ModelExchange", stop_time=1.0)
    assert any(m.startswith("at t = 0: the saddle-point system [M G^T; G 0] is singular (M singular, or the "
                            "constraints dependent: G has lost rank, a dead point of the mechanism)") for m in messages)
    export_fmu(lg.derive(_pendulum("late", LATE)), tmp_path / "late.fmu", initial={"x": 1.0, "y": 0.0})
    messages.clear()
    _fails(fmpy, str(tmp_path / "late.fmu"), messages, fmi_type="CoSimulation", start_time=4.0, stop_time=6.0,
           output_interval=1.0)
    assert any("the projection onto the constraints failed: a constraint's residual or Jacobian is not finite" in m
               for m in messages), messages
    export_fmu(lg.derive(_pendulum("kick", Q={"y": "1/(t - 0.5)"})), tmp_path / "kick.fmu",
               initial={"x": 1.0, "y": 0.0})
    messages.clear()
    _fails(fmpy, str(tmp_path / "kick.fmu"), messages, fmi_type="CoSimulation", start_time=0.5, stop_time=1.0)
    assert any(m.startswith("at t = 0.5: M, f, G or c is not finite (NaN or infinity)") for m in messages), messages
    messages.clear()
    _fails(fmpy, fmus["cartesian-pendulum"], messages, fmi_type="ModelExchange", stop_time=1.0,
           start_values={"x_dot": 1.0})
    assert any("the velocities that may change cannot meet the constraints" in m for m in messages), messages


# ----------------------------------------------------------------------------------- Modelica


@pytest.mark.parametrize("name, wrapper, t_end, states, multipliers", [
    ("cartesian-pendulum", None, 2.0, 1e-8, 5e-8),
    ("four-bar", "tau = 0.5", 1.0, 1e-7, 2e-6),
    ("rolling-disk", None, 1.0, 1e-8, 1e-8)])
def test_constrained_modelica_is_the_dae_and_rumoca_simulates_it(name, wrapper, t_end, states, multipliers, tmp_path):
    """The model is the DAE: M der(q_dot) = f + G^T lambda and the constraints as equations
    (g = 0, a . q_dot + b = 0); rumoca finds nothing to report, finds it balanced, reduces its
    index and simulates it (rtol 1e-12) to lagrangian's trajectory. Measured: the pendulum
    9.5e-10 (lambda 5.7e-9), the driven four-bar 2.7e-8 (5.3e-7), the rolling disk (velocity
    constraints) 6.1e-10 (1.4e-10)."""
    rm = _rumoca()
    from lagrangian.export._modelica import class_name

    eq = _eq(name)
    cls = class_name(name)
    path = tmp_path / f"{cls}.mo"
    export_modelica(eq, path)
    text = path.read_text()
    assert rm.validate(str(path), model=cls) == []
    for m in eq.multipliers:
        assert f"  output Real {m.name} " in text
    if name == "cartesian-pendulum":
        assert "  (m)*der(x_dot) = (-x/sqrt(x^2 + y^2))*lambda_rod;" in text
        assert "  (m)*der(y_dot) = -g*m + (-y/sqrt(x^2 + y^2))*lambda_rod;" in text
        assert "  l - sqrt(x^2 + y^2) = 0;  // holonomic constraint rod" in text
        assert "  Real x(start = 1.0, fixed = false)" in text and "  Real y(start = 0.0, fixed = true)" in text
    if name == "four-bar":
        assert "  Real th1(start = 1.2, fixed = true)" in text and "  Real th2(start = 0.4253" in text
    session = rm.Session(roots=[str(tmp_path)])
    if wrapper:
        model = session.loads(f"model Test\n  {cls} plant({wrapper});\nend Test;\n", model="Test")
        prefix, inputs = "plant.", {k.strip(): float(v) for k, v in (wrapper.split("="),)}
    else:
        model, prefix, inputs = session.load(str(path), model=cls), "", None
    assert model.structure().is_balanced
    res = model.simulate(t=(0.0, t_end), dt=0.1, config=rm.SimConfig(rtol=1e-12, atol=1e-12))
    ours = lg.simulate(eq, t_end, t_eval=np.asarray(res.time), inputs=inputs, rtol=1e-13, atol=1e-13)
    assert np.max(np.abs(_columns(res, eq.state_names, prefix) - ours.x)) < states
    assert np.max(np.abs(_columns(res, [m.name for m in eq.multipliers], prefix) - ours.multipliers)) < multipliers


# ------------------------------------------------------------------------------------ command


@needs_cc
@pytest.mark.slow
def test_export_command_takes_a_constrained_model(tmp_path, capsys):
    fmu, mo, c = tmp_path / "four.fmu", tmp_path / "four.mo", tmp_path / "four-c"
    assert main(["export", "four-bar", "--fmu", str(fmu), "--modelica", str(mo), "--c", str(c),
                 "--initial", "th1=2.0", "--param", "mb=1.5"]) == 0
    out = capsys.readouterr().out
    assert f"wrote {fmu} (FMI 2.0 FMU, Model Exchange and Co-Simulation, binary for " in out
    assert f"wrote {mo} (Modelica model FourBar)" in out and f"to {c}" in out
    start = lg.simulate(_eq("four-bar"), 0.01, {"th1": 2.0, "th1_dot": 4.0}, params={"mb": 1.5}, dt=0.01).x[0]
    assert "four_bar_initial_state[] = {" + ", ".join(repr(float(v)) for v in start) + "}" in (
        c / "four_bar.c").read_text()
    assert f"Real th2(start = {float(start[1])!r}, fixed = false)" in mo.read_text()
    assert main(["export", "cartesian-pendulum", "--c", str(tmp_path / "p"), "--initial", "x=2,y=0"]) == 2
    assert ("lagrangian export: error: [initial]: the initial coordinates do not meet constraint 'rod' (l - sqrt(x**2 "
            "+ y**2) = -1, not 0), and changing the coordinates that were not given (none; given: x, y) does not fix "
            "it: give fewer coordinates (the independent ones) or values that meet it") in capsys.readouterr().err
