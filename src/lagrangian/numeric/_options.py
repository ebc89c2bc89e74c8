"""SimulationOptions: the options of one simulation, built once from the model file and merged with
the caller's by one rule.

The same rule serves the API (:func:`lagrangian.simulate`, :func:`lagrangian.simulate_batch`), the
command line (``lagrangian simulate``, ``animate``, ``export``...), the exports and the playground:

* The model file's ``[simulation]`` table gives the defaults (``t_end``, ``dt``, ``rtol``,
  ``atol``, ``initial``, ``inputs``, ``sample_time``; ``independent`` and ``independent_speeds``
  for a constrained model); without it, dt = 0.01, rtol = atol = 1e-9 and every initial value and
  input is 0.
* **A single value given replaces the model's** (``t_end``, ``dt``, ``rtol``, ``method``...); a
  value not given (None) keeps it.
* **A mapping given updates the model's name by name**: ``initial={"th2": 0.5}`` (``--initial
  th2=0.5``) sets th2 and keeps the model file's other initial values; ``inputs``, ``params``,
  ``events`` and a ``sample_time`` mapping likewise. A full state array for ``initial`` (shape
  (2n,)) replaces all of them; a number for ``sample_time`` replaces the model's.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from types import MappingProxyType

from .._limits import number_problem
from .._util import shown_value
from ..errors import ModelError, Problem

__all__ = ["BY_NAME", "SimulationOptions"]

#: The options whose mappings update the model's name by name (see the module's docstring).
BY_NAME = ("initial", "inputs", "params", "sample_time", "events")
#: The defaults when neither the model file nor the caller gives a value.
DEFAULTS = {"dt": 0.01, "rtol": 1e-9, "atol": 1e-9}
#: The smallest relative tolerance an integrator can meet in double precision (as SciPy's solve_ivp): 100
#: machine epsilons.
MIN_RTOL = 100 * 2.220446049250313e-16


def _name(key):
    return getattr(key, "name", key)


def _signal_files(inputs: Mapping) -> dict:
    """The model file's inputs with each CSV column it names (io's SignalFile) read as a Signal; an
    error names the model file and its key before the CSV's own words."""
    from ..io._signalspec import SignalFile

    out = dict(inputs)
    for name, value in inputs.items():
        if isinstance(value, SignalFile):
            try:
                out[name] = _read_signal(value.path, value.column, value.interpolation, value.extrapolation,
                                         _stamp(value.path))
            except ModelError as exc:
                raise ModelError(f"{value.where}: '{value.text}': {exc}") from None
    return out


def _stamp(path: str) -> tuple[int, int] | None:
    """(modification time in ns, size) of the file at `path`, None where it cannot be read (the
    reading then says why): a changed file is read again."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size


@functools.lru_cache(maxsize=32)
def _read_signal(path: str, column: str, interpolation: str, extrapolation: str, stamp):
    """The Signal of a CSV column, read once per version of the file (`stamp`): every simulate()
    of a model file that names a CSV builds its options from the file again. A Signal is immutable,
    and a failed reading raises (nothing is kept)."""
    from ._inputs import Signal

    return Signal.from_csv(path, column, interpolation, extrapolation)


def _frozen(mapping: Mapping) -> Mapping:
    return MappingProxyType({_name(k): v for k, v in mapping.items()})


@dataclass(frozen=True)
class SimulationOptions:
    """What one simulation is asked to do (see the module's docstring for the merge rule).

    Attributes
    ----------
    t_end : float or None
        Final time (None: not given, an error when simulating).
    dt : float
        Output interval, unless `t_eval` gives the output times.
    t_eval : array_like or None
        Explicit output times.
    initial : mapping of str to float, or array_like, shape (2n,)
        Initial coordinates and velocities by name (others 0), or the whole state.
    given : mapping, array_like or None
        The initial values the caller gave on top of the model file's (None: none): a constrained
        model's consistent initial state keeps these.
    inputs, params, events : mapping of str
        Inputs (constants, expressions or functions), parameter values, event functions, by name.
    sample_time : float, mapping of str to float, or None
    stop_on : tuple of str
    method : str or Solver
    rtol, atol, max_step : float
    step : float or None
        The fixed step of method "variational".
    backend : str
    constraints : str
        "project" or "eliminate".
    progress : bool or None
    independent, independent_speeds : tuple of str
        [simulation] independent and independent_speeds of a constrained model.
    """

    t_end: float | None = None
    dt: float = DEFAULTS["dt"]
    t_eval: object = None
    initial: object = field(default_factory=lambda: MappingProxyType({}))
    given: object = None
    inputs: Mapping = field(default_factory=lambda: MappingProxyType({}))
    params: Mapping = field(default_factory=lambda: MappingProxyType({}))
    sample_time: object = None
    events: Mapping = field(default_factory=lambda: MappingProxyType({}))
    stop_on: tuple = ()
    method: object = "DOP853"
    rtol: float = DEFAULTS["rtol"]
    atol: float = DEFAULTS["atol"]
    max_step: float = math.inf
    step: float | None = None
    backend: str = "auto"
    constraints: str = "project"
    progress: bool | None = None
    independent: tuple = ()
    independent_speeds: tuple = ()

    @classmethod
    def from_model(cls, model) -> SimulationOptions:
        """The options of the model file's [simulation] table (``model.simulation``), the defaults
        for what it does not give."""
        sim = getattr(model, "simulation", None) or {}
        values = {k: v for k, v in sim.items() if k in _FIELDS and v is not None}
        for key in ("initial", "inputs"):
            values[key] = _frozen(values.get(key) or {})
        for key in ("independent", "independent_speeds"):
            values[key] = tuple(str(v) for v in values.get(key, ()))
        if isinstance(values.get("sample_time"), Mapping):
            values["sample_time"] = _frozen(values["sample_time"])
        return cls(**values)

    def merged(self, **overrides) -> SimulationOptions:
        """These options with the caller's: a value given replaces this one, a mapping given for
        initial, inputs, params, events or sample_time updates this one's name by name (see the
        module's docstring); None keeps this one. An unknown option is a TypeError."""
        unknown = sorted(set(overrides) - _FIELDS)
        if unknown:
            raise TypeError(f"unknown simulation option{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}; "
                            f"the options are {', '.join(sorted(_FIELDS - {'given'}))}")
        changes = {}
        for key, value in overrides.items():
            if value is None:
                continue
            if key in BY_NAME and isinstance(value, Mapping):
                mine = getattr(self, key)
                base = dict(mine) if isinstance(mine, Mapping) else {}
                changes[key] = _frozen({**base, **{_name(k): v for k, v in value.items()}})
                if key == "initial":
                    given = self.given if isinstance(self.given, Mapping) else {}
                    changes["given"] = _frozen({**given, **value})
            elif key in ("inputs", "params", "events"):
                example = {"inputs": "inputs={'F': 1.0}", "params": "params={'m': 2.0}",
                           "events": "events={'ground': 'y'}"}[key]
                raise ModelError([Problem(f"{key} must be a mapping of names to values, such as {example}, got "
                                          f"{type(value).__name__} {shown_value(value)}", key=key)])
            elif key == "stop_on":
                names = (value,) if isinstance(value, str) else tuple(value) if isinstance(value, (list, tuple)) \
                    else None
                if names is None or not all(isinstance(n, str) for n in names):
                    raise ModelError([Problem(f"stop_on must be the name of an event or a list of names, such as "
                                              f"stop_on='ground' or stop_on=['ground', 'wall'], got "
                                              f"{shown_value(value)}", key="stop_on")])
                changes[key] = names
            else:
                changes[key] = value
                if key == "initial":
                    changes["given"] = value
        if not changes:
            return self
        out = object.__new__(type(self))  # replace(self, **changes), without its __init__ of every field
        out.__dict__.update(self.__dict__)
        out.__dict__.update(changes)
        return out

    def read_signals(self) -> SimulationOptions:
        """These options with every CSV column the model file names as an input (``[simulation]
        inputs = { F = "@data.csv:acc" }``) read as a Signal. Called after the caller's overrides are
        merged, so an input the caller replaces is never read (a missing or bad CSV then does not
        matter), and options built only for their initial values read no file."""
        from ..io._signalspec import SignalFile

        if not any(isinstance(v, SignalFile) for v in self.inputs.values()):
            return self
        return replace(self, inputs=_frozen(_signal_files(self.inputs)))

    @property
    def held(self) -> frozenset[str]:
        """The coordinates and velocities a constrained model's consistent initial state keeps as
        the model file names them: the independent coordinates and the independent speeds (default:
        the independent coordinates' velocities)."""
        speeds = self.independent_speeds or tuple(f"{q}_dot" for q in self.independent)
        return frozenset(self.independent) | frozenset(speeds)

    def problems(self) -> list[Problem]:
        """The problems of the single values (t_end, dt, rtol, atol, step, max_step, constraints),
        every one at once; the names (initial, inputs, params, events...) are checked against the
        model by :func:`lagrangian.simulate`."""
        out = []
        t_end = self.t_end
        if t_end is None:
            out.append(Problem("t_end is needed: pass t_end=... (--t-end on the command line) or set "
                               "t_end under [simulation] in the model file", key="t_end"))
        elif number_problem(t_end, "t_end", positive=True):  # the CLI's rule (lagrangian._limits)
            out.append(Problem(number_problem(t_end, "t_end", positive=True), key="t_end"))
        if number_problem(self.dt, "dt", positive=True):
            out.append(Problem(number_problem(self.dt, "dt", positive=True), key="dt"))
        rtol_problem = number_problem(self.rtol, "rtol", positive=True, maximum=1.0,
                                      example="rtol=1e-9 (--rtol 1e-9)")
        if rtol_problem:
            out.append(Problem(rtol_problem, key="rtol"))
        elif self.rtol < MIN_RTOL:  # the integrators would raise it to this bound, silently (as SciPy's does)
            out.append(Problem(f"rtol = {self.rtol:g} is smaller than a relative error double precision can meet: "
                               f"at least 100 machine epsilons, {MIN_RTOL:.3g}; use rtol={MIN_RTOL:.3g} or larger "
                               f"(--rtol {MIN_RTOL:.3g})", key="rtol"))
        if number_problem(self.atol, "atol", positive=True):
            out.append(Problem(number_problem(self.atol, "atol", positive=True) + " (with atol = 0 a state "
                               "component that passes through zero cannot be controlled)", key="atol"))
        return out

    def step_problems(self) -> list[Problem]:
        """The problems of step and max_step (after the method's and the backend's, as reported)."""
        out = []
        if self.step is not None and number_problem(self.step, "step", positive=True):
            out.append(Problem(number_problem(self.step, "step", positive=True), key="step"))
        if self.max_step != math.inf and number_problem(self.max_step, "max_step", positive=True):
            out.append(Problem(number_problem(self.max_step, "max_step", positive=True) + " (or math.inf: no limit)",
                               key="max_step"))
        return out

    def constraints_problems(self) -> list[Problem]:
        if self.constraints not in ("project", "eliminate"):
            return [Problem(f"constraints must be 'project' or 'eliminate', got {self.constraints!r}",
                            key="constraints")]
        return []


#: The names of the options (simulate() merges them on every call: read once).
_FIELDS = frozenset(f.name for f in fields(SimulationOptions))
