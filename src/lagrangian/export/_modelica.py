"""export_modelica: the model as one self-contained Modelica model (no library needed).

The equations are written as the model has them, M(q, t) der(q_dot) = f(q, q_dot, t, u), one
equation per coordinate, with der(q) = q_dot: the Modelica tool solves the linear system for the
accelerations itself. Parameters keep their names and values, inputs are ``input Real``, the
states are ``Real`` with ``fixed = true`` start values, and the energy is an ``output Real``.

A constrained model is written as the DAE itself: M der(q_dot) = f + G^T lambda with the
multipliers ``output Real lambda_<name>``, the holonomic constraints g(q, t) = 0 and the velocity
constraints a(q, t) . q_dot + b(q, t) = 0 as equations (the Modelica tool reduces the index).
Its start values are consistent (made so as lagrangian's simulation makes them); the independent
coordinates and speeds have ``fixed = true``, the others ``fixed = false`` (the tool's guesses).
"""

from __future__ import annotations

import os
from typing import Mapping

import sympy
from sympy.printing.str import StrPrinter

from .._codetext import IDENTIFIER, RESERVED, comment_text, modelica_string, module_identifier
from ..equations import Equations
from ..errors import ModelError
from ..io._files import check_replaceable, write_atomically
from ._c import cannot_write
from ._common import ExportResult, energy_name, equations_of, output_file, parameter_values, start_state

__all__ = ["export_modelica", "modelica_source", "class_name"]

_FUNCTIONS = {"sin": "sin", "cos": "cos", "tan": "tan", "asin": "asin", "acos": "acos", "atan": "atan",
              "atan2": "atan2", "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "exp": "exp", "log": "log",
              "Abs": "abs", "sign": "sign"}


def modelica_name(name: str) -> str:
    """A Modelica identifier: the name itself, or quoted ('end', 'Real') when it is a reserved word
    or a built-in name of Modelica (lagrangian._codetext.RESERVED)."""
    if IDENTIFIER.match(name) and name not in RESERVED["modelica"]:
        return name
    return "'" + name.replace("\\", "\\\\").replace("'", "\\'") + "'"


def class_name(name: str, taken=()) -> str:
    """The model's name as a Modelica class name: cart-pendulum -> CartPendulum; never a reserved
    word or built-in name, nor one of `taken` (the names declared inside the class)."""
    ident = module_identifier(name, "modelica")
    while ident in taken:
        ident += "Model"
    return ident


class _ModelicaPrinter(StrPrinter):
    """SymPy expressions in Modelica syntax: x^2, abs, time, the model's names (quoted where they
    are reserved words), pi as the model's own constant."""

    def __init__(self, names: Mapping[str, str], time: str, pi: str):
        super().__init__({"full_prec": True})
        self.names, self.time, self.pi = names, time, pi

    def _print_Symbol(self, expr):
        if expr.name == "t":
            return self.time
        return self.names.get(expr.name, modelica_name(expr.name))

    def _print_Pi(self, expr):
        return self.pi

    def _print_Exp1(self, expr):
        return "exp(1)"

    def _print_Pow(self, expr, rational=False):
        base, e = expr.args
        if e == sympy.Rational(1, 2):
            return f"sqrt({self._print(base)})"
        if e == -sympy.Rational(1, 2):
            return f"1/sqrt({self._print(base)})"
        b = self.parenthesize(base, sympy.printing.precedence.PRECEDENCE["Pow"], strict=True)
        x = self._print(e)
        if not (e.is_Integer and e >= 0) and not e.is_Symbol:
            x = f"({x})"
        return f"{b}^{x}"

    def _print_Function(self, expr):
        name = _FUNCTIONS.get(type(expr).__name__)
        if name is None:
            raise ModelError(f"the function {type(expr).__name__} has no Modelica counterpart; the model cannot be "
                             "exported to Modelica")
        return f"{name}({', '.join(self._print(a) for a in expr.args)})"

    def _print_Piecewise(self, expr):
        """(if c1 then e1 elseif c2 then e2 else en): the one-sided springs' potentials and forces."""
        *pieces, (last, cond) = expr.args
        if cond != sympy.true or not all(isinstance(c, sympy.core.relational.Relational) for _, c in pieces):
            raise ModelError("a Piecewise whose conditions are not comparisons has no Modelica counterpart; the "
                             "model cannot be exported to Modelica")
        text = "".join(f"{'if' if k == 0 else ' elseif'} {self._print(c.lhs)} {c.rel_op} {self._print(c.rhs)} "
                       f"then {self._print(e)}" for k, (e, c) in enumerate(pieces))
        return f"({text} else {self._print(last)})"

    def _print_Float(self, expr):
        return repr(float(expr))

    def _print_Rational(self, expr):
        return f"{_integer(expr.p)}/{_integer(expr.q)}" if expr.q != 1 else _integer(expr.p)

    def _print_Integer(self, expr):
        return _integer(expr.p)


def _integer(k: int) -> str:
    """An integer literal, or a Real one past Modelica's Integer (32 bits in most tools)."""
    return str(k) if abs(k) < 2**31 else repr(float(k))


def _number(value: float) -> str:
    return repr(float(value))


def modelica_source(eq: Equations, params: Mapping | None = None, initial: Mapping | None = None) -> str:
    """The Modelica text of the model (see :func:`export_modelica`)."""
    from .._version import __version__

    pvalues = parameter_values(eq, params)
    x0 = start_state(eq, initial, params)
    n = eq.n
    fixed = _fixed_states(eq, x0, pvalues) if eq.is_constrained else [True] * (2 * n)
    outputs = dict(eq.model.outputs) if eq.model is not None else {}  # the named outputs: output Real
    used = (set(eq.state_names) | {u.name for u in eq.inputs} | {p.name for p in eq.parameters}
            | {m.name for m in eq.multipliers} | set(outputs))
    pi = "pi"
    while pi in used:
        pi += "_"
    names = {s: modelica_name(s) for s in used}
    printer = _ModelicaPrinter(names, "time", pi)
    energy = energy_name(eq)
    cls = class_name(eq.model.name, used | {pi, energy})
    lines = [f"model {cls} {modelica_string(eq.model.description or eq.model.name + ': Lagrange equations')}",
             f"  // Generated by lagrangian {__version__} from the model '{comment_text(eq.model.name)}'; "
             "self-contained (no library).",
             ("  // Lagrange's equations as M(q, t) der(q_dot) = f(q, q_dot, t, u) + G(q, t)^T lambda, with der(q) = "
              "q_dot,\n  // and the constraints (the holonomic ones g(q, t) = 0: the tool reduces the index)."
              if eq.is_constrained else
              "  // Lagrange's equations as M(q, t) der(q_dot) = f(q, q_dot, t, u), with der(q) = q_dot.")]
    for p, v in zip(eq.parameters, pvalues):
        lines.append(f"  parameter Real {names[p.name]} = {_number(v)};")
    for u in eq.inputs:
        lines.append(f"  input Real {names[u.name]}(start = 0) \"input\";")
    for i, s in enumerate(eq.state_names):
        what = "coordinate" if i < n else f"velocity of {eq.state_names[i - n]}"
        if eq.is_constrained:  # the tool selects the states among q, q_dot after index reduction
            lines.append(f"  Real {names[s]}(start = {_number(x0[i])}, fixed = {str(fixed[i]).lower()}) \"{what}"
                         f"{'' if fixed[i] else ' (its start value a guess)'}\";")
        else:
            lines.append(f"  Real {names[s]}(start = {_number(x0[i])}, fixed = true, stateSelect = StateSelect.prefer) "
                         f"\"{what}\";")
    lines.append(f"  output Real {modelica_name(energy)} \"the Jacobi integral h = q_dot . dL/dq_dot - L (the energy T "
                 "+ V when T* = T2)\";")
    for con, lam in zip(eq.model.constraints, eq.multipliers):
        what = modelica_string(f"the multiplier of the {con.kind} constraint {con.name}")
        lines.append(f"  output Real {names[lam.name]} {what};")
    for name in outputs:
        lines.append(f"  output Real {names[name]} {modelica_string(f'the output {name} of the model file')};")
    lines.append("protected")
    lines.append(f"  constant Real {pi} = {_number(float(sympy.pi))};")
    lines.append("equation")
    q, qd = eq.state_names[:n], eq.state_names[n:]
    for a, b in zip(q, qd):
        lines.append(f"  der({names[a]}) = {names[b]};")
    M, f = eq.mass_matrix, eq.forcing
    G = eq.constraint_jacobian if eq.is_constrained else None
    for i in range(n):
        terms = []
        for j in range(n):
            m = M[i, j]
            if m == 0:
                continue
            terms.append(f"({printer.doprint(m)})*der({names[qd[j]]})")
        right = printer.doprint(f[i])
        if G is not None:  # + (G^T lambda)_i
            forces = [f"({printer.doprint(G[k, i])})*{names[lam.name]}" for k, lam in enumerate(eq.multipliers)
                      if G[k, i] != 0]
            right = " + ".join(([] if f[i] == 0 else [right]) + forces) or "0"
        lines.append(f"  {' + '.join(terms) or '0'} = {right};")
    for con in eq.model.constraints:
        lines.append(f"  {printer.doprint(eq.constraints[con.name])} = 0;  // {con.kind} constraint {con.name}")
    lines.append(f"  {modelica_name(energy)} = {printer.doprint(eq.readable(eq.jacobi_integral))};")
    for name, expr in outputs.items():
        lines.append(f"  {names[name]} = {printer.doprint(eq.readable(expr))};")
    sim = eq.model.simulation
    if sim.get("t_end"):
        parts = [f"StartTime = 0, StopTime = {_number(sim['t_end'])}"]
        if sim.get("dt"):
            parts.append(f"Interval = {_number(sim['dt'])}")
        if sim.get("rtol"):
            parts.append(f"Tolerance = {_number(sim['rtol'])}")
        lines.append(f"  annotation(experiment({', '.join(parts)}));")
    lines.append(f"end {cls};")
    return "\n".join(lines) + "\n"


def _fixed_states(eq: Equations, x0, pvalues) -> list[bool]:
    """Which states get fixed = true in a constrained model: the independent coordinates and speeds
    of [simulation] where they are as many as the constraints leave free and the others follow from
    them at x0; otherwise those left when the best-conditioned columns of G (of the holonomic rows
    for the coordinates, of all for the velocities) are taken as dependent (QR with pivoting)."""
    import numpy as np
    from scipy.linalg import qr

    from ..numeric._compiled import compile_equations
    from ..numeric._constrained import constrained_model
    from ._common import held_names
    from ..numeric._codegen_constrained import holonomic_rows

    n = eq.n
    cm = constrained_model(eq, compile_equations(eq))
    _, G, _ = cm._velocity_parts(0.0, np.array(x0, float), np.array(pvalues, float))
    held = held_names(eq)

    def choose(rows: np.ndarray, names) -> list[bool]:
        k = rows.shape[0]
        given = [name in held for name in names]
        dependent = [j for j in range(n) if not given[j]]
        if k == 0:
            return [True] * n
        if len(dependent) == k:
            s = np.linalg.svd(rows[:, dependent], compute_uv=False)
            if s[-1] > 1e-9 * s[0]:
                return given
        _, _, piv = qr(rows, pivoting=True)
        return [j not in set(piv[:k]) for j in range(n)]

    hol = holonomic_rows(eq)
    return choose(G[hol], eq.state_names[:n]) + choose(G, eq.state_names[n:])


def export_modelica(system, path, *, params: Mapping | None = None, initial: Mapping | None = None,
                    force: bool = False) -> ExportResult:
    """Write the model as a self-contained Modelica model (one ``model`` class, no library).

    The class is named after the model in CamelCase (cart-pendulum: ``CartPendulum``); its
    parameters keep their names and the model's values, its inputs are ``input Real`` (start 0),
    its coordinates and velocities are ``Real`` states with ``fixed = true`` start values (the
    model's [simulation] initial values, or `initial`), and the energy is an ``output Real``.
    The equations are ``der(q) = q_dot`` and ``M(q, t) der(q_dot) = f`` in the readable form of
    lagrangian's derivation. A [simulation] table gives the experiment annotation.

    Parameters
    ----------
    system : Model, Equations or str
    path : str or Path
        The .mo file to write.
    params, initial : mapping of str to float, optional
        Parameter values and initial state values that replace the model's.
    force : bool
        Replace a file that lagrangian did not write, or a symbolic link (the link itself, never
        its target); without it they are refused (:class:`~lagrangian.errors.OutputFileError`).
        The file is written atomically.

    Returns
    -------
    ExportResult
    """
    eq = equations_of(system)
    path = output_file(path, ".mo", "--modelica", "a Modelica file's name")
    text = modelica_source(eq, params, initial)
    check_replaceable((path, "--modelica"), force=force)
    try:
        write_atomically(path, text)
    except OSError as exc:
        raise cannot_write("--modelica", path, exc) from None
    return ExportResult((os.fspath(path),))
