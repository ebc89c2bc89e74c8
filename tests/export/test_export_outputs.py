"""The model's named outputs ([outputs], Model.add_output) in the C export and the FMU (issue 21,
Part 0): <id>_outputs in the C (built with -Wall -Wextra -pedantic -Werror) and the example's last
CSV columns give lagrangian's outputs; the FMU's outputs, appended after its other variables, are
valid for fmpy and give lagrangian's outputs in Model Exchange and Co-Simulation; a model without
outputs exports as before, byte for byte; names that are C or FMI words are inert text."""

from __future__ import annotations

import importlib
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.export import export_c, export_fmu
from lagrangian.export._c import c_files
from lagrangian.numeric._cbackend import c_compiler
from lagrangian.numeric._trajectory import evaluate_outputs

needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler ($CC, cc or gcc) to build the export")
HERE = Path(__file__).resolve().parent
DP_TEXT = (HERE.parent / "models" / "double-pendulum-outputs.toml").read_text()
OUTPUTS = ("tip_x", "tip_y", "push", "wave")
# a time-dependent output besides the file's three (a position, a point's component, an input's feedthrough)
DP_MORE = DP_TEXT + '\nwave = "sin(3*t)*th2_dot + m2*th1_dot"\n'
START = {"th1": 0.7, "th2": -0.4, "th1_dot": 0.2}


def _dp(text: str = DP_MORE):
    return lg.derive(lg.io.loads_model(text, source="dp.toml"))


def _without_outputs(text: str) -> str:
    return text.split("[outputs]")[0]


def _fmpy():
    fmpy = pytest.importorskip("fmpy", reason="fmpy (pip install 'lagrangian[fmu]') runs the FMUs")
    importlib.import_module("fmpy.validation")
    return fmpy


def _build(folder: Path, *sources: str) -> Path:
    exe = folder / "run"
    build = subprocess.run([*c_compiler().split(), "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2",
                            "-o", str(exe), *(str(folder / s) for s in sources), "-lm"], capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    return exe


def _csv(text: str) -> tuple[list[str], np.ndarray]:
    lines = text.splitlines()
    return lines[0].split(","), np.array([[float(v) for v in line.split(",")] for line in lines[1:]])


# ------------------------------------------------------------------------- without outputs


def test_c_export_without_outputs_is_byte_for_byte_as_before(monkeypatch):
    """The C export of a model without outputs is the text it was before outputs existed (the four
    files of cart-pendulum written by commit d1c9aa8's export, in tests/export/data/, the generated
    code of numeric._codegen.c_source stubbed so that only the export's own text is compared; every
    model of the zoo was compared whole when outputs came). A deliberate change of the C export's
    text updates these files."""
    import lagrangian.numeric._codegen as codegen
    from lagrangian._version import __version__

    monkeypatch.setattr(codegen, "c_source", lambda eq, prefix="lg_", storage="", quiet=False:
                        f"/* the generated code ({prefix}, {storage!r}, {quiet}) */\n#include <math.h>\n")
    files = c_files(lg.derive(lg.load("cart-pendulum")), initial={"q2": 1.4})
    golden = HERE / "data" / "c-export-without-outputs"
    assert sorted(files) == sorted(p.name[:-4] for p in golden.iterdir())
    for name, text in files.items():
        assert text.replace(f"lagrangian {__version__}", "lagrangian @VERSION@") == (golden / f"{name}.txt").read_text()
    assert not any("_NY" in text or "output" in text for text in files.values())


def test_removing_the_outputs_table_removes_every_trace_of_it():
    """The same model with and without [outputs]: the files without it have no outputs' part, and
    every line of theirs but the example's CSV lines is in the files with it."""
    without = c_files(_dp(_without_outputs(DP_TEXT)))
    with_ = c_files(_dp())
    assert "DP_NY" not in without["dp.h"] and "dp_outputs" not in without["dp.c"] and "NY" not in without["main.c"]
    assert "#define DP_NY 4    /* named outputs */" in with_["dp.h"]
    assert "void dp_outputs(double t, const double *x, const double *u, const double *p, double *y);" in with_["dp.h"]
    assert 'const char *const dp_output_names[] = {"tip_x", "tip_y", "push", "wave"};' in with_["dp.c"]
    for name in ("dp.h", "dp.c", "CMakeLists.txt"):
        assert set(without[name].splitlines()) <= set(with_[name].splitlines()), name


# ------------------------------------------------------------------------------------- C


@needs_cc
@pytest.mark.subprocess
def test_c_outputs_give_lagrangian_s_outputs(tmp_path):
    """dp_outputs at random times, states, inputs and parameters gives lagrangian's outputs (the
    vectorised evaluation of a simulation) to rounding; the names and DP_NY as declared."""
    eqs = _dp()
    folder = tmp_path / "c"
    export_c(eqs, folder)
    rng = np.random.default_rng(21)
    N = 6
    T, X, U = rng.uniform(0, 3, N), rng.uniform(-2, 2, (N, 4)), rng.uniform(-1, 1, (N, 1))
    P = rng.uniform(0.5, 2.0, (N, 5))
    rows = lambda a: ",\n".join("{" + ", ".join(repr(float(v)) for v in r) + "}" for r in a)  # noqa: E731
    (folder / "check.c").write_text(f"""#include <stdio.h>
#include "dp.h"
int main(void) {{
    const double T[{N}] = {{{", ".join(repr(float(v)) for v in T)}}};
    const double X[{N}][4] = {{{rows(X)}}};
    const double U[{N}][1] = {{{rows(U)}}};
    const double P[{N}][5] = {{{rows(P)}}};
    double y[DP_NY];
    int k, i;
    printf("%d", DP_NY);
    for (i = 0; i < DP_NY; i++) printf(" %s", dp_output_names[i]);
    printf("\\n");
    for (k = 0; k < {N}; k++) {{
        dp_outputs(T[k], X[k], U[k], P[k], y);
        for (i = 0; i < DP_NY; i++) printf("%.17g ", y[i]);
        printf("\\n");
    }}
    return 0;
}}
""")
    out = subprocess.run([str(_build(folder, "check.c", "dp.c"))], capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out[0].split() == ["4", *OUTPUTS]
    got = np.array([[float(v) for v in line.split()] for line in out[1:]])
    for k in range(N):
        ours = evaluate_outputs(eqs, T[k:k + 1], X[k:k + 1], U[k:k + 1], P[k])
        np.testing.assert_allclose(got[k], [ours[name][0] for name in OUTPUTS], rtol=1e-13, atol=1e-14)
    # the closed forms, at the first row
    th1, th2, th1d, th2d = X[0]
    m1, m2, l1, l2, g = P[0]
    np.testing.assert_allclose(got[0], [l1 * np.sin(th1) + l2 * np.sin(th2), -l1 * np.cos(th1) - l2 * np.cos(th2),
                                        2 * U[0, 0] + th1, np.sin(3 * T[0]) * th2d + m2 * th1d], rtol=1e-14)


@needs_cc
@pytest.mark.subprocess
def test_c_example_prints_the_outputs_as_the_last_columns(tmp_path):
    """The example main.c prints the outputs after the energy, as lagrangian's CSV does, and its RK4
    run gives lagrangian's outputs (inputs 0) to 1e-9."""
    eqs = _dp()
    folder = tmp_path / "c"
    export_c(eqs, folder, initial=START)
    out = subprocess.run([str(_build(folder, "main.c", "dp.c")), "2", "0.001", "100"], capture_output=True,
                         text=True, check=True).stdout
    header, data = _csv(out)
    ours = lg.simulate(eqs, 2.0, START, dt=0.1, rtol=1e-13, atol=1e-13)
    assert header == [c for c in ours.columns if c != "F"] and header[-4:] == list(OUTPUTS)
    for k, name in enumerate(header[1:], 1):
        assert np.max(np.abs(data[:, k] - ours[name])) < 1e-9, name


@needs_cc
@pytest.mark.subprocess
def test_c_example_of_a_constrained_model_prints_multipliers_then_outputs(tmp_path):
    """cartesian-pendulum with outputs: the example's columns are t, the state, the energy, the
    tension lambda_rod, then the outputs; the outputs are lagrangian's, and the radius output holds
    the rod's length (the example projects onto the constraint after every step)."""
    text = (Path(lg.__file__).parent / "examples" / "cartesian-pendulum.toml").read_text()
    text += '\n[outputs]\nangle = "atan2(x, -y)"\nradius = "sqrt(x**2 + y**2)"\n'
    eqs = lg.derive(lg.io.loads_model(text, source="cartesian-pendulum.toml"))
    folder = tmp_path / "c"
    export_c(eqs, folder)
    out = subprocess.run([str(_build(folder, "main.c", "cartesian_pendulum.c")), "1", "0.001", "100"],
                         capture_output=True, text=True, check=True).stdout
    header, data = _csv(out)
    assert header == ["t", "x", "y", "x_dot", "y_dot", "energy", "lambda_rod", "angle", "radius"]
    ours = lg.simulate(eqs, 1.0, dt=0.1, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(data[:, 8] - 1.0)) < 1e-12
    for k, name in enumerate(header[1:], 1):
        assert np.max(np.abs(data[:, k] - ours[name])) < 1e-7, name
    assert data[0, 7] == pytest.approx(np.pi / 2) and data[-1, 7] < 0.1  # from the horizontal, past the bottom


# ------------------------------------------------------------------------------------ FMU


@pytest.fixture(scope="module")
def dp_fmu(tmp_path_factory):
    if c_compiler() is None:
        pytest.skip("no C compiler ($CC, cc or gcc) to build the FMU's binary")
    path = tmp_path_factory.mktemp("fmu") / "dp.fmu"
    result = export_fmu(_dp(), path, initial=START)
    assert result.warnings == () and result.binary is not None
    return str(path)


def _variables(path) -> tuple[list[ET.Element], ET.Element]:
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    return list(root.find("ModelVariables")), root.find("ModelStructure")


def test_fmu_outputs_are_appended_and_the_other_value_references_stay(tmp_path):
    """Each output is an FMI output variable (continuous, calculated, no start), after every
    variable of the same model without outputs, whose value references do not move; the outputs
    are in ModelStructure's Outputs and InitialUnknowns (indices ascending, as FMI 2.0 asks)."""
    export_fmu(_dp(_without_outputs(DP_TEXT)), tmp_path / "plain.fmu", binary=False)
    export_fmu(_dp(), tmp_path / "dp.fmu", binary=False)
    plain, _ = _variables(tmp_path / "plain.fmu")
    variables, structure = _variables(tmp_path / "dp.fmu")
    assert len(variables) == len(plain) + 4
    for a, b in zip(plain, variables):
        assert (a.get("name"), a.get("valueReference"), a.get("causality")) == \
            (b.get("name"), b.get("valueReference"), b.get("causality"))
    assert [v.get("name") for v in plain[-3:]] == ["solver.rtol", "solver.atol", "solver.max_step"]
    for k, (v, name) in enumerate(zip(variables[len(plain):], OUTPUTS)):
        assert v.get("name") == name and v.get("valueReference") == str(len(plain) + k)
        assert (v.get("causality"), v.get("variability"), v.get("initial")) == ("output", "continuous", "calculated")
        assert v.find("Real").get("start") is None
    assert variables[-4].get("description") == "the model's output tip_x = l1*sin(th1) + l2*sin(th2)"
    indices = {str(len(plain) + k + 1) for k in range(4)}  # 1-based
    for part in ("Outputs", "InitialUnknowns"):
        listed = [u.get("index") for u in structure.find(part)]
        assert indices <= set(listed) and [int(i) for i in listed] == sorted(int(i) for i in listed)
    assert not indices & {u.get("index") for u in structure.find("Derivatives")}


def test_fmpy_validation_of_the_outputs_fmu_reports_nothing(dp_fmu):
    _fmpy()
    from fmpy.validation import validate_fmu

    assert validate_fmu(dp_fmu) == []


def test_fmu_outputs_in_model_exchange_match_lagrangian(dp_fmu):
    """fmpy's Model Exchange (CVode) with an input and a parameter set through their start values
    gives lagrangian's outputs to 1e-8, the input's feedthrough (push = 2 F + th1) and the
    time-dependent output (wave) included."""
    fmpy = _fmpy()
    ours = lg.simulate(_dp(), 2.0, START, inputs={"F": 0.5}, params={"m2": 0.9}, dt=0.1, rtol=1e-13, atol=1e-13)
    res = fmpy.simulate_fmu(dp_fmu, fmi_type="ModelExchange", stop_time=2.0, output_interval=0.1,
                            relative_tolerance=1e-12, start_values={"F": 0.5, "m2": 0.9}, output=["th1", *OUTPUTS])
    np.testing.assert_allclose(res["time"], ours.t, atol=1e-12)
    for name in ("th1", *OUTPUTS):
        assert np.max(np.abs(res[name] - ours[name])) < 1e-8, name
    assert np.ptp(ours["wave"]) > 0.5 and np.ptp(ours["push"]) > 0.5  # outputs that move


def test_fmu_outputs_in_co_simulation_match_lagrangian(dp_fmu):
    """The embedded DOP853 at 1e-12 with a constant input and a changed parameter: lagrangian's outputs
    to 1e-9 at every communication point. (With an input that changes, fmpy records the outputs after
    fmi2DoStep and before it sets the next input: an output with feedthrough, computed with the input
    the FMU holds, then lags lagrangian's held input by one step; the states agree as before.)"""
    fmpy = _fmpy()
    ours = lg.simulate(_dp(), 2.0, START, inputs={"F": 0.5}, params={"l2": 0.9}, dt=0.1, rtol=1e-13, atol=1e-13)
    res = fmpy.simulate_fmu(dp_fmu, fmi_type="CoSimulation", stop_time=2.0, output_interval=0.1,
                            start_values={"F": 0.5, "l2": 0.9, "solver.rtol": 1e-12, "solver.atol": 1e-12},
                            output=list(OUTPUTS))
    np.testing.assert_allclose(res["time"], ours.t, atol=1e-12)
    for name in OUTPUTS:
        assert np.max(np.abs(res[name] - ours[name])) < 1e-9, name


def _slave(fmpy, path, messages: list | None = None):
    """The FMU instantiated for Co-Simulation and initialized, with a logger of our own that appends
    to `messages` (fmpy's default logger may point at another test's logger, gone by now), and
    {name: value reference}."""
    from ctypes import byref

    from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                           fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
    from fmpy.fmi2 import calloc, free
    from fmpy.logging import addLoggerProxy

    said = [] if messages is None else messages
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(lambda env, name, status, category, text: said.append(text.decode()))
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(callbacks))
    md = fmpy.read_model_description(path)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="test")
    fmu.instantiate(callbacks=callbacks)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


def test_fmu_refuses_to_set_an_output(dp_fmu):
    """An output is calculated: fmi2SetReal on it fails; fmi2GetReal gives it at the start state."""
    fmpy = _fmpy()
    messages: list[str] = []
    fmu, vr = _slave(fmpy, dp_fmu, messages)
    try:
        tip_x, = fmu.getReal([vr["tip_x"]])
        assert tip_x == pytest.approx(1.3 * np.sin(0.7) + 0.7 * np.sin(-0.4), rel=1e-15)
        with pytest.raises(Exception, match="fmi2SetReal"):
            fmu.setReal([vr["tip_x"]], [1.0])
        assert "fmi2SetReal: tip_x is calculated by the FMU and cannot be set" in messages
    finally:
        fmu.terminate()
        fmu.freeInstance()


# ------------------------------------------------------------------------------- constrained


@needs_cc
@pytest.mark.subprocess
def test_constrained_fmu_outputs_match_lagrangian(tmp_path):
    """A constrained model's FMU (cartesian-pendulum): the outputs after solver.max_step, the
    multipliers where they were; Co-Simulation gives lagrangian's outputs to 1e-9."""
    fmpy = _fmpy()
    text = (Path(lg.__file__).parent / "examples" / "cartesian-pendulum.toml").read_text()
    text += '\n[outputs]\nangle = "atan2(x, -y)"\nheight = "y + l"\n'
    eqs = lg.derive(lg.io.loads_model(text, source="cartesian-pendulum.toml"))
    path = tmp_path / "cp.fmu"
    export_fmu(eqs, path)
    names = [v.get("name") for v in _variables(path)[0]]
    assert names[-6:] == ["lambda_rod", "solver.rtol", "solver.atol", "solver.max_step", "angle", "height"]
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(path)) == []
    ours = lg.simulate(eqs, 1.0, dt=0.1, rtol=1e-13, atol=1e-13)
    res = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", stop_time=1.0, output_interval=0.1,
                            start_values={"solver.rtol": 1e-12, "solver.atol": 1e-12},
                            output=["angle", "height", "lambda_rod"])
    for name in ("angle", "height", "lambda_rod"):
        assert np.max(np.abs(res[name] - ours[name])) < 1e-9, name


# ---------------------------------------------------------------------------------- hostile

#: output names that are C keywords, C library names, names of the generated code (locals, macros,
#: functions) or FMI/fmpy words: each is a valid output name of a model, and stays inert text
HOSTILE = ("int", "double", "main", "return", "printf", "sin", "r", "y", "x", "i", "k", "c0", "v_th1", "NX", "NR",
           "NY", "VR_OUTPUT", "DP_NY", "dp_outputs", "dp_gen_outputs", "fmi2Component", "fmi2OK", "der", "solver",
           "__import__", "time")


def _hostile_model():
    accepted, text = [], DP_TEXT
    for k, name in enumerate(HOSTILE):
        try:
            lg.io.loads_model(DP_TEXT + f'\n{name} = "th1 + {k}"\n', source="dp.toml")
        except ModelError:
            continue  # a name the model itself refuses never reaches an export
        accepted.append(name)
        text += f'\n{name} = "th1 + {k}"'
    return _dp(text + "\n"), accepted


def test_the_model_refuses_some_hostile_names_and_accepts_the_others():
    _, accepted = _hostile_model()
    assert "sin" not in accepted  # a function's name
    assert {"int", "double", "main", "time", "NX", "VR_OUTPUT", "dp_outputs", "fmi2Component", "__import__"} <= \
        set(accepted)


@needs_cc
@pytest.mark.subprocess
def test_hostile_output_names_in_c_compile_with_werror_and_keep_their_values(tmp_path):
    eqs, accepted = _hostile_model()
    folder = tmp_path / "c"
    export_c(eqs, folder, initial={"th1": 0.25})
    for name in accepted:  # only in string literals and comments
        assert f'"{name}"' in (folder / "dp.c").read_text()
    out = subprocess.run([str(_build(folder, "main.c", "dp.c")), "0.5", "0.01", "50"], capture_output=True,
                         text=True, check=True).stdout
    header, data = _csv(out)
    assert header[-len(accepted):] == accepted
    for name in accepted:
        k = HOSTILE.index(name)
        np.testing.assert_allclose(data[:, header.index(name)], data[:, 1] + k, rtol=0, atol=1e-14)


@needs_cc
@pytest.mark.subprocess
def test_hostile_output_names_in_the_fmu_are_valid_and_keep_their_values(tmp_path):
    """fmpy validates the FMU; Co-Simulation gives each output th1 + k. fmpy keeps the name `time` for
    its own time column and does not record an output of that name: read by value reference, it is
    there."""
    fmpy = _fmpy()
    from fmpy.validation import validate_fmu

    eqs, accepted = _hostile_model()
    path = str(tmp_path / "hostile.fmu")
    export_fmu(eqs, path, initial={"th1": 0.25})
    assert validate_fmu(path) == []
    res = fmpy.simulate_fmu(path, fmi_type="CoSimulation", stop_time=0.5, output_interval=0.25,
                            output=["th1", *accepted])
    for name in accepted:
        if name != "time":
            np.testing.assert_allclose(res[name], res["th1"] + HOSTILE.index(name), rtol=0, atol=1e-14)
    fmu, vr = _slave(fmpy, path)
    try:
        assert fmu.getReal([vr["time"], vr["int"]]) == [0.25 + HOSTILE.index("time"), 0.25 + HOSTILE.index("int")]
    finally:
        fmu.terminate()
        fmu.freeInstance()


# ----------------------------------------------------------------------------------- errors


def test_an_output_named_like_the_renamed_energy_is_refused(tmp_path):
    """A parameter named `energy` pushes the exported energy to `energy_`; an output of that name would
    be a second variable (FMU) or column (C example) of the same name: refused, saying why and the fix."""
    m = lg.Model("osc", coordinates=["q"], T="q_dot**2/2", V="energy*q**2/2", parameters={"energy": 1.0})
    m.add_output("energy_", "q")
    eqs = lg.derive(m)
    message = (r"\[outputs.energy_\]: output 'energy_': the export already has a variable of that name \(the "
               r"exported energy, named 'energy_' since the model uses 'energy'\); rename the output")
    with pytest.raises(ModelError, match=message):
        export_fmu(eqs, tmp_path / "osc.fmu", binary=False)
    with pytest.raises(ModelError, match=message):
        export_c(eqs, tmp_path / "c")
    assert not (tmp_path / "osc.fmu").exists() and not (tmp_path / "c").exists()


def test_an_output_c_cannot_compute_is_refused_with_its_name(tmp_path):
    import sympy

    m = lg.Model("g", coordinates=["q"], T="q_dot**2/2", V="q**2/2")
    m.add_output("fine", "q")
    m.add_output("gam", sympy.gamma(sympy.Symbol("q")) + 1)
    eqs = lg.derive(m)
    message = (r"\[outputs.gam\]: output 'gam' cannot be exported to C \(nor to an FMU\): 'tgamma' in a generated "
               r"expression is not a function the generated C may call; write the output with the functions a model "
               r"file knows \(sin, cos, tan, atan2, exp, log, sqrt, abs, sign, \.\.\.\), or export the model "
               r"without it")
    with pytest.raises(ModelError, match=message):
        export_c(eqs, tmp_path / "c")
    with pytest.raises(ModelError, match=message):
        export_fmu(eqs, tmp_path / "g.fmu", binary=False)


def test_the_export_command_says_the_output_error(tmp_path, capsys):
    from lagrangian.cli import main

    model = tmp_path / "osc.toml"
    model.write_text('name = "osc"\ncoordinates = ["q"]\n[parameters]\nenergy = 1.0\n[energy]\nT = "q_dot**2/2"\n'
                     'V = "energy*q**2/2"\n[outputs]\nenergy_ = "q"\n')
    assert main(["export", str(model), "--c", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert "output 'energy_': the export already has a variable of that name" in err and "Traceback" not in err
