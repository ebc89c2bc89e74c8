"""OptimalMotion: the answer of ``optimal_motion``, checked by a replay (frozen)."""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["OptimalMotion"]


@dataclass(frozen=True, eq=False)
class OptimalMotion:
    """An optimal motion found by direct collocation (returned by :func:`lagrangian.optimal_motion`).

    Attributes
    ----------
    t : ndarray, shape (P,)
        The collocation points' times (the mesh's nodes and the intervals' midpoints, P = 2N + 1).
    x : ndarray, shape (P, 2n)
        The states [q, q_dot] there (``motion["q1"]`` gives a column).
    u : ndarray, shape (P, k)
        The inputs there (every input of the model; the held ones constant).
    accelerations : ndarray, shape (P, n)
    multipliers : ndarray, shape (P, m)
        The constraints' multipliers (constrained models; else shape (P, 0)).
    cost : float
        The objective at the optimum.
    duration : float
    iterations : int
        IPOPT's iterations, summed over the meshes.
    status : str
        IPOPT's return status on the last mesh ("Solve_Succeeded").
    intervals : int
        The last mesh's intervals N.
    collocation_error : float
        The largest interval's collocation error on the last mesh (see ``_collocation``).
    converged : bool
        True when the collocation error is at most the tolerance.
    meshes : tuple of dict
        Each mesh solved: {"intervals", "collocation_error", "iterations", "cost"}.
    constraint_error : float
        The largest |g(q)| and |G q_dot + b| of the constraints over the points (0 unconstrained).
    input_law : dict of str to Signal
        The free inputs as signals (cubic or linear between the points) that ``simulate`` accepts.
    replay_deviation : dict of str to float
        ``simulate`` from the initial state with ``input_law``: the largest |difference| from the
        collocated motion of each state over the points (NaN with ``replay_failure`` when it failed).
    replay_failure : str or None
    """

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    accelerations: np.ndarray
    multipliers: np.ndarray
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    cost: float
    duration: float
    iterations: int
    status: str
    intervals: int
    collocation_error: float
    converged: bool
    tolerance: float
    meshes: tuple[dict, ...]
    constraint_error: float
    input_law: dict[str, Any]
    replay_deviation: dict[str, float]
    replay_failure: str | None = None
    equations: Any = field(default=None, repr=False)
    _transcription: Any = field(default=None, repr=False)

    # ------------------------------------------------------------------ access
    @property
    def n(self) -> int:
        return len(self.state_names) // 2

    @property
    def model(self):
        return None if self.equations is None else self.equations.model

    @property
    def columns(self) -> tuple[str, ...]:
        """t, the states, then the inputs (the CSV's header)."""
        return ("t", *self.state_names, *self.input_names)

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "t":
            return self.t
        if name in self.state_names:
            return self.x[:, self.state_names.index(name)]
        if name in self.input_names:
            return self.u[:, self.input_names.index(name)]
        from .._util import did_you_mean

        raise KeyError(f"the optimal motion has no column '{name}'{did_you_mean(name, self.columns)}; its columns "
                       f"are {', '.join(self.columns)}")

    @property
    def max_replay_deviation(self) -> float:
        return max(self.replay_deviation.values()) if self.replay_deviation else 0.0

    def state_at(self, s: float) -> np.ndarray:
        """The state at time s: the collocation's cubic Hermite interpolant (exact at the points)."""
        n = self.n
        nodes = self.t[0::2]
        s = min(max(float(s), nodes[0]), nodes[-1])
        j = min(max(int(np.searchsorted(nodes, s, side="right")) - 1, 0), len(nodes) - 2)
        h = nodes[j + 1] - nodes[j]
        x0, x1 = self.x[2 * j], self.x[2 * j + 2]
        f0 = np.concatenate([x0[n:], self.accelerations[2 * j]])
        f1 = np.concatenate([x1[n:], self.accelerations[2 * j + 2]])
        r = (s - nodes[j]) / h
        return ((2 * r**3 - 3 * r**2 + 1) * x0 + (r**3 - 2 * r**2 + r) * h * f0 + (-2 * r**3 + 3 * r**2) * x1
                + (r**3 - r**2) * h * f1)

    def tracking_lqr(self, Q=None, R=None, Qf=None):
        """A time-varying LQR that holds this motion on the nonlinear model (unconstrained models).

        Parameters
        ----------
        Q : mapping of state name to weight, or array, shape (2n, 2n); default identity
        R : mapping of input name to weight (> 0), or array, shape (k, k); default identity
        Qf : array, shape (2n, 2n), optional
            The final weight S(T) (default Q).

        Returns
        -------
        TrackingLaw
            ``law.gains`` K(t) at the points; ``simulate(eqs, T, initial=x0, inputs=law.inputs())``
            runs u = u*(t) - K(t) (x - x*(t)).
        """
        from ._tracking import tracking_lqr

        return tracking_lqr(self, Q, R, Qf)

    # ------------------------------------------------------------------ output
    def to_dict(self) -> dict:
        """Plain data (JSON-ready: a number that is not finite is None): the numbers, the checks and the columns."""
        return _finite({
            "status": self.status, "cost": self.cost, "duration": self.duration, "iterations": self.iterations,
            "intervals": self.intervals, "collocation_error": self.collocation_error, "tolerance": self.tolerance,
            "converged": self.converged, "constraint_error": self.constraint_error,
            "replay_deviation": dict(self.replay_deviation),
            "replay_failure": self.replay_failure, "meshes": [dict(m) for m in self.meshes],
            "columns": list(self.columns),
            "t": self.t.tolist(), "states": {s: self[s].tolist() for s in self.state_names},
            "inputs": {u: self[u].tolist() for u in self.input_names},
        })

    def to_csv(self, path: str | os.PathLike | None = None) -> str | None:
        """The columns t, states, inputs as CSV (header first); the text when `path` is None, else
        written atomically (the same rules as ``Trajectory.to_csv``)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        for row in np.hstack([self.t[:, None], self.x, self.u]):
            w.writerow([repr(float(v)) for v in row])
        text = buf.getvalue()
        if path is None:
            return text
        from ..io._files import write_output

        write_output(path, text, "OptimalMotion.to_csv")
        return None

    def input_law_csv(self, path: str | os.PathLike | None = None, *, per_interval: int = 8) -> str | None:
        """The input law sampled as CSV (t, then each free input): `per_interval` samples per mesh
        interval, so that ``simulate --input F=@law.csv:F`` (linear between the samples) replays it
        closely (the law itself is piecewise quadratic)."""
        names = list(self.input_law)
        nodes = self.t[0::2]
        s = np.linspace(0.0, 1.0, per_interval + 1)[:-1]
        times = np.append((nodes[:-1, None] + np.diff(nodes)[:, None] * s).ravel(), nodes[-1])
        columns = [np.asarray(self.input_law[n](times), dtype=float) for n in names]
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["t", *names])
        for i, ti in enumerate(times):
            w.writerow([repr(float(ti))] + [repr(float(c[i])) for c in columns])
        text = buf.getvalue()
        if path is None:
            return text
        from ..io._files import write_output

        write_output(path, text, "--input-law")
        return None

    def plot(self, names=None, **kwargs):
        """Time histories (default: the coordinates, then the inputs); returns the Matplotlib figure."""
        from ..plot import time_history

        if names is None:
            names = [*self.state_names[: self.n], *self.input_law]
        return time_history(self, names, **kwargs)

    def __repr__(self) -> str:
        dev = f"{self.max_replay_deviation:.2g}" if self.replay_failure is None else "failed"
        return (f"OptimalMotion(status={self.status!r}, cost={self.cost:.6g}, duration={self.duration:.6g}, "
                f"intervals={self.intervals}, collocation_error={self.collocation_error:.2g}, "
                f"replay_deviation={dev})")


def _finite(value):
    """The same data with every float that is not finite (NaN, inf) as None: strict JSON."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value
