"""Inputs for the compiled integrators: each input's expression of t, the state and the
parameters is translated to a short postfix program that the compiled code evaluates. One
compiled model thus runs any input expression, a feedback law included, and a new expression
compiles nothing.

Switches (the comparisons in the conditions of ``where``, which is ``sympy.Piecewise``, and
``sign``) are numbered: the compiled DOP853 freezes them during a step and locates where one
changes (see ``dop853`` in _kernels.py). ``min``, ``max`` and ``clip`` are continuous and are
evaluated as they are."""

from __future__ import annotations

import numpy as np
import sympy
from sympy.logic.boolalg import BooleanFalse, BooleanTrue

from ._kernels import OPCODES

__all__ = ["Programs", "programs", "constant_programs", "NotCompilable"]

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
    return Programs(em.ops, em.args, starts, depth, em.nswitch, em.reads_state)


def constant_programs(values) -> Programs:
    """Constant inputs."""
    values = [float(v) for v in values]
    return Programs([OPCODES["const"]] * len(values), values, list(range(len(values) + 1)), 1)
