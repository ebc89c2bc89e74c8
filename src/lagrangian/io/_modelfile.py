"""The model-file reader: a TOML description of a mechanical system -> :class:`~lagrangian.Model`.

A model file is data, never code. It is read with :mod:`tomllib`, every expression goes through
the safe parser :func:`lagrangian.model._expr.parse_expression` (never ``eval`` or ``sympify``),
and the whole file is checked in one pass: :func:`load_model_file` and :func:`loads_model`
raise a single :class:`~lagrangian.errors.ModelFileError` that lists *every* problem found,
each with its key (``"particles[1].position[0]"``) and its line in the file.

Format
------
Expressions are strings in the expression syntax of :mod:`lagrangian.model._expr` (numbers,
names, ``+ - * / ** ^``, parentheses and the functions ``sin cos tan asin acos atan atan2
sinh cosh tanh exp log sqrt abs sign``, and ``pi``). Wherever an expression is expected, a
plain TOML number is accepted too (``mass = 2.5``). An expression may use the coordinates,
their velocities ``<coordinate>_dot``, the parameters, the inputs and the time ``t``.

.. code-block:: toml

    name = "cart-pendulum"               # optional, default: the file name without .toml
    description = "..."                  # optional
    coordinates = ["q1", "q2"]           # required: a non-empty list of names
    inputs = ["F"]                       # optional: external forces, torques, signals

    [parameters]                         # every other name used must have a value here (SI)
    M1 = 1.0                             # a number (int or float), not a string, not a bool

    [energy]                             # optional: T (kinetic co-energy), V, D (dissipation)
    T = "1/2*M1*q1_dot**2"
    V = "0"
    D = "0"

    [forces]                             # optional: generalized forces by coordinate name
    q1 = "F"

    [[points]]                           # massless named points (pivots, attachments)
    name = "pivot"
    position = ["0", "0"]                # 2 or 3 expressions

    [[particles]]                        # point masses
    name = "bob"                         # optional in every element (default particle1, ...)
    mass = "m"
    position = ["l*sin(theta)", "-l*cos(theta)"]

    [[bodies]]                           # planar rigid bodies
    name = "rod"
    mass = "M"
    inertia = "M*l**2/12"                # centroidal moment of inertia
    position = ["l/2*sin(theta)", "-l/2*cos(theta)"]
    angle = "theta"

    [[frames]]                           # reference frames, chained from the inertial frame "world"
    name = "body"
    parent = "world"                     # optional, default "world"
    origin = ["0", "0", "0"]             # optional: in the parent's axes, default 0
    rotation = [["z", "phi"], ["x", "theta"], ["z", "psi"]]   # about the frame's own axes, in turn
    # matrix = [["cos(q)", "-sin(q)", "0"], ["sin(q)", "cos(q)", "0"], ["0", "0", "1"]]  # or this

    [[bodies]]                           # a rigid body in space: it has a frame
    name = "top"
    mass = "m"
    frame = "body"                       # its orientation
    inertia = ["I1", "I1", "I3"]         # centroidal, in the frame's axes: 3 principal values, the
                                         # 6 components [xx, yy, zz, xy, yz, zx], or a 3x3 list
    center = ["0", "0", "l"]             # optional: its centre of mass in the frame, default 0
    center_frame = "body"                # optional: the frame of center ("world" for world axes)
    shape = "disk"                       # optional, drawn only: a disk in the animations ...
    radius = "R"                         # ... of this radius (parameters and numbers) ...
    axis = "z"                           # ... across this body axis (optional, default "z")

Points, particles and loads take an optional ``frame = "body"``: their position (a force's
components) are then given in that frame. A torque on a body in space is a list of 3 expressions,
in the axes of ``frame`` (default: the body's own frame).

    [[springs]]                          # linear springs, V = k (length - rest_length)^2 / 2
    stiffness = "k"
    between = ["pivot", "bob"]           # two point/particle/body names, or two position lists
    # length = "q1"                      # ... or any length expression: exactly one of the two
    rest_length = "0"                    # optional, default 0

    [[dampers]]                          # linear viscous dampers, D = c (d length/dt)^2 / 2
    coefficient = "c"
    between = ["pivot", "bob"]           # or: length = "..." (exactly one of the two)

    [gravity]                            # optional: uniform gravity on particles and bodies
    g = "g"
    direction = ["0", "-1"]              # optional, default -y (2D) or -z (3D)

    [[loads]]                            # forces and torques
    force = ["F", "0"]                   # a force vector ...
    at = "cart"                          # ... at a point name or a position list

    [[loads]]
    torque = "tau"                       # a torque ...
    angle = "theta"                      # ... on an angle expression, or: body = "rod"

    [outputs]                            # optional: named outputs (trajectory columns, rows of C, D)
    tip_x = "l*sin(theta)"               # an expression of the state, t, inputs and parameters ...
    tip_y = "bob.y"                      # ... or "<point>.x" (.y, .z): a component of a position

    [simulation]                         # optional defaults for simulate
    t_end = 10.0                         # > 0
    dt = 0.01                            # > 0: output step
    rtol = 1e-9                          # > 0
    atol = 1e-9                          # > 0
    initial = { q2 = 0.5, q2_dot = 0.0 } # coordinate and velocity names -> numbers
    inputs = { F = "0.5*sin(3*t)" }      # input name -> expression of t, the coordinates, velocities
                                         # and parameters (a feedback law), or number
    sample_time = 0.01                   # optional, > 0: the inputs sampled and held (a digital
                                         # controller); or { F = 0.01 } for the named inputs only

Frames are built first (in the order of their parents); elements in the order points, particles,
bodies, springs, dampers, gravity, loads, so
a spring, a damper or a load may refer to any named point, particle or body. Element names must
be unique across all elements. The validated ``[simulation]`` table is stored in
``model.simulation`` as a plain dict ``{"t_end": float, "dt": float, "rtol": float,
"atol": float, "initial": {name: float}, "inputs": {name: str or float}, "sample_time": float or
{name: float}}`` (only the keys given); an input "@data.csv:acc" (a CSV column, the CLI's --input syntax,
relative to the model file's folder) is stored as an ``io._signalspec.SignalFile``, read when simulated.
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import os
import re
import sys
import tomllib
from pathlib import Path
from typing import Any, Mapping, Sequence

import sympy

from .._util import closest, did_you_mean
from ..errors import ExpressionError, ModelError, ModelFileError, Problem, UnknownNameError
from ..model._elements import Element, shape_problems
from ..model._model import Model, derived_order
from ._expr import parse_expression
from ._jointtable import build_joint, declare_joint_coordinates, joint_child

__all__ = ["load_model_file", "loads_model"]

# --------------------------------------------------------------------------- the schema

#: Top-level keys and tables, with what each holds (for messages).
_TOP_LEVEL: dict[str, str] = {
    "name": 'the model name, a string: name = "cart-pendulum"',
    "description": 'a string: description = "..."',
    "coordinates": 'a list of names: coordinates = ["q1", "q2"]',
    "inputs": 'a list of names: inputs = ["F"]',
    "parameters": "a table [parameters] of name = number",
    "energy": "a table [energy] with T, V and D",
    "forces": "a table [forces] of coordinate = expression",
    "points": "[[points]] tables",
    "particles": "[[particles]] tables",
    "bodies": "[[bodies]] tables",
    "frames": "[[frames]] tables",
    "joints": "[[joints]] tables (name, type, parent, child, origin, rotation, axis, ...): joints that create frames",
    "springs": "[[springs]] tables",
    "dampers": "[[dampers]] tables",
    "gravity": "a table [gravity] with g and direction",
    "loads": "[[loads]] tables",
    "constraints": "[[constraints]] tables (name, and holonomic or velocity)",
    "wheels": "[[wheels]] tables (frame, radius, axis, center, name): wheels rolling on the ground z = 0",
    "operating_point": "a table [operating_point] of coordinate or velocity = number or expression of parameters",
    "simulation": "a table [simulation] with t_end, dt, rtol, atol, initial and inputs",
    "outputs": "a table [outputs] of name = expression (or \"<point>.x\"): named outputs of the state",
    "optimal_control": "a table [optimal_control] (duration, objective, initial, final, inputs, bounds, path): "
                       "the optimal motion problem of lagrangian optimize",
}

#: Keys of each kind of element table: required ones first, then optional ones.
_ELEMENT_KEYS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "points": (("position",), ("name", "frame")),
    "particles": (("mass", "position"), ("name", "frame")),
    "bodies": (("mass", "inertia", "position", "angle"), ("name", "inertia_about")),
    "springs": (("stiffness",), ("name", "between", "length", "rest_length", "acts")),
    "dampers": (("coefficient",), ("name", "between", "length", "body")),
    "loads": ((), ("name", "force", "at", "torque", "angle", "body", "frame")),
}
#: Keys of a body in space (a [[bodies]] table with a frame).
_BODY3D_KEYS = (("mass", "inertia", "frame"), ("name", "center", "center_frame", "shape", "radius", "axis",
                                               "inertia_about"))
_FRAME_KEYS = ("name", "parent", "origin", "rotation", "matrix")
_ENERGY_KEYS = ("T", "V", "D")
_GRAVITY_KEYS = ("g", "direction")
_SIMULATION_KEYS = ("t_end", "dt", "rtol", "atol", "initial", "inputs", "sample_time", "independent",
                    "independent_speeds")
_CONSTRAINT_KEYS = ("name", "holonomic", "velocity")
_WHEEL_KEYS = (("frame", "radius"), ("name", "axis", "center", "lateral", "shape", "semi_axes"))
#: Default element names: particle1, body2, ...
_DEFAULT_PREFIX = {"points": "point", "particles": "particle", "bodies": "body",
                   "springs": "spring", "dampers": "damper"}
_SINGULAR = {"points": "point", "particles": "particle", "bodies": "rigid body",
             "springs": "spring", "dampers": "damper", "loads": "load", "constraints": "constraint",
             "wheels": "wheel", "joints": "joint"}
#: What to add for each required key of an element (for "missing key" messages).
_EXAMPLES = {
    "mass": 'mass = "m" (and m = 1.0 under [parameters])',
    "position": 'position = ["x", "0"] (2 or 3 expressions)',
    "inertia": 'inertia = "m*l**2/12" (the centroidal moment of inertia)',
    "angle": 'angle = "theta" (its rotation angle)',
    "frame": 'frame = "body" (the name of a [[frames]] table)',
    "stiffness": 'stiffness = "k" (and k = 100.0 under [parameters])',
    "coefficient": 'coefficient = "c" (and c = 0.5 under [parameters])',
}
#: Element kinds, in the order they are built.
_ELEMENT_ORDER = ("points", "particles", "bodies", "springs", "dampers", "loads")
#: Kinds whose elements have a position that springs, dampers and loads may refer to.
_LOCATED = ("points", "particles", "bodies")


# --------------------------------------------------------------------------- public API

def load_model_file(path: str | os.PathLike[str]) -> Model:
    """Read a model file (TOML) into a :class:`~lagrangian.Model`.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.toml`` file. The model's name defaults to the file name without its suffix.

    Returns
    -------
    Model
        With its coordinates, parameters (with values), inputs, energies, generalized forces
        and elements, and ``model.simulation`` holding the validated ``[simulation]`` table.

    Raises
    ------
    ModelFileError
        If the file does not exist, cannot be read, is not valid TOML or describes an invalid
        model: one error listing every problem, each with its key and line, and the file name.

    Examples
    --------
    >>> model = load_model_file("cart-pendulum.toml")  # doctest: +SKIP
    """
    file = Path(path)
    source = str(file)
    try:
        regular = file.is_file()
    except OSError as exc:  # a name too long for a path (ENAMETOOLONG)
        short = source if len(source) <= 80 else source[:77] + "..."
        raise ModelFileError([Problem(f"no such model file '{short}': {exc.strerror or exc}; check the path")],
                             file=short) from None
    if not regular:
        if file.is_dir():
            why = f"no such model file '{source}': it is a directory; give the path of a .toml file"
        elif file.exists():
            why = (f"'{source}' is not a regular file (a device, a pipe or a socket); give the path of a .toml "
                   "model file")
        else:
            why = f"no such model file '{source}': check the path" + _similar_files(file)
        raise ModelFileError([Problem(why)], file=source)
    try:
        text = file.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = file.read_bytes()[:exc.start].count(b"\n") + 1
        raise ModelFileError([Problem("the model file is not UTF-8 text: save it as UTF-8 "
                                      f"(the byte at offset {exc.start} cannot be decoded)",
                                      line=line)], file=source) from None
    except OSError as exc:
        raise ModelFileError([Problem(f"cannot read the model file: {exc.strerror or exc}; "
                                      "check that it exists and that you may read it")],
                             file=source) from None
    return _Reader(text, source=source, default_name=file.stem or "model").read()


def loads_model(text: str, *, source: str = "<string>") -> Model:
    """Read a model from the text of a model file (TOML).

    Parameters
    ----------
    text : str
        The content of a model file (see the module documentation for the format).
    source : str, optional
        Where the text comes from, used in error messages (a file name, ``"<string>"``).
        The model's name defaults to its stem, or to ``"model"`` for ``"<...>"`` sources.

    Returns
    -------
    Model

    Raises
    ------
    ModelFileError
        Listing every problem of the text, each with its key and line.
    TypeError
        If `text` is not a str.

    Examples
    --------
    >>> m = loads_model('coordinates = ["x"]\\n[parameters]\\nk = 2\\n'
    ...                 '[energy]\\nT = "x_dot**2/2"\\nV = "k*x**2/2"\\n')
    >>> m.q, m.V
    ((x,), k*x**2/2)
    """
    if not isinstance(text, str):
        raise TypeError(f"loads_model() expects the text of a model file (a str), got "
                        f"{type(text).__name__}; use load_model_file() for a path")
    if source.startswith("<") and source.endswith(">"):
        default = "model"
    else:
        default = Path(source).stem or "model"
    return _Reader(text, source=source, default_name=default).read()


def _similar_files(file: Path) -> str:
    """' (did you mean ...?)' for a file of the same folder with a close name, or ''."""
    folder = file.parent if str(file.parent) else Path(".")
    try:
        names = [p.name for p in folder.iterdir() if p.is_file()]
    except OSError:
        return ""
    close = closest(file.name, names)
    return f" (did you mean '{folder / close}'?)" if close else ""


# --------------------------------------------------------------------------- line finding

_BARE_OR_QUOTED = r"""(?:[A-Za-z0-9_-]+|"(?:[^"\\]|\\.)*"|'[^']*')"""
_KEY_LINE = re.compile(rf"\s*({_BARE_OR_QUOTED}(?:\s*\.\s*{_BARE_OR_QUOTED})*)\s*=")
_HEADER_LINE = re.compile(rf"\s*(\[\[?)\s*({_BARE_OR_QUOTED}(?:\s*\.\s*{_BARE_OR_QUOTED})*)\s*\]")
_KEY_PART = re.compile(r"([^.\[\]]+)|\[(\d+)\]")


def _split_dotted(key: str) -> tuple[str, ...]:
    """``'a . "b c".d'`` -> ``('a', 'b c', 'd')``."""
    parts = re.findall(_BARE_OR_QUOTED, key)
    return tuple(p[1:-1] if p[:1] in "\"'" else p for p in parts)


@dataclasses.dataclass
class _Section:
    """A table of the file: its header path, array-of-tables index, lines and keys."""

    path: tuple[str, ...]
    index: int | None  # n for the n-th [[path]] header, None for a [path] table or the root
    line: int | None  # the header's line (None for the root)
    end: int  # last line of the section
    keys: dict[str, int]  # dotted key -> line where it is set


class _LineIndex:
    """Best-effort map from a file key (``"particles[1].position[0]"``) to its line.

    The text is scanned line by line for table headers and ``key =`` lines, skipping the
    inside of multi-line arrays, inline tables and strings.
    """

    def __init__(self, text: str):
        self.lines = text.splitlines()
        self.sections: list[_Section] = [_Section((), None, None, len(self.lines), {})]
        counts: dict[tuple[str, ...], int] = {}
        depth, multiline = 0, None
        for number, line in enumerate(self.lines, start=1):
            if depth == 0 and multiline is None:
                header = _HEADER_LINE.match(line)
                if header:
                    path = _split_dotted(header.group(2))
                    index = None
                    if header.group(1) == "[[":
                        index = counts.get(path, 0)
                        counts[path] = index + 1
                    self.sections[-1].end = number - 1
                    self.sections.append(_Section(path, index, number, len(self.lines), {}))
                    continue
                key = _KEY_LINE.match(line)
                if key:
                    self.sections[-1].keys.setdefault(".".join(_split_dotted(key.group(1))), number)
            depth, multiline = _scan(line, depth, multiline)

    def find(self, key: str | None) -> int | None:
        """The line of `key` (or of its table when the key itself is absent), or None."""
        if not key:
            return None
        parts: list[tuple[str, int | None]] = []
        for name, index in _KEY_PART.findall(key):
            if name:
                parts.append((name.strip(), None))
            elif parts:
                parts[-1] = (parts[-1][0], int(index))
        names = [name for name, _ in parts]
        for k in range(len(parts), -1, -1):
            section = self._section(parts[:k])
            if section is not None:
                return self._in_section(section, names[k:])
        return None

    def _section(self, parts: Sequence[tuple[str, int | None]]) -> _Section | None:
        path = tuple(name for name, _ in parts)
        index = parts[-1][1] if parts else None
        for section in self.sections:
            if section.path != path:
                continue
            if section.index is None or section.index == (index or 0):
                return section
        return None

    def _in_section(self, section: _Section, names: Sequence[str]) -> int | None:
        if not names:
            return section.line
        for j in range(len(names), 0, -1):
            line = section.keys.get(".".join(names[:j]))
            if line is not None:
                break
        else:
            return section.line
        for name in names[j:]:
            pattern = re.compile(rf"""(?:^|[\s{{,.])["']?{re.escape(name)}["']?\s*=""")
            for number in range(line, section.end + 1):
                if pattern.search(self.lines[number - 1]):
                    line = number
                    break
            else:
                break
        return line


def _scan(line: str, depth: int, multiline: str | None) -> tuple[int, str | None]:
    """Bracket depth and open multi-line string after `line`, skipping strings and comments."""
    i, n = 0, len(line)
    while i < n:
        if multiline is not None:
            end = line.find(multiline, i)
            if end < 0:
                return depth, multiline
            i, multiline = end + 3, None
            continue
        c = line[i]
        if c == "#":
            break
        if line.startswith('"""', i) or line.startswith("'''", i):
            multiline = line[i:i + 3]
            i += 3
        elif c == '"':
            i += 1
            while i < n and line[i] != '"':
                i += 2 if line[i] == "\\" else 1
            i += 1
        elif c == "'":
            end = line.find("'", i + 1)
            i = n if end < 0 else end + 1
        else:
            if c in "[{":
                depth += 1
            elif c in "]}":
                depth = max(0, depth - 1)
            i += 1
    return depth, multiline


# --------------------------------------------------------------------------- helpers

def _describe(value: object) -> str:
    """A value as a reader sees it: "the string '2'", "a list of 3 items", "a table"."""
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        shown = value if len(value) <= 60 else value[:57] + "..."
        return f"the string {shown!r}"
    if isinstance(value, list):
        return f"a list of {len(value)} item{'s' if len(value) != 1 else ''}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, (datetime.date, datetime.time)):
        return f"the date/time {value.isoformat()}"
    return f"a {type(value).__name__}"  # pragma: no cover - tomllib gives nothing else


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _toml_number(text: str) -> str | None:
    """`text` written as a TOML number when it reads as one ("2" -> "2"), else None."""
    try:
        value = float(text.strip())
    except ValueError:
        return None
    if not math.isfinite(value):
        return None
    stripped = text.strip()
    return stripped if re.fullmatch(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", stripped) else repr(value)


def _with_suggestions(exc: UnknownNameError, names: Mapping[str, object]) -> str:
    """The reason of `exc`, with a looser 'did you mean' for names it has none for.

    The parser's cutoff misses one-letter slips in short names (``q3`` for ``q2``).
    """
    candidates = [n for n in names if n != "t"]
    unknown = [(name, position, suggestion or closest(name, candidates, 0.5))
               for name, position, suggestion in exc.unknown]
    return UnknownNameError(exc.text, unknown).reason


def _caret(text: str, position: int | None) -> str:
    """The expression with a caret under `position`, on indented lines (single-line text only)."""
    if position is None or "\n" in text or len(text) > 200:
        return ""
    return f"\n    {text}\n    {' ' * position}^"


@dataclasses.dataclass
class _Entry:
    """One element table of the file: kind, index, table, name and what was built."""

    kind: str
    index: int
    table: dict[str, Any]
    name: str | None = None
    dimension: int | None = None  # number of position components, when known
    ok: bool = True  # False once a problem was found: nothing refers to it silently
    element: Element | None = None

    @property
    def key(self) -> str:
        return f"{self.kind}[{self.index}]"


# --------------------------------------------------------------------------- the reader

class _Reader:
    """Checks a parsed model file in one pass, collecting problems, and builds the Model."""

    def __init__(self, text: str, *, source: str, default_name: str):
        self.text = text
        self.source = source
        self.default_name = default_name
        self.problems: list[Problem] = []
        self.lines = _LineIndex(text)
        self.model = Model(default_name)
        self.names: dict[str, sympy.Symbol] = {}
        self.entries: dict[str, _Entry] = {}  # element name -> entry
        self.key_map: dict[str, tuple[str, dict[str, str]]] = {}  # Model.check prefix -> file

    # -- collecting problems ------------------------------------------------------------
    def problem(self, key: str | None, message: str) -> None:
        self.problems.append(Problem(message, key=key, line=self.lines.find(key)))

    def model_error(self, key: str, exc: ModelError) -> None:
        """Record the problems of a ModelError raised by a Model method, under file key `key`."""
        for p in exc.problems:
            self.problem(self.translate(p.key) if p.key else key, p.message)

    def raise_if_problems(self) -> None:
        """Raise one ModelFileError with every problem, in the order of the file's lines."""
        if self.problems:
            ordered = sorted(self.problems, key=lambda p: math.inf if p.line is None else p.line)
            raise ModelFileError(ordered, file=self.source)

    # -- the whole file -----------------------------------------------------------------
    def read(self) -> Model:
        try:
            data = tomllib.loads(self.text)
        except tomllib.TOMLDecodeError as exc:
            self.toml_error(exc)
        except RecursionError:
            self.problems.append(Problem(
                "invalid TOML: arrays or tables nested too deeply for the reader (hundreds of levels of [ ] or "
                "{ }); a model file needs at most a few levels: a list of lists such as rotation = "
                '[["z", "phi"]] is the deepest', line=_deepest_line(self.text)))
        except ValueError as exc:  # tomllib's int() of an integer with more digits than Python converts
            too_long = "digits" in str(exc)
            self.problems.append(Problem(
                f"invalid TOML: an integer too long to read ({exc}); a model's numbers are floating-point "
                "numbers, at most about 1.8e308: write it with an exponent, such as 1.5e20" if too_long else
                f"invalid TOML: {exc}", line=_longest_digits_line(self.text) if too_long else None))
        if self.problems:
            self.raise_if_problems()
            raise AssertionError("unreachable")  # pragma: no cover
        for key in data:
            if key not in _TOP_LEVEL:
                self.unknown_top_level(key, data[key])
        self.read_header(data)
        self.read_symbols(data)
        declare_joint_coordinates(self, data.get("joints"))
        self.names = {**self.model.names(accelerations=True), **self.model.derived_parameters}
        self.frame_keys: dict[str, str] = {}  # frame name -> its file key ("frames[0]")
        self.read_frames(data.get("frames"), data.get("joints"))  # and the [[joints]] tables, parents first
        self.read_elements(data)
        # [energy] and [forces] after the elements: they may use "<point>.x" (a point's position component)
        self.names = {**self.names, **self.model._point_components()}
        self.read_energy(data.get("energy"))
        self.read_forces(data.get("forces"))
        self.read_constraints(data.get("constraints"))
        self.read_wheels(data.get("wheels"))
        self.read_outputs(data.get("outputs"))
        self.read_simulation(data.get("simulation"))
        self.read_operating_point(data.get("operating_point"))
        self.read_optimal_control(data.get("optimal_control"))
        self.check_model()
        self.raise_if_problems()
        return self.model

    def toml_error(self, exc: tomllib.TOMLDecodeError) -> None:
        message = str(exc)
        line: int | None = None
        where = ""
        match = re.search(r"\s*\(at line (\d+), column (\d+)\)\s*$", message)
        if match:
            line = int(match.group(1))
            where = f" at column {match.group(2)}"
            message = message[:match.start()]
        elif message.endswith("(at end of document)"):
            line = max(1, len(self.lines.lines))
            where = " at the end of the file"
            message = message[:-len("(at end of document)")].rstrip()
        self.problems.append(Problem(
            f"invalid TOML{where}: {message}. Fix the syntax there: keys are written key = value, "
            'expressions are strings in quotes (T = "1/2*m*x_dot**2"), lists are in [ ] and '
            "tables start with a [name] or [[name]] header", line=line))

    def unknown_top_level(self, key: str, value: object) -> None:
        if key in _ENERGY_KEYS:
            hint = f"; put {key} under an [energy] table"
        elif key in _SIMULATION_KEYS:
            hint = f"; put {key} under a [simulation] table"
        elif any(key in req + opt for req, opt in _ELEMENT_KEYS.values()) or key in _GRAVITY_KEYS:
            hint = (f"; '{key}' belongs inside an element table: write it after its [[particles]], "
                    "[[bodies]], [[springs]], ... header")
        else:
            hint = did_you_mean(key, _TOP_LEVEL)
        is_table = isinstance(value, dict) or (
            isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value))
        what = "table" if is_table else "key"
        self.problem(key, f"unknown top-level {what} '{key}'{hint}. The known ones are: "
                          + ", ".join(_TOP_LEVEL))

    def unknown_key(self, key: str, name: str, allowed: Sequence[str], table: str) -> None:
        """A key that does not belong in `table`."""
        if name in _TOP_LEVEL and name not in allowed:
            hint = (f"; '{name}' is a top-level key: in TOML every key after a {table} header "
                    "belongs to that table, so move it before the first [table] header")
        else:
            hint = did_you_mean(name, allowed)
        self.problem(key, f"unknown key '{name}' in {table}{hint}; the keys of {table} are: "
                          + ", ".join(allowed))

    # -- name, description ---------------------------------------------------------------
    def read_header(self, data: Mapping[str, Any]) -> None:
        name = data.get("name", self.default_name)
        if not isinstance(name, str) or not name.strip():
            self.problem("name", f"expected the model's name, a non-empty string, got "
                                 f"{_describe(name)}; write name = \"my-model\", or leave it out "
                                 "to use the file name")
        else:
            self.model.name = name
        description = data.get("description", "")
        if not isinstance(description, str):
            self.problem("description", f"expected a string, got {_describe(description)}; "
                                        'write description = "..."')
        else:
            self.model.description = description

    # -- coordinates, inputs, parameters ----------------------------------------------------
    def read_symbols(self, data: Mapping[str, Any]) -> None:
        if "coordinates" not in data and "joints" not in data:
            self.problem("coordinates", "missing required key 'coordinates': list the generalized "
                                        'coordinates at the top of the file, e.g. coordinates = ["q1", "q2"]')
        elif "coordinates" in data:
            names = self.name_list(data["coordinates"], "coordinates", "q1")
            if names is not None and not names:
                self.problem("coordinates", "the list of coordinates is empty: a model needs at "
                                            'least one, e.g. coordinates = ["x"]')
            for i, name in enumerate(names or ()):
                self.declare(f"coordinates[{i}]", self.model.coordinate, name)
        if "inputs" in data:
            for i, name in enumerate(self.name_list(data["inputs"], "inputs", "F") or ()):
                self.declare(f"inputs[{i}]", self.model.input, name)
        parameters = data.get("parameters")
        if parameters is None:
            return
        if not isinstance(parameters, dict):
            self.problem("parameters", f"expected a table of name = number, got {_describe(parameters)}; "
                                       "write a [parameters] header followed by lines such as m = 1.5")
            return
        derived: dict[str, str] = {}  # name = "expression of other parameters"
        for name, value in parameters.items():
            key = f"parameters.{name}"
            if name in _TOP_LEVEL and not _is_number(value):
                self.problem(key, f"'{name}' is a top-level key, not a parameter: in TOML every key "
                                  "after the [parameters] header belongs to that table, so move it "
                                  "before the first [table] header")
                continue
            if isinstance(value, str) and _toml_number(value) is None:
                derived[name] = value
                continue
            number = self.number(value, key, name, what="parameter value")
            # declared even without a valid value, so that expressions using it still parse
            self.declare(key, self.model.parameter, name, number)
        self.derived_parameters(derived)

    def derived_parameters(self, derived: Mapping[str, str]) -> None:
        """Parameters given as expressions of the others, declared in dependency order (a cycle is a problem)."""
        if not derived:
            return
        known = {p.name: None for p in self.model.parameters}
        try:
            order = [n for n in derived_order({**known, **derived}) if n in derived]
        except ModelError as exc:
            self.model_error("parameters", exc)
            order = []
        for name in order:
            self.declare(f"parameters.{name}", self.model.parameter, name, derived[name])
        for name in derived:  # one that failed is declared without a value, so that the expressions
            if name not in self.model.derived_parameters and not any(p.name == name for p in self.model.parameters):
                try:  # using it still parse (one problem, at its own key, not one per use)
                    self.model.parameter(name, None)
                except ModelError:
                    pass

    def name_list(self, value: object, key: str, example: str) -> list[str] | None:
        """A list of names (coordinates, inputs), or None after recording a problem."""
        if isinstance(value, str):
            self.problem(key, f"expected a list of names, got {_describe(value)}; write "
                              f"{key} = [\"{value}\"] (square brackets, each name in quotes)")
            return None
        if not isinstance(value, list):
            self.problem(key, f"expected a list of names, got {_describe(value)}; write "
                              f"{key} = [\"{example}\"] (each name in quotes)")
            return None
        names = []
        for i, item in enumerate(value):
            if isinstance(item, str):
                names.append(item)
            else:
                self.problem(f"{key}[{i}]", f"expected a name in quotes, got {_describe(item)}; "
                                            f"write it as \"{item}\" if it is a name")
        return names

    def declare(self, key: str, method: Any, *args: Any) -> None:
        """Call a Model method declaring a symbol; its ModelError becomes a problem at `key`."""
        try:
            method(*args)
        except ModelError as exc:
            self.model_error(key, exc)

    def number(self, value: object, key: str, name: str, *, minimum: float | None = None,
               strict: bool = True, what: str = "value") -> float | None:
        """A finite number (int or float), or None after recording a problem.

        `minimum` with `strict` requires value > minimum, without it value >= minimum.
        """
        if not _is_number(value):
            if isinstance(value, str):
                written = _toml_number(value)
                fix = (f"; write {name} = {written} (a number, without quotes)" if written
                       else f"; a {what} is a plain number such as {name} = 1.5, not an expression "
                            "or a name")
            elif isinstance(value, bool):
                fix = f"; write a number such as {name} = {int(value)}"
            else:
                fix = f"; write a number such as {name} = 1.5"
            self.problem(key, f"expected a number, got {_describe(value)}{fix}")
            return None
        try:
            number = float(value)  # type: ignore[arg-type]
        except OverflowError:  # an integer beyond the doubles
            number = math.inf
        if not math.isfinite(number):
            self.problem(key, f"expected a finite number, got {_shown_number(value)}; write a number such as "
                              f"{name} = 1.5 (at most about 1.8e308)")
            return None
        if minimum is not None and (number <= minimum if strict else number < minimum):
            bound = f"greater than {minimum:g}" if strict else f"at least {minimum:g}"
            self.problem(key, f"{name} = {value!r}, but it must be {bound}; give a {what} "
                              f"{bound}")
            return None
        return number

    # -- expressions -----------------------------------------------------------------------
    def expr(self, value: object, key: str, names: Mapping[str, sympy.Basic] | None = None,
             *, context: str = "model") -> sympy.Expr | None:
        """Parse one expression (a string or a number), or return None after recording a problem."""
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            self.problem(key, f"expected an expression (a string such as \"m*g\") or a number, "
                              f"got {_describe(value)}")
            return None
        if not isinstance(value, str):
            if (abs(value) > _LARGEST_FLOAT) if isinstance(value, int) else not math.isfinite(value):
                self.problem(key, f"expected a finite number, got {_shown_number(value)}; the largest a "
                                  "simulation can compute is about 1.8e308")
                return None
            if isinstance(value, int):
                return sympy.Integer(value)
            return sympy.Rational(repr(value))
        try:
            return parse_expression(value, self.names if names is None else names,
                                    feedback=context == "signal")
        except UnknownNameError as exc:
            if context == "model":
                fix = ("every name must be a coordinate, a velocity (<coordinate>_dot), an input, "
                       "t, or a parameter: fix the spelling, or declare "
                       + ("it" if len(exc.unknown) == 1 else "them")
                       + f" under [parameters] with a value ({exc.unknown[0][0]} = 1.0), or in "
                       "coordinates = [...] or inputs = [...]")
            else:
                fix = ("an input may use t, the coordinates, velocities (<coordinate>_dot) and "
                       "parameters: fix the spelling, or declare it under [parameters] with a value "
                       f"({exc.unknown[0][0]} = 1.0)")
            where = f" at position {exc.position + 1}" if exc.position is not None else ""
            reason = _with_suggestions(exc, self.names if names is None else names)
            self.problem(key, f"{reason} in the expression{where}; {fix}"
                              + _caret(value, exc.position))
        except ExpressionError as exc:
            where = f" at position {exc.position + 1}" if exc.position is not None else ""
            self.problem(key, f"malformed expression{where}: {exc.reason}"
                              + _caret(value, exc.position))
        except (TypeError, ValueError, ArithmeticError, RecursionError) as exc:  # defensive
            self.problem(key, f"the expression {value!r} cannot be read ({exc}); write a formula "
                              "such as \"m*g*l*cos(theta)\"")
        return None

    def vector(self, value: object, key: str, what: str = "position") -> tuple[sympy.Expr, ...] | None:
        """A list of 2 or 3 expressions, or None after recording a problem."""
        if not isinstance(value, list):
            self.problem(key, f"expected a {what}: a list of 2 or 3 expressions such as "
                              f"[\"x\", \"0\"], got {_describe(value)}")
            return None
        if len(value) not in (2, 3):
            self.problem(key, f"expected a {what} with 2 components (x, y) or 3 (x, y, z), got "
                              f"{len(value)}; write it as [\"x\", \"y\"] or [\"x\", \"y\", \"z\"]")
            for i, item in enumerate(value):  # still report what is wrong inside
                self.expr(item, f"{key}[{i}]")
            return None
        out = [self.expr(item, f"{key}[{i}]") for i, item in enumerate(value)]
        return None if any(e is None for e in out) else tuple(out)  # type: ignore[misc]

    # -- [energy], [forces] -------------------------------------------------------------------
    def table(self, value: object, key: str, example: str) -> dict[str, Any] | None:
        if value is None:
            return None
        if not isinstance(value, dict):
            self.problem(key, f"expected a table [{key}], got {_describe(value)}; write a [{key}] "
                              f"header followed by lines such as {example}")
            return None
        return value

    def read_energy(self, value: object) -> None:
        table = self.table(value, "energy", 'T = "1/2*m*x_dot**2"')
        if table is None:
            return
        for name, item in table.items():
            key = f"energy.{name}"
            if name not in _ENERGY_KEYS:
                self.unknown_key(key, name, _ENERGY_KEYS, "[energy]")
                continue
            e = self.expr(item, key)
            if e is not None:
                try:
                    self.model.add_energy(**{name: e})
                except ModelError as exc:
                    self.model_error(key, exc)

    def read_outputs(self, value: object) -> None:
        """[outputs]: name = expression of the state, t, inputs and parameters, or "<point>.x"."""
        table = self.table(value, "outputs", 'tip_x = "l1*sin(th1) + l2*sin(th2)"')
        if table is None:
            return
        for name, item in table.items():
            key = f"outputs.{name}"
            try:
                if self.model._point_component(item, key) is None:
                    item = self.expr(item, key)
                    if item is None:
                        continue
                self.model.add_output(name, item)
            except ModelError as exc:
                self.model_error(key, exc)

    def read_forces(self, value: object) -> None:
        table = self.table(value, "forces", 'q1 = "F"')
        if table is None:
            return
        coordinates = [c.name for c in self.model.q]
        for name, item in table.items():
            key = f"forces.{name}"
            e = self.expr(item, key)
            if name not in coordinates:
                listed = ", ".join(coordinates) if coordinates else "(none declared)"
                self.problem(key, f"'{name}' is not a coordinate{did_you_mean(name, coordinates, 0.5)}: "
                                  "[forces] gives generalized forces by coordinate name; use one of "
                                  f"{listed}, or add {name} to coordinates")
                continue
            if e is not None:
                try:
                    self.model.add_generalized_force(name, e)
                except ModelError as exc:
                    self.model_error(key, exc)

    # -- frames ---------------------------------------------------------------------------------
    def read_frames(self, value: object, joints: object = None) -> None:
        """[[frames]] and [[joints]] tables: checked, then built parents first, whatever their order in the file
        (a frame may hang from a joint's child frame, a joint from a frame); a cycle of parents is reported."""
        from ..model._frames import WORLD

        tables = self.element_tables("frames", value)
        joint_entries = self.element_tables("joints", joints)
        named: dict[str, _Entry] = {}
        self.frame_names = dict.fromkeys(t.table.get("name") for t in tables if isinstance(t.table.get("name"), str))
        children = {joint_child(j.table): j for j in joint_entries if joint_child(j.table) is not None}
        for entry in tables:
            key = entry.key
            for name in entry.table:
                if name not in _FRAME_KEYS:
                    self.unknown_key(f"{key}.{name}", name, _FRAME_KEYS, "[[frames]]")
            name = entry.table.get("name")
            if not isinstance(name, str) or not name.isidentifier():
                self.problem(f"{key}.name", "a frame needs a name, an identifier such as name = \"body\""
                             + ("" if "name" not in entry.table else f", got {_describe(name)}"))
                continue
            if name == WORLD or name in named:
                self.problem(f"{key}.name", f"the name '{name}' is taken ("
                             + ("the inertial frame" if name == WORLD else f"by {named[name].key}")
                             + "): give each frame its own name")
                continue
            entry.name = name
            named[name] = entry
        # parents first; a parent that is unknown or in a cycle stops its children. A joint waits only for a
        # parent that another table creates (an unknown parent is reported by Model.add_joint).
        built: set[str] = {WORLD}
        pending = list(named.values())
        waiting = list(joint_entries)
        failed: set[str] = set()  # the child frames of joints that could not be built
        while pending or waiting:
            progress = [e for e in pending if _parent_name(e.table) in built]
            for entry in progress:
                self.build_frame(entry)
                built.add(entry.name)
            pending = [e for e in pending if e not in progress]
            ready = [j for j in waiting if not (isinstance(j.table.get("parent"), str)
                                                and j.table["parent"] not in built
                                                and (j.table["parent"] in named or j.table["parent"] in children))]
            for entry in ready:
                child = joint_child(entry.table)
                if build_joint(self, entry):
                    built.add(child)
                elif child is not None:
                    failed.add(child)
            waiting = [j for j in waiting if j not in ready]
            if progress or ready:
                continue
            stuck = [e for e in pending if _parent_name(e.table) not in failed]
            self.report_parents(named, stuck, children)
            reported: set[str] = set()
            for entry in waiting:  # in a cycle, or below one, or below a joint with problems
                self.report_joint_parent(entry, named, children, reported)
                build_joint(self, entry, parent=WORLD)  # a stand-in parent: its own keys are checked in this run
            break
        # the frames below an unknown parent or in a cycle: built under "world" as well, so that their own keys
        # and the elements placed in them are checked in this same run (the problems above keep the model out)
        for entry in pending:
            parent = _parent_name(entry.table)
            self.build_frame(entry, parent=parent if parent in self.frame_keys else WORLD)

    def report_parents(self, named: Mapping[str, _Entry], pending: list[_Entry],
                       children: Mapping[str, _Entry] | None = None) -> None:
        """The problem of each frame whose parent is not a built frame: unknown, not a name, or a cycle (through
        frames and the child frames of joints, `children`)."""
        from ..model._frames import WORLD

        children = children or {}
        in_reported_cycle: set[str] = set()
        for entry in pending:
            parent = entry.table.get("parent", WORLD)
            if not isinstance(parent, str):
                self.problem(f"{entry.key}.parent", f"expected a frame's name, got {_describe(parent)}; "
                                                    "write parent = \"world\" or the name of a [[frames]] table")
            elif parent not in named and parent not in children:
                self.problem(f"{entry.key}.parent", f"no frame is named '{parent}'"
                             f"{did_you_mean(parent, [WORLD, *named, *children])}; use \"world\" (the inertial "
                             "frame) or the name of a [[frames]] table" + (" or of a joint's child frame" if children
                                                                          else ""))
            elif _cycle(named, entry.name, children) and entry.name not in in_reported_cycle:
                loop = _cycle(named, entry.name, children)
                in_reported_cycle.update(loop)
                self.problem(f"{entry.key}.parent", f"the frames {', '.join(loop[:-1])} form a cycle of "
                             f"parents ({' -> '.join(loop)}): every frame must hang, through its parents, "
                             "from \"world\"")

    def report_joint_parent(self, entry: _Entry, named: Mapping[str, _Entry], children: Mapping[str, _Entry],
                            reported: set[str]) -> None:
        """The problem of a joint whose parent frame is never built, when it is in a cycle of joints' frames only
        (once per cycle; a cycle through a [[frames]] table is reported under that table, and a joint below a
        cycle or below a table with problems has nothing to add)."""
        child = joint_child(entry.table)
        loop = _cycle(named, child, children) if child is not None else None
        if loop is None or child in reported or any(n in named for n in loop):
            return
        reported.update(loop)
        self.problem(f"{entry.key}.parent", f"the frames {', '.join(loop[:-1])} form a cycle of parents "
                     f"({' -> '.join(loop)}): every frame must hang, through its parents, from \"world\"")

    def build_frame(self, entry: _Entry, parent: str | None = None) -> None:
        """Add the frame of `entry` (under `parent`, default its own). A frame with problems in its origin or
        rotation is still added, provisionally (origin 0, the rotations that could be read), as is one built
        under "world" in place of an unknown parent: the elements placed in it are then checked in the same
        run, and the problems recorded keep the model from being returned."""
        key, table = entry.key, entry.table
        before = len(self.problems)
        origin = self.vector(table["origin"], f"{key}.origin") if "origin" in table else (0, 0, 0)
        if origin is not None and len(origin) != 3:
            self.problem(f"{key}.origin", f"a frame's origin has 3 components (x, y, z), got {len(origin)}")
            origin = None
        rotation = None
        if "rotation" in table and "matrix" in table:
            self.problem(f"{key}.matrix", "give the rotation either as rotation = [[axis, angle], ...] or as "
                                          "matrix = [[...], [...], [...]], not both: remove one of them")
        elif "rotation" in table:
            rotation = self.rotation_steps(table["rotation"], f"{key}.rotation")
        elif "matrix" in table:
            rotation = self.matrix3(table["matrix"], f"{key}.matrix", "rotation matrix")
        if len(self.problems) > before:
            origin = origin if origin is not None else (0, 0, 0)
            rotation = rotation or None
        try:
            self.model.add_frame(entry.name, parent=table.get("parent", "world") if parent is None else parent,
                                 origin=origin, rotation=rotation)
        except ModelError as exc:
            self.model_error(key, exc)
            return
        self.frame_keys[entry.name] = key
        self.key_map[f"frame '{entry.name}'"] = (key, {"rotation": "matrix"})

    def rotation_steps(self, value: object, key: str) -> list | None:
        example = 'rotation = [["z", "phi"], ["x", "theta"]]'
        if not isinstance(value, list) or not value:
            self.problem(key, f"expected a list of [axis, angle] pairs, got {_describe(value)}; write {example}")
            return None
        steps = []
        for i, step in enumerate(value):  # every step checked: each bad one is a problem of its own
            k = f"{key}[{i}]"
            if not isinstance(step, list) or len(step) != 2:
                self.problem(k, f"expected [axis, angle] such as [\"z\", \"phi\"], got {_describe(step)}")
                continue
            axis, angle = step
            good = True
            if isinstance(axis, str):
                if axis not in ("x", "y", "z"):
                    self.problem(f"{k}[0]", f"'{axis}' is not an axis: use \"x\", \"y\", \"z\" or a list of 3 "
                                            "numbers such as [1, 1, 0]")
                    good = False
            elif isinstance(axis, list) and len(axis) == 3 and all(_is_number(a) for a in axis):
                if not any(axis):
                    self.problem(f"{k}[0]", "the zero vector is not an axis; give its direction, e.g. [0, 0, 1]")
                    good = False
            else:
                self.problem(f"{k}[0]", f"expected an axis: \"x\", \"y\", \"z\" or a list of 3 numbers, got "
                                        f"{_describe(axis)}")
                good = False
            e = self.expr(angle, f"{k}[1]")
            if good and e is not None:
                steps.append((axis, e))
        return steps if len(steps) == len(value) else steps or None

    def matrix3(self, value: object, key: str, what: str) -> list | None:
        if not (isinstance(value, list) and len(value) == 3
                and all(isinstance(r, list) and len(r) == 3 for r in value)):
            self.problem(key, f"expected a {what}: 3 rows of 3 expressions, [[\"1\", \"0\", \"0\"], "
                              f"[\"0\", \"1\", \"0\"], [\"0\", \"0\", \"1\"]], got {_describe(value)}")
            return None
        rows = [[self.expr(x, f"{key}[{i}][{j}]") for j, x in enumerate(r)] for i, r in enumerate(value)]
        return None if any(x is None for r in rows for x in r) else rows

    def frame_of(self, entry: _Entry, name: str = "frame", stand_in: bool = False) -> str | None:
        """The frame an element names (None after a problem, or when its frame had problems). With `stand_in`,
        an unknown frame is reported and "world" returned in its place, so that the element's other keys are
        still checked in this run (the problem keeps the model from being returned)."""
        from ..model._frames import WORLD

        value = entry.table[name]
        if isinstance(value, str) and (value == WORLD or value in self.frame_keys):
            return value
        if isinstance(value, str) and self.model_has_frame_problem(value):
            entry.ok = False
            return None
        known = [WORLD, *(f for f in self.frame_names if f.isidentifier() and f != WORLD)]  # problems or not
        self.problem(f"{entry.key}.{name}", (f"no frame is named '{value}'{did_you_mean(value, known)}"
                                             if isinstance(value, str) else f"expected a frame's name, got "
                                             f"{_describe(value)}")
                     + f"; the frames are {', '.join(known)} (add a [[frames]] table with this name)")
        if stand_in:
            return WORLD
        entry.ok = False
        return None

    def model_has_frame_problem(self, name: str) -> bool:
        """Whether `name` is a [[frames]] table that was not built because of its own problems."""
        return (any(p.key and p.key.startswith(("frames[", "joints[")) for p in self.problems)
                and name in self.frame_names)

    # -- elements -------------------------------------------------------------------------------
    def read_elements(self, data: Mapping[str, Any]) -> None:
        entries: list[_Entry] = []
        for kind in _ELEMENT_ORDER:
            entries.extend(self.element_tables(kind, data.get(kind)))
        self.name_elements(entries)
        for entry in entries:
            if entry.kind == "loads":
                continue
            build = getattr(self, f"build_{entry.kind}")
            try:
                build(entry)
            except ModelError as exc:
                entry.ok = False
                self.model_error(entry.key, exc)
        self.read_gravity(data.get("gravity"))
        for entry in entries:
            if entry.kind == "loads":
                try:
                    self.build_loads(entry)
                except ModelError as exc:
                    self.model_error(entry.key, exc)

    def element_tables(self, kind: str, value: object) -> list[_Entry]:
        if value is None:
            return []
        if not isinstance(value, list):
            self.problem(kind, f"expected [[{kind}]] tables (an array of tables, with double "
                               f"brackets), got {_describe(value)}; write each {_SINGULAR[kind]} "
                               f"under its own [[{kind}]] header")
            return []
        entries = []
        for i, item in enumerate(value):
            if isinstance(item, dict):
                entries.append(_Entry(kind, i, item))
            else:
                self.problem(f"{kind}[{i}]", f"expected a table describing a {_SINGULAR[kind]}, got "
                                             f"{_describe(item)}; write it under a [[{kind}]] header")
        return entries

    def name_elements(self, entries: list[_Entry]) -> None:
        """Check explicit names (unique across all elements) and give the others default names."""
        for entry in entries:
            if "name" not in entry.table:
                continue
            name = entry.table["name"]
            key = f"{entry.key}.name"
            if not isinstance(name, str) or not name.strip():
                self.problem(key, f"expected a non-empty string, got {_describe(name)}; write "
                                  f"name = \"my_{_DEFAULT_PREFIX.get(entry.kind, 'load')}\", or leave it out")
                entry.ok = False
            elif name in self.entries:
                other = self.entries[name]
                self.problem(key, f"the name '{name}' is already used by {other.key}: give each "
                                  "element its own name")
                entry.ok = False
            else:
                entry.name = name
                self.entries[name] = entry
        counters: dict[str, int] = {}
        for entry in entries:
            if entry.name is not None:
                continue
            if entry.kind == "loads":
                prefix = "torque" if "torque" in entry.table and "force" not in entry.table else "force"
            else:
                prefix = _DEFAULT_PREFIX[entry.kind]
            i = counters.get(prefix, 0) + 1
            while f"{prefix}{i}" in self.entries:
                i += 1
            counters[prefix] = i
            entry.name = f"{prefix}{i}"
            if entry.ok:
                self.entries[entry.name] = entry

    def check_keys(self, entry: _Entry, required: Sequence[str] | None = None,
                   keys: tuple[tuple[str, ...], tuple[str, ...]] | None = None) -> bool:
        """Unknown and missing keys of an element table; False when a required key is missing."""
        req, opt = keys or _ELEMENT_KEYS[entry.kind]
        required = req if required is None else required
        allowed = req + opt
        for name in entry.table:
            if name not in allowed:
                self.unknown_key(f"{entry.key}.{name}", name, allowed, f"[[{entry.kind}]]")
        complete = True
        for name in required:
            if name not in entry.table:
                complete = False
                entry.ok = False
                self.problem(f"{entry.key}.{name}", f"missing required key '{name}' in this "
                                                    f"[[{entry.kind}]] table (the {_SINGULAR[entry.kind]} "
                                                    f"'{entry.name}'); add {_EXAMPLES[name]}")
        return complete

    def nonnegative(self, e: sympy.Expr | None, key: str, what: str) -> sympy.Expr | None:
        """`e`, or None after a problem when it is a negative number."""
        if e is not None and e.is_number and e.is_real and e.is_negative:
            self.problem(key, f"the {what} is negative ({float(e):g}): a {what} must be zero or "
                              "positive; check the sign")
            return None
        return e

    def field(self, entry: _Entry, name: str, what: str | None = None) -> sympy.Expr | None:
        """The expression `name` of an element (None if absent or invalid)."""
        if name not in entry.table:
            return None
        e = self.expr(entry.table[name], f"{entry.key}.{name}")
        if what is not None:
            e = self.nonnegative(e, f"{entry.key}.{name}", what)
        if e is None:
            entry.ok = False
        return e

    def position(self, entry: _Entry, name: str = "position") -> tuple[sympy.Expr, ...] | None:
        if name not in entry.table:
            return None
        value = entry.table[name]
        if isinstance(value, list) and len(value) in (2, 3):
            entry.dimension = len(value)
        v = self.vector(value, f"{entry.key}.{name}")
        if v is None:
            entry.ok = False
        return v

    def record(self, entry: _Entry, element: Element, fields: Mapping[str, str] | None = None) -> None:
        """Remember where an element comes from, to translate Model.check keys."""
        entry.element = element
        self.key_map[f"{element.kind} '{element.name}'"] = (entry.key, dict(fields or {}))

    def placed(self, entry: _Entry) -> str | None:
        """The frame of a point or particle given in one (its position then has 3 components)."""
        if "frame" not in entry.table:
            return None
        frame = self.frame_of(entry)
        if frame is not None and entry.dimension not in (None, 3):
            self.problem(f"{entry.key}.position", f"a position in the frame '{frame}' has 3 components "
                                                  f"(x, y, z), got {entry.dimension}")
            entry.ok = False
        entry.dimension = 3
        return frame

    def build_points(self, entry: _Entry) -> None:
        complete = self.check_keys(entry)
        position = self.position(entry)
        frame = self.placed(entry)
        if complete and entry.ok and position is not None:
            self.record(entry, self.model.add_point(entry.name, position, frame=frame))

    def build_particles(self, entry: _Entry) -> None:
        complete = self.check_keys(entry)
        mass = self.field(entry, "mass", "mass")
        position = self.position(entry)
        frame = self.placed(entry)
        if complete and entry.ok and mass is not None and position is not None:
            self.record(entry, self.model.add_particle(mass, position, frame=frame, name=entry.name))

    def build_body_in_space(self, entry: _Entry) -> None:
        for name in ("position", "angle"):
            if name in entry.table:
                self.problem(f"{entry.key}.{name}", f"a body in space (it has a frame) takes its orientation from "
                                                    f"its frame and its centre from center = [...] in the frame's "
                                                    f"axes: remove '{name}'")  # the rest is still checked
        complete = self.check_keys(entry, keys=(_BODY3D_KEYS[0], _BODY3D_KEYS[1] + ("position", "angle")))
        mass = self.field(entry, "mass", "mass")
        inertia = (self.inertia3(entry.table.get("inertia"), f"{entry.key}.inertia")
                   if "inertia" in entry.table else None)
        frame = self.frame_of(entry, stand_in=True) if "frame" in entry.table else None
        center = (0, 0, 0)
        if "center" in entry.table:
            center = self.vector(entry.table["center"], f"{entry.key}.center", "centre of mass")
            if center is not None and len(center) != 3:
                self.problem(f"{entry.key}.center", f"the centre of mass of a body in space has 3 components, "
                                                    f"got {len(center)}")
                center = None
        center_frame = self.frame_of(entry, "center_frame") if "center_frame" in entry.table else None
        shape = self.body_shape(entry)
        entry.dimension = 3
        about = self.inertia_about(entry, 3)
        if complete and entry.ok and None not in (mass, inertia, frame, center) and (
                "center_frame" not in entry.table or center_frame is not None):
            body = self.model.add_rigid_body(mass, inertia, frame=frame, center=center, center_frame=center_frame,
                                             **shape, inertia_about=about, name=entry.name)
            self.record(entry, body, {"position": "center"})

    def body_shape(self, entry: _Entry) -> dict[str, Any]:
        """The shape, radius and axis of a body in space, as keywords of add_rigid_body ({} after a problem)."""
        table = entry.table
        radius = self.expr(table["radius"], f"{entry.key}.radius") if "radius" in table else None
        given = sympy.Integer(1) if radius is None and "radius" in table else radius  # unreadable: reported
        found = shape_problems(table.get("shape"), given, table.get("axis"),
                               set(self.names.values()) - set(self.model.parameters))
        for name, message in found:
            self.problem(f"{entry.key}.{name}", message)
        if found or ("radius" in table and radius is None):
            entry.ok = False
            return {}
        return {"shape": table.get("shape"), "radius": radius, "axis": table.get("axis")}

    def inertia3(self, value: object, key: str):
        """A body's inertia in space: [I1, I2, I3], [xx, yy, zz, xy, yz, zx], {xx = ..., ...} or 3 rows."""
        if isinstance(value, dict):
            allowed = ("xx", "yy", "zz", "xy", "yz", "zx")
            bad = [k for k in value if k not in allowed]
            if bad or not {"xx", "yy", "zz"} <= set(value):
                self.problem(key, "expected the inertia tensor's components xx, yy, zz (required) and xy, yz, zx "
                                  f"(default 0), got {', '.join(map(str, value)) or 'none'}")
                return None
            out = {k: self.expr(v, f"{key}.{k}") for k, v in value.items()}
            return None if any(v is None for v in out.values()) else out
        if isinstance(value, list) and len(value) == 3 and all(isinstance(r, list) for r in value):
            return self.matrix3(value, key, "3x3 inertia tensor")
        if isinstance(value, list) and len(value) in (3, 6):
            out = [self.expr(v, f"{key}[{i}]") for i, v in enumerate(value)]
            return None if any(v is None for v in out) else out
        self.problem(key, "a body in space needs its inertia in body axes: 3 principal moments [\"I1\", \"I2\", "
                          "\"I3\"], the 6 components [xx, yy, zz, xy, yz, zx], a table {xx = ..., yy = ..., "
                          f"zz = ...}} or 3 rows of 3; got {_describe(value)}")
        return None

    def build_bodies(self, entry: _Entry) -> None:
        if "frame" in entry.table or "center" in entry.table:
            self.build_body_in_space(entry)
            return
        complete = self.check_keys(entry)
        mass = self.field(entry, "mass", "mass")
        inertia = self.field(entry, "inertia", "inertia")
        position = self.position(entry)
        angle = self.field(entry, "angle")
        about = self.inertia_about(entry, 2)
        if complete and entry.ok and None not in (mass, inertia, position, angle):
            self.record(entry, self.model.add_rigid_body(mass, inertia, position, angle, inertia_about=about,
                                                         name=entry.name))

    def inertia_about(self, entry: _Entry, dimension: int) -> Any:
        """A body's inertia_about: a point's name or a position list (None when absent; a problem when bad)."""
        if "inertia_about" not in entry.table:
            return None
        key, value = f"{entry.key}.inertia_about", entry.table["inertia_about"]
        where = "in world coordinates [\"x\", \"y\"]" if dimension == 2 else "in the body frame's axes [x, y, z]"
        if isinstance(value, str):
            target = self.entries.get(value)
            if target is None or target.kind not in ("points", "particles"):
                located = [e.name for e in self.entries.values() if e.kind in ("points", "particles")]
                self.problem(key, f"no point is named '{value}'{did_you_mean(value, located)}: the inertia is about "
                                  f"a [[points]] (or [[particles]]) element's position, or a position {where}")
                entry.ok = False
                return None
            if target.element is None:
                entry.ok = False
                return None
            return value
        if not isinstance(value, list) or len(value) != dimension:
            self.problem(key, f"expected a point's name or a position {where} ({dimension} expressions), got "
                              f"{_describe(value)}")
            entry.ok = False
            return None
        out = [self.expr(v, f"{key}[{i}]") for i, v in enumerate(value)]
        if any(v is None for v in out):
            entry.ok = False
            return None
        return out

    def build_springs(self, entry: _Entry) -> None:
        complete = self.check_keys(entry)
        stiffness = self.field(entry, "stiffness", "stiffness")
        rest_length = self.field(entry, "rest_length") if "rest_length" in entry.table else sympy.Integer(0)
        span = self.span(entry)
        acts = entry.table.get("acts", "both")
        if not isinstance(acts, str):
            self.problem(f"{entry.key}.acts", f"expected \"both\", \"compression\" or \"tension\" in quotes, got "
                                              f"{_describe(acts)}")
            entry.ok = False
        if complete and entry.ok and None not in (stiffness, rest_length, span):
            spring = self.model.add_spring(stiffness, name=entry.name, rest_length=rest_length, acts=acts,
                                           **span)  # type: ignore[arg-type]
            self.record(entry, spring, {"length": "between" if "between" in span else "length"})

    def build_dampers(self, entry: _Entry) -> None:
        if "body" in entry.table:
            self.build_rotational_damper(entry)
            return
        complete = self.check_keys(entry)
        coefficient = self.field(entry, "coefficient", "coefficient")
        span = self.span(entry)
        if complete and entry.ok and None not in (coefficient, span):
            damper = self.model.add_damper(coefficient, name=entry.name, **span)  # type: ignore[arg-type]
            self.record(entry, damper, {"length": "between" if "between" in span else "length"})

    def build_rotational_damper(self, entry: _Entry) -> None:
        """A [[dampers]] table with body = "<rigid body>": the torque -c omega on that body."""
        complete = self.check_keys(entry)
        coefficient = self.field(entry, "coefficient", "coefficient")
        key, body = f"{entry.key}.body", entry.table["body"]
        for other in ("between", "length"):
            if other in entry.table:
                self.problem(f"{entry.key}.{other}", f"the damper '{entry.name}' has a body (a rotational damper, "
                                                     f"the torque -c omega on it): remove '{other}', or remove body "
                                                     "for a damper along a length")
                entry.ok = False
        bodies = [e.name for e in self.entries.values() if e.kind == "bodies"]
        if not isinstance(body, str):
            self.problem(key, f"expected the name of a [[bodies]] element in quotes, got {_describe(body)}")
            return
        target = self.entries.get(body)
        if target is None or target.kind != "bodies":
            what = f"'{body}' is a {_SINGULAR[target.kind]} ({target.key}), not a rigid body" if target else (
                f"no rigid body is named '{body}'{did_you_mean(body, bodies)}")
            self.problem(key, f"{what}: a rotational damper acts on a rigid body; use the name of a [[bodies]] "
                              "element")
            return
        if complete and entry.ok and coefficient is not None and target.element is not None:
            self.record(entry, self.model.add_damper(coefficient, body=body, name=entry.name))

    def span(self, entry: _Entry) -> dict[str, Any] | None:
        """``{"between": [...]}`` or ``{"length": expr}`` of a spring or damper, or None."""
        has_between, has_length = "between" in entry.table, "length" in entry.table
        what = _SINGULAR[entry.kind]
        if has_between == has_length:
            entry.ok = False
            if has_between:
                self.problem(f"{entry.key}.length", f"give either between or length for the {what} "
                                                    f"'{entry.name}', not both: remove one of them")
            else:
                self.problem(f"{entry.key}.between", f"the {what} '{entry.name}' needs its ends or its "
                                                     "length: add between = [\"pivot\", \"bob\"] (two "
                                                     "point names or positions) or length = \"q1\"")
            self.field(entry, "length")
            return None
        if has_length:
            length = self.field(entry, "length")
            return None if length is None else {"length": length}
        key = f"{entry.key}.between"
        value = entry.table["between"]
        if not isinstance(value, list) or len(value) != 2:
            count = f"{len(value)} items" if isinstance(value, list) else _describe(value)
            self.problem(key, f"expected two points, got {count}; write between = [\"a\", \"b\"] "
                              "with two point/particle/body names, or two position lists such as "
                              "[[\"0\", \"0\"], [\"x\", \"0\"]]")
            entry.ok = False
            return None
        ends = [self.location(item, f"{key}[{i}]", entry) for i, item in enumerate(value)]
        if any(end is None for end in ends):
            entry.ok = False
            return None
        dims = [d for _, d in ends]  # type: ignore[misc]
        if None not in dims and dims[0] != dims[1]:
            self.problem(key, f"the two ends have {dims[0]} and {dims[1]} components: give two "
                              "points of the same dimension (both planar or both spatial)")
            entry.ok = False
            return None
        (a, _), (b, _) = ends  # type: ignore[misc]
        if (isinstance(a, str) and a == b) or (not isinstance(a, str) and not isinstance(b, str)
                                              and a == b):
            self.problem(key, f"both ends of the {what} '{entry.name}' are the same point, so its "
                              "length is always zero: give two different points")
            entry.ok = False
            return None
        return {"between": [a, b]}

    def location(self, value: object, key: str, entry: _Entry) -> tuple[Any, int | None] | None:
        """A point name or a position list -> (what Model takes, number of components)."""
        if isinstance(value, str):
            target = self.entries.get(value)
            located = [e.name for e in self.entries.values() if e.kind in _LOCATED]
            if target is None:
                self.problem(key, f"no point, particle or body is named '{value}'"
                                  f"{did_you_mean(value, located)}; use the name of a [[points]], "
                                  "[[particles]] or [[bodies]] element, or a position list such as "
                                  "[\"x\", \"0\"]")
                return None
            if target.kind not in _LOCATED:
                self.problem(key, f"'{value}' is a {_SINGULAR[target.kind]} ({target.key}), not a "
                                  "point: use the name of a [[points]], [[particles]] or [[bodies]] "
                                  "element, or a position list")
                return None
            if target.element is None:
                return None  # its own problems are already reported
            return value, target.dimension
        v = self.vector(value, key)
        return None if v is None else (v, len(v))

    def read_gravity(self, value: object) -> None:
        table = self.table(value, "gravity", 'g = "g"')
        if table is None:
            return
        for name in table:
            if name not in _GRAVITY_KEYS:
                self.unknown_key(f"gravity.{name}", name, _GRAVITY_KEYS, "[gravity]")
        if "g" not in table:
            self.problem("gravity.g", "missing required key 'g' in [gravity]: add g = \"g\" "
                                      "(with g = 9.81 under [parameters]) or g = 9.81")
            g = None
        else:
            g = self.expr(table["g"], "gravity.g")
        direction = None
        if "direction" in table:
            direction = self.vector(table["direction"], "gravity.direction", "direction")
            if direction is not None:
                if all(c.is_number and c.is_zero for c in direction):
                    self.problem("gravity.direction", "the direction is the zero vector: give a "
                                                      "nonzero direction such as [\"0\", \"-1\"]")
                    direction = None
                else:
                    self.gravity_dimension(len(direction))
            if direction is None:
                return
        if g is not None:
            try:
                self.model.add_gravity(g, direction)
            except ModelError as exc:
                self.model_error("gravity", exc)

    def gravity_dimension(self, n: int) -> None:
        for entry in self.entries.values():
            if entry.kind in ("particles", "bodies") and entry.dimension not in (None, n):
                self.problem("gravity.direction", f"the direction has {n} components but "
                                                  f"{entry.key} ('{entry.name}') has a position with "
                                                  f"{entry.dimension}: give the direction as many "
                                                  "components as the positions")
                return

    def build_loads(self, entry: _Entry) -> None:
        table = entry.table
        is_force, is_torque = "force" in table, "torque" in table
        allowed = _ELEMENT_KEYS["loads"][1]
        for name in table:
            if name not in allowed:
                self.unknown_key(f"{entry.key}.{name}", name, allowed, "[[loads]]")
        if is_force and is_torque:
            self.problem(f"{entry.key}.torque", "a load is either a force or a torque, not both: "
                                                "put the torque in its own [[loads]] table")
            return
        if not (is_force or is_torque):
            self.problem(f"{entry.key}.force", "this load has neither force nor torque: add "
                                               "force = [\"F\", \"0\"] with at = \"point\", or "
                                               "torque = \"tau\" with angle = \"theta\" or body = \"rod\"")
            return
        if is_force:
            self.build_force(entry)
        else:
            self.build_torque(entry)

    def build_force(self, entry: _Entry) -> None:
        table = entry.table
        for name in ("angle", "body"):
            if name in table:
                self.problem(f"{entry.key}.{name}", f"'{name}' belongs to a torque, but this load is a "
                                                    "force: remove it (a force acts at a point: at = ...)")
                entry.ok = False
        force = self.vector(table["force"], f"{entry.key}.force", "force vector")
        if "at" not in table:
            self.problem(f"{entry.key}.at", "missing required key 'at': say where the force acts, "
                                            "at = \"cart\" (a point name) or at = [\"x\", \"0\"]")
            return
        at = self.location(table["at"], f"{entry.key}.at", entry)
        if force is None or at is None or not entry.ok:
            return
        where, n = at
        frame = self.frame_of(entry) if "frame" in table else None
        if "frame" in table and frame is None:
            return
        if n is not None and len(force) != n:
            self.problem(f"{entry.key}.force", f"the force has {len(force)} components but the point "
                                               f"it acts at has {n}: give them the same dimension")
            return
        element = self.model.add_force(force, where, frame=frame, name=entry.name)
        self.record(entry, element, {"force": "force",
                                     "position": "at" if isinstance(where, str) else "at[]"})

    def build_torque(self, entry: _Entry) -> None:
        table = entry.table
        if "at" in table:
            self.problem(f"{entry.key}.at", "'at' belongs to a force, but this load is a torque: "
                                            "give angle = \"theta\" or body = \"rod\" instead")
            entry.ok = False
        spatial = isinstance(table["torque"], list)
        torque = (self.vector(table["torque"], f"{entry.key}.torque", "torque vector") if spatial
                  else self.expr(table["torque"], f"{entry.key}.torque"))
        has_angle, has_body = "angle" in table, "body" in table
        if has_angle == has_body:
            self.problem(f"{entry.key}.angle",
                         "give either angle (an expression) or body (a rigid body's name), not both"
                         if has_angle else
                         "say what the torque turns: add angle = \"theta\" (an angle expression) "
                         "or body = \"rod\" (the name of a [[bodies]] element)")
            return
        angle = body = None
        if has_angle:
            angle = self.expr(table["angle"], f"{entry.key}.angle")
            if angle is None:
                return
        else:
            body = table["body"]
            bodies = [e.name for e in self.entries.values() if e.kind == "bodies"]
            target = self.entries.get(body) if isinstance(body, str) else None
            if not isinstance(body, str):
                self.problem(f"{entry.key}.body", f"expected the name of a rigid body, got "
                                                  f"{_describe(body)}; write body = \"rod\"")
                return
            if target is None or target.kind != "bodies":
                what = f" ('{body}' is a {_SINGULAR[target.kind]})" if target is not None else ""
                self.problem(f"{entry.key}.body", f"no rigid body is named '{body}'{what}"
                                                  f"{did_you_mean(body, bodies)}; use the name of a "
                                                  "[[bodies]] element, or angle = \"...\" for any angle")
                return
            if target.element is None:
                return
            in_space = "frame" in target.table or "center" in target.table
            if in_space != spatial:
                self.problem(f"{entry.key}.torque", f"the body '{body}' is {'in space' if in_space else 'planar'}: "
                             + ("its torque is a list of 3 expressions, torque = [\"0\", \"0\", \"tau\"], in "
                                "the axes of frame = ... (default: the body's frame)" if in_space else
                                "its torque is one expression, torque = \"tau\" (about the plane's normal)"))
                return
        frame = None
        if "frame" in table:
            if not spatial:
                self.problem(f"{entry.key}.frame", "only a torque on a body in space has axes: remove frame, or "
                                                   "give the torque as a list of 3 expressions on such a body")
                return
            frame = self.frame_of(entry)
            if frame is None:
                return
        if torque is None or not entry.ok:
            return
        element = self.model.add_torque(torque, angle=angle, body=body, frame=frame, name=entry.name)
        self.record(entry, element, {"angle": "body" if body is not None else "angle"})

    # -- [simulation] ------------------------------------------------------------------------
    def read_constraints(self, value: object) -> None:
        """[[constraints]] tables: a name and one of holonomic = "g(q, t)" or velocity = "a . q_dot + b"."""
        for entry in self.element_tables("constraints", value):
            key = entry.key
            for name in entry.table:
                if name not in _CONSTRAINT_KEYS:
                    self.unknown_key(f"{key}.{name}", name, _CONSTRAINT_KEYS, "[[constraints]]")
            kinds = [k for k in ("holonomic", "velocity") if k in entry.table]
            if len(kinds) != 1:
                self.problem(key, "a constraint needs exactly one of holonomic = \"g(q, t)\" (= 0, on the "
                                  "coordinates) or velocity = \"a(q, t) . q_dot + b\" (= 0, linear in the velocities)"
                             + (", got both" if len(kinds) == 2 else ""))
                continue
            name = entry.table.get("name")
            if name is not None and not isinstance(name, str):
                self.problem(f"{key}.name", f"a constraint's name is a string such as name = \"rod\", got "
                                            f"{_describe(name)}")
                continue
            e = self.expr(entry.table[kinds[0]], f"{key}.{kinds[0]}")
            if e is None:
                continue
            try:
                add = self.model.add_constraint if kinds[0] == "holonomic" else self.model.add_velocity_constraint
                con = add(e, name=name)
                self.key_map[f"constraint '{con.name}'"] = (f"{key}.{kinds[0]}", {})
            except ModelError as exc:
                self.model_error(f"{key}.name" if name is not None else key, exc)

    def read_wheels(self, value: object) -> None:
        """[[wheels]] tables: frame, radius, and optionally axis (default "y"), center, name."""
        for entry in self.element_tables("wheels", value):
            key = entry.key
            required, optional = _WHEEL_KEYS
            for name in entry.table:
                if name not in required + optional:
                    self.unknown_key(f"{key}.{name}", name, required + optional, "[[wheels]]")
            ellipsoid = entry.table.get("shape") == "ellipsoid"
            missing = [k for k in required if k not in entry.table and not (ellipsoid and k == "radius")]
            for k in missing:
                self.problem(key, f"a wheel needs {k}: " + ('frame = "wheel" (the frame that carries it, its '
                                                             'spin its last rotation)' if k == "frame"
                                                             else 'radius = "r" (a parameter or a number)'))
            shape = entry.table.get("shape", "disk")
            if not isinstance(shape, str):
                self.problem(f"{key}.shape", f"expected \"disk\" or \"ellipsoid\" in quotes, got {_describe(shape)}")
                continue
            semi_axes = entry.table.get("semi_axes")
            if semi_axes is not None:
                if not isinstance(semi_axes, list) or len(semi_axes) != 3:
                    self.problem(f"{key}.semi_axes", "expected the 3 semi-axes [\"a\", \"b\", \"c\"] along the "
                                                     f"frame's x, y and z axes, got {_describe(semi_axes)}")
                    continue
                semi_axes = [self.expr(a, f"{key}.semi_axes[{i}]") for i, a in enumerate(semi_axes)]
                if any(a is None for a in semi_axes):
                    continue
            name, frame, axis = (entry.table.get(k) for k in ("name", "frame", "axis"))
            for k, v in (("name", name), ("frame", frame), ("axis", axis)):
                if v is not None and not isinstance(v, str):
                    self.problem(f"{key}.{k}", f"expected a string, got {_describe(v)}")
                    missing.append(k)
            radius = self.expr(entry.table["radius"], f"{key}.radius") if "radius" in entry.table else None
            center = entry.table.get("center", [0, 0, 0])
            if not isinstance(center, list) or len(center) != 3:
                self.problem(f"{key}.center", f"expected 3 expressions (the wheel's centre in its frame's axes), "
                                              f"got {_describe(center)}")
                continue
            center = [self.expr(c, f"{key}.center[{i}]") for i, c in enumerate(center)]
            lateral = entry.table.get("lateral", True)
            if not isinstance(lateral, bool):
                self.problem(f"{key}.lateral", f"expected true or false, got {_describe(lateral)}; write lateral = "
                                               "false to leave out the wheel's lateral no-slip condition (one of "
                                               "two wheels on a rigid axle), or leave the key out")
                continue
            if missing or (radius is None and "radius" in entry.table) or any(c is None for c in center):
                continue
            try:
                wheel = self.model.add_wheel(frame, radius, axis=axis or "y", center=center, lateral=lateral,
                                             shape=shape, semi_axes=semi_axes, name=name)
                for cname in wheel.constraint_names:
                    self.key_map[f"constraint '{cname}'"] = (key, {})
            except ModelError as exc:
                self.model_error(key, exc)

    def read_operating_point(self, value: object) -> None:
        """[operating_point]: coordinate or velocity = number or expression of the parameters."""
        table = self.table(value, "operating_point", 'thetaR_dot = "-v/rR"')
        if table is None:
            return
        coordinates = [c.name for c in self.model.q]
        allowed = coordinates + [f"{c}_dot" for c in coordinates]
        params = {p.name: p for p in self.model.parameters}
        out = {}
        for name, item in table.items():
            key = f"operating_point.{name}"
            if name not in allowed:
                self.problem(key, f"'{name}' is not a coordinate or a velocity{did_you_mean(name, allowed, 0.5)}")
                continue
            e = self.expr(item, key)
            if e is None:
                continue
            other = sorted(str(v) for v in e.free_symbols if v.name not in params)
            if other:
                self.problem(key, f"an operating point's value is a number or an expression of the parameters, got "
                                  f"{item!r} (with {', '.join(other)})")
                continue
            out[name] = e
        self.model.operating_point = out

    def read_optimal_control(self, value: object) -> None:
        """[optimal_control]: checked by the one validator of the problem (io._optimal)."""
        if value is None:
            return
        from ._optimal import check_optimal_control

        names = {k: v for k, v in self.names.items() if not k.endswith("_ddot")}
        table = check_optimal_control(value, names, [c.name for c in self.model.q],
                                      [u.name for u in self.model.inputs], self.problem,
                                      lambda item, key, known: self.expr(item, key, known))
        if table is not None:
            self.model.optimal_control = table

    def read_names(self, value: object, key: str, names: list[str], what: str) -> list[str] | None:
        """A list of names among `names` (what: "coordinate" or "velocity"), or None after problems."""
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            self.problem(f"simulation.{key}", f"expected a list of {what} names such as {key} = "
                                              f"[\"{names[0] if names else 'q1'}\"], got {_describe(value)}")
            return None
        bad = [v for v in value if v not in names]
        for v in bad:
            self.problem(f"simulation.{key}", f"'{v}' is not a {what}{did_you_mean(v, names, 0.5)}; "
                                              f"the {what}s are {', '.join(names)}")
        return None if bad else list(value)

    def read_simulation(self, value: object) -> None:
        table = self.table(value, "simulation", "t_end = 10.0")
        if table is None:
            return
        out: dict[str, Any] = {}
        limits = {"t_end": (0.0, True, "final time"), "dt": (0.0, True, "time step"),
                  "rtol": (0.0, True, "relative tolerance"), "atol": (0.0, True, "absolute tolerance")}
        for name, item in table.items():
            key = f"simulation.{name}"
            if name in limits:
                minimum, strict, what = limits[name]
                number = self.number(item, key, name, minimum=minimum, strict=strict, what=what)
                if number is not None:
                    out[name] = number
            elif name == "initial":
                initial = self.read_initial(item)
                if initial is not None:
                    out["initial"] = initial
            elif name == "inputs":
                inputs = self.read_input_signals(item)
                if inputs is not None:
                    out["inputs"] = inputs
            elif name == "independent":
                independent = self.read_names(item, "independent", [c.name for c in self.model.q], "coordinate")
                if independent is not None:
                    out["independent"] = independent
            elif name == "independent_speeds":
                speeds = self.read_names(item, "independent_speeds", [f"{c.name}_dot" for c in self.model.q],
                                         "velocity")
                if speeds is not None:
                    out["independent_speeds"] = speeds
            elif name == "sample_time":
                sample_time = self.read_sample_time(item)
                if sample_time is not None:
                    out["sample_time"] = sample_time
            else:
                self.unknown_key(key, name, _SIMULATION_KEYS, "[simulation]")
        given = out.get("initial", {})  # a quaternion joint's q0 = 1 (Model.add_joint), unless the file gives one
        defaults = {k: v for j in self.model.joints.values() if j.parametrization == "quaternion"
                    and not any(c.name in given for c in j.coordinates[-4:])
                    for k, v in self.model.simulation.get("initial", {}).items() if k == j.coordinates[-4].name}
        if defaults:
            out["initial"] = {**defaults, **given}
        self.model.simulation = out
        if "initial" in out and any(j.parametrization == "quaternion" for j in self.model.joints.values()):
            from ..model._joints import quaternion_start  # an all-zero quaternion: refused here, named

            try:
                quaternion_start(self.model, out["initial"])
            except ModelError as exc:
                for p in exc.problems:
                    self.problem("simulation.initial", p.message)

    def read_initial(self, value: object) -> dict[str, float] | None:
        if not isinstance(value, dict):
            self.problem("simulation.initial", f"expected a table of name = number, got "
                                               f"{_describe(value)}; write initial = {{ q1 = 0.1, "
                                               "q1_dot = 0.0 }")
            return None
        coordinates = [c.name for c in self.model.q]
        allowed = coordinates + [f"{c}_dot" for c in coordinates]
        out: dict[str, float] = {}
        for name, item in value.items():
            key = f"simulation.initial.{name}"
            number = self.number(item, key, name, what="initial value")
            if name not in allowed:
                self.problem(key, f"'{name}' is not a coordinate or a velocity{did_you_mean(name, allowed, 0.5)}: "
                                  "initial values are given for coordinates and their velocities "
                                  f"(<coordinate>_dot); use one of {', '.join(allowed) or '(none)'}")
            elif number is not None:
                out[name] = number
        return out

    def read_sample_time(self, value: object) -> float | dict[str, float] | None:
        """sample_time = 0.01, or a table of input = period."""
        inputs = [u.name for u in self.model.inputs]
        if not isinstance(value, dict):
            return self.number(value, "simulation.sample_time", "sample_time", minimum=0.0, strict=True,
                               what="sample time (seconds)")
        out: dict[str, float] = {}
        for name, item in value.items():
            key = f"simulation.sample_time.{name}"
            if name not in inputs:
                declared = f"the inputs are {', '.join(inputs)}" if inputs else "no input is declared"
                self.problem(key, f"'{name}' is not an input{did_you_mean(name, inputs, 0.5)}: {declared}; "
                                  "sample_time names the inputs that are sampled")
                continue
            number = self.number(item, key, name, minimum=0.0, strict=True, what="sample time (seconds)")
            if number is not None:
                out[name] = number
        return out

    def read_input_signals(self, value: object) -> dict[str, str | float] | None:
        if not isinstance(value, dict):
            self.problem("simulation.inputs", f"expected a table of input = expression, got "
                                              f"{_describe(value)}; write inputs = {{ F = \"sin(t)\" }}")
            return None
        inputs = [u.name for u in self.model.inputs]
        names = {k: v for k, v in self.model.names().items() if k not in inputs}
        out: dict[str, str | float] = {}
        for name, item in value.items():
            key = f"simulation.inputs.{name}"
            if name not in inputs:
                declared = f"the inputs are {', '.join(inputs)}" if inputs else "no input is declared"
                self.problem(key, f"'{name}' is not an input{did_you_mean(name, inputs, 0.5)}: {declared}; "
                                  f"declare it with inputs = [\"{name}\"] or fix the name")
                continue
            if isinstance(item, str) and item.startswith("@"):
                signal = self.signal_file(name, item, key)
                if signal is not None:
                    out[name] = signal
                continue
            if self.expr(item, key, names, context="signal") is not None:
                out[name] = item if isinstance(item, str) else float(item)
        return out

    def signal_file(self, name: str, text: str, key: str):
        """inputs = { F = "@data.csv:acc" }: the CLI's --input syntax, the path relative to the model
        file's folder and inside it; a SignalFile (the numeric layer reads the CSV when it simulates)."""
        from ._signalspec import SignalFile, split_signal_spec

        path, column, options = split_signal_spec(name, text)
        fix = f"put the CSV file in the model file's folder (or below it) and write {name} = \"@data.csv:{name}\""
        if self.source.startswith("<") and self.source.endswith(">"):
            if self.source == "<playground>":
                self.problem(key, f"a model sent to the playground cannot read files on the server; '{text}' names "
                                  f"a CSV file: give {name} as an expression of t (for example \"0.5*sin(3*t)\"), or "
                                  "simulate the model file with the CSV beside it from the command line "
                                  "(lagrangian simulate model.toml)")
            else:
                self.problem(key, f"'{text}' names a CSV file, but this model was not read from a file, so there is "
                                  "no folder to read it from; save the model as a .toml file beside the CSV and load "
                                  "that file, or pass lagrangian.Signal.from_csv(...) as inputs= to simulate")
            return None
        if not path:
            self.problem(key, f"expected a CSV file after '@', for example {name} = \"@data.csv:{name}\" "
                              f"(or \"@data.csv:{name}:cubic\", \"@data.csv:{name}:hold\")")
            return None
        raw = path.replace("\\", "/")
        if raw.startswith("/") or (len(raw) > 1 and raw[1] == ":") or os.path.isabs(path):
            self.problem(key, f"'{path}' is an absolute path; expected a path relative to the model file's folder; "
                              f"{fix}")
            return None
        if ".." in raw.split("/"):
            self.problem(key, f"'{path}' contains '..'; expected a path inside the model file's folder; {fix}")
            return None
        folder = Path(self.source).resolve().parent
        full = (folder / raw).resolve()
        if not full.is_relative_to(folder):
            self.problem(key, f"'{path}' resolves (following symbolic links) to {full}, outside the model file's "
                              f"folder {folder}; expected a file inside it; {fix}")
            return None
        if not full.is_file():
            self.problem(key, f"no such CSV file '{path}' in the model file's folder {folder}; expected a CSV file "
                              "with a header row (t, then the columns); check the name, or put the file there")
            return None
        return SignalFile(str(full), column, where=f"{self.source}: {key}", text=text, **options)

    # -- Model.check ----------------------------------------------------------------------
    def translate(self, key: str) -> str:
        """A Model.check key ("particle 'bob'.position[0]") as a file key ("particles[0].position[0]")."""
        if key == "gravity 'gravity'" or key.startswith("gravity 'gravity'."):
            return "gravity" + key[len("gravity 'gravity'"):]
        for prefix, (file_key, fields) in self.key_map.items():
            if key == prefix:
                return file_key
            if key.startswith(prefix + "."):
                rest = key[len(prefix) + 1:]
                base, bracket, index = rest.partition("[")
                mapped = fields.get(base, base)
                if mapped == "at[]":
                    return f"{file_key}.at[{index}" if bracket else f"{file_key}.at"
                if mapped in ("at", "body", "between"):
                    return f"{file_key}.{mapped}"
                return f"{file_key}.{mapped}{bracket}{index}"
        return key

    def check_model(self) -> None:
        """Model.check() on what was built, skipping keys that already have a problem."""
        taken = {p.key for p in self.problems}
        try:
            found = self.model.check()
        except (TypeError, ValueError, ArithmeticError) as exc:  # pragma: no cover - defensive
            self.problem(None, f"the model could not be checked: {exc}")
            return
        for p in found:
            key = self.translate(p.key) if p.key else None
            if key in taken or (key == "coordinates" and any(
                    k and k.startswith("coordinates") for k in taken)):
                continue
            self.problem(key, p.message)


def _cycle(frames: Mapping[str, _Entry], start: str, joints: Mapping[str, _Entry] | None = None) -> list[str] | None:
    """The cycle of parents that `start` belongs to, as [start, ..., start], or None; through the [[frames]]
    tables (`frames`, by name) and the child frames of the [[joints]] tables (`joints`, by child name)."""
    tables = {**(joints or {}), **frames}
    seen = [start]
    name = tables[start].table.get("parent", "world")
    while isinstance(name, str) and name in tables:
        if name == start:
            return seen + [start]
        if name in seen:
            return None  # a cycle above start, reported for its own members
        seen.append(name)
        name = tables[name].table.get("parent", "world")
    return None


_LARGEST_FLOAT = int(sys.float_info.max)


def _parent_name(table: Mapping[str, Any]) -> str | None:
    """A frame table's parent, "world" by default; None when it is not a name (reported elsewhere)."""
    from ..model._frames import WORLD

    parent = table.get("parent", WORLD)
    return parent if isinstance(parent, str) else None


def _deepest_line(text: str) -> int | None:
    """The line where the nesting of [ and { (outside strings, roughly) is deepest: where a file nested too deeply
    for the TOML reader goes wrong."""
    depth, deepest, line, where = 0, 0, 1, None
    for ch in text:
        if ch == "\n":
            line += 1
        elif ch in "[{":
            depth += 1
            if depth > deepest:
                deepest, where = depth, line
        elif ch in "]}":
            depth = max(0, depth - 1)
    return where


def _longest_digits_line(text: str) -> int | None:
    """The line of the longest run of digits: where an integer too long to read is."""
    best = max(re.finditer(r"[0-9_]+", text), key=lambda m: len(m.group()), default=None)
    return None if best is None else text.count("\n", 0, best.start()) + 1


def _shown_number(value: object) -> str:
    """A number as a message shows it: an integer too long to read as its count of digits."""
    text = repr(value)
    return text if len(text) < 30 else f"an integer of {len(str(abs(value)))} digits"  # type: ignore[arg-type]
