"""modes(linear_model) -> Modes: natural frequencies, mode shapes, modal masses and damping ratios.

The undamped modes solve K phi = omega^2 M phi (K's symmetric part; M symmetric positive definite),
with shapes normalized so that phi^T M phi = 1. A mode with omega^2 = 0 (to round-off) is rigid; one
with omega^2 < 0 is unstable (it diverges, and has no frequency). The damping ratios come from the
eigenvalues of the state matrix A (which keeps damping and gyroscopic terms): each pair
lambda = -zeta omega_n +- i omega_n sqrt(1 - zeta^2) is matched to the undamped mode it moves most,
zeta = -Re(lambda) / |lambda|; an overdamped mode (two real eigenvalues) has
zeta = -(lambda1 + lambda2) / (2 sqrt(lambda1 lambda2)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ._linearize import LinearModel
from .._util import read_only

__all__ = ["modes", "Modes"]


@dataclass(frozen=True, eq=False)
class Modes:
    """The modes of a linearization (returned by :func:`modes`); arrays are read-only, one entry
    (or row) per mode, rigid and elastic modes by ascending frequency, then unstable ones.

    Attributes
    ----------
    coordinate_names : tuple of str
    frequencies : ndarray, shape (n,)
        Undamped natural frequencies omega (rad/s); 0 for rigid modes, NaN for unstable ones.
    frequencies_hz : ndarray, shape (n,)
        omega / (2 pi).
    kinds : tuple of str
        "rigid", "elastic" or "unstable" for each mode.
    shapes : ndarray, shape (n, n)
        Mode shapes, one row per mode, mass-normalized: phi^T M phi = 1.
    unit_shapes : ndarray, shape (n, n)
        The same shapes scaled so that their largest component is +1.
    modal_masses, modal_stiffnesses : ndarray, shape (n,)
        phi^T M phi and phi^T K phi for the unit shapes (their ratio is omega^2).
    damping_ratios : ndarray, shape (n,)
        zeta of each mode from the eigenvalues of A (NaN for rigid and unstable modes); exactly 0
        when the velocity terms neither take nor give power (C = 0 and G skew-symmetric), not the
        round-off of the eigenvalues. (A rolling bicycle's weave decays with C = 0: its velocity
        terms from the constraints are not skew-symmetric.)
    damped_frequencies : ndarray, shape (n,)
        |Im(lambda)| (rad/s): 0 for an overdamped mode.
    proportional_damping : bool
        Whether the damping matrix is diagonal in the modal coordinates (classical damping).
    eigenvalues : ndarray of complex, shape (2n,)
        Of A.
    damped : bool
        Whether the linearization has damping at all (C != 0: a damper, a viscous force); False
        for a conservative system, a rolling one included.
    coupling : tuple of str
        "gyroscopic" (G != 0) and "circulatory" (K not symmetric) when the linearization has such
        terms: the modes above are those of M and K's symmetric part alone, and the motion's
        eigenvalues (of A) decide its stability (a spinning top, a rolling wheel, a bicycle).
    """

    coordinate_names: tuple[str, ...]
    frequencies: np.ndarray = field(repr=False)
    frequencies_hz: np.ndarray
    kinds: tuple[str, ...]
    shapes: np.ndarray = field(repr=False)
    unit_shapes: np.ndarray = field(repr=False)
    modal_masses: np.ndarray = field(repr=False)
    modal_stiffnesses: np.ndarray = field(repr=False)
    damping_ratios: np.ndarray
    damped_frequencies: np.ndarray = field(repr=False)
    proportional_damping: bool
    eigenvalues: np.ndarray = field(repr=False)
    coupling: tuple[str, ...] = ()
    damped: bool = True

    def to_dict(self) -> dict:
        """The JSON contract: frequencies_hz (ascending; null for unstable modes), damping_ratios
        (null where undefined), shapes (one list per mode, mass-normalized), and the rest."""
        def listed(a):
            return [None if not math.isfinite(x) else float(x) for x in a]

        return {
            "coordinates": list(self.coordinate_names),
            "frequencies_hz": listed(self.frequencies_hz),
            "frequencies_rad_s": listed(self.frequencies),
            "kinds": list(self.kinds),
            "damping_ratios": listed(self.damping_ratios),
            "damped_frequencies_rad_s": listed(self.damped_frequencies),
            "shapes": [listed(s) for s in self.shapes],
            "unit_shapes": [listed(s) for s in self.unit_shapes],
            "modal_masses": listed(self.modal_masses),
            "modal_stiffnesses": listed(self.modal_stiffnesses),
            "proportional_damping": self.proportional_damping,
            "damped": self.damped,
            "coupling": list(self.coupling),
        }

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.text())}</pre>"

    def text(self) -> str:
        lines = [f"{'mode':>4}  {'kind':<8} {'f (Hz)':>12} {'omega (rad/s)':>14} {'zeta':>10}  shape ("
                 + ", ".join(self.coordinate_names) + "; largest component 1)"]
        for k in range(len(self.kinds)):
            def num(x, fmt):
                return f"{x:{fmt}}" if math.isfinite(x) else f"{'-':>{fmt.split('.')[0]}}"

            shape = ", ".join(f"{x:.4g}" for x in self.unit_shapes[k])
            lines.append(f"{k + 1:>4}  {self.kinds[k]:<8} {num(self.frequencies_hz[k], '12.6g')} "
                         f"{num(self.frequencies[k], '14.6g')} {num(self.damping_ratios[k], '10.4g')}  [{shape}]")
        lines.append("no damping (C = 0)" if not self.damped else "damping is " + (
            "proportional (classical)" if self.proportional_damping
            else "not proportional: the modes couple through it"))
        if self.coupling:
            from ._linearize import _complex_text

            lines.append(f"{' and '.join(self.coupling)} terms couple these modes, which are those of M and K alone: "
                         "the motion's eigenvalues are " + ", ".join(_complex_text(z) for z in self.eigenvalues)
                         + " (they, not the kinds above, decide its stability)")
        return "\n".join(lines)


def modes(linear_model: LinearModel) -> Modes:
    """The modes of a linearization (see the module docstring for the definitions).

    Parameters
    ----------
    linear_model : LinearModel
        From :func:`linearize`, usually at a stable equilibrium.

    Returns
    -------
    Modes
    """
    if not isinstance(linear_model, LinearModel):
        raise TypeError(f"modes() expects a LinearModel (lagrangian.linearize(...)), got "
                        f"{type(linear_model).__name__}")
    import scipy.linalg

    lin = linear_model
    M, K, C = np.asarray(lin.M), np.asarray(lin.K), np.asarray(lin.C)
    n = lin.n
    Ks = (K + K.T) / 2
    lam, phi = scipy.linalg.eigh(Ks, M)
    scale = max(float(np.abs(lam).max()), 1e-300) if lam.size else 1.0
    tol = 1e-9 * scale
    kinds = ["rigid" if abs(x) <= tol else "elastic" if x > 0 else "unstable" for x in lam]
    order = sorted(range(n), key=lambda k: (kinds[k] == "unstable", lam[k] if kinds[k] != "unstable" else -lam[k]))
    lam, phi = lam[order], phi[:, order]
    kinds = [kinds[k] for k in order]
    omega = np.array([0.0 if k == "rigid" else math.sqrt(x) if k == "elastic" else math.nan
                      for k, x in zip(kinds, lam)])
    shapes = phi.T.copy()
    for s in shapes:  # sign: largest component positive
        if s[np.argmax(np.abs(s))] < 0:
            s *= -1
    unit = shapes / np.abs(shapes).max(axis=1, keepdims=True)
    for s in unit:
        if s[np.argmax(np.abs(s))] < 0:
            s *= -1
    modal_m = np.einsum("ki,ij,kj->k", unit, M, unit)
    modal_k = np.einsum("ki,ij,kj->k", unit, K, unit)
    zeta, wd = _damping(lin, shapes, kinds)
    Cm = shapes @ C @ shapes.T
    off = Cm - np.diag(np.diag(Cm))
    proportional = bool(np.abs(off).max(initial=0.0) <= 1e-8 * max(np.abs(Cm).max(initial=0.0), 1e-300))
    size = max(float(np.abs(K).max(initial=0.0)), float(np.abs(M).max(initial=0.0)), 1e-300)
    coupling = tuple(word for word, present in (
        ("gyroscopic", np.abs(np.asarray(lin.G)).max(initial=0.0) > 1e-12 * size),
        ("circulatory", np.abs(K - K.T).max(initial=0.0) > 1e-12 * size)) if present)
    return Modes(lin.coordinate_names, read_only(omega), read_only(omega / (2 * math.pi)), tuple(kinds),
                 read_only(shapes), read_only(unit), read_only(modal_m), read_only(modal_k),
                 read_only(zeta), read_only(wd), proportional, lin.eigenvalues, coupling, bool(np.any(C)))


def _damping(lin: LinearModel, shapes: np.ndarray, kinds: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Match the eigenvalues of A to the undamped modes; zeta and the damped frequency of each."""
    n = lin.n
    lam, vec = np.linalg.eig(np.asarray(lin.A))
    M = np.asarray(lin.M)
    scale = max(1.0, float(np.abs(lam).max()))
    # one member of each complex pair, and every real eigenvalue
    keep = [k for k in range(2 * n) if lam[k].imag > 1e-9 * scale or abs(lam[k].imag) <= 1e-9 * scale]
    content = np.zeros((n, len(keep)))
    for c, k in enumerate(keep):
        v = vec[:n, k]
        w = np.abs(shapes @ M @ v)
        content[:, c] = w / max(w.sum(), 1e-300)
    slots = {j: 2 if kinds[j] == "elastic" else 0 for j in range(n)}
    assigned: dict[int, list[complex]] = {j: [] for j in range(n)}
    need = {c: (2 if abs(lam[k].imag) > 1e-9 * scale else 1) for c, k in enumerate(keep)}
    pairs = sorted(((content[j, c], j, c) for j in range(n) for c in range(len(keep))), reverse=True)
    used = set()
    for _, j, c in pairs:
        if c in used or slots[j] < need[c]:
            continue
        slots[j] -= need[c]
        used.add(c)
        assigned[j].append(lam[keep[c]])
    zeta = np.full(n, math.nan)
    wd = np.full(n, math.nan)
    V = np.asarray(lin.C) + np.asarray(lin.G)
    undamped = not np.any(V + V.T)  # velocity terms that neither take nor give power: real parts are round-off
    for j, values in assigned.items():
        if len(values) == 1 and abs(values[0].imag) > 1e-9 * scale:
            z = values[0]
            zeta[j] = 0.0 if undamped else -z.real / abs(z) + 0.0
            wd[j] = abs(z.imag)
        elif len(values) == 2 and all(abs(z.imag) <= 1e-9 * scale for z in values):
            a, b = (z.real for z in values)
            if a * b > 0:
                zeta[j] = -(a + b) / (2 * math.sqrt(a * b))
                wd[j] = 0.0
    return zeta, wd
