"""Inputs u(t) for the compiled integrators: each input's expression of t and the parameters is
translated to a short postfix program that the compiled code evaluates. One compiled model thus
runs any input expression, and a new expression compiles nothing."""

from __future__ import annotations

import numpy as np
import sympy

from ._kernels import OPCODES

__all__ = ["Programs", "programs", "constant_programs"]

_UNARY = {sympy.sin: "sin", sympy.cos: "cos", sympy.tan: "tan", sympy.exp: "exp", sympy.log: "log",
          sympy.Abs: "abs", sympy.sign: "sign", sympy.asin: "asin", sympy.acos: "acos",
          sympy.atan: "atan", sympy.sinh: "sinh", sympy.cosh: "cosh", sympy.tanh: "tanh",
          sympy.Heaviside: "heaviside", sympy.floor: "floor", sympy.ceiling: "ceiling"}
_NARY = {sympy.Add: "add", sympy.Mul: "mul", sympy.Max: "max", sympy.Min: "min"}


class NotCompilable(Exception):
    """An input the compiled integrators cannot evaluate (a Python function, or an unsupported
    function in an expression)."""


class Programs:
    """The inputs' programs: ops, args (float64), starts (offsets, len m + 1) and stack size."""

    def __init__(self, ops, args, starts, depth):
        self.ops = np.asarray(ops, dtype=np.int64)
        self.args = np.asarray(args, dtype=np.float64)
        self.starts = np.asarray(starts, dtype=np.int64)
        self.nstack = max(1, int(depth))


def _emit(expr, t, params, ops, args, states=(), inputs=()) -> int:
    """Append the postfix program of `expr`; returns the stack depth it needs."""
    if expr == t:
        ops.append(OPCODES["t"]), args.append(0.0)
        return 1
    if expr in params:
        ops.append(OPCODES["param"]), args.append(float(params.index(expr)))
        return 1
    if expr in states:
        ops.append(OPCODES["x"]), args.append(float(states.index(expr)))
        return 1
    if expr in inputs:
        ops.append(OPCODES["u"]), args.append(float(inputs.index(expr)))
        return 1
    if expr.is_number:
        try:
            value = complex(expr)
        except TypeError:
            raise NotCompilable(f"'{expr}' is not a number") from None
        if value.imag != 0:
            raise NotCompilable(f"'{expr}' is complex")
        ops.append(OPCODES["const"]), args.append(value.real)
        return 1
    func = expr.func
    if func is sympy.Pow:
        base, e = expr.args
        if e == sympy.Rational(1, 2):
            d = _emit(base, t, params, ops, args, states, inputs)
            ops.append(OPCODES["sqrt"]), args.append(0.0)
            return d
        d1 = _emit(base, t, params, ops, args, states, inputs)
        d2 = _emit(e, t, params, ops, args, states, inputs)
        ops.append(OPCODES["pow"]), args.append(0.0)
        return max(d1, d2 + 1)
    if func in _NARY:
        depth = 0
        for k, a in enumerate(expr.args):
            depth = max(depth, _emit(a, t, params, ops, args, states, inputs) + (1 if k else 0))
            if k:
                ops.append(OPCODES[_NARY[func]]), args.append(0.0)
        return depth
    if func is sympy.atan2:
        d1 = _emit(expr.args[0], t, params, ops, args, states, inputs)
        d2 = _emit(expr.args[1], t, params, ops, args, states, inputs)
        ops.append(OPCODES["atan2"]), args.append(0.0)
        return max(d1, d2 + 1)
    if func in _UNARY and len(expr.args) == 1:
        d = _emit(expr.args[0], t, params, ops, args, states, inputs)
        ops.append(OPCODES[_UNARY[func]]), args.append(0.0)
        return d
    raise NotCompilable(f"the function {func.__name__} in an input is not supported by the compiled "
                        "integrators")


def programs(exprs, t, params, states=(), inputs=()) -> Programs:
    """The programs of `exprs` (sympy expressions of t and the parameters, and for events also of
    the state and inputs)."""
    params, states, inputs = list(params), list(states), list(inputs)
    ops: list[int] = []
    args: list[float] = []
    starts = [0]
    depth = 1
    for e in exprs:
        depth = max(depth, _emit(sympy.sympify(e), t, params, ops, args, states, inputs))
        starts.append(len(ops))
    return Programs(ops, args, starts, depth)


def constant_programs(values) -> Programs:
    """Constant inputs."""
    values = [float(v) for v in values]
    return Programs([OPCODES["const"]] * len(values), values, list(range(len(values) + 1)), 1)
