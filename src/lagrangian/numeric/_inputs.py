"""Inputs for the compiled integrators: each input's expression of t, the state and the
parameters is translated to a short postfix program that the compiled code evaluates. One
compiled model thus runs any input expression, a feedback law included, and a new expression
compiles nothing.

Switches (the comparisons in the conditions of ``where``, which is ``sympy.Piecewise``, and
``sign``) are numbered: the compiled DOP853 freezes them during a step and locates where one
changes (see ``dop853`` in _kernels.py). ``min``, ``max`` and ``clip`` are continuous and are
evaluated as they are.

A measured signal (:class:`Signal`: a table of times and values, linear or not-a-knot cubic) is a
sympy function of its argument whose program is the opcode ``table``: its argument popped, the
interpolated value pushed. The table itself (the breakpoints and each interval's four polynomial
coefficients) is appended to the program's ``args`` after the last opcode's argument, and the
opcode's argument is its offset there, so the kernels interpolate (binary search) in compiled code
and every backend that runs the programs runs tables too."""

from __future__ import annotations

import bisect
import itertools
import math
import os

import numpy as np
import sympy
from sympy.logic.boolalg import BooleanFalse, BooleanTrue

from .._util import number_array
from ..errors import ModelError, Problem
from ._kernels import OPCODES

__all__ = ["Programs", "programs", "constant_programs", "NotCompilable", "Signal", "signal_problems"]

INTERPOLATIONS = ("linear", "cubic")
EXTRAPOLATIONS = ("error", "hold")
_COUNTER = itertools.count()


class Signal:
    """A measured input: values at times, interpolated between them in compiled code.

    ``lg.simulate(eqs, 20, inputs={"F": lg.Signal(t, values)})``, or ``Signal.from_csv("data.csv",
    "acc")``. `interpolation`: "linear" (piecewise linear, error O(h^2) in the sample spacing h) or
    "cubic" (the not-a-knot cubic spline of scipy.interpolate.CubicSpline, error O(h^4)).
    `extrapolation`: "error" (default: a run that leaves [times[0], times[-1]] is refused before it
    starts) or "hold" (the first and last values are held outside the table).

    Calling a Signal on a number or an array gives its values there (NumPy); on a sympy expression
    (``sig(t - 0.1)``) it gives the sympy expression of the signal at that argument, which an input
    expression may use (``2*sig(t)``)."""

    def __init__(self, times, values, interpolation: str = "linear", extrapolation: str = "error",
                 name: str | None = None):
        if name is not None and not isinstance(name, str):
            raise ModelError(f"a signal's name must be text, such as name='acc', got {type(name).__name__}")
        self.name = name or "signal"
        what = f"signal '{self.name}'"
        if not isinstance(interpolation, str) or not isinstance(extrapolation, str):
            raise ModelError(f"{what}: interpolation and extrapolation are names (text): interpolation 'linear' or "
                             "'cubic', extrapolation 'error' or 'hold'")
        if interpolation not in INTERPOLATIONS:
            raise ModelError(f"{what}: unknown interpolation '{interpolation}'; choose 'linear' or 'cubic' "
                             "(the not-a-knot cubic spline)")
        if extrapolation not in EXTRAPOLATIONS:
            raise ModelError(f"{what}: unknown extrapolation '{extrapolation}'; choose 'error' (refuse a run "
                             "outside the table's times) or 'hold' (hold the first and last values)")
        try:
            t = np.array(times, dtype=np.float64).ravel()
            v = np.array(values, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            raise ModelError(f"{what}: times and values must be arrays of numbers") from None
        if t.shape != v.shape:
            raise ModelError(f"{what}: {t.size} times but {v.size} values; give one value per time")
        need = 2 if interpolation == "linear" else 4
        if t.size < need:
            raise ModelError(f"{what}: {t.size} samples, but {interpolation} interpolation needs at least {need}; "
                             "give more samples")
        for arr, label in ((t, "time"), (v, "value")):
            bad = np.flatnonzero(~np.isfinite(arr))
            if bad.size:
                raise ModelError(f"{what}: {bad.size} {label}(s) not finite (NaN or inf), the first at index "
                                 f"{bad[0]} ({arr[bad[0]]}); remove or fill those samples")
        steps = np.diff(t)
        bad = np.flatnonzero(steps <= 0)
        if bad.size:
            k = int(bad[0]) + 1
            kind = "repeated" if steps[bad[0]] == 0 else "not increasing"
            raise ModelError(f"{what}: times must increase strictly, but the time at index {k} ({t[k]:g}) is "
                             f"{kind} after {t[k - 1]:g}; sort the samples and remove repeated times")
        self.times = t
        self.values = v
        self.interpolation = interpolation
        self.extrapolation = extrapolation
        self.times.setflags(write=False)
        self.values.setflags(write=False)
        if interpolation == "linear":
            coef = np.zeros((t.size - 1, 4))
            coef[:, 2] = np.diff(v) / steps
            coef[:, 3] = v[:-1]
        else:
            from scipy.interpolate import CubicSpline

            coef = np.ascontiguousarray(CubicSpline(t, v, bc_type="not-a-knot").c.T)
        #: each interval's polynomial in (s - times[i]), highest power first: (n - 1, 4)
        self.coefficients = coef
        self.coefficients.setflags(write=False)
        self._knots = t.tolist()
        self._rows = coef.tolist()
        self.function = type(f"signal_{next(_COUNTER)}", (sympy.Function,),
                             {"nargs": 1, "signal": self, "_imp_": staticmethod(self._scalar)})

    @classmethod
    def from_polynomials(cls, times, coefficients, extrapolation: str = "error", name: str | None = None,
                         interpolation: str = "piecewise polynomial") -> "Signal":
        """A signal given by its polynomial on each interval [times[k], times[k+1]], in powers of
        (s - times[k]), highest power first, of degree at most 3: `coefficients` has shape
        (len(times) - 1, d + 1) with d <= 3 (an optimal motion's piecewise-quadratic input, a spline
        computed elsewhere). `interpolation` is the label it reports (``repr``, ``.interpolation``)."""
        what = f"signal '{name or 'signal'}'"
        try:
            coef = np.array(coefficients, dtype=np.float64)
            t = np.array(times, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            raise ModelError(f"{what}: times and coefficients must be arrays of numbers") from None
        if coef.ndim != 2 or coef.shape[0] != t.size - 1 or not 1 <= coef.shape[1] <= 4:
            raise ModelError(f"{what}: coefficients must have shape ({max(t.size - 1, 0)}, d + 1) with degree "
                             f"d <= 3 (one row per interval between the {t.size} times), got {coef.shape}")
        if not np.all(np.isfinite(coef)):
            raise ModelError(f"{what}: a coefficient is not finite (NaN or inf); give finite polynomials")
        coef = np.hstack([np.zeros((coef.shape[0], 4 - coef.shape[1])), coef])
        h = np.diff(t)
        last = ((coef[-1, 0] * h[-1] + coef[-1, 1]) * h[-1] + coef[-1, 2]) * h[-1] + coef[-1, 3] if h.size else 0.0
        signal = cls(t, np.append(coef[:, 3], last), "linear", extrapolation, name)  # checks the times
        coef.setflags(write=False)
        signal.coefficients = coef
        signal._rows = coef.tolist()
        signal.interpolation = str(interpolation)
        return signal

    @classmethod
    def from_csv(cls, path, column: str, interpolation: str = "linear", extrapolation: str = "error") -> "Signal":
        """The signal of `column` of the CSV file `path` (a header row; time is the column named t or
        time, else the first column)."""
        t, v = read_csv_column(path, column)
        return cls(t, v, interpolation, extrapolation, name=f"{os.path.basename(str(path))}:{column}")

    @property
    def span(self) -> tuple[float, float]:
        return float(self.times[0]), float(self.times[-1])

    def table(self) -> np.ndarray:
        """The block the kernels read: [n, times (n), coefficients (4 (n - 1), row by row)]."""
        return np.concatenate(([float(self.times.size)], self.times, self.coefficients.ravel()))

    def _scalar(self, s) -> float:
        """The value at one time, in plain Python (SciPy's path calls it at every stage)."""
        t, s = self._knots, float(s)
        s = min(max(s, t[0]), t[-1])
        i = min(max(bisect.bisect_right(t, s) - 1, 0), len(t) - 2)
        d = s - t[i]
        c0, c1, c2, c3 = self._rows[i]
        return ((c0 * d + c1) * d + c2) * d + c3

    def _values(self, s):
        arr = number_array(s)
        if arr is None:
            raise ModelError(f"signal '{self.name}': a signal is evaluated at a time (a number), an array of times or "
                             f"a sympy expression of t, got {type(s).__name__}")
        s = np.clip(arr, self.times[0], self.times[-1])
        i = np.clip(np.searchsorted(self.times, s, side="right") - 1, 0, self.times.size - 2)
        d = s - self.times[i]
        c = self.coefficients[i]
        return ((c[..., 0] * d + c[..., 1]) * d + c[..., 2]) * d + c[..., 3]

    def __call__(self, s):
        if isinstance(s, sympy.Basic):
            return self.function(s)
        return self._values(s)

    def __repr__(self) -> str:
        lo, hi = self.span
        return (f"Signal({self.name!r}, {self.times.size} samples on [{lo:g}, {hi:g}], {self.interpolation}, "
                f"extrapolation={self.extrapolation!r})")


def signals_in(expr) -> list:
    """The (signal, argument) pairs of a sympy expression."""
    if not isinstance(expr, sympy.Basic):
        return []
    return [(f.func.signal, f.args[0]) for f in expr.atoms(sympy.Function) if isinstance(getattr(f.func, "signal",
                                                                                                  None), Signal)]


def signal_problems(inputs, t, t0: float, t_end) -> list[Problem]:
    """Problems of the signals among the inputs (name: spec) on the run [t0, t_end]: a signal that
    does not cover it (unless it holds its end values), or whose argument is not t plus a constant."""
    problems: list[Problem] = []
    if not isinstance(t_end, (int, float)) or isinstance(t_end, bool):
        return problems
    for name, spec in (inputs or {}).items():
        name = getattr(name, "name", name)
        pairs = [(spec, t)] if isinstance(spec, Signal) else signals_in(spec)
        for sig, arg in pairs:
            if sig.extrapolation == "hold":
                continue
            shift = sympy.simplify(arg - t)
            if not shift.is_number:
                problems.append(Problem(f"input '{name}': the argument of {sig.name} is {arg}, not t plus a "
                                        "constant, so its range is not known before the run; give "
                                        "extrapolation='hold' to hold its end values", key=f"inputs.{name}"))
                continue
            lo, hi = t0 + float(shift), float(t_end) + float(shift)
            a, b = sig.span
            if lo < a - 1e-12 * max(1.0, abs(a)) or hi > b + 1e-12 * max(1.0, abs(b)):
                problems.append(Problem(f"input '{name}': {sig.name} covers t = {a:g} .. {b:g}, but the run needs "
                                        f"it on {lo:g} .. {hi:g}; shorten t_end, give a longer table, or give "
                                        "extrapolation='hold' to hold its end values outside the table",
                                        key=f"inputs.{name}"))
    return problems


def read_csv_column(path, column: str) -> tuple[np.ndarray, np.ndarray]:
    """(times, values) of `column` of a CSV file with a header row; time is the column named t or time
    (else the first column). Every bad cell is an error naming the file, the row and the column."""
    import csv

    path = str(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise ModelError(f"cannot read the signal file {path}: {exc.strerror or exc}; check the path") from None
    except UnicodeDecodeError:
        raise ModelError(f"{path}: not a text CSV file (not UTF-8); save it as CSV text") from None
    rows = [r for r in rows if any(c.strip() for c in r)]
    if not rows:
        raise ModelError(f"{path}: the file is empty; expected a header row (t,{column}) and rows of numbers")
    header = [c.strip() for c in rows[0]]
    lowered = [h.lower() for h in header]
    ti = lowered.index("t") if "t" in lowered else (lowered.index("time") if "time" in lowered else 0)
    if column not in header:
        from .._util import did_you_mean

        raise ModelError(f"{path}: no column '{column}'{did_you_mean(column, header, 0.5)}; its header row has "
                         f"{', '.join(header)}")
    ci = header.index(column)
    if ci == ti:
        raise ModelError(f"{path}: column '{column}' is the time column; name a column of values")
    t, v = [], []
    for r, row in enumerate(rows[1:], start=2):
        out = []
        for k, label in ((ti, header[ti]), (ci, column)):
            cell = row[k].strip() if k < len(row) else ""
            try:
                x = float(cell)
            except ValueError:
                x = math.nan
                cell = cell or "empty"
            if not math.isfinite(x):
                raise ModelError(f"{path}: row {r}, column '{label}': '{cell}' is not a finite number; every cell "
                                 "of the time and value columns must be a number (remove the row or fill it)")
            out.append(x)
        t.append(out[0])
        v.append(out[1])
    if len(t) < 2:
        raise ModelError(f"{path}: {len(t)} data row(s); a signal needs at least 2 (4 for cubic interpolation)")
    for r in range(1, len(t)):
        if t[r] <= t[r - 1]:
            kind = "repeats" if t[r] == t[r - 1] else "is earlier than"
            raise ModelError(f"{path}: row {r + 2}, column '{header[ti]}': time {t[r]:g} {kind} the time "
                             f"{t[r - 1]:g} of row {r + 1}; times must increase strictly (sort the rows and remove "
                             "repeated times)")
    return np.array(t), np.array(v)

_UNARY = {sympy.sin: "sin", sympy.cos: "cos", sympy.tan: "tan", sympy.exp: "exp", sympy.log: "log",
          sympy.Abs: "abs", sympy.sign: "sign", sympy.asin: "asin", sympy.acos: "acos",
          sympy.atan: "atan", sympy.sinh: "sinh", sympy.cosh: "cosh", sympy.tanh: "tanh",
          sympy.Heaviside: "heaviside", sympy.floor: "floor", sympy.ceiling: "ceiling"}
_NARY = {sympy.Add: "add", sympy.Mul: "mul", sympy.Max: "max", sympy.Min: "min",
         sympy.And: "and", sympy.Or: "or"}
# comparisons as a > b or a >= b: (opcode, operands swapped)
_RELATIONS = {sympy.StrictGreaterThan: ("gt", False), sympy.GreaterThan: ("ge", False),
              sympy.StrictLessThan: ("gt", True), sympy.LessThan: ("ge", True)}
_SWITCHED = {sympy.sign: "sign_switch", sympy.Heaviside: "heaviside_switch"}


class NotCompilable(Exception):
    """An input the compiled integrators cannot evaluate (a Python function, or an unsupported
    function in an expression)."""


class Programs:
    """The inputs' programs: ops, args (float64), starts (offsets, len m + 1) and stack size;
    `nswitch` switches, numbered 0 .. nswitch - 1 in the args of their opcodes; `reads_state`:
    whether a program reads the state (a feedback law)."""

    def __init__(self, ops, args, starts, depth, nswitch: int = 0, reads_state: bool = False):
        self.ops = np.asarray(ops, dtype=np.int64)
        self.args = np.asarray(args, dtype=np.float64)
        self.starts = np.asarray(starts, dtype=np.int64)
        self.nstack = max(1, int(depth))
        self.nswitch = int(nswitch)
        self.reads_state = bool(reads_state)


class _Emitter:
    """Appends postfix programs to `ops` and `args`, numbering the switches."""

    def __init__(self, t, params, states, inputs, switches: bool):
        self.t, self.params, self.states, self.inputs = t, list(params), list(states), list(inputs)
        self.switches = switches
        self.ops: list[int] = []
        self.args: list[float] = []
        self.nswitch = 0
        self.reads_state = False
        self.tables: list[tuple[int, Signal]] = []  # (index of the opcode, its signal)

    def op(self, name: str, arg: float = 0.0) -> None:
        self.ops.append(OPCODES[name])
        self.args.append(float(arg))

    def switch(self, name: str) -> None:
        self.op(name, self.nswitch)
        self.nswitch += 1

    def emit(self, expr) -> int:
        """Append the program of `expr`; returns the stack depth it needs."""
        if expr == self.t:
            self.op("t")
            return 1
        if expr in self.params:
            self.op("param", self.params.index(expr))
            return 1
        if expr in self.states:
            self.op("x", self.states.index(expr))
            self.reads_state = True
            return 1
        if expr in self.inputs:
            self.op("u", self.inputs.index(expr))
            return 1
        if isinstance(expr, (BooleanTrue, BooleanFalse)):
            self.op("const", 1.0 if expr else 0.0)
            return 1
        if expr.is_number:
            try:
                value = complex(expr)
            except TypeError:
                raise NotCompilable(f"'{expr}' is not a number") from None
            if value.imag != 0:
                raise NotCompilable(f"'{expr}' is complex")
            self.op("const", value.real)
            return 1
        func = expr.func
        if func is sympy.Pow:
            base, e = expr.args
            if e == sympy.Rational(1, 2):
                d = self.emit(base)
                self.op("sqrt")
                return d
            return self.binary(base, e, "pow")
        if func in _NARY:
            depth = 0
            for k, a in enumerate(expr.args):
                depth = max(depth, self.emit(a) + (1 if k else 0))
                if k:
                    self.op(_NARY[func])
            return depth
        if func in _RELATIONS:
            name, swapped = _RELATIONS[func]
            a, b = expr.args[::-1] if swapped else expr.args
            depth = self.binary(a, b, None)
            self.switch(name) if self.switches else self.op(name, 0)
            return depth
        if func is sympy.Not:
            d = self.emit(expr.args[0])
            self.op("not")
            return d
        if func is sympy.Piecewise:
            return self.piecewise(expr.args)
        if func is sympy.atan2:
            return self.binary(expr.args[0], expr.args[1], "atan2")
        sig = getattr(func, "signal", None)
        if isinstance(sig, Signal):
            d = self.emit(expr.args[0])
            self.op("table", 0.0)
            self.tables.append((len(self.ops) - 1, sig))
            return d
        if func in _UNARY and len(expr.args) == 1:
            d = self.emit(expr.args[0])
            if self.switches and func in _SWITCHED:
                self.switch(_SWITCHED[func])
            else:
                self.op(_UNARY[func])
            return d
        raise NotCompilable(f"the function {func.__name__} in an input is not supported by the compiled "
                            "integrators")

    def binary(self, a, b, name: str | None) -> int:
        d1 = self.emit(a)
        d2 = self.emit(b)
        if name:
            self.op(name)
        return max(d1, d2 + 1)

    def piecewise(self, pieces) -> int:
        """Piecewise((e1, c1), (e2, c2), ...) as where(c1, e1, where(c2, e2, ...)); NaN where no
        condition holds."""
        (value, condition), rest = pieces[0], pieces[1:]
        if condition == sympy.true:
            return self.emit(value)
        d1 = self.emit(condition)
        d2 = self.emit(value)
        if rest:
            d3 = self.piecewise(rest)
        else:
            self.op("const", float("nan"))
            d3 = 1
        self.op("where")
        return max(d1, d2 + 1, d3 + 2)


def programs(exprs, t, params, states=(), inputs=(), switches: bool = True) -> Programs:
    """The programs of `exprs`, sympy expressions of t, the parameters, the state (and, for
    events, the inputs). `switches`: number the comparisons and sign, for the integrator to
    freeze during a step (inputs); otherwise they are evaluated as they are (events)."""
    em = _Emitter(t, params, states, inputs, switches)
    starts = [0]
    depth = 1
    for e in exprs:
        depth = max(depth, em.emit(sympy.sympify(e)))
        starts.append(len(em.ops))
    offsets: dict[int, int] = {}
    for c, sig in em.tables:  # the tables after the last opcode's argument, each once
        if id(sig) not in offsets:
            offsets[id(sig)] = len(em.args)
            em.args.extend(sig.table().tolist())
        em.args[c] = float(offsets[id(sig)])
    return Programs(em.ops, em.args, starts, depth, em.nswitch, em.reads_state)


def constant_programs(values) -> Programs:
    """Constant inputs."""
    values = [float(v) for v in values]
    return Programs([OPCODES["const"]] * len(values), values, list(range(len(values) + 1)), 1)
