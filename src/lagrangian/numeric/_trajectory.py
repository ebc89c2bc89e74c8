"""Trajectory: the immutable result of a simulation."""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass, field

import numpy as np

from .._util import read_only
from ..errors import Status
from ._cache import cached

__all__ = ["Trajectory"]


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A simulated motion.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Output times.
    x : ndarray, shape (N, 2n)
        States [q, q_dot] at those times, columns in `state_names` order.
    state_names : tuple of str
    u : ndarray, shape (N, m)
        Input values, columns in `input_names` order.
    input_names : tuple of str
    energy : ndarray, shape (N,) or None
        The energy T* + V, or the Jacobi integral when T* has terms of degree 1 or 0 in the
        velocities; None when L depends explicitly on t.
    energy_name : str or None
        "energy" or "jacobi_integral".
    conservative : bool
        Whether `energy` should be constant (L free of t, D = 0 and Q = 0).
    parameters : dict of str to float
        The parameter values used.
    nfev : int
        Number of right-hand-side evaluations.
    message : str
        The integrator's message.
    model : Model or None
        The (frozen) model that was simulated, for drawing it (:meth:`animate`); None when unknown.
    stats : dict
        How it was computed: "backend" (numba, c or scipy), "method", "nfev", "nstep"
        (accepted steps) and "nreject" (rejected steps); "stopped_by" and "stop_time" when an
        event stopped it.
    events : dict of str to dict
        For each event of ``simulate(events=...)``, its zero crossings: {"t": times (k,),
        "x": states (k, 2n)}.
    multipliers : ndarray, shape (N, number of constraints), or None
        The Lagrange multipliers of a constrained model (columns ``lambda_<name>``, in
        `multiplier_names` order); None without constraints. ``stats["constraint_drift"]``
        holds the largest |g| ("position") and |G q_dot + b| ("velocity") at the outputs.
    multiplier_names : tuple of str
    failure : str or None
        None for a complete run. For the rows a failed simulation computed before it stopped
        (``SimulationError.partial``, ``SingularMassMatrixError.partial``): the error's message;
        the CSV then starts with a comment line ``# partial: ...``.
    outputs : dict of str to ndarray
        The model's named outputs (``Model.add_output``, ``[outputs]``) along the run, each shape
        (N,), in the order they were declared: the last columns of the CSV; {} without outputs.
    """

    t: np.ndarray
    x: np.ndarray
    state_names: tuple[str, ...]
    u: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    input_names: tuple[str, ...] = ()
    energy: np.ndarray | None = None
    energy_name: str | None = None
    conservative: bool = False
    parameters: dict = field(default_factory=dict)
    nfev: int = 0
    message: str = ""
    stats: dict = field(default_factory=dict)
    events: dict = field(default_factory=dict)
    model: object = field(default=None, repr=False)
    multipliers: np.ndarray | None = None
    multiplier_names: tuple[str, ...] = ()
    failure: str | None = None
    outputs: dict = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "t", read_only(self.t, float))
        object.__setattr__(self, "x", _frozen(self.x))
        object.__setattr__(self, "u", _frozen(self.u, (len(self.t), len(self.input_names))))
        if self.energy is not None:
            object.__setattr__(self, "energy", _frozen(self.energy))
        if self.multipliers is not None:
            shape = (len(self.t), len(self.multiplier_names))
            object.__setattr__(self, "multipliers", read_only(np.reshape(self.multipliers, shape), float))
        object.__setattr__(self, "outputs", {k: read_only(np.reshape(v, len(self.t)), float)
                                             for k, v in self.outputs.items()})

    def __setstate__(self, state):
        """Unpickled as it was made: its arrays read-only again (pickle gives fresh, writable arrays)."""
        self.__dict__.update(state)
        arrays = (self.t, self.x, self.u, self.energy, self.multipliers, *self.outputs.values())
        if any(isinstance(a, np.ndarray) and a.flags.writeable for a in arrays):  # a copy.copy shares them
            self.__post_init__()

    @property
    def n(self) -> int:
        """Number of coordinates."""
        return len(self.state_names) // 2

    @property
    def q(self) -> np.ndarray:
        """Coordinates, shape (N, n)."""
        return self.x[:, : self.n]

    @property
    def q_dot(self) -> np.ndarray:
        """Velocities, shape (N, n)."""
        return self.x[:, self.n:]

    @property
    def columns(self) -> tuple[str, ...]:
        """Column names of the CSV: t, coordinates, velocities, inputs, the energy, then the
        multipliers ``lambda_<name>`` of a constrained model, then the model's named outputs."""
        extra = (self.energy_name,) if self.energy is not None else ()
        return ("t", *self.state_names, *self.input_names, *extra, *self.multiplier_names, *self.outputs)

    def __getitem__(self, name: str) -> np.ndarray:
        """A column by name: ``traj["q2"]``, ``traj["q2_dot"]``, ``traj["t"]``, ``traj["energy"]``."""
        if name == "t":
            return self.t
        if name in self.state_names:
            return self.x[:, self.state_names.index(name)]
        if name in self.input_names:
            return self.u[:, self.input_names.index(name)]
        if self.energy is not None and name == self.energy_name:
            return self.energy
        if name in self.multiplier_names:
            return self.multipliers[:, self.multiplier_names.index(name)]
        if name in self.outputs:
            return self.outputs[name]
        raise KeyError(f"the trajectory has no column '{name}'; its columns are {', '.join(self.columns)}")

    def conserved(self) -> dict[str, np.ndarray]:
        """The model's conserved quantities (``Equations.conserved_quantities``: the energy or the
        Jacobi integral, and the momentum ``p_<q>`` of each cyclic coordinate) along the trajectory;
        {} when the model is unknown."""
        if self.model is None or not len(self.t):
            return {}
        import sympy

        from ..equations import derive

        eqs = derive(self.model)
        quantities = eqs.conserved_quantities
        if not quantities:
            return {}
        symbols = [eqs.t, *eqs.coordinates, *eqs.velocities, *eqs.inputs, *eqs.parameters]
        f = sympy.lambdify(symbols, list(quantities.values()), "numpy")
        p = [np.full(len(self.t), float(self.parameters.get(s.name, np.nan))) for s in eqs.parameters]
        u = [self.u[:, k] for k in range(self.u.shape[1])] if self.u.ndim == 2 else []
        values = f(self.t, *self.x.T, *u, *p)
        return {k: read_only(np.broadcast_to(v, self.t.shape), float) for k, v in zip(quantities, values)}

    def conserved_drift(self) -> dict[str, float]:
        """max |c(t) - c(0)| of each conserved quantity (see :meth:`conserved`)."""
        return {k: float(np.max(np.abs(v - v[0]))) for k, v in self.conserved().items()}

    @property
    def energy_drift(self) -> float | None:
        """max |E(t) - E(0)| (None when the energy is not defined)."""
        if self.energy is None or len(self.energy) == 0:
            return None
        return float(np.max(np.abs(self.energy - self.energy[0])))

    def table(self) -> np.ndarray:
        """All columns as one array, shape (N, len(columns))."""
        parts = [self.t[:, None], self.x, self.u]
        if self.energy is not None:
            parts.append(self.energy[:, None])
        if self.multipliers is not None:
            parts.append(self.multipliers)
        parts += [v[:, None] for v in self.outputs.values()]
        return np.hstack(parts)

    @property
    def partial(self) -> bool:
        """Whether these are only the rows computed before a simulation failed (see `failure`)."""
        return self.failure is not None

    def to_csv(self, path: str | os.PathLike | None = None) -> str | None:
        """Write the columns as CSV (header first) to `path`; return the text when `path` is None.

        The rows of a failed run (`partial`) are preceded by one comment line, ``# partial: `` and
        the first line of the failure's message (read such a file with ``pandas.read_csv(path,
        comment="#")``). A regular file is replaced atomically (a temporary file beside it, then a
        rename; created with the user's umask); a FIFO or a character device is written as a
        stream; a symbolic link to a file is refused (:class:`~lagrangian.errors.OutputFileError`)."""
        buf = io.StringIO()
        if self.failure is not None:
            first = self.failure.splitlines()[0] if self.failure.strip() else "the simulation failed"
            buf.write(f"# partial: {first}\n")
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        for row in self.table():
            w.writerow([repr(float(v)) for v in row])
        text = buf.getvalue()
        if path is None:
            return text
        from ..io._files import write_output

        write_output(path, text, "Trajectory.to_csv")
        return None

    # ------------------------------------------------------------ plotting
    def plot(self, names=None, **kwargs):
        """Time histories of the named columns (default: the coordinates); see
        :func:`lagrangian.plot.time_history`. Returns the Matplotlib figure."""
        from ..plot import time_history

        return time_history(self, names, **kwargs)

    def phase_portrait(self, q=None, **kwargs):
        """Phase portraits (q, q_dot); see :func:`lagrangian.plot.phase_portrait`."""
        from ..plot import phase_portrait

        return phase_portrait(self, q, **kwargs)

    def animate(self, **kwargs):
        """An animation of the mechanism drawn from its model's geometry; see :func:`lagrangian.plot.animate`.
        Shown inline in a notebook; ``.save("out.gif")`` writes it."""
        from ..plot import animate

        return animate(self, **kwargs)

    def _repr_html_(self) -> str:
        import html

        name = html.escape(getattr(self.model, "name", "")) if self.model is not None else ""
        rows = [("samples", f"{len(self.t)}"),
                ("t", f"{self.t[0]:g} .. {self.t[-1]:g} s" if len(self.t) else "-"),
                ("coordinates", ", ".join(self.state_names[: self.n])),
                ("inputs", ", ".join(self.input_names) or "none"),
                ("parameters", ", ".join(f"{k} = {v:g}" for k, v in self.parameters.items()) or "none")]
        if self.energy is not None and len(self.t):
            rows.append((self.energy_name.replace("_", " "),
                         f"{self.energy[0]:.6g} at t = 0; max drift {self.energy_drift:.2e}"
                         + (" (conserved)" if self.conservative else " (not conserved)")))
        if len(self.t):
            for i, c in enumerate(self.state_names):
                rows.append((c, f"{self.x[0, i]:.6g} .. {self.x[-1, i]:.6g} (start .. end), "
                                f"range [{self.x[:, i].min():.4g}, {self.x[:, i].max():.4g}]"))
        body = "".join(f"<tr><th style='text-align:left'>{html.escape(k)}</th>"
                       f"<td style='text-align:left'>{html.escape(v)}</td></tr>" for k, v in rows)
        title = f"Trajectory of {name}" if name else "Trajectory"
        return f"<div><b>{title}</b> ({html.escape(self.message)})<table>{body}</table></div>"

    def __repr__(self) -> str:
        return (f"<Trajectory: {len(self.t)} samples, t in [{self.t[0]:g}, {self.t[-1]:g}], "
                f"states {', '.join(self.state_names)}>") if len(self.t) else "<Trajectory: empty>"


def run_trajectory(equations, t, x, u, p, *, energy=None, stats: dict, status, message: str | None = None,
                   events: dict | None = None, failure: str | None = None, multipliers=None,
                   fresh: bool = False) -> Trajectory:
    """The one builder of a simulation's Trajectory: the names, the energy's name (``Equations.
    energy_name``; no energy column where it is None), whether it is conserved, the parameters by
    name and ``stats["status"]`` (a :class:`~lagrangian.errors.Status`) from `equations`, the
    parameter values `p` and the run's `status`; `message` defaults to the status's. `fresh`: `x`,
    `u` and `energy` are the run's own arrays, which nothing writes to after: the Trajectory takes
    them as they are, made read-only, instead of read-only copies."""
    status = None if status is None else Status.of(status)  # None: a failed run's rows (see `failure`)
    names = cached(equations, "trajectory.names", lambda: _Names(equations))
    name = names.energy_name
    stats = {**stats, "status": status} if status is not None else dict(stats)
    energy = None if name is None or energy is None else np.asarray(energy, float)
    outputs = evaluate_outputs(equations, t, x, u, p)
    if fresh:
        x, u = _Own(x), _Own(u)
        energy = None if energy is None else _Own(energy)
    return Trajectory(
        t=t, x=x, state_names=names.state_names, u=u, input_names=names.input_names,
        energy=energy, energy_name=name,
        conservative=names.conservative, parameters=dict(zip(names.parameter_names, map(float, p))),
        nfev=int(stats.get("nfev", 0)),
        message=message if message is not None else getattr(status, "message", f"status {status}"),
        stats=stats, events=events or {}, model=equations.model, multipliers=multipliers,
        multiplier_names=names.multiplier_names if multipliers is not None else (), failure=failure,
        outputs=outputs)


class RunTemplate:
    """What run_trajectory gives every complete run of one checked simulate() call (the names, the
    energy's name, the parameters by name, the model) built once, for the same call again
    (numeric/_simulate.py, _Repeat): `make` fills in a run's own arrays and stats, the same
    Trajectory as run_trajectory's (the same fields, read-only arrays the run's own, frozen), without
    the dataclass's __init__. For models without named outputs (their values need the run)."""

    __slots__ = ("fields", "parameters", "energy")

    def __init__(self, equations, p):
        names = cached(equations, "trajectory.names", lambda: _Names(equations))
        self.energy = names.energy_name is not None
        self.parameters = dict(zip(names.parameter_names, map(float, p)))
        self.fields = dict(  # in the order of the dataclass's fields (its __init__ sets them so)
            t=None, x=None, state_names=names.state_names, u=None, input_names=names.input_names, energy=None,
            energy_name=names.energy_name, conservative=names.conservative, parameters=None, nfev=0,
            message=Status.SUCCESS.message, stats=None, events=None, model=equations.model, multipliers=None,
            multiplier_names=(), failure=None, outputs=None)

    def make(self, t, x, u, energy, stats: dict) -> Trajectory:
        """The Trajectory of a complete run: a copy of its times `t` (shared by the runs), its states
        `x`, inputs `u` and `energy` (its own, float64 and C-contiguous, made read-only), its `stats`
        (with "status" SUCCESS)."""
        t = np.array(t, dtype=float)
        for a in (t, x, u, energy):
            a.setflags(write=False)
        tr = object.__new__(Trajectory)
        d = tr.__dict__
        d.update(self.fields)
        d["t"], d["x"], d["u"], d["parameters"], d["nfev"] = t, x, u, dict(self.parameters), stats["nfev"]
        d["stats"], d["events"], d["outputs"] = stats, {}, {}
        if self.energy:
            d["energy"] = energy
        return tr


def evaluate_outputs(equations, t, x, u, p) -> dict[str, np.ndarray]:
    """The model's named outputs along a run, evaluated vectorised (SymEngine over all rows) by the
    one numeric model (``NumericModel.function``): name -> shape (N,); {} without outputs."""
    outputs = equations.model.outputs if equations.model is not None else {}
    if not outputs:
        return {}
    from ._compiled import compile_equations

    t = np.asarray(t, float)
    values = compile_equations(equations, "scipy").function("outputs", lambda: list(outputs.values()))(
        t, np.reshape(x, (len(t), -1)), np.reshape(u, (len(t), -1)), p)
    return {name: values[:, k] for k, name in enumerate(outputs)}


class _Own:
    """An array handed to a Trajectory by run_trajectory (`fresh`): the run's own, which the
    Trajectory takes without a copy (see _frozen)."""

    __slots__ = ("array",)

    def __init__(self, array):
        self.array = array


def _frozen(a, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """`a` as a read-only float array (of `shape`, when given): a read-only copy, or the array
    itself, made read-only, when run_trajectory hands over a run's own (_Own) of that type and shape."""
    if type(a) is _Own:
        a = a.array
        if type(a) is np.ndarray and a.dtype == np.float64 and (shape is None or a.shape == shape):
            a.setflags(write=False)
            return a
    return read_only(a if shape is None else np.reshape(a, shape), float)


class _Names:
    """What every Trajectory of one Equations object shares (run_trajectory builds it once)."""

    def __init__(self, equations):
        self.state_names = tuple(equations.state_names)
        self.input_names = tuple(s.name for s in equations.inputs)
        self.energy_name = equations.energy_name
        self.conservative = equations.is_conservative
        self.parameter_names = tuple(s.name for s in equations.parameters)
        self.multiplier_names = tuple(m.name for m in equations.multipliers)
