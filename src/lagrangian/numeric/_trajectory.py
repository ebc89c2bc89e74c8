"""Trajectory: the immutable result of a simulation."""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Trajectory"]


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


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

    def __post_init__(self):
        object.__setattr__(self, "t", _frozen(self.t))
        object.__setattr__(self, "x", _frozen(self.x))
        object.__setattr__(self, "u", _frozen(np.reshape(self.u, (len(self.t), len(self.input_names)))))
        if self.energy is not None:
            object.__setattr__(self, "energy", _frozen(self.energy))

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
        """Column names of the CSV: t, coordinates, velocities, inputs, then the energy."""
        extra = (self.energy_name,) if self.energy is not None else ()
        return ("t", *self.state_names, *self.input_names, *extra)

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
        raise KeyError(f"the trajectory has no column '{name}'; its columns are {', '.join(self.columns)}")

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
        return np.hstack(parts)

    def to_csv(self, path: str | os.PathLike | None = None) -> str | None:
        """Write the columns as CSV (header first) to `path`; return the text when `path` is None."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        for row in self.table():
            w.writerow([repr(float(v)) for v in row])
        text = buf.getvalue()
        if path is None:
            return text
        with open(path, "w", newline="") as fh:
            fh.write(text)
        return None

    def __repr__(self) -> str:
        return (f"<Trajectory: {len(self.t)} samples, t in [{self.t[0]:g}, {self.t[-1]:g}], "
                f"states {', '.join(self.state_names)}>") if len(self.t) else "<Trajectory: empty>"
