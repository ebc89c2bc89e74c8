"""State feedback designed on a linearization: LQR and pole placement.

A :class:`~lagrangian.analysis.LinearModel` about an equilibrium (x0, u0) gives
dx' = A dx + B du with dx = x - x0, du = u - u0. A gain K (m x 2n) closes the loop with

    u = u0 - K (x - x0),      dx' = (A - B K) dx,

and the law is written as one expression per input, in the language of ``simulate``'s inputs, so
that the nonlinear model is simulated with it as it is (a feedback law compiles nothing).

* :func:`lqr`: K = R^-1 B^T P, P the stabilizing solution of the continuous algebraic Riccati
  equation A^T P + P A - P B R^-1 B^T P + Q = 0 (minimizing the integral of dx^T Q dx + du^T R du);
  with a sample time, the discrete Riccati equation of the zero-order-hold discretization
  (Ad, Bd), minimizing the sum of dx_k^T Q dx_k + du_k^T R du_k.
* :func:`place`: K such that the eigenvalues of A - B K are the given poles (SciPy's
  ``place_poles``); with a sample time, those of Ad - Bd K are exp(pole * Ts).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np

from .._limits import MAX_MAGNITUDE
from .._util import did_you_mean, read_only, shown_value
from ..equations._exact import exact_number
from ..errors import DesignError, ModelError, Problem

__all__ = ["StateFeedback", "DesignError", "lqr", "place", "discretize"]


def _frozen(a) -> np.ndarray:
    """A read-only float array, complex where `a` is (eigenvalues)."""
    return read_only(a, complex if np.iscomplexobj(a) else float)


def _sorted(eigenvalues: np.ndarray) -> np.ndarray:
    lam = np.asarray(eigenvalues, dtype=complex)
    if lam.size:  # round-off as exact zeros
        tiny = 1e-12 * max(1.0, float(np.abs(lam).max()))
        lam = (np.where(np.abs(lam.real) <= tiny, 0.0, lam.real)
               + 1j * np.where(np.abs(lam.imag) <= tiny, 0.0, lam.imag))
    return lam[np.lexsort((lam.imag, lam.real))]


def _number_text(value: float) -> str:
    """A float as the shortest text that reads back as it (17 digits at most), without a
    trailing '.0' for whole numbers."""
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


@dataclass(frozen=True, eq=False)
class StateFeedback:
    """A state-feedback law u = u0 - K (x - x0) designed on a linearization (returned by
    :func:`lqr`, :func:`place`, ``LinearModel.lqr`` and ``LinearModel.place``).

    Attributes
    ----------
    K : ndarray, shape (m, 2n)
        The gain; rows in `input_names` order, columns in `state_names` order.
    state_names, input_names : tuple of str
    operating_point : mapping of str to float
        x0 by state name.
    input_values : mapping of str to float
        u0 by input name.
    eigenvalues : ndarray of complex, shape (2n,)
        The closed-loop eigenvalues: of A - B K, or, with a sample time, of Ad - Bd K (the
        z-plane; |z| < 1 is stable); sorted by real part, then imaginary part.
    open_loop : ndarray of complex, shape (2n,)
        The eigenvalues of A (or Ad).
    method : str
        "lqr" or "place".
    sample_time : float or None
        The period of a discrete design (the law is then to be sampled every sample_time
        seconds: ``simulate(..., sample_time=fb.sample_time)``); None for a continuous one.
    Q, R, P : ndarray or None
        The weights and the Riccati solution (LQR only).
    """

    K: np.ndarray = field(repr=False)
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    operating_point: Mapping[str, float]
    input_values: Mapping[str, float]
    eigenvalues: np.ndarray = field(repr=False)
    open_loop: np.ndarray = field(repr=False)
    method: str
    sample_time: float | None = None
    Q: np.ndarray | None = field(default=None, repr=False)
    R: np.ndarray | None = field(default=None, repr=False)
    P: np.ndarray | None = field(default=None, repr=False)
    exact_point: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}), repr=False)
    model_name: str = ""

    @property
    def gains(self) -> dict[str, dict[str, float]]:
        """K by name: ``gains[input][state]``."""
        return {u: {x: float(self.K[i, j]) for j, x in enumerate(self.state_names)}
                for i, u in enumerate(self.input_names)}

    @property
    def stable(self) -> bool:
        """Whether the designed closed loop is asymptotically stable."""
        if self.sample_time is None:
            return bool(np.all(self.eigenvalues.real < 0))
        return bool(np.all(np.abs(self.eigenvalues) < 1))

    def _error(self, name: str, wrap: Sequence[str]) -> str:
        """The text of x - x0 for one state; an angle in `wrap` as atan2(sin(.), cos(.))."""
        x0 = self.operating_point[name]
        if name in wrap:
            inner = name if x0 == 0 else f"{name} - {self._x0_text(name)}"
            return f"atan2(sin({inner}), cos({inner}))"
        if x0 == 0:
            return name
        return f"({name} - {self._x0_text(name)})" if x0 > 0 else f"({name} + {self._x0_text(name, -1)})"

    def _x0_text(self, name: str, sign: int = 1) -> str:
        exact = self.exact_point.get(name)
        if exact is not None:
            if sign > 0:
                return exact
            return exact[1:] if exact.startswith("-") else f"({exact})"
        return _number_text(sign * self.operating_point[name])

    def law(self, wrap: Sequence[str] = ()) -> dict[str, str]:
        """The law u = u0 - K (x - x0) as an expression for each input, in the language of
        ``simulate``'s inputs (``--input NAME=EXPR``), with the gains to full precision.

        Parameters
        ----------
        wrap : sequence of str
            Coordinates that are angles: their error is taken modulo 2 pi,
            ``atan2(sin(q - q0), cos(q - q0))``, so that the law holds the nearest of the
            equivalent positions (q0 + 2 pi k) instead of unwinding the turns made.

        Returns
        -------
        dict of str to str
            ``{input name: expression}``: pass it as ``simulate(..., inputs=...)``.
        """
        wrap = tuple(wrap)
        n = len(self.state_names) // 2
        unknown = [w for w in wrap if w not in self.state_names[:n]]
        if unknown:
            raise ModelError(f"wrap names {', '.join(unknown)}, which {'is' if len(unknown) == 1 else 'are'} not "
                             f"a coordinate; the coordinates are {', '.join(self.state_names[:n])}")
        out = {}
        for i, u in enumerate(self.input_names):
            terms = []
            u0 = self.input_values.get(u, 0.0)
            if u0:
                terms.append(_number_text(u0))
            for j, name in enumerate(self.state_names):
                k = -float(self.K[i, j])
                if k == 0:
                    continue
                sign = "-" if k < 0 else "+"
                text = f"{_number_text(abs(k))}*{self._error(name, wrap)}"
                terms.append(f"{sign} {text}" if terms else (f"-{text}" if k < 0 else text))
            out[u] = " ".join(terms) if terms else "0"
        return out

    @property
    def inputs(self) -> dict[str, str]:
        """:meth:`law` without wrapping: ``simulate(eqs, ..., inputs=fb.inputs)``."""
        return self.law()

    def input_options(self, wrap: Sequence[str] = ()) -> list[str]:
        """The law as command-line options: ``['--input', 'F=...', ...]`` (and
        ``--sample-time`` for a discrete design)."""
        out = []
        for u, expr in self.law(wrap).items():
            out += ["--input", f"{u}={expr}"]
        if self.sample_time is not None:
            out += ["--sample-time", _number_text(self.sample_time)]
        return out

    def to_dict(self, wrap: Sequence[str] = ()) -> dict:
        """The JSON contract of ``lagrangian lqr --json`` and ``lagrangian place --json`` (see
        docs/conventions.md)."""
        out = {
            "model": self.model_name,
            "method": self.method,
            "state_names": list(self.state_names),
            "input_names": list(self.input_names),
            "operating_point": dict(self.operating_point),
            "inputs": dict(self.input_values),
            "K": self.K.tolist(),
            "gains": self.gains,
            "closed_loop_eigenvalues": [[float(z.real), float(z.imag)] for z in self.eigenvalues],
            "open_loop_eigenvalues": [[float(z.real), float(z.imag)] for z in self.open_loop],
            "stable": self.stable,
            "sample_time": self.sample_time,
            "law": self.law(wrap),
            "input_options": self.input_options(wrap),
        }
        if self.method == "lqr":
            out.update(Q=self.Q.tolist(), R=self.R.tolist(), P=self.P.tolist())
        return out

    @property
    def _letters(self) -> dict[str, str]:
        """The letters of the state and input vectors: x and u, or others where the model has those names."""
        from ..equations._equations import vector_letters

        return vector_letters({*self.state_names, *self.input_names})

    def text(self, wrap: Sequence[str] = ()) -> str:
        """A report: the gain by name, the eigenvalues and the law."""
        at = ", ".join(f"{k} = {self._x0_text(k) if k in self.exact_point else f'{v:.6g}'}"
                       for k, v in self.operating_point.items())
        kind = {"lqr": "LQR", "place": "Pole placement"}[self.method]
        if self.sample_time is not None:
            kind += f", discrete (sampled every {self.sample_time:g} s, zero-order hold)"
        lines = [f"{kind} for {self.model_name or 'the model'} at {at}"
                 + (", inputs " + ", ".join(f"{k} = {v:g}" for k, v in self.input_values.items())
                    if any(self.input_values.values()) else ""),
                 "  {u} = {u}0 - K ({x} - {x}0), K =".format(**self._letters)]
        width = max(12, *(len(s) + 2 for s in self.state_names))
        lines.append("    " + " " * max(len(u) for u in self.input_names)
                     + "".join(f"{s:>{width}}" for s in self.state_names))
        for i, u in enumerate(self.input_names):
            lines.append(f"    {u:>{max(len(v) for v in self.input_names)}}"
                         + "".join(f"{float(k):>{width}.6g}" for k in self.K[i]))
        plane = "z-plane, |z| < 1 stable" if self.sample_time is not None else "A - B K"
        lines.append(f"  closed-loop eigenvalues ({plane}): " + ", ".join(_complex(z) for z in self.eigenvalues))
        lines.append("  open-loop eigenvalues: " + ", ".join(_complex(z) for z in self.open_loop))
        lines.append("  " + ("stable" if self.stable else "NOT stable"))
        lines.append("  the law, to simulate the nonlinear model with:")
        for u, expr in self.law(wrap).items():
            lines.append(f"    --input \"{u}={expr}\"")
        if self.sample_time is not None:
            lines.append(f"    --sample-time {_number_text(self.sample_time)}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (f"<StateFeedback ({self.method}) of {self.model_name!r}: K {self.K.shape}, closed-loop eigenvalues "
                + ", ".join(_complex(z) for z in self.eigenvalues) + ">")


def _complex(z: complex) -> str:
    if abs(z.imag) <= 1e-12 * max(1.0, abs(z)):
        return f"{z.real:.6g}"
    return f"{z.real:.6g}{z.imag:+.6g}j"


# --------------------------------------------------------------------------- checks


def _weights(value, names: tuple[str, ...], what: str, default_missing: float | None,
             problems: list[Problem]) -> np.ndarray | None:
    """A weight matrix from None (identity), a number (times the identity), a vector (diagonal),
    a matrix, or a mapping of names to diagonal weights (the names not given: `default_missing`,
    or a problem when None)."""
    k = len(names)
    if value is None:
        return np.eye(k)
    if isinstance(value, Mapping):
        diag = np.full(k, np.nan if default_missing is None else default_missing)
        for name, w in value.items():
            name = getattr(name, "name", name)
            if name not in names:
                problems.append(Problem(f"'{name}' is not one of {', '.join(names)}" + did_you_mean(name, names, 0.5),
                                        key=f"{what}.{name}"))
            elif (not isinstance(w, numbers.Real) or isinstance(w, bool) or not math.isfinite(w)
                  or abs(w) > MAX_MAGNITUDE):
                problems.append(Problem(f"the weight of '{name}' must be a finite number of magnitude at most "
                                        f"{MAX_MAGNITUDE:g}, got {shown_value(w)}", key=f"{what}.{name}"))
            else:
                diag[names.index(name)] = float(w)
        missing = [n for n, d in zip(names, diag) if np.isnan(d)]
        if missing:
            problems.append(Problem(f"{what} must give every one of {', '.join(names)} a weight; missing "
                                    f"{', '.join(missing)}", key=what))
            return None
        return np.diag(diag)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        problems.append(Problem(f"{what} must be a number, a vector of {k} weights, a {k} x {k} matrix or a "
                                f"mapping of names to weights, got {shown_value(value)}", key=what))
        return None
    if arr.ndim == 0:
        arr = float(arr) * np.eye(k)
    elif arr.ndim == 1:
        if arr.shape != (k,):
            problems.append(Problem(f"{what} as a vector must have {k} weights ({', '.join(names)}), got "
                                    f"{arr.shape[0]}", key=what))
            return None
        arr = np.diag(arr)
    if arr.shape != (k, k):
        problems.append(Problem(f"{what} must be {k} x {k} ({', '.join(names)}), got shape {arr.shape}", key=what))
        return None
    if not np.all(np.isfinite(arr)):
        problems.append(Problem(f"{what} must be finite", key=what))
        return None
    if arr.size and np.max(np.abs(arr)) > MAX_MAGNITUDE:
        problems.append(Problem(f"{what} has a weight of {np.max(np.abs(arr)):g}, too large: at most "
                                f"{MAX_MAGNITUDE:g} in magnitude; scale the weights down (only their ratios matter)",
                                key=what))
        return None
    return arr


def _check_symmetric(W: np.ndarray, what: str, definite: bool, problems: list[Problem]) -> None:
    scale = max(1.0, float(np.abs(W).max())) if W.size else 1.0
    if not np.allclose(W, W.T, rtol=1e-10, atol=1e-12 * scale):
        problems.append(Problem(f"{what} must be symmetric", key=what))
        return
    lowest = float(np.linalg.eigvalsh((W + W.T) / 2).min()) if W.size else 1.0
    if definite and lowest <= 1e-14 * scale:
        problems.append(Problem(f"{what} must be positive definite (every input needs a positive weight: a free "
                                f"input has no cost), but its smallest eigenvalue is {lowest:.3g}", key=what))
    elif not definite and lowest < -1e-12 * scale:
        problems.append(Problem(f"{what} must be positive semi-definite (weights >= 0), but its smallest eigenvalue "
                                f"is {lowest:.3g}", key=what))


def _check_design(lin, sample_time) -> None:
    """The linearization must be about an equilibrium, with inputs."""
    if not lin.input_names:
        raise ModelError(f"{lin.equations.model.name} has no inputs, so there is nothing to feed back: declare an "
                         "input (inputs = [\"F\"] and a force or torque that uses it)")
    if not lin.is_equilibrium:
        qdd = ", ".join(f"{c}_ddot = {a:.3g}" for c, a in zip(lin.coordinate_names, lin.accelerations))
        raise ModelError(f"the operating point is not an equilibrium ({qdd}): a state feedback holds the system at "
                         "an equilibrium; choose the point (--at, at=...) and the constant inputs "
                         "(--input, inputs=...) "
                         "so that every acceleration is 0")
    if sample_time is not None and (not isinstance(sample_time, numbers.Real) or isinstance(sample_time, bool)
                                    or not sample_time > 0 or not math.isfinite(sample_time)):
        raise ModelError(f"sample_time must be a positive number of seconds, got {sample_time!r}")


def discretize(A: np.ndarray, B: np.ndarray, sample_time: float) -> tuple[np.ndarray, np.ndarray]:
    """The zero-order-hold discretization (Ad, Bd) = (e^{A Ts}, int_0^Ts e^{A s} ds B)."""
    from scipy.linalg import expm

    n, m = B.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n] = A
    block[:n, n:] = B
    E = expm(block * sample_time)
    return E[:n, :n], E[:n, n:]


def _uncontrollable(A, B, discrete: bool) -> list[complex]:
    """The unstable eigenvalues of A that the inputs cannot move (PBH test)."""
    lam = np.linalg.eigvals(A)
    scale = max(1.0, float(np.abs(A).max()), float(np.abs(B).max()) if B.size else 1.0)
    out = []
    for z in lam:
        unstable = abs(z) >= 1 - 1e-9 if discrete else z.real >= -1e-9 * scale
        if not unstable:
            continue
        M = np.hstack((A - z * np.eye(len(A)), B))
        s = np.linalg.svd(M, compute_uv=False)
        if s[-1] <= 1e-9 * scale and not any(abs(z - w) <= 1e-9 * scale for w in out):
            out.append(complex(z))
    return out


def _uncontrollable_error(lin, modes: list[complex]) -> DesignError:
    shown = ", ".join(_complex(z) for z in _sorted(np.array(modes)))
    cyclic = f" (cyclic coordinates, free to drift: {', '.join(lin.family)})" if lin.family else ""
    return DesignError(f"no state feedback stabilizes {lin.equations.model.name} here: the unstable eigenvalue(s) "
                       f"{shown} of A cannot be moved by the inputs {', '.join(lin.input_names)}{cyclic}; "
                       "add an input that acts on that motion, or linearize about another point")


def _plant(lin, sample_time) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the design: the linearization's, or its zero-order-hold discretization; refused
    when an unstable mode cannot be moved by the inputs."""
    A, B = np.asarray(lin.A, float), np.asarray(lin.B, float)
    if sample_time is not None:
        with np.errstate(over="ignore", invalid="ignore"):
            A, B = discretize(A, B, float(sample_time))
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
            raise ModelError(f"sample_time {float(sample_time):g} s is too long for {lin.equations.model.name}: "
                             "e^(A Ts) of its unstable modes overflows double precision; choose a sample time "
                             "shorter than the time scales of the motion (for example 0.01 s)")
    bad = _uncontrollable(A, B, sample_time is not None)
    if bad:
        raise _uncontrollable_error(lin, bad)
    return A, B


def _result(lin, K, A, B, method, sample_time, **extra) -> StateFeedback:
    exact = {}
    for name, v in lin.operating_point.items():
        e = exact_number(v, lin._exact_point.get(name))
        if e.free_symbols == set() and not e.is_Float and not e.is_Integer:
            exact[name] = str(e)
    return StateFeedback(
        K=_frozen(K), state_names=lin.state_names, input_names=lin.input_names,
        operating_point=MappingProxyType(dict(lin.operating_point)),
        input_values=MappingProxyType({u: float(lin.input_values.get(u, 0.0)) for u in lin.input_names}),
        eigenvalues=_frozen(_sorted(np.linalg.eigvals(A - B @ K))), open_loop=_frozen(_sorted(np.linalg.eigvals(A))),
        method=method, sample_time=None if sample_time is None else float(sample_time),
        exact_point=MappingProxyType(exact), model_name=lin.equations.model.name,
        **{k: (None if v is None else _frozen(v)) for k, v in extra.items()})


# --------------------------------------------------------------------------- designs


def lqr(linear_model, Q=None, R=None, *, sample_time: float | None = None) -> StateFeedback:
    """The linear-quadratic regulator of a linearization.

    Parameters
    ----------
    linear_model : LinearModel
        A linearization about an equilibrium (``lg.linearize(eqs, at=...)``).
    Q : None, float, array_like (2n,) or (2n, 2n), or mapping of str to float
        State weights: the identity (None), a multiple of it, a diagonal, a symmetric positive
        semi-definite matrix, or diagonal weights by state name (the states not named weigh 0).
    R : None, float, array_like (m,) or (m, m), or mapping of str to float
        Input weights (positive definite): the identity (None), ..., or a weight for every
        input by name.
    sample_time : float, optional
        Design for a controller sampled every `sample_time` seconds with a zero-order hold:
        the discrete LQR of the exact discretization (Ad, Bd).

    Returns
    -------
    StateFeedback

    Raises
    ------
    ModelError
        Bad weights (shape, sign, names), no inputs, or an operating point that is not an
        equilibrium.
    DesignError
        An unstable mode that the inputs cannot move, or no stabilizing solution of the
        Riccati equation (an unstable mode that Q does not see).
    """
    from scipy import linalg

    lin = linear_model
    _check_design(lin, sample_time)
    problems: list[Problem] = []
    Qm = _weights(Q, lin.state_names, "Q", 0.0, problems)
    Rm = _weights(R, lin.input_names, "R", None, problems)
    if Qm is not None:
        _check_symmetric(Qm, "Q", False, problems)
    if Rm is not None:
        _check_symmetric(Rm, "R", True, problems)
    if problems:
        raise ModelError(problems)
    A, B = _plant(lin, sample_time)
    discrete = sample_time is not None
    try:
        if discrete:
            P = linalg.solve_discrete_are(A, B, Qm, Rm)
            K = np.linalg.solve(Rm + B.T @ P @ B, B.T @ P @ A)
        else:
            P = linalg.solve_continuous_are(A, B, Qm, Rm)
            K = np.linalg.solve(Rm, B.T @ P)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise DesignError(f"the Riccati equation has no stabilizing solution ({exc}): an unstable or marginal mode is "
                          "probably not seen by Q; give the states of that motion a positive weight") from None
    closed = np.linalg.eigvals(A - B @ K)
    if (np.any(np.abs(closed) >= 1) if discrete else np.any(closed.real >= 0)) or not np.all(np.isfinite(K)):
        raise DesignError("the LQR gain does not stabilize the linearization (closed-loop eigenvalues "
                          + ", ".join(_complex(z) for z in _sorted(closed)) + "): a mode on the stability boundary is "
                          "probably not seen by Q; give the states of that motion a positive weight")
    return _result(lin, K, A, B, "lqr", sample_time, Q=Qm, R=Rm, P=P)


def place(linear_model, poles, *, sample_time: float | None = None) -> StateFeedback:
    """Pole placement on a linearization: K such that A - B K has the given eigenvalues.

    Parameters
    ----------
    linear_model : LinearModel
        A linearization about an equilibrium.
    poles : sequence of complex, length 2n
        The closed-loop eigenvalues (s-plane); complex ones in conjugate pairs, each repeated at
        most as many times as there are inputs.
    sample_time : float, optional
        Design for a controller sampled every `sample_time` seconds: the eigenvalues of
        Ad - Bd K are exp(pole * sample_time).

    Returns
    -------
    StateFeedback

    Raises
    ------
    ModelError
        Wrong number of poles, unpaired complex poles, a pole repeated more often than there
        are inputs, no inputs, or an operating point that is not an equilibrium.
    DesignError
        An uncontrollable mode, or SciPy's placement failing.
    """
    from scipy.signal import place_poles

    lin = linear_model
    _check_design(lin, sample_time)
    nx, m = len(lin.state_names), len(lin.input_names)
    try:
        wanted = np.asarray(list(poles), dtype=complex).ravel()
    except (TypeError, ValueError):
        raise ModelError(f"poles must be a sequence of {nx} numbers (complex ones in conjugate pairs), "
                         f"got {poles!r}") from None
    problems = []
    if wanted.shape != (nx,):
        problems.append(f"{nx} poles are needed (one for each state: {', '.join(lin.state_names)}), got {wanted.size}")
    if not np.all(np.isfinite(wanted)):
        problems.append("every pole must be finite")
    if not problems:
        for z in wanted[wanted.imag != 0]:
            if np.sum(np.isclose(wanted, np.conj(z), rtol=1e-12, atol=1e-12)) != np.sum(
                    np.isclose(wanted, z, rtol=1e-12, atol=1e-12)):
                problems.append(f"the complex pole {_complex(z)} needs its conjugate {_complex(np.conj(z))} too")
                break
        for z in np.unique(wanted):
            count = int(np.sum(wanted == z))
            if count > m:
                problems.append(f"the pole {_complex(z)} is repeated {count} times, but with {m} input"
                                f"{'s' if m > 1 else ''} a pole may be placed at most {m} time{'s' if m > 1 else ''}; "
                                "move the copies apart a little (-2, -2.1, ...)")
                break
    if problems:
        raise ModelError("; ".join(problems))
    A, B = _plant(lin, sample_time)
    targets = wanted if sample_time is None else np.exp(wanted * float(sample_time))
    try:
        result = place_poles(A, B, targets, method="YT", maxiter=100)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise DesignError(f"the poles cannot be placed: {exc}") from None
    K = np.asarray(result.gain_matrix, dtype=float)
    got = _sorted(np.linalg.eigvals(A - B @ K))
    scale = max(1.0, float(np.abs(targets).max()))
    if not np.allclose(got, _sorted(targets), rtol=1e-6, atol=1e-6 * scale):
        raise DesignError("the poles could not be placed accurately (the system is nearly uncontrollable): asked "
                          + ", ".join(_complex(z) for z in _sorted(targets)) + "; got "
                          + ", ".join(_complex(z) for z in got))
    return _result(lin, K, A, B, "place", sample_time)
