"""The playground's work, run in the worker processes: each task takes a request's payload and
returns a :class:`Reply` (status, content type, body), never raising for bad input.

Every task calls the same library functions as the CLI (``load``/``loads_model``, ``derive``,
``report``, ``equilibria``, ``modes``, ``simulate``, the plot layer's ``scene_of``); nothing is
computed here that the library does not compute. Model text only goes through the safe
model-file reader (:func:`lagrangian.io.loads_model`); values such as ``pi/2`` through the safe
expression parser.

Status codes: 200; 400 for a bad request or a bad model (``{"errors": [{"line", "key",
"message"}, ...]}``, the messages the CLI prints); 422 for a computation that fails on a valid
request (a simulation that reaches a singular mass matrix: what the CLI exits 1 for); 500 only
for a fault of ours.
"""

from __future__ import annotations

import html
import json
import math
import numbers
import re
import traceback
from dataclasses import dataclass, field

from .._util import did_you_mean, named_values
from ..errors import ExpressionError, LagrangianError, ModelError, Problem

__all__ = ["Reply", "run", "TASKS", "MAX_ROWS", "MAX_FRAMES", "errors_reply"]

#: The most output rows (t_end / dt + 1) one simulation request may ask for.
MAX_ROWS = 100_000
#: The most animation frames a simulation reply carries (the trajectory is sampled down to them).
MAX_FRAMES = 4000
#: The fields of a simulation request, with what each holds (for messages).
SIMULATE_FIELDS = {
    "model": "the model-file text (a string)",
    "t_end": "the final time, a number > 0 (default: the model's [simulation] t_end)",
    "initial": "initial coordinates and velocities, {name: number or constant such as \"pi/2\"}",
    "inputs": "each input as an expression of t, the coordinates and velocities (a feedback law), {name: "
              "\"1.5*sin(3*t)\", \"-20*(q2 - pi/2) - 5*q2_dot\" or a number}, or a measured signal {name: {\"t\": "
              "[...], \"values\": [...], \"interpolation\": \"linear\" or \"cubic\"}}",
    "params": "parameter values that override the model's, {name: number}",
    "dt": "the output interval, a number > 0 (default: the model's, or 0.01)",
    "rtol": "the relative tolerance, a number > 0 (default 1e-9)",
    "atol": "the absolute tolerance, a number > 0 (default 1e-9)",
    "method": "the integrator: DOP853 (default), variational, RK45, RK23, Radau, BDF or LSODA",
}
#: The fields of an equilibria request.
EQUILIBRIA_FIELDS = {
    "model": SIMULATE_FIELDS["model"],
    "params": SIMULATE_FIELDS["params"],
    "inputs": "constant input values, {name: number}",
}
REPORT_FORMATS = {"html": "text/html; charset=utf-8", "md": "text/markdown; charset=utf-8",
                  "tex": "application/x-tex; charset=utf-8"}


@dataclass(frozen=True)
class Reply:
    """What a task answers: the HTTP status, the content type, the body and extra headers."""

    status: int
    body: bytes
    content_type: str = "application/json"
    headers: dict = field(default_factory=dict)


def json_reply(obj, status: int = 200) -> Reply:
    return Reply(status, json.dumps(obj, allow_nan=False).encode())


def errors_reply(status: int, problems) -> Reply:
    """``{"errors": [{"line", "key", "message"}, ...]}`` from Problems or messages."""
    items = []
    for p in problems:
        if isinstance(p, str):
            p = Problem(p)
        items.append({"line": p.line, "key": p.key, "message": p.message})
    return json_reply({"errors": items}, status)


class BadRequest(Exception):
    """A request the server refuses before any computation (status 400)."""

    def __init__(self, *messages: str):
        self.messages = messages
        super().__init__("; ".join(messages))


# ------------------------------------------------------------------ reading requests
def _model_text(payload) -> str:
    if isinstance(payload, bytes):
        try:
            return payload.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise BadRequest(f"the request body is not UTF-8 text (the byte at offset {exc.start} cannot be "
                             "decoded): send the model file's text as UTF-8") from None
    return payload


def _json_object(body: bytes, fields: dict[str, str], problems: list[str] | None = None, *,
                 example: str = '{"model": "...", "t_end": 5}') -> dict:
    """The request body as a JSON object with only known fields, and a string `model`. The
    problems of its fields are raised together, or added to `problems` when it is given (the
    caller checks the values too and raises every problem at once). `example` is the object
    the message of a body that is not JSON shows."""
    try:
        obj = json.loads(_model_text(body))
    except json.JSONDecodeError as exc:
        raise BadRequest(f"the request body is not valid JSON ({exc.msg} at line {exc.lineno}, column "
                         f"{exc.colno}): send an object such as {example}") from None
    if not isinstance(obj, dict):
        raise BadRequest(f"the request body must be a JSON object with the fields {', '.join(fields)}; "
                         f"got {type(obj).__name__}")
    found = []
    for key in obj:
        if key not in fields:
            found.append(f"unknown field '{key}'{did_you_mean(key, fields)}; the fields are {', '.join(fields)}")
    if "model" not in obj:
        found.append("the field 'model' is missing: give the model-file text, "
                     "{\"model\": \"coordinates = [\\\"x\\\"] ...\"}")
    elif not isinstance(obj["model"], str):
        found.append(f"the field 'model' must be the model file's text (a string), got "
                     f"{type(obj['model']).__name__}")
    if problems is not None:
        problems.extend(found)
    elif found:
        raise BadRequest(*found)
    return obj


def _number(value, where: str, *, positive: bool = False) -> float:
    """A JSON number, or a string holding a constant expression such as "pi/2" (parsed safely)."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, str)):
        raise BadRequest(f"{where}: expected a number, got {json.dumps(value)}")
    if isinstance(value, str):
        from ..model._expr import constant_value

        try:
            value = constant_value(value, where)
        except ModelError as exc:
            raise BadRequest(str(exc)) from None
    value = float(value)
    if not math.isfinite(value) or (positive and not value > 0):
        raise BadRequest(f"{where}: expected a {'positive' if positive else 'finite'} number, got {value!r}")
    return value


def _numbers(obj: dict, key: str) -> dict[str, float] | None:
    value = obj.get(key)
    if value is None:
        return None
    if not isinstance(value, dict):
        raise BadRequest(f"{key}: expected an object {{name: value}}, got {json.dumps(value)[:80]}")
    out, problems = {}, []
    for k, v in value.items():
        try:
            out[str(k)] = _number(v, f"{key}.{k}")
        except BadRequest as exc:
            problems.extend(exc.messages)
    if problems:
        raise BadRequest(*problems)
    return out


def _checked(problems: list[str], read, *args, **kwargs):
    """read(*args, **kwargs), or None with its BadRequest's messages added to `problems`."""
    try:
        return read(*args, **kwargs)
    except BadRequest as exc:
        problems.extend(exc.messages)
        return None


#: The fields of a request whose body is the model file's text, when it is sent as JSON.
TEXT_FIELDS = {"model": SIMULATE_FIELDS["model"]}


def _request_text(body: bytes, json_body: bool) -> str:
    """The model text of a derive, analysis or report request: the body itself, or with
    ``Content-Type: application/json`` (what the page sends) the field ``model`` of a JSON object."""
    if not json_body:
        return _model_text(body)
    example = ('{"model": "coordinates = [\\"x\\"] ..."} (or send the model file\'s text itself with another '
               "Content-Type, such as text/plain)")
    return _json_object(body, TEXT_FIELDS, example=example)["model"]


def _load(text: str):
    from ..examples import example_source
    from ..io import loads_model

    name = text.strip()
    if name and not any(c in name for c in "=[\n\"'#") and example_source(name) is not None:
        raise BadRequest(f"'{name}' is the name of a built-in example, not a model file's text: send its text "
                         f"(GET /api/examples/{name} gives it, as {{\"name\", \"text\"}})")
    return loads_model(text, source="<playground>")


# ------------------------------------------------------------------ the tasks
def derive_task(body: bytes, *, json_body: bool = False) -> Reply:
    """The JSON of ``lagrangian derive --json`` for the model text in `body`."""
    from .. import derive

    eqs = derive(_load(_request_text(body, json_body)))
    return Reply(200, (eqs.to_json() + "\n").encode())


_SECTION = re.compile(r'<section id="([^"]+)">\n<h2>(.*?)</h2>\n(.*?)\n</section>', re.S)


def analysis_task(body: bytes, *, json_body: bool = False) -> Reply:
    """The derivation report's sections as HTML (MathML), the model's [simulation] defaults, the
    initial values a simulation takes as given (``given``: the others are completed, 0 or from the
    constraints), and whether (or why not) the model can be drawn."""
    from .. import derive, report
    from ..numeric._simulate import given_initial_names
    from ..plot._geometry import check_drawable

    model = _load(_request_text(body, json_body))
    eqs = derive(model)
    page = report(eqs, equilibria=False).to_html()
    sections = [{"key": k, "title": html.unescape(title), "html": inner} for k, title, inner in _SECTION.findall(page)]
    try:
        check_drawable(model)
        not_drawable = None
    except ModelError as exc:
        not_drawable = str(exc)
    return json_reply({
        "name": model.name,
        "description": getattr(model, "description", "") or "",
        "coordinates": [c.name for c in eqs.coordinates],
        "velocities": [v.name for v in eqs.velocities],
        "inputs": [u.name for u in eqs.inputs],
        "parameters": {p.name: v for p, v in eqs.parameters.items()},
        "simulation": {k: v for k, v in model.simulation.items()},
        "given": given_initial_names(model),
        "drawable": not_drawable is None,
        "not_drawable": not_drawable,
        "sections": sections,
    })


def equilibria_task(body: bytes) -> Reply:
    """The equilibria (with the given parameter and input values), their stability, and the modes
    about each stable one: as JSON (the CLI's ``equilibria --json`` and ``modes --json`` objects)
    and as an HTML section with MathML."""
    from .. import derive, equilibria, modes

    problems: list[str] = []
    obj = _json_object(body, EQUILIBRIA_FIELDS, problems)
    params, inputs = _checked(problems, _numbers, obj, "params"), _checked(problems, _numbers, obj, "inputs")
    if problems:
        raise BadRequest(*problems)
    eqs = derive(_load(obj["model"]))
    found = equilibria(eqs, params=params, inputs=inputs)
    shown = []
    for e in found:
        m = None
        if e.stable and e.isolated and e.linear_model is not None:
            m = modes(e.linear_model)
        shown.append((e, m))
    return json_reply({
        "equilibria": [e.to_dict() for e in found],
        "notes": list(getattr(found, "notes", ())),
        "modes": [None if m is None else m.to_dict() for _, m in shown],
        "html": _equilibria_html(eqs, shown, getattr(found, "notes", ())),
    })


def _equilibria_html(eqs, shown, notes) -> str:
    import sympy

    from ..analysis._equilibria import condition_text
    from ..reporting._printing import math_element, mathml

    if not shown:
        out = ["<p>There is no equilibrium (with the inputs at zero and these parameter values):</p>"]
        out += [f"<p>{html.escape(n[:1].upper() + n[1:])}.</p>" for n in notes]
        return "\n".join(out)

    def configuration(e):
        exact = e.exact or {}
        parts = []
        for name, value in e.coordinates.items():
            ex = exact.get(name)
            rhs = ex if ex is not None else sympy.Float(value, 6)
            eq = sympy.Eq(sympy.Symbol(name), rhs, evaluate=False)
            text = math_element(mathml(eq), block=False)
            if ex is not None and not ex.is_Number:
                text += f" = {value:.6g}"
            parts.append(text)
        extra = []
        if e.family:
            extra.append(f"any {', '.join(e.family)}")
        if not e.isolated:
            extra.append("not isolated: one point of a set of equilibria")
        if e.conditions:
            extra.append("exists when " + " and ".join(condition_text(c) for c in e.conditions))
        return ", ".join(parts) + "".join(f' <span class="note">({html.escape(x)})</span>' for x in extra)

    def eig(z):
        z = complex(z)
        return f"{z.real:.4g}" if abs(z.imag) < 1e-12 else f"{z.real:.4g}{z.imag:+.4g}i"

    rows = []
    for k, (e, _) in enumerate(shown, start=1):
        cls = "stable" if e.stable else "unstable"
        rows.append(f'<tr class="{cls}"><td>{k}</td><td>{configuration(e)}</td>'
                    f"<td>{html.escape(e.stability)}</td>"
                    f"<td>{html.escape(', '.join(eig(z) for z in list(e.eigenvalues)[:8]))}</td></tr>")
    out = ['<table class="equilibria"><thead><tr><th></th><th>configuration</th><th>stability</th>'
           "<th>eigenvalues of A</th></tr></thead><tbody>" + "".join(rows) + "</tbody></table>"]
    for k, (e, m) in enumerate(shown, start=1):
        if m is None:
            continue
        names = m.coordinate_names
        head = "".join(f"<th>{html.escape(n)}</th>" for n in names)
        body = []
        for j, kind in enumerate(m.kinds):
            def num(x, fmt=".6g"):
                return f"{x:{fmt}}" if math.isfinite(x) else "&#x2013;"

            shape = "".join(f"<td>{x:.4g}</td>" for x in m.unit_shapes[j])
            body.append(f"<tr><td>{j + 1}</td><td>{kind}</td><td>{num(m.frequencies_hz[j])}</td>"
                        f"<td>{num(m.frequencies[j])}</td><td>{num(m.damping_ratios[j], '.4g')}</td>{shape}</tr>")
        damping = ("proportional (classical)" if m.proportional_damping
                   else "not proportional: the modes couple through it")
        out.append(f'<h3>Modes about equilibrium {k}</h3><table class="modes"><thead><tr><th>mode</th><th>kind</th>'
                   f"<th>f (Hz)</th><th>&#x3C9; (rad/s)</th><th>&#x3B6;</th>{head}</tr></thead>"
                   f"<tbody>{''.join(body)}</tbody></table>"
                   f'<p class="note">Shapes scaled so that their largest component is 1; damping is {damping}.</p>')
    return "\n".join(out)


def simulate_request(body: bytes, problems: list[str] | None = None) -> tuple[dict, dict]:
    """(the request object, the keyword arguments of ``simulate``) of a simulation request. The
    problems of its fields are raised together, or added to `problems` when it is given (the
    caller then checks the model too, and raises every problem at once)."""
    given = problems
    problems = [] if given is None else given
    obj = _json_object(body, SIMULATE_FIELDS, problems)
    kwargs = {}
    for key in ("t_end", "dt", "rtol", "atol"):
        if obj.get(key) is not None:
            value = _checked(problems, _number, obj[key], key, positive=True)
            if value is not None:
                kwargs[key] = value
    kwargs["initial"] = _checked(problems, _numbers, obj, "initial")
    kwargs["params"] = _checked(problems, _numbers, obj, "params")
    inputs = obj.get("inputs")
    if inputs is not None:
        if not isinstance(inputs, dict):
            problems.append(f"inputs: expected an object {{name: expression}}, got {json.dumps(inputs)[:80]}")
        else:
            kwargs["inputs"] = dict(inputs)
            for k, v in inputs.items():
                if isinstance(v, dict):
                    kwargs["inputs"][k] = _checked(problems, _signal, v, f"inputs.{k}")
                elif isinstance(v, bool) or not isinstance(v, (str, numbers.Real)):
                    problems.append(f"inputs.{k}: expected an expression of t, the coordinates and velocities (a "
                                    f"string such as \"1.5*sin(3*t)\" or \"-20*(q2 - pi/2) - 5*q2_dot\"), a number, "
                                    f"or a measured signal {{\"t\": [...], \"values\": [...]}}, got "
                                    f"{json.dumps(v)[:80]}")
    if obj.get("method") is not None:
        if not isinstance(obj["method"], str):
            problems.append(f"method: expected a name such as \"DOP853\", got {json.dumps(obj['method'])}")
        else:
            kwargs["method"] = obj["method"]
    if problems and given is None:
        raise BadRequest(*problems)
    return obj, kwargs


#: The keys of a measured signal in a simulation request.
SIGNAL_KEYS = ("t", "values", "interpolation", "extrapolation")


def _signal(obj: dict, where: str):
    """A measured signal sent as data, {"t": [...], "values": [...], "interpolation": "linear" or
    "cubic", "extrapolation": "error" or "hold"}: a table of numbers (at most MAX_ROWS samples) that
    the browser read from the user's CSV; never a file on the server."""
    from ..numeric import Signal

    unknown = [k for k in obj if k not in SIGNAL_KEYS]
    if unknown:
        raise BadRequest(f"{where}: unknown key '{str(unknown[0])[:40]}'{did_you_mean(str(unknown[0]), SIGNAL_KEYS)}; "
                         f"a measured signal has the keys {', '.join(SIGNAL_KEYS)}")
    columns = []
    for key in ("t", "values"):
        column = obj.get(key)
        if not isinstance(column, list) or not all(isinstance(v, numbers.Real) and not isinstance(v, bool)
                                                   for v in column):
            raise BadRequest(f"{where}.{key}: expected a list of numbers, got {json.dumps(column)[:80]}")
        if len(column) > MAX_ROWS:
            raise BadRequest(f"{where}.{key}: {len(column)} samples, more than the limit of {MAX_ROWS} per request; "
                             "resample the signal more coarsely")
        columns.append(column)
    options = {}
    for key, default in (("interpolation", "linear"), ("extrapolation", "error")):
        value = obj.get(key, default)
        if not isinstance(value, str):
            raise BadRequest(f"{where}.{key}: expected a string, got {json.dumps(value)[:80]}")
        options[key] = value
    try:
        return Signal(*columns, options["interpolation"], options["extrapolation"], name=where.partition(".")[2])
    except ModelError as exc:
        raise BadRequest(f"{where}: {exc}") from None


def _request_problems(obj: dict, problems: list[str]) -> ModelError:
    """Every problem of a simulation request at once: those of its fields, then those of its model
    text, or, when the model loads, the names in initial, params and inputs that it does not have
    (with simulate's messages)."""
    found = [Problem(message) for message in problems]
    if isinstance(obj.get("model"), str):
        try:
            model = _load(obj["model"])
        except BadRequest as exc:
            found += [Problem(message) for message in exc.messages]
        except ModelError as exc:
            found += exc.problems
        else:
            coordinates = tuple(c.name for c in model.coordinates)
            choices = {"initial": (coordinates + tuple(f"{c}_dot" for c in coordinates), "a coordinate or velocity"),
                       "params": (tuple(p.name for p in model.parameters), "a parameter of the model"),
                       "inputs": (tuple(u.name for u in model.inputs), "an input of the model")}
            for key, (names, what) in choices.items():
                raw = obj.get(key)
                given = {str(name): 0.0 for name in raw} if isinstance(raw, dict) else {}  # values: checked above
                named_values(given, names, what, key, found)
    return ModelError(found)


def _simulate(body: bytes):
    from .. import derive, simulate
    from ..numeric import SimulationOptions

    problems: list[str] = []
    obj, kwargs = simulate_request(body, problems)
    if problems:
        raise _request_problems(obj, problems)
    model = _load(obj["model"])
    options = SimulationOptions.from_model(model).merged(t_end=kwargs.get("t_end"), dt=kwargs.get("dt"))
    t_end, dt = options.t_end, options.dt
    if t_end is not None and t_end / dt + 1 > MAX_ROWS:
        rows = t_end / dt + 1
        shown = f"{math.floor(rows)}" if rows < 1e15 else f"{rows:.3g}"  # 1e+302, not 303 digits; inf at dt = 1e-320
        raise _request_problems(obj, [f"the simulation would output {shown} rows (t_end / dt + 1), more than the "
                                      f"limit of {MAX_ROWS} per request: raise dt or shorten t_end"])  # with the names
    return model, simulate(derive(model), **kwargs)  # initial and inputs update the model file's by name


def simulate_task(body: bytes) -> Reply:
    """The trajectory as JSON: every CSV column by name, the energy, the run's statistics, and the
    mechanism's geometry for the animation (or why it cannot be drawn)."""
    model, traj = _simulate(body)
    table = traj.table()
    out = {
        "model": model.name,
        "names": list(traj.columns),
        "columns": {name: table[:, k].tolist() for k, name in enumerate(traj.columns)},
        "state_names": list(traj.state_names),
        "input_names": list(traj.input_names),
        "output_names": list(traj.outputs),
        "energy_name": traj.energy_name,
        "conservative": bool(traj.conservative),
        "energy_drift": traj.energy_drift,
        "parameters": dict(traj.parameters),
        "stats": {k: (v if isinstance(v, (str, int, float, bool)) or v is None else str(v))
                  for k, v in traj.stats.items()},
        "geometry": None,
        "not_drawable": None,
    }
    try:
        out["geometry"] = geometry(model, traj)
    except ModelError as exc:
        out["not_drawable"] = str(exc)
    return json_reply(out)


def simulate_csv_task(body: bytes) -> Reply:
    """The trajectory as the CSV of ``lagrangian simulate`` (``Trajectory.to_csv``)."""
    model, traj = _simulate(body)
    return Reply(200, traj.to_csv().encode(), "text/csv; charset=utf-8",
                 {"Content-Disposition": f'attachment; filename="{_file_name(model.name)}.csv"'})


def geometry(model, traj) -> dict:
    """What the page's canvas draws: the scene of :func:`lagrangian.plot._geometry.scene_of` (nodes,
    rods, springs, dampers, tracks, the ground), the node positions and body angles at each frame,
    the bodies in space (their frame's origin and rotation, by rows, and the link that carries them,
    at each frame; the axes' length), and the framing (:func:`~lagrangian.plot._geometry.framing_of`:
    its centre at each frame when it follows the mechanism, else one; its half-widths; its size)."""
    import numpy as np

    from ..plot._geometry import grid_step, scene_of

    scene = scene_of(model, traj.parameters)
    step = max(1, math.ceil(len(traj.t) / MAX_FRAMES))
    idx = np.arange(0, len(traj.t), step)
    t, q = traj.t[idx], traj.q[idx]
    positions = scene.positions(t, q)
    angles = scene.angles(t, q)
    framing, axis_length, drawings = scene.framed(traj.t, traj.q, idx)

    def rounded(a):
        return np.round(np.asarray(a, dtype=float), 9).tolist()

    return {
        "dim": scene.dim,
        "nodes": [{"name": n.name, "kind": n.kind, "mass": n.mass, "inertia": n.inertia, "fixed": n.fixed,
                   "slider": n.slider} for n in scene.nodes],
        "rods": [list(r) for r in scene.rods],
        "springs": [[name, i, j] for name, i, j in scene.springs],
        "dampers": [[name, i, j] for name, i, j in scene.dampers],
        "tracks": [{"point": rounded(p), "direction": rounded(d)} for p, d in scene.tracks],
        "bodies": list(scene.bodies),
        "undrawn": list(scene.undrawn),
        "t": rounded(t),
        "positions": rounded(positions),
        "angles": rounded(angles),
        "spatial": [{"name": b.name, "frame": b.frame, "node": b.node, "radius": b.radius, "axis": b.axis,
                     "origin": rounded(d.origin), "rotation": rounded(d.rotation.reshape(len(idx), 9)),
                     "link": rounded(d.link)} for b, d in zip(scene.spatial, drawings)],
        "axis_length": axis_length,
        "ground": {"step": grid_step(2 * float(np.max(framing.half[:2]) + 0.12 * framing.size))}
        if scene.ground else None,
        "framing": {"follow": framing.follow,
                    "centre": rounded(framing.centre if framing.follow else framing.centre[:1]),
                    "half": rounded(framing.half), "size": framing.size},
    }


def report_task(body: bytes, fmt: str = "html", *, json_body: bool = False) -> Reply:
    """The derivation report (``lagrangian report``) as HTML, Markdown or LaTeX, as a download."""
    from .. import derive, report

    if fmt not in REPORT_FORMATS:
        raise BadRequest(f"format '{fmt}': choose html, md or tex")
    model = _load(_request_text(body, json_body))
    text = report(derive(model)).render(fmt)
    return Reply(200, text.encode(), REPORT_FORMATS[fmt],
                 {"Content-Disposition": f'attachment; filename="{_file_name(model.name)}.{fmt}"'})


#: The fields of an FMU request.
FMU_FIELDS = {
    "model": SIMULATE_FIELDS["model"],
    "params": "parameter values, the FMU's start values, {name: number} (default: the model's)",
    "initial": "initial coordinates and velocities, the FMU's start values, {name: number}",
}


def fmu_task(body: bytes) -> Reply:
    """The model as an FMI 2.0 FMU (``lagrangian export --fmu``; Model Exchange and Co-Simulation),
    with the given parameter and initial values as start values, as a download; the exporter's
    warnings (a sources-only FMU where there is no C compiler) in the X-Lagrangian-Warnings header."""
    import tempfile
    from pathlib import Path

    from .. import derive
    from ..export import export_fmu

    problems: list[str] = []
    obj = _json_object(body, FMU_FIELDS, problems)
    params, initial = _checked(problems, _numbers, obj, "params"), _checked(problems, _numbers, obj, "initial")
    if problems:
        raise BadRequest(*problems)
    model = _load(obj["model"])
    name = _file_name(model.name)
    with tempfile.TemporaryDirectory(prefix="lagrangian-fmu-") as folder:
        result = export_fmu(derive(model), Path(folder) / f"{name}.fmu", params=params, initial=initial)
        data = Path(result.files[0]).read_bytes()
    headers = {"Content-Disposition": f'attachment; filename="{name}.fmu"'}
    if result.warnings:
        headers["X-Lagrangian-Warnings"] = json.dumps(list(result.warnings))  # ASCII: json escapes the rest
    return Reply(200, data, "application/zip", headers)


def _file_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "model"


TASKS = {"derive": derive_task, "analysis": analysis_task, "equilibria": equilibria_task,
         "simulate": simulate_task, "simulate_csv": simulate_csv_task, "report": report_task, "fmu": fmu_task}


def run(kind: str, body: bytes, *args, **options) -> Reply:
    """Run the task `kind`; bad input and failed computations become error replies, never exceptions,
    except MemoryError (past the worker's memory cap), which the worker answers by handing over to a
    fresh process."""
    from ..errors import SimulationError, SingularMassMatrixError

    try:
        return TASKS[kind](body, *args, **options)
    except BadRequest as exc:
        return errors_reply(400, exc.messages)
    except ModelError as exc:
        return errors_reply(400, exc.problems)
    except ExpressionError as exc:
        return errors_reply(400, [str(exc)])
    except (SingularMassMatrixError, SimulationError) as exc:
        return errors_reply(422, [str(exc)])
    except LagrangianError as exc:
        return errors_reply(422, [str(exc)])
    except RecursionError:
        return errors_reply(422, ["the model's expressions are nested too deeply to handle: simplify them"])
    except MemoryError:
        raise
    except Exception as exc:  # a fault of ours: say so, with the traceback's last line for the bug report
        last = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return errors_reply(500, [f"internal error while running {kind}: {last}; please report it with the model"])


def warm_up() -> None:
    """Load the compiled integrators (compiled once per machine, then cached) with a tiny simulation,
    so that the first request of a user does not pay for it."""
    run("simulate", json.dumps({"model": 'coordinates = ["x"]\n[energy]\nT = "x_dot**2/2"\nV = "x**2/2"\n',
                                "t_end": 0.1}).encode())
