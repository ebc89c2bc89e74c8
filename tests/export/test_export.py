"""Export: the FMU run by fmpy (validation, Model Exchange and Co-Simulation against lagrangian's
own trajectories), the Modelica model compiled and simulated by rumoca, and the C sources built
and run."""

import importlib
import math
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.export import export_c, export_fmu, export_modelica
from lagrangian.numeric._cbackend import c_compiler

STATES = ("q1", "q2", "q1_dot", "q2_dot")
needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler ($CC, cc or gcc) to build the FMU's binary")


@pytest.fixture(scope="module")
def cart():
    return lg.derive(lg.load("cart-pendulum"))


@pytest.fixture(scope="module")
def fmu(cart, tmp_path_factory):
    """The cart-pendulum's FMU, built once for the module, starting at q2 = 1.4."""
    if c_compiler() is None:
        pytest.skip("no C compiler ($CC, cc or gcc) to build the FMU's binary")
    path = tmp_path_factory.mktemp("fmu") / "cart.fmu"
    result = export_fmu(cart, path, initial={"q2": 1.4})
    assert result.warnings == () and result.binary is not None
    return str(path)


def _fmpy():
    fmpy = pytest.importorskip("fmpy", reason="fmpy (pip install 'lagrangian[fmu]') runs the FMUs")
    importlib.import_module("fmpy.validation")  # the validation the tests call, a submodule

    return fmpy


def _states(result) -> np.ndarray:
    return np.column_stack([result[n] for n in STATES])


# ------------------------------------------------------------------------------------ FMU


@pytest.mark.subprocess
def test_fmu_archive_and_model_description(fmu, cart):
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
        root = ET.fromstring(z.read("modelDescription.xml"))
    assert {"modelDescription.xml", "sources/cart_pendulum.c", "sources/cart_pendulum.h", "sources/fmu.c",
            "sources/fmi2Functions.h", "sources/fmi2FunctionTypes.h", "sources/fmi2TypesPlatform.h",
            "documentation/licenses/fmi2-headers-LICENSE.txt"} <= names
    assert any(n.startswith("binaries/") and n.endswith("cart_pendulum" + (".dll" if os.name == "nt" else ".so"))
               or n.endswith(".dylib") for n in names)
    assert root.get("fmiVersion") == "2.0" and root.get("numberOfEventIndicators") == "0"
    assert root.find("ModelExchange").get("modelIdentifier") == "cart_pendulum"
    assert root.find("CoSimulation").get("canHandleVariableCommunicationStepSize") == "true"
    variables = {v.get("name"): v for v in root.find("ModelVariables")}
    assert list(variables)[:4] == list(STATES)
    for name in STATES:
        assert variables[name].get("causality") == "output" and variables[name].get("initial") == "exact"
    assert variables["q2"].find("Real").get("start") == "1.4"
    for name, value in {"M1": 1.0, "M2": 0.5, "L": 1.0, "g": 9.81}.items():
        v = variables[name]
        assert v.get("causality") == "parameter" and v.get("variability") == "tunable"
        assert float(v.find("Real").get("start")) == value
    assert variables["F"].get("causality") == "input"
    assert variables["energy"].get("causality") == "output"
    assert variables["der(q2_dot)"].find("Real").get("derivative") == "4"
    assert variables["solver.rtol"].get("causality") == "parameter"
    with zipfile.ZipFile(fmu) as z:
        license_text = z.read("documentation/licenses/fmi2-headers-LICENSE.txt").decode()
        header = z.read("sources/fmi2Functions.h").decode()
    assert "2-Clause BSD License" in license_text and "Modelica Association" in license_text
    assert "2-Clause BSD License" in header


def test_the_fmi_headers_ship_with_their_license_in_the_package():
    """The package data (pyproject.toml) carries the FMI headers, their license and the FMU's C
    template, so that an installed lagrangian exports as a checkout does."""
    import fnmatch
    import tomllib
    from pathlib import Path

    import lagrangian.export

    root = Path(__file__).resolve().parents[2]
    if not (root / "pyproject.toml").exists():
        pytest.skip("not a source checkout: no pyproject.toml")
    patterns = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["lagrangian"]
    here = Path(lagrangian.export.__file__).resolve().parent
    shipped = ["fmu_template.c", "fmi2/LICENSE.txt", "fmi2/fmi2Functions.h", "fmi2/fmi2FunctionTypes.h",
               "fmi2/fmi2TypesPlatform.h"]
    for name in shipped:
        assert (here / name).is_file()
        assert any(fnmatch.fnmatch(f"export/{name}", pattern) for pattern in patterns), name
    license_text = (here / "fmi2" / "LICENSE.txt").read_text()
    assert "2-Clause BSD License" in license_text and "Modelica Association" in license_text


def test_fmpy_validation_reports_nothing(fmu):
    _fmpy()
    from fmpy.validation import validate_fmu

    assert validate_fmu(fmu) == []


def test_model_exchange_matches_lagrangian_to_1e_8(fmu, cart):
    """fmpy's Model Exchange (its own CVode solver) at a tight tolerance gives lagrangian's
    trajectory to 1e-8, a constant input set through its start value, and a changed parameter."""
    fmpy = _fmpy()
    ours = lg.simulate(cart, 2.0, {"q2": 1.4}, inputs={"F": 0.5}, params={"M2": 0.8}, dt=0.1, rtol=1e-13,
                       atol=1e-13)
    res = fmpy.simulate_fmu(fmu, fmi_type="ModelExchange", stop_time=2.0, output_interval=0.1,
                            relative_tolerance=1e-12, start_values={"F": 0.5, "M2": 0.8},
                            output=[*STATES, "energy"])
    np.testing.assert_allclose(res["time"], ours.t, atol=1e-12)
    assert np.max(np.abs(_states(res) - ours.x)) < 1e-8
    assert np.max(np.abs(res["energy"] - ours.energy)) < 1e-8


def test_co_simulation_matches_lagrangian_with_held_inputs(fmu, cart):
    """Co-Simulation holds each input over a communication step: fmpy's linearly interpolated
    F = 0.3 t, sampled at the communication points, is lagrangian's F = 0.3 t with
    sample_time = 0.1 (zero-order hold); the embedded DOP853 at solver.rtol = 1e-12 gives the
    same states to 1e-9, and at its default 1e-8 to 1e-6."""
    fmpy = _fmpy()
    ours = lg.simulate(cart, 2.0, {"q2": 1.4}, inputs={"F": "0.3*t"}, sample_time=0.1, dt=0.1, rtol=1e-13,
                       atol=1e-13)
    signal = np.array([(0.0, 0.0), (2.0, 0.6)], dtype=[("time", float), ("F", float)])
    tight = fmpy.simulate_fmu(fmu, fmi_type="CoSimulation", stop_time=2.0, output_interval=0.1, input=signal,
                              start_values={"solver.rtol": 1e-12, "solver.atol": 1e-12}, output=list(STATES))
    assert np.max(np.abs(_states(tight) - ours.x)) < 1e-9
    loose = fmpy.simulate_fmu(fmu, fmi_type="CoSimulation", stop_time=2.0, output_interval=0.1, input=signal,
                              output=list(STATES))
    assert 1e-12 < np.max(np.abs(_states(loose) - ours.x)) < 1e-6


def test_co_simulation_with_a_measured_signal_matches_lagrangian(fmu, cart):
    """The FMU comparison of a measured signal (issue 21, Part 0): a recorded table (201 samples,
    kinks at every one) given to lagrangian as lg.Signal, held at its samples (sample_time = the
    spacing), and to the FMU's Co-Simulation through fmpy's input with the communication step = the
    spacing (each input held over a step): the same motion to 1e-10."""
    fmpy = _fmpy()
    t = np.linspace(0.0, 2.0, 201)
    force = 0.6 * np.sin(7.0 * t) + 0.2 * np.cos(31.0 * t + 0.4)
    ours = lg.simulate(cart, 2.0, {"q2": 1.4}, inputs={"F": lg.Signal(t, force)}, sample_time=0.01, dt=0.01,
                       rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(ours["F"], force, rtol=0, atol=1e-12)  # held at the samples: the samples
    table = np.array(list(zip(t, force)), dtype=[("time", float), ("F", float)])
    res = fmpy.simulate_fmu(fmu, fmi_type="CoSimulation", stop_time=2.0, output_interval=0.01, input=table,
                            start_values={"solver.rtol": 1e-12, "solver.atol": 1e-12}, output=list(STATES))
    np.testing.assert_allclose(res["time"], ours.t, atol=1e-12)
    assert np.max(np.abs(_states(res) - ours.x)) < 1e-10
    smooth = lg.simulate(cart, 2.0, {"q2": 1.4}, inputs={"F": lg.Signal(t, force)}, dt=0.01)
    assert np.max(np.abs(smooth.x - ours.x)) > 1e-4  # interpolated, not held: a different motion


def test_co_simulation_step_and_tolerance_are_settable(fmu, cart):
    """solver.max_step bounds the embedded DOP853's step: at a loose tolerance (1e-3) the steps
    it would choose miss lagrangian's trajectory by about 1e-3, a largest step of 0.01 s brings
    it to 1e-10; a negative step or tolerance is refused through the logger, saying which."""
    fmpy = _fmpy()
    ours = lg.simulate(cart, 2.0, {"q2": 1.4}, dt=0.5, rtol=1e-13, atol=1e-13)
    loose = {"solver.rtol": 1e-3, "solver.atol": 1e-3}

    def error(**start):
        res = fmpy.simulate_fmu(fmu, fmi_type="CoSimulation", stop_time=2.0, output_interval=0.5,
                                start_values={**loose, **start}, output=list(STATES))
        return np.max(np.abs(_states(res) - ours.x))

    assert error() > 1e-5 and error(**{"solver.max_step": 0.01}) < 1e-10
    for start, message in [({"solver.max_step": -1.0}, "solver.max_step must be 0 (no limit but the communication "
                                                         "step) or positive (got -1)"),
                           ({"solver.rtol": -1.0}, "solver.rtol and solver.atol must be positive (got -1 and 1e-08)")]:
        messages = []

        def logger(component, instance, status, category, text):
            messages.append(text.decode())

        with pytest.raises(Exception, match="fmi2DoStep failed"):
            fmpy.simulate_fmu(fmu, fmi_type="CoSimulation", stop_time=1.0, output_interval=0.5, start_values=start,
                              logger=logger)
        assert message in messages, messages


@pytest.mark.subprocess
def test_fmu_reports_a_singular_mass_matrix(tmp_path):
    """The massless cart's M is singular with the pendulum upright: the FMU refuses to initialize
    there and says why through the logger."""
    fmpy = _fmpy()
    if c_compiler() is None:
        pytest.skip("no C compiler to build the FMU")
    path = tmp_path / "massless.fmu"
    export_fmu("cart-pendulum-massless", path, initial={"q2": math.pi / 2})
    messages = []

    def logger(component, instance, status, category, message):
        messages.append(message.decode())

    with pytest.raises(Exception):
        fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=1.0, logger=logger)
    assert any("the mass matrix M is singular" in m for m in messages), messages


@pytest.mark.slow
def test_sources_only_fmu_warns_and_builds_elsewhere(cart, tmp_path, monkeypatch):
    """Without a C compiler the FMU carries its sources only, with a warning that says how to
    build it; fmpy builds it from those sources (with CMake) and it runs as the other one."""
    fmpy = _fmpy()
    import lagrangian.numeric._cbackend as cbackend

    monkeypatch.setattr(cbackend, "c_compiler", lambda: None)
    path = tmp_path / "sources.fmu"
    result = export_fmu(cart, path, initial={"q2": 1.4})
    assert result.binary is None
    assert result.warnings == ("the FMU has no binary, only its sources: no C compiler was found ($CC, cc or gcc). "
                               "An importing tool that compiles sources (fmpy: fmpy.build.build_platform_binary) can "
                               "build it, or install a C compiler (gcc) and export again",)
    with zipfile.ZipFile(path) as z:
        assert not any(n.startswith("binaries/") for n in z.namelist())
    assert fmpy.validation.validate_fmu(str(path)) == []
    monkeypatch.undo()
    if shutil.which("cmake") is None or c_compiler() is None:
        pytest.skip("no cmake or C compiler for fmpy to build the sources")
    from fmpy.build import build_platform_binary

    folder = tmp_path / "unzipped"
    with zipfile.ZipFile(path) as z:
        z.extractall(folder)
    build_platform_binary(folder)
    rebuilt = shutil.make_archive(str(tmp_path / "rebuilt"), "zip", folder)
    os.replace(rebuilt, tmp_path / "rebuilt.fmu")
    res = fmpy.simulate_fmu(str(tmp_path / "rebuilt.fmu"), fmi_type="CoSimulation", stop_time=1.0,
                            output_interval=0.5, start_values={"solver.rtol": 1e-12, "solver.atol": 1e-12})
    ours = lg.simulate(cart, 1.0, {"q2": 1.4}, dt=0.5, rtol=1e-13, atol=1e-13)
    assert np.max(np.abs(_states(res) - ours.x)) < 1e-9


@pytest.mark.subprocess
def test_a_failing_compiler_is_said_with_its_status(cart, tmp_path, monkeypatch):
    import lagrangian.numeric._cbackend as cbackend

    if shutil.which("false") is None:
        pytest.skip("no `false` command to stand for a failing compiler")
    monkeypatch.setattr(cbackend, "c_compiler", lambda: "false")
    result = export_fmu(cart, tmp_path / "x.fmu")
    assert result.binary is None
    assert result.warnings[0].startswith("the FMU has no binary, only its sources: the C compiler (false) failed with "
                                         "exit status 1: it printed nothing. An importing tool")


def test_export_errors(cart, tmp_path):
    with pytest.raises(lg.ModelError, match=r"--fmu .*x\.zip: an FMU's file name ends in \.fmu"):
        export_fmu(cart, tmp_path / "x.zip")
    with pytest.raises(lg.ModelError, match=r"the folder .*nowhere does not exist"):
        export_fmu(cart, tmp_path / "nowhere" / "x.fmu")
    with pytest.raises(lg.ModelError, match=r"\[params.M3\]: 'M3' is not a parameter of the model \(did you mean "
                                            r"'M2'\?\); the choices are M1, M2, L, g"):
        export_modelica(cart, tmp_path / "x.mo", params={"M3": 1.0})
    free = lg.derive(lg.Model("free", coordinates=["x"], parameters={"k": None}, T="x_dot**2/2", V="k*x**2/2"))
    with pytest.raises(lg.ModelError, match=r"parameter 'k' has no value: an exported model needs one; give it in "
                                            r"the model or pass params=\{'k': \.\.\.\} \(--param k=\.\.\.\)"):
        export_c(free, tmp_path / "c")
    with pytest.raises(lg.ModelError, match=r"a Modelica file's name ends in \.mo"):
        export_modelica(cart, tmp_path / "x.txt")


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc, where no file can be created")
@pytest.mark.subprocess
def test_a_place_that_cannot_be_written_is_named_as_given(capsys):
    """Not the temporary file's name, nor a bare OSError: the option, the path given, the reason."""
    for argv, path in [(["--fmu", "/proc/x.fmu"], "/proc/x.fmu"), (["--modelica", "/proc/x.mo"], "/proc/x.mo"),
                       (["--c", "/proc/sys/lagrangian-c"], "/proc/sys/lagrangian-c")]:
        assert main(["export", "cart-pendulum", *argv]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"lagrangian export: error: {argv[0]} {path}: cannot write there (") and err.endswith(
            "); give a path in a folder you can write to\n"), err


# ------------------------------------------------------------------------------- Modelica


def test_modelica_model_is_compiled_and_simulated_by_rumoca(cart, tmp_path):
    """rumoca (an open-source Modelica compiler) finds nothing to report in the exported model,
    finds it balanced, and simulates it (driven by a wrapper that sets the input) to lagrangian's
    numbers."""
    rm = pytest.importorskip("rumoca", reason="rumoca (pip install rumoca), a Modelica compiler, checks the model")
    path = tmp_path / "CartPendulum.mo"
    export_modelica(cart, path, initial={"q2": 1.4}, params={"M2": 0.8})
    text = path.read_text()
    assert text.startswith("model CartPendulum") and "parameter Real M2 = 0.8;" in text
    assert "(M1 + M2)*der(q1_dot) + (-L*M2*sin(q2))*der(q2_dot) = F + L*M2*q2_dot^2*cos(q2);" in text
    assert rm.validate(str(path), model="CartPendulum") == []
    session = rm.Session(roots=[str(tmp_path)])
    model = session.loads("model Test\n  CartPendulum plant(F = 0.3*time);\nend Test;\n", model="Test")
    assert model.structure().is_balanced
    res = model.simulate(t=(0.0, 2.0), dt=0.1, config=rm.SimConfig(rtol=1e-12, atol=1e-12))
    ours = lg.simulate(cart, 2.0, {"q2": 1.4}, inputs={"F": "0.3*t"}, params={"M2": 0.8}, dt=0.1, rtol=1e-13,
                       atol=1e-13)
    X = np.column_stack([res[f"plant.{n}"] for n in STATES])
    assert np.max(np.abs(X - ours.x)) < 1e-7
    assert np.max(np.abs(res["plant.energy"] - ours.energy)) < 1e-7


def test_modelica_names_that_are_reserved_words_are_quoted(tmp_path):
    rm = pytest.importorskip("rumoca", reason="rumoca (pip install rumoca), a Modelica compiler, checks the model")
    model = lg.Model("spring 2", coordinates=["x"], parameters={"final": 4.0, "time": 1.0},
                     T="time*x_dot**2/2", V="final*x**2/2")
    model.simulation = {"initial": {"x": 1.0}}
    path = tmp_path / "spring.mo"
    export_modelica(lg.derive(model), path)
    text = path.read_text()
    assert "parameter Real 'final' = 4.0;" in text and "model Spring2" in text
    assert rm.validate(str(path), model="Spring2") == []
    res = rm.Session(roots=[str(tmp_path)]).load(str(path), model="Spring2").simulate(
        t=(0.0, 1.0), dt=0.5, config=rm.SimConfig(rtol=1e-12, atol=1e-12))
    assert res["x"][-1] == pytest.approx(math.cos(2.0), abs=1e-8)  # x'' = -4 x


def test_modelica_outputs_are_output_reals_that_rumoca_simulates(tmp_path):
    """The model file's [outputs] are `output Real`s of the Modelica model (issue 21, Part 0): rumoca
    simulates them to lagrangian's outputs; an output named like a Modelica keyword is quoted."""
    rm = pytest.importorskip("rumoca", reason="rumoca (pip install rumoca), a Modelica compiler, checks the model")
    from pathlib import Path

    text = (Path(__file__).parents[1] / "models" / "double-pendulum-outputs.toml").read_text()
    eqs = lg.derive(lg.io.loads_model(text + '\nfinal = "th1 - th2"\n', source="dp.toml"))
    path = tmp_path / "dp.mo"
    export_modelica(eqs, path, initial={"th1": 0.7, "th2": -0.4})
    mo = path.read_text()
    assert "  output Real tip_x \"the output tip_x of the model file\";" in mo
    assert "  output Real 'final' " in mo and "  'final' = th1 - th2;" in mo
    assert rm.validate(str(path), model="Dp") == []
    session = rm.Session(roots=[str(tmp_path)])
    model = session.loads("model Test\n  Dp plant(F = 0.3*time);\nend Test;\n", model="Test")
    res = model.simulate(t=(0.0, 2.0), dt=0.1, config=rm.SimConfig(rtol=1e-12, atol=1e-12))
    ours = lg.simulate(eqs, 2.0, {"th1": 0.7, "th2": -0.4}, inputs={"F": "0.3*t"}, dt=0.1, rtol=1e-13, atol=1e-13)
    for name, quoted in (("tip_x", "tip_x"), ("tip_y", "tip_y"), ("push", "push"), ("final", "'final'")):
        assert np.max(np.abs(res[f"plant.{quoted}"] - ours[name])) < 1e-7, name


# -------------------------------------------------------------------------------------- C


@needs_cc
@pytest.mark.subprocess
def test_c_export_builds_and_gives_the_model_s_numbers(cart, tmp_path):
    """The exported C, built with -Wall -Wextra -pedantic -Werror beside a test program, gives the
    compiled model's right-hand side, M, forcing and energy at random states to rounding."""
    folder = tmp_path / "c"
    export_c(cart, folder)
    rng = np.random.default_rng(3)
    X = rng.uniform(-2, 2, (5, 4))
    U = rng.uniform(-1, 1, 5)
    rows = ",\n".join("{" + ", ".join(repr(float(v)) for v in x) + "}" for x in X)
    (folder / "check.c").write_text(f"""#include <stdio.h>
#include "cart_pendulum.h"
int main(void) {{
    const double X[5][4] = {{{rows}}};
    const double U[5] = {{{", ".join(repr(float(u)) for u in U)}}};
    double dx[4], M[4], f[2];
    int k, i;
    for (k = 0; k < 5; k++) {{
        double r = cart_pendulum_rhs(0.3, X[k], &U[k], cart_pendulum_parameter_values, dx);
        cart_pendulum_mass_matrix(0.3, X[k], &U[k], cart_pendulum_parameter_values, M);
        cart_pendulum_forcing(0.3, X[k], &U[k], cart_pendulum_parameter_values, f);
        printf("%.17g", r);
        for (i = 0; i < 4; i++) printf(" %.17g", dx[i]);
        for (i = 0; i < 4; i++) printf(" %.17g", M[i]);
        for (i = 0; i < 2; i++) printf(" %.17g", f[i]);
        printf(" %.17g\\n", cart_pendulum_energy(0.3, X[k], &U[k], cart_pendulum_parameter_values));
    }}
    return 0;
}}
""")
    cc = c_compiler().split()
    build = subprocess.run([*cc, "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2", "-o",
                            str(folder / "check"), str(folder / "check.c"), str(folder / "cart_pendulum.c"), "-lm"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    out = subprocess.run([str(folder / "check")], capture_output=True, text=True, check=True).stdout
    nm = lg.compile(cart)
    p = nm.parameter_values
    for line, x, u in zip(out.splitlines(), X, U):
        values = np.array([float(v) for v in line.split()])
        np.testing.assert_allclose(values[1:5], nm.rhs(0.3, x, [u], p), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(values[5:9], nm.mass_matrix(0.3, x, [u], p).ravel(), rtol=1e-13, atol=1e-14)
        np.testing.assert_allclose(values[9:11], nm.forcing(0.3, x, [u], p), rtol=1e-13, atol=1e-14)
        assert values[11] == pytest.approx(nm.energy(0.3, x, [u], p), rel=1e-13)
        assert 0 < values[0] <= 1


@needs_cc
@pytest.mark.subprocess
def test_c_export_of_models_without_inputs_or_parameters_compiles_without_warnings(tmp_path):
    """A model without inputs (the heavy top, a body in space) or without parameters does not read
    u or p: its C and the example still build with -Wall -Wextra -pedantic -Werror, and the
    example integrates a free fall exactly (RK4 is exact on a parabola)."""
    fall = lg.Model("free fall", coordinates=["x"], T="x_dot**2/2", V="9.81*x")
    for system, ident, initial in [("heavy-top", "heavy_top", None), (lg.derive(fall), "free_fall", {"x": 1.0})]:
        folder = tmp_path / ident
        export_c(system, folder, initial=initial)
        build = subprocess.run([*c_compiler().split(), "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2",
                                "-o", str(folder / "example"), str(folder / "main.c"), str(folder / f"{ident}.c"),
                                "-lm"], capture_output=True, text=True)
        assert build.returncode == 0, build.stderr
    out = subprocess.run([str(tmp_path / "free_fall" / "example"), "1", "0.01", "50"], capture_output=True,
                         text=True, check=True).stdout.splitlines()
    t, x, v, energy = (float(s) for s in out[-1].split(","))
    assert t == 1 and x == pytest.approx(1 - 9.81 / 2, abs=1e-12) and v == pytest.approx(-9.81, abs=1e-12)


@needs_cc
@pytest.mark.subprocess
@pytest.mark.slow
def test_c_example_built_with_cmake_integrates_the_model(cart, tmp_path):
    if shutil.which("cmake") is None:
        pytest.skip("no cmake to build the C export's CMakeLists.txt")
    folder = tmp_path / "c"
    export_c(cart, folder, initial={"q2": 1.4})
    build = tmp_path / "build"
    for cmd in (["cmake", "-S", str(folder), "-B", str(build)], ["cmake", "--build", str(build)]):
        run = subprocess.run(cmd, capture_output=True, text=True)
        assert run.returncode == 0, run.stdout + run.stderr
    out = subprocess.run([str(build / "cart_pendulum_example"), "1", "0.001", "100"], capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out[0] == "t,q1,q2,q1_dot,q2_dot,energy" and len(out) == 12
    data = np.array([[float(v) for v in line.split(",")] for line in out[1:]])
    ours = lg.simulate(cart, 1.0, {"q2": 1.4}, dt=0.1, rtol=1e-13, atol=1e-13)
    assert np.max(np.abs(data[:, 1:5] - ours.x)) < 1e-9  # RK4 with h = 1e-3: error of order h^4
    assert np.max(np.abs(data[:, 5] - ours.energy)) < 1e-9


# ---------------------------------------------------------------------------------- command


@needs_cc
@pytest.mark.subprocess
def test_export_command(tmp_path, capsys):
    fmu, mo, c = tmp_path / "cart.fmu", tmp_path / "cart.mo", tmp_path / "cart-c"
    assert main(["export", "cart-pendulum", "--fmu", str(fmu), "--modelica", str(mo), "--c", str(c),
                 "--param", "M2=0.8", "--initial", "q2=1.2"]) == 0
    out = capsys.readouterr().out
    assert f"wrote {fmu} (FMI 2.0 FMU, Model Exchange and Co-Simulation, binary for " in out
    assert f"wrote {mo} (Modelica model CartPendulum)" in out
    assert f"wrote cart_pendulum.h, cart_pendulum.c, main.c, CMakeLists.txt to {c}" in out
    assert "parameter Real M2 = 0.8;" in mo.read_text() and "q2(start = 1.2," in mo.read_text()
    assert "M2 = 0.8" not in (c / "cart_pendulum.c").read_text()
    assert "1.0, 0.8, 1.0, 9.81" in (c / "cart_pendulum.c").read_text()
    assert main(["export", "cart-pendulum", "--fmu", str(tmp_path / "s.fmu"), "--no-binary"]) == 0
    said = capsys.readouterr()
    assert "sources only" in said.out
    assert ("lagrangian export: warning: the FMU has no binary, only its sources, as asked (binary=False, "
            "--no-binary)") in said.err
    assert main(["export", "cart-pendulum"]) == 2
    assert "nothing to export: give --fmu FILE.fmu, --modelica FILE.mo and/or --c DIR" in capsys.readouterr().err
    assert main(["export", "cart-pendulum", "--fmu", str(tmp_path / "x.zip")]) == 2
    assert "an FMU's file name ends in .fmu" in capsys.readouterr().err
    assert main(["export", "cart-pendulum", "--c", str(fmu)]) == 2
    assert "it is a file; give a folder for the C sources" in capsys.readouterr().err


@needs_cc
@pytest.mark.subprocess
def test_a_body_in_space_exports_the_same_way(tmp_path):
    """The heavy top (a rigid body in space, three Euler angles) through the same writers: its
    FMU validates and its Co-Simulation follows lagrangian to 1e-9; rumoca reads its Modelica."""
    fmpy = _fmpy()
    eqs = lg.derive(lg.load("heavy-top"))
    path = tmp_path / "top.fmu"
    export_fmu(eqs, path)
    assert fmpy.validation.validate_fmu(str(path)) == []
    res = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=1.0, output_interval=0.1,
                            start_values={"solver.rtol": 1e-12, "solver.atol": 1e-12}, output=list(eqs.state_names))
    ours = lg.simulate(eqs, 1.0, dt=0.1, rtol=1e-13, atol=1e-13)
    assert np.max(np.abs(np.column_stack([res[n] for n in eqs.state_names]) - ours.x)) < 1e-9
    rm = pytest.importorskip("rumoca", reason="rumoca (pip install rumoca), a Modelica compiler, checks the model")
    export_modelica(eqs, tmp_path / "top.mo")
    assert rm.validate(str(tmp_path / "top.mo"), model="HeavyTop") == []
