"""export_fmu: an FMI 2.0 FMU, Model Exchange and Co-Simulation in one archive.

The archive holds modelDescription.xml, ``sources/`` (the model's generated C code, the FMI
interface fmu.c and the FMI 2.0 headers, always), ``binaries/<platform>/<id>.<so|dylib|dll>``
built with the machine's C compiler (left out, with a warning, when there is none), and
``documentation/licenses/`` (the license of the FMI headers)."""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from typing import Mapping
from .._codetext import c_strings, comment_text, xml_attribute

from ..equations import Equations
from ..io._files import check_replaceable, replacing
from ._c import c_files, cannot_write
from ._common import (ExportResult, energy_name, equations_of, identifier, named_outputs, output_file,
                      parameter_values, start_state)

__all__ = ["export_fmu", "fmu_platform", "SOLVER_DEFAULTS"]

_HERE = Path(__file__).resolve().parent
_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
#: The Co-Simulation integrator's parameters and their default values.
SOLVER_DEFAULTS = {"solver.rtol": 1e-8, "solver.atol": 1e-8, "solver.max_step": 0.0}


def fmu_platform() -> tuple[str, str] | None:
    """(FMI platform folder, shared library suffix) of this machine, or None when FMI 2.0 names
    none for it (a 32-bit or non-x86 machine is still named by its OS: the binary is for it)."""
    bits = "64" if sys.maxsize > 2**32 else "32"
    if sys.platform.startswith("linux"):
        return f"linux{bits}", ".so"
    if sys.platform == "darwin":
        return f"darwin{bits}", ".dylib"
    if sys.platform in ("win32", "cygwin"):
        return f"win{bits}", ".dll"
    return None


def _dop853_tables() -> str:
    from scipy.integrate._ivp import dop853_coefficients as c

    def row(values):
        return "{" + ", ".join(repr(float(v)) for v in values) + "}"

    A = c.A[:12, :12]
    return "\n".join([
        "/* DOP853's coefficients (Hairer, Norsett and Wanner), as in SciPy's dop853_coefficients */",
        "static const double DOP853_A[12][12] = {" + ",\n    ".join(row(r) for r in A) + "};",
        f"static const double DOP853_B[12] = {row(c.A[12, :12])};",
        f"static const double DOP853_C[12] = {row(c.C[:12])};",
        f"static const double DOP853_E3[13] = {row(c.E3)};",
        f"static const double DOP853_E5[13] = {row(c.E5)};",
    ])


def _variables(eq: Equations, pvalues, x0) -> list[dict]:
    """The FMU's variables in value-reference order (see fmu_template.c)."""
    n = eq.n
    out = []
    # a constrained model's start state is made consistent by the FMU (its start values are kept
    # where they meet the constraints): "approx", the FMU computes them in initialization
    initial = "approx" if eq.is_constrained else "exact"
    for i, name in enumerate(eq.state_names):
        what = (f"the coordinate {name}" if i < n else f"the velocity of {eq.state_names[i - n]}")
        out.append(dict(name=name, causality="output", variability="continuous", initial=initial, start=x0[i],
                        description=f"state: {what}"))
    for i, name in enumerate(eq.state_names):
        out.append(dict(name=f"der({name})", causality="local", variability="continuous", initial="calculated",
                        derivative=i + 1, description=f"the derivative of {name}"))
    for p, v in zip(eq.parameters, pvalues):
        out.append(dict(name=p.name, causality="parameter", variability="tunable", initial="exact", start=v,
                        description="parameter"))
    for u in eq.inputs:
        out.append(dict(name=u.name, causality="input", variability="continuous", start=0.0, description="input"))
    energy = energy_name(eq)
    out.append(dict(name=energy, causality="output", variability="continuous", initial="calculated",
                    description="the Jacobi integral h = q_dot . dL/dq_dot - L (the energy T + V when T* = T2)"))
    for con, lam in zip(eq.model.constraints, eq.multipliers):
        out.append(dict(name=lam.name, causality="output", variability="continuous", initial="calculated",
                        description=f"the multiplier of the {con.kind} constraint {con.name}: {con.expression} = 0"))
    notes = {"solver.rtol": "relative tolerance of the Co-Simulation integrator (DOP853)",
             "solver.atol": "absolute tolerance of the Co-Simulation integrator (DOP853)",
             "solver.max_step": "largest step of the Co-Simulation integrator (0: no limit but the communication "
                                "step)"}
    for name, value in SOLVER_DEFAULTS.items():
        out.append(dict(name=name, causality="parameter", variability="tunable", initial="exact", start=value,
                        description=notes[name]))
    # the model's named outputs last: the value references above are those of an FMU without outputs
    for name, expr in named_outputs(eq, [v["name"] for v in out]).items():
        out.append(dict(name=name, causality="output", variability="continuous", initial="calculated",
                        description=f"the model's output {name} = {expr}"))
    return out


def _model_description(eq: Equations, ident: str, guid: str, variables: list[dict], sources: list[str]) -> str:
    from .._version import __version__

    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    n2 = 2 * eq.n
    files = "".join(f'\n      <File name="{f}"/>' for f in sources)
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="2.0" modelName={xml_attribute(eq.model.name)} guid="{guid}"',
             f'  description={xml_attribute((eq.model.description or f"{eq.model.name}: Lagrangian model").strip())}',
             f'  generationTool="lagrangian {__version__}" generationDateAndTime="{now}"',
             '  variableNamingConvention="structured" numberOfEventIndicators="0">',
             f'  <ModelExchange modelIdentifier="{ident}" canGetAndSetFMUstate="true" canSerializeFMUstate="true"',
             '    completedIntegratorStepNotNeeded="true" canNotUseMemoryManagementFunctions="false">',
             f'    <SourceFiles>{files}\n    </SourceFiles>',
             '  </ModelExchange>',
             f'  <CoSimulation modelIdentifier="{ident}" canHandleVariableCommunicationStepSize="true"',
             '    canInterpolateInputs="false" maxOutputDerivativeOrder="0" canRunAsynchronuously="false"',
             '    canGetAndSetFMUstate="true" canSerializeFMUstate="true" canNotUseMemoryManagementFunctions="false">',
             f'    <SourceFiles>{files}\n    </SourceFiles>',
             '  </CoSimulation>',
             '  <LogCategories>',
             '    <Category name="logStatusError" description="errors: a singular mass matrix, a failed step"/>',
             '  </LogCategories>']
    sim = eq.model.simulation
    if sim.get("t_end"):
        extra = f' tolerance="{sim["rtol"]!r}"' if sim.get("rtol") else ""
        extra += f' stepSize="{sim["dt"]!r}"' if sim.get("dt") else ""
        lines.append(f'  <DefaultExperiment startTime="0" stopTime="{float(sim["t_end"])!r}"{extra}/>')
    lines.append('  <ModelVariables>')
    for vr, v in enumerate(variables):
        attrs = (f'name={xml_attribute(v["name"])} valueReference="{vr}" description={xml_attribute(v["description"])} '
                 f'causality="{v["causality"]}" variability="{v["variability"]}"')
        if "initial" in v:
            attrs += f' initial="{v["initial"]}"'
        real = []
        if "start" in v:
            real.append(f'start="{float(v["start"])!r}"')
        if "derivative" in v:
            real.append(f'derivative="{v["derivative"]}"')
        lines.append(f'    <ScalarVariable {attrs}>')
        lines.append(f'      <Real {" ".join(real)}/>'.replace("<Real />", "<Real/>"))
        lines.append('    </ScalarVariable>')
    lines.append('  </ModelVariables>')
    # the energy, the multipliers and the named outputs: the outputs without a start value
    calculated = [i + 1 for i, v in enumerate(variables) if v["causality"] == "output" and "start" not in v]
    outputs = [*range(1, n2 + 1), *calculated]
    states = list(range(1, n2 + 1)) if variables[0]["initial"] == "approx" else []
    lines += ['  <ModelStructure>', '    <Outputs>']
    lines += [f'      <Unknown index="{i}"/>' for i in outputs]
    lines += ['    </Outputs>', '    <Derivatives>']
    lines += [f'      <Unknown index="{n2 + i}"/>' for i in range(1, n2 + 1)]
    lines += ['    </Derivatives>', '    <InitialUnknowns>']
    lines += [f'      <Unknown index="{i}"/>' for i in [*states, *range(n2 + 1, 2 * n2 + 1), *calculated]]
    lines += ['    </InitialUnknowns>', '  </ModelStructure>', '</fmiModelDescription>', '']
    return "\n".join(lines)


def _build(sources: dict[str, str], ident: str, suffix: str, folder: Path) -> tuple[Path | None, str | None]:
    """Compile the sources into a shared library; (its path, None) or (None, why not)."""
    from ..numeric._cbackend import c_compiler

    cc = c_compiler()
    if cc is None:
        return None, "no C compiler was found ($CC, cc or gcc)"
    out = folder / f"{ident}{suffix}"
    c_names = [folder / name for name in sources if name.endswith(".c")]
    cmd = [*cc.split(), "-std=c99", "-O2", "-shared", "-fPIC", "-fvisibility=hidden", f"-I{folder}", "-o", str(out),
           *map(str, c_names), "-lm"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        said = (run.stderr.strip() or run.stdout.strip())[:1500] or "it printed nothing"
        return None, f"the C compiler ({cc}) failed with exit status {run.returncode}: {said}"
    return out, None


def export_fmu(system, path, *, params: Mapping | None = None, initial: Mapping | None = None,
               binary: bool = True, force: bool = False) -> ExportResult:
    """Write the model as an FMI 2.0 FMU (Model Exchange and Co-Simulation in one archive).

    Variables: the states (coordinates and velocities, by their names) as outputs with the
    model's initial values as start values, their derivatives ``der(<name>)``, the parameters
    as tunable parameters with the model's values, the inputs as inputs (start 0), the energy
    (``energy``, or ``jacobi_integral`` when T* has terms of degree 0 or 1 in the velocities)
    as an output, and the Co-Simulation integrator's ``solver.rtol``, ``solver.atol`` (default
    1e-8) and ``solver.max_step`` (default 0: no limit but the communication step) as tunable
    parameters. Co-Simulation integrates with an embedded adaptive DOP853, the inputs held over
    each communication step (``fmi2SetupExperiment``'s tolerance, when given, sets both
    tolerances).

    The model's named outputs (``[outputs]``, ``Model.add_output``) are outputs too (causality
    output, continuous, calculated), after all the variables above (the value references of an FMU
    without outputs do not move), computed with the energy from the exported C's ``<id>_outputs``.
    An output whose name the FMU already uses (``energy_`` when a parameter takes ``energy``) is
    refused (:class:`~lagrangian.errors.ModelError`).

    A constrained model's FMU also has the multipliers ``lambda_<name>`` as outputs (after the
    energy), and x' solves the saddle-point system [M G^T; G 0] [q_ddot; -lambda] = [f; c]. Its
    states are ``initial="approx"``: when initialization ends the FMU moves them onto the
    constraints, holding the independent coordinates and speeds and the start values that were
    set to other values (the exported start values already meet the constraints, made so as
    :func:`lagrangian.simulate` makes its initial state). Co-Simulation projects the state onto
    the constraints after every step (the drift stays at round-off); Model Exchange gives the
    index-1 form to the importing tool, whose integration error makes the constraints drift.

    Parameters
    ----------
    system : Model, Equations or str
    path : str or Path
        The .fmu file to write.
    params, initial : mapping of str to float, optional
        Parameter values and initial state values that replace the model's (as start values).
    binary : bool
        Build the binary for this platform with the machine's C compiler (default). Without a
        compiler, or with False, the FMU has its sources only (and ``warnings`` says so).
    force : bool
        Replace a file that lagrangian did not write, or a symbolic link (the link itself, never
        its target); without it they are refused (:class:`~lagrangian.errors.OutputFileError`)
        before anything is built. The archive is written atomically.

    Returns
    -------
    ExportResult
        ``files`` (the .fmu), ``binary`` (the platform built, or None) and ``warnings``.
    """
    from ..numeric._codegen import fingerprint

    eq = equations_of(system)
    path = output_file(path, ".fmu", "--fmu", "an FMU's file name")
    check_replaceable((path, "--fmu"), force=force)
    ident = identifier(eq.model.name)
    pvalues = parameter_values(eq, params)
    x0 = start_state(eq, initial, params)
    variables = _variables(eq, pvalues, x0)
    key = f"lagrangian:{fingerprint(eq)}:{pvalues}:{x0}"
    if eq.is_constrained:  # the fingerprint does not see the constraints
        key += ":" + "|".join(f"{c.kind}:{c.name}:{c.expression}" for c in eq.model.constraints)
    outputs = named_outputs(eq)
    if outputs:  # nor the outputs
        key += ":outputs:" + "|".join(f"{name}={expr}" for name, expr in outputs.items())
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, key)) + "}"
    files = c_files(eq, params, initial)
    template = (_HERE / "fmu_template.c").read_text()
    names = c_strings(v["name"] for v in variables)
    starts = ", ".join(repr(float(v.get("start", 0.0))) for v in variables)
    fmu_c = (template.replace("@ID@", ident).replace("@NAME@", comment_text(eq.model.name))
             .replace("@NX@", str(2 * eq.n))
             .replace("@NU@", str(len(eq.inputs))).replace("@NC@", str(len(eq.multipliers)))
             .replace("@NY@", str(len(outputs)))
             .replace("@UP@", ident.upper()).replace("@NP@", str(len(eq.parameters))).replace("@GUID@", guid)
             .replace("@START@", starts).replace("@NAMES@", names).replace("@DOP853@", _dop853_tables()))
    sources = {f"{ident}.h": files[f"{ident}.h"], f"{ident}.c": files[f"{ident}.c"], "fmu.c": fmu_c}
    for header in _HEADERS:
        sources[header] = (_HERE / "fmi2" / header).read_text()
    warnings: list[str] = []
    built = None
    with tempfile.TemporaryDirectory(prefix="lagrangian-fmu-") as tmp:
        folder = Path(tmp)
        for name, text in sources.items():
            (folder / name).write_text(text)
        where = fmu_platform()
        library = None
        if binary and where is None:
            warnings.append(f"FMI 2.0 names no platform for {sys.platform} ({platform.machine()})")
        elif binary:
            library, why = _build(sources, ident, where[1], folder)
            if library is None:
                warnings.append(why)
            else:
                built = where[0]
        if binary and built is None:
            warnings[-1] = (f"the FMU has no binary, only its sources: {warnings[-1]}. An importing tool that "
                            "compiles sources (fmpy: fmpy.build.build_platform_binary) can build it, or install a "
                            "C compiler (gcc) and export again")
        elif not binary:
            warnings.append("the FMU has no binary, only its sources, as asked (binary=False, --no-binary): an "
                            "importing tool that compiles sources (fmpy: fmpy.build.build_platform_binary) can "
                            "build it; export without --no-binary for one built here")
        description = _model_description(eq, ident, guid, variables, [f"{ident}.c", "fmu.c"])
        try:
            with replacing(path) as tmp_zip, zipfile.ZipFile(tmp_zip, "w", zipfile.ZIP_DEFLATED) as z:
                z.writestr("modelDescription.xml", description)
                for name, text in sources.items():
                    z.writestr(f"sources/{name}", text)
                if library is not None:
                    z.write(library, f"binaries/{built}/{library.name}")
                z.write(_HERE / "fmi2" / "LICENSE.txt", "documentation/licenses/fmi2-headers-LICENSE.txt")
                z.writestr("documentation/index.html", _documentation(eq, variables))
        except OSError as exc:
            raise cannot_write("--fmu", path, exc) from None
    return ExportResult((os.fspath(path),), built, tuple(warnings))


def _documentation(eq: Equations, variables: list[dict]) -> str:
    from html import escape

    constrained = projected = ""
    if eq.is_constrained:
        constrained = escape(" + G(q, t)^T lambda with the constraints " + ", ".join(
            f"{c.name} ({c.kind}: {c.expression} = 0)" for c in eq.model.constraints)
            + ": x' and the multipliers solve [M G^T; G 0] [q_ddot; -lambda] = [f; c]")
        projected = (", the state projected onto the constraints after every step. Model Exchange leaves the "
                     "integration to the importing tool: the constraints then drift with its integration error")
    rows = "\n".join(f"<tr><td>{vr}</td><td>{escape(v['name'])}</td><td>{v['causality']}</td>"
                     f"<td>{escape(str(v.get('start', '')))}</td><td>{escape(v['description'])}</td></tr>"
                     for vr, v in enumerate(variables))
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{escape(eq.model.name)}</title></head><body>"
            f"<h1>{escape(eq.model.name)}</h1><p>Generated by lagrangian from the model's Lagrange equations "
            f"M(q, t) q_ddot = f(q, q_dot, t, u){constrained}, x = [{', '.join(eq.state_names)}]. Co-Simulation "
            "integrates them with an adaptive DOP853 (solver.rtol, solver.atol, solver.max_step), the inputs held over "
            f"each communication step{projected}.</p><table border='1'><tr><th>value reference</th><th>name</th>"
            "<th>causality</th><th>start</th>"
            f"<th>description</th></tr>\n{rows}\n</table></body></html>\n")
