"""The named form of M and f: equations too large to expand, written with named intermediate quantities.

The readable form (``_readable``) expands each entry of M and f and merges its terms; past its budget
(an entry whose expansion could have more than 5,000 terms: a chain of bodies in space, the bicycle)
an entry is left as derived, and printing it gives megabytes nobody reads. Here M and f are built
again, in the form of Kane's method (the virtual power of the inertia forces), which is equal to
Lagrange's but far shorter for bodies in space:

    M = sum_b  m_b J_vb^T J_vb + J_wb^T I_b J_wb                          + d2T_rest/dq_dot2,
    f = -sum_b J_vb^T m_b a_b + J_wb^T (I_b alpha_b + w_b x I_b w_b)      + f_rest,

for each particle and rigid body b, with v_b the velocity of its mass centre (world axes), w_b its
angular velocity (body axes, derived from its rotation), J_vb = dv_b/dq_dot and J_wb = dw_b/dq_dot
their Jacobians, and a_b = dv_b/dt and alpha_b = dw_b/dt at q_ddot = 0 (the accelerations that do
not come from q_ddot). f_rest is Lagrange's forcing of everything else: T* written in the [energy]
table or by other elements, V, D and Q. Then the common subexpressions of all entries are named
(``x1``, ``x2``, ...; the angular velocity and mass-centre velocity of each body by their own names,
``w_<body>`` and ``v_<body>``) and listed once, in the order they are defined.

The form is checked against the derived M and f (the tests substitute the named quantities back
and compare at random states); the numerical layer still compiles the derived ones.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import symengine as se

from ..model._elements import Particle, RigidBody, RigidBody3D

__all__ = ["NamedForm", "named_form"]

_AXES = "xyz"


@dataclass(frozen=True)
class NamedForm:
    """M and f (and G and c of the constraints) in terms of named quantities (SymEngine).

    Attributes
    ----------
    quantities : tuple of (name, expression, note)
        In the order of definition: each expression uses only the coordinates, velocities, time,
        inputs, parameters and the quantities named before it. `note` says what a quantity is
        ("angular velocity of <body> in its axes", ...) or is empty for a common subexpression.
    M : tuple of tuple, shape (n, n)
    f : tuple, shape (n,)
    G : tuple of tuple, shape (m, n); c : tuple, shape (m,); g : tuple, shape (m,)
        The constraints' Jacobian, acceleration terms (G q_ddot = c) and left sides; empty without
        constraints.
    """

    quantities: tuple
    M: tuple
    f: tuple
    G: tuple = ()
    c: tuple = ()
    g: tuple = ()

    def substituted(self) -> dict[str, list]:
        """{"M": rows, "f": ..., "G": rows, "c": ..., "g": ...} with every named quantity substituted
        back (SymEngine; for checks: the trees share the quantities, so this is quick)."""
        values: dict = {}
        for name, expr, _ in self.quantities:  # in order: each uses only those before it
            values[se.Symbol(name)] = se.DenseMatrix([expr]).xreplace(values)[0] if values else expr
        table = list(values.items())
        every = [x for row in self.M for x in row] + list(self.f) + [x for row in self.G for x in row]
        every += list(self.c) + list(self.g)
        back = list(se.DenseMatrix(every).xreplace(dict(table))) if every else []
        n, m = len(self.f), len(self.c)
        out, pos = {}, 0
        out["M"] = [back[i * n:(i + 1) * n] for i in range(n)]
        pos = n * n
        out["f"], pos = back[pos:pos + n], pos + n
        out["G"], pos = [back[pos + k * n:pos + (k + 1) * n] for k in range(m)], pos + m * n
        out["c"], out["g"] = back[pos:pos + m], back[pos + m:pos + 2 * m]
        return out

    def size(self) -> int:
        """Characters of the printed quantities, M and f (and G, c and g)."""
        return len("\n".join(self.lines()))

    def lines(self) -> list[str]:
        """The quantities, one a line, then M (one row a line), f, G and c (one entry a line), as
        ``Equations.text()`` prints them (without headings)."""
        out = [f"  {name} = {expr}" + (f"    # {note}" if note else "") for name, expr, note in self.quantities]
        out += ["    [" + ", ".join(str(x) for x in row) + "]" for row in self.M]
        out += [f"    {x}" for x in self.f]
        out += ["    [" + ", ".join(str(x) for x in row) + "]" for row in self.G]
        out += [f"    {x}" for x in (*self.c, *self.g)]
        return out


def _massive_kane(element, varying: set, kin) -> bool:
    """Whether `element`'s kinetic co-energy is taken in Kane's form: a particle or rigid body with
    constant mass and inertia (free of the state)."""
    if not isinstance(element, (Particle, RigidBody, RigidBody3D)):
        return False
    parts = [element.mass]
    if isinstance(element, RigidBody):
        parts.append(element.inertia)
    elif isinstance(element, RigidBody3D):
        parts += [x for row in element.inertia for x in row]
    return not any(set(kin.se(p).free_symbols) & varying for p in parts)


def kane_form(model, kin) -> tuple[list, list, list]:
    """(M, f, quantities) of `model` (frozen snapshot) with its particles and bodies in Kane's form
    and the rest by Lagrange's operator, in SymEngine (trees sharing their subexpressions).
    `quantities` is [(name, [components], note)] of each body's angular velocity and mass-centre
    velocity."""
    q, qd, t = kin.q, kin.qd, kin.t
    n = len(q)
    varying = set(q) | set(qd) | {t}
    M = [[se.Integer(0)] * n for _ in range(n)]
    f = [se.Integer(0)] * n

    def at_rest(vec):  # d/dt at q_ddot = 0
        return [sum((x.diff(qj) * v for qj, v in zip(q, qd)), x.diff(t)) for x in vec]

    T_rest = kin.se(model.T)
    V = kin.se(model.V)
    D = kin.se(model.D)
    Q = [kin.se(model.Q.get(c, 0)) for c in model.q]
    quantities = []
    for element in model.elements:
        if _massive_kane(element, varying, kin):
            mass = kin.se(element.mass)
            v = kin.velocity(element.position)
            quantities.append((f"v_{element.name}", v, f"velocity of the mass centre of {element.name} (world axes)"))
            Jv = [[x.diff(u) for u in qd] for x in v]
            a = at_rest(v)
            for i in range(n):
                for j in range(i, n):
                    M[i][j] = M[i][j] + mass * sum((Jv[k][i] * Jv[k][j] for k in range(len(v))), se.Integer(0))
                f[i] = f[i] - mass * sum((Jv[k][i] * a[k] for k in range(len(v))), se.Integer(0))
            if isinstance(element, RigidBody):
                w = kin.rate(element.angle)
                quantities.append((f"w_{element.name}", [w], f"angular velocity of {element.name}"))
                I = kin.se(element.inertia)
                Jw = [w.diff(u) for u in qd]
                alpha = at_rest([w])[0]
                for i in range(n):
                    for j in range(i, n):
                        M[i][j] = M[i][j] + I * Jw[i] * Jw[j]
                    f[i] = f[i] - Jw[i] * I * alpha
            elif isinstance(element, RigidBody3D):
                w = element.omega(kin)
                quantities.append((f"w_{element.name}", w, f"angular velocity of {element.name} (its axes)"))
                I = [[kin.se(x) for x in row] for row in element.inertia]
                Jw = [[x.diff(u) for u in qd] for x in w]
                alpha = at_rest(w)
                Iw = [sum((I[r][k] * w[k] for k in range(3)), se.Integer(0)) for r in range(3)]
                torque = [sum((I[r][k] * alpha[k] for k in range(3)), se.Integer(0)) for r in range(3)]
                torque = [torque[0] + w[1] * Iw[2] - w[2] * Iw[1], torque[1] + w[2] * Iw[0] - w[0] * Iw[2],
                          torque[2] + w[0] * Iw[1] - w[1] * Iw[0]]
                for i in range(n):
                    for j in range(i, n):
                        M[i][j] = M[i][j] + sum((Jw[r][i] * I[r][k] * Jw[k][j] for r in range(3) for k in range(3)),
                                                se.Integer(0))
                    f[i] = f[i] - sum((Jw[r][i] * torque[r] for r in range(3)), se.Integer(0))
            continue
        c = element.contribute(kin)
        T_rest, V, D = T_rest + c.T, V + c.V, D + c.D
        if c.Q:
            Q = [x + y for x, y in zip(Q, c.Q)]
    L = T_rest - V
    p = [L.diff(v) for v in qd]
    for i in range(n):
        for j in range(i, n):
            M[i][j] = M[i][j] + p[i].diff(qd[j])
        fi = L.diff(q[i]) - p[i].diff(t) - D.diff(qd[i]) + Q[i]
        f[i] = f[i] + fi - sum((p[i].diff(q[j]) * qd[j] for j in range(n)), se.Integer(0))
    for i in range(n):
        for j in range(i):
            M[i][j] = M[j][i]
    return M, f, quantities


def named_form(equations) -> NamedForm:
    """The :class:`NamedForm` of `equations` (an :class:`~lagrangian.equations.Equations`)."""
    from ..model._elements import Particle as _P, RigidBody as _R, RigidBody3D as _R3
    from ..model._kinematics import Kinematics

    model, core = equations.model, equations.core
    massive = [e for e in model.elements if isinstance(e, (_P, _R, _R3))]
    kin = Kinematics(model.q, massive)
    M, f, quantities = kane_form(model, kin)
    n = len(f)
    G = core.G
    m = 0 if G is None else G.rows
    upper = [M[i][j] for i in range(n) for j in range(i, n)]
    rows = [G[k, j] for k in range(m) for j in range(n)]
    defined = [x for _, vec, _ in quantities for x in vec]
    exprs = defined + upper + list(f) + rows + list(core.c) + list(core.g)
    taken = {s.name for s in (*model.q, *model.q_dot, *model.q_ddot, *model.parameters, *model.inputs)}
    taken |= {"t"} | {name for name, _, _ in quantities}
    replacements, reduced = se.cse(exprs)
    prefix = _prefix(taken)
    # the quantities named by the model come first, as their own names where cse made them one temporary
    names: dict = {}
    temporaries = {lhs for lhs, _ in replacements}
    k = 0
    for name, vec, note in quantities:
        for axis, _ in zip(_AXES if len(vec) == 3 else ("",), vec):
            r = reduced[k]
            k += 1
            if type(r) is se.Symbol and r not in names and r in temporaries:
                names[r] = se.Symbol(f"{name}_{axis}" if axis else name)
    counter = 0
    for lhs, _ in replacements:
        if lhs not in names:
            counter += 1
            names[lhs] = se.Symbol(f"{prefix}{counter}")
    notes = {}
    for name, vec, note in quantities:
        for axis in (_AXES if len(vec) == 3 else ("",)):
            notes[f"{name}_{axis}" if axis else name] = note
    # renamed in one call (xreplace converts its dictionary on each call)
    renamed = list(se.DenseMatrix([rhs for _, rhs in replacements] + list(reduced[len(defined):]) or [0])
                   .xreplace(names)) if replacements or len(reduced) > len(defined) else []
    listed = [(names[lhs].name, rhs, notes.get(names[lhs].name, ""))
              for (lhs, _), rhs in zip(replacements, renamed)]
    rest = renamed[len(replacements):]
    Mn = [[None] * n for _ in range(n)]
    pos = 0
    for i in range(n):
        for j in range(i, n):
            Mn[i][j] = Mn[j][i] = rest[pos]
            pos += 1
    fn = rest[pos:pos + n]
    pos += n
    Gn = [rest[pos + k * n: pos + (k + 1) * n] for k in range(m)]
    pos += m * n
    cn = rest[pos:pos + m]
    gn = rest[pos + m:pos + 2 * m]
    return NamedForm(quantities=tuple(listed), M=tuple(tuple(r) for r in Mn), f=tuple(fn),
                     G=tuple(tuple(r) for r in Gn), c=tuple(cn), g=tuple(gn))


def _prefix(taken: set) -> str:
    """The letter(s) of the common subexpressions' names: ``x`` unless a model name is ``x<digits>``."""
    for prefix in ("x", "z", "e", "xx"):
        if not any(re.fullmatch(rf"{prefix}[0-9]+", name) for name in taken):
            return prefix
    k = 1
    while any(re.fullmatch(rf"cse{k}_[0-9]+", name) for name in taken):
        k += 1
    return f"cse{k}_"
