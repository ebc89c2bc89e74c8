"""A time-varying LQR along an optimal motion: it holds the motion on the nonlinear model.

Along the collocated motion x*(t), u*(t) the equations are linearized at every collocation point,
A = dF/dx and B = dF/du with F = [q_dot, a] and a from M a = f (implicit differentiation of the
residual M a - f: da/dx = M^-1 (df/dx - d(M a)/dx), da/du = M^-1 df/du; exact, by CasADi's AD of the
same SX graph the collocation used). The Riccati equation

    -S' = A^T S + S A - S B R^-1 B^T S + Q,   S(T) = Q_f

is integrated backwards (SciPy's DOP853, A and B linear between the points), and the law is

    u(t, x) = u*(t) - K(t) (x - x*(t)),   K = R^-1 B^T S,

x* the collocation's cubic Hermite interpolant and u* its input law.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ModelError

__all__ = ["TrackingLaw", "tracking_lqr"]


@dataclass(frozen=True, eq=False)
class TrackingLaw:
    """The time-varying LQR of an optimal motion (from :meth:`OptimalMotion.tracking_lqr`).

    Attributes
    ----------
    t : ndarray, shape (P,)
        The motion's points.
    gains : ndarray, shape (P, k, 2n)
        K(t) at the points (the free inputs' rows).
    riccati : ndarray, shape (P, 2n, 2n)
        S(t) at the points.
    input_names : tuple of str
        The free inputs, the rows of K.
    """

    t: np.ndarray
    gains: np.ndarray
    riccati: np.ndarray
    input_names: tuple[str, ...]
    motion: Any = field(repr=False)

    def gain(self, s: float) -> np.ndarray:
        """K at time s (linear between the points)."""
        s = min(max(float(s), self.t[0]), self.t[-1])
        i = min(max(int(np.searchsorted(self.t, s, side="right")) - 1, 0), len(self.t) - 2)
        w = (s - self.t[i]) / (self.t[i + 1] - self.t[i])
        return (1 - w) * self.gains[i] + w * self.gains[i + 1]

    def inputs(self) -> dict[str, Any]:
        """The law as simulate's inputs: ``simulate(eqs, T, initial=x0, inputs=law.inputs())``, each free
        input a function u(t, x) (SciPy's path) and every held input its value."""
        motion = self.motion
        out: dict[str, Any] = {}
        for name in motion.input_names:
            if name not in self.input_names:
                out[name] = float(motion[name][0])
        for j, name in enumerate(self.input_names):
            law = motion.input_law[name]

            def u(t, x, j=j, law=law):
                return float(law(t)) - float(self.gain(t)[j] @ (np.asarray(x, dtype=float) - motion.state_at(t)))

            out[name] = u
        return out


def tracking_lqr(motion, Q: Mapping[str, float] | np.ndarray | None = None,
                 R: Mapping[str, float] | np.ndarray | None = None,
                 Qf: np.ndarray | None = None) -> TrackingLaw:
    """The time-varying LQR along `motion` (see the module docstring); Q, R as diagonals by name
    ({"th": 10}) or matrices; defaults: identity; Qf defaults to Q."""
    from scipy.integrate import solve_ivp

    tr = motion._transcription
    if tr is None:
        raise ModelError("this optimal motion has no transcription to linearize (built by hand?); compute it with "
                         "lagrangian.optimal_motion")
    if tr.m:
        raise ModelError("tracking_lqr does not handle constrained models yet (the LQR would act in the "
                         "independent coordinates); simulate the input law open loop (motion.input_law)")
    n2 = 2 * tr.n
    free = [j for j, name in enumerate(tr.input_names) if name in motion.input_law]
    names = tuple(tr.input_names[j] for j in free)
    if not free:
        raise ModelError("the optimal motion has no free input to feed back; give inputs bounds in the problem")
    Qm = _weights(Q, motion.state_names, "Q")
    Rm = _weights(R, names, "R")
    Qfm = Qm if Qf is None else _weights(Qf, motion.state_names, "Qf")
    if np.any(np.linalg.eigvalsh(Rm) <= 0):
        raise ModelError("R must be positive definite (every input weighted): give R = {input: weight > 0}")
    A = np.empty((len(motion.t), n2, n2))
    B = np.empty((len(motion.t), n2, len(free)))
    for p, ti in enumerate(motion.t):
        Ap, Bp = tr.linear(motion.x[p], motion.u[p], float(ti))
        A[p], B[p] = Ap, Bp[:, free]
    t = np.asarray(motion.t)
    Rinv = np.linalg.inv(Rm)

    def at(arr, s):
        i = min(max(int(np.searchsorted(t, s, side="right")) - 1, 0), len(t) - 2)
        w = (s - t[i]) / (t[i + 1] - t[i])
        return (1 - w) * arr[i] + w * arr[i + 1]

    def rhs(s, y):
        S = y.reshape(n2, n2)
        As, Bs = at(A, s), at(B, s)
        dS = -(As.T @ S + S @ As - S @ Bs @ Rinv @ Bs.T @ S + Qm)
        return ((dS + dS.T) / 2).ravel()

    sol = solve_ivp(rhs, (t[-1], t[0]), Qfm.ravel(), t_eval=t[::-1], method="DOP853", rtol=1e-8, atol=1e-10)
    if not sol.success:
        raise ModelError(f"the Riccati equation could not be integrated backwards: {sol.message}")
    S = sol.y.T[::-1].reshape(len(t), n2, n2)
    K = np.stack([Rinv @ B[p].T @ S[p] for p in range(len(t))])
    for arr in (K, S):
        arr.setflags(write=False)
    return TrackingLaw(t=t, gains=K, riccati=S, input_names=names, motion=motion)


def _weights(value, names, what: str) -> np.ndarray:
    size = len(names)
    if value is None:
        return np.eye(size)
    if isinstance(value, Mapping):
        unknown = [k for k in value if k not in names]
        if unknown:
            from .._util import did_you_mean

            raise ModelError(f"{what}: '{unknown[0]}' is not one of {', '.join(names)}"
                             f"{did_you_mean(unknown[0], names, 0.5)}; give {what} as {{name: weight}}")
        diag = np.array([float(value.get(k, 0.0)) for k in names])
        if np.any(~np.isfinite(diag)) or np.any(diag < 0):
            raise ModelError(f"{what}: the weights must be finite and >= 0, got {dict(value)}")
        return np.diag(diag)
    m = np.asarray(value, dtype=float)
    if m.shape != (size, size) or not np.all(np.isfinite(m)):
        raise ModelError(f"{what}: expected a finite {size} x {size} matrix (or {{name: weight}}), got shape "
                         f"{m.shape}")
    return (m + m.T) / 2
