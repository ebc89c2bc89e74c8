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
from ..model._frames import WORLD

__all__ = ["NamedForm", "named_form", "QuasiVelocityForm", "quasi_velocity_form"]

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


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _rotT(R, x):
    """R^T x for a 3x3 SymEngine matrix R and a 3-list x."""
    return [R[0, i] * x[0] + R[1, i] * x[1] + R[2, i] * x[2] for i in range(3)]


def _add(*vectors):
    return [sum(parts, se.Integer(0)) for parts in zip(*vectors)]


class _FrameMotion:
    """Each frame's angular velocity w, origin velocity v (both in the frame's own axes), their
    Jacobians Jw[j], Jv[j] (d/dq_dot_j) and their components' rates at q_ddot = 0 (alpha, a),
    by recursion down the chain of frames (as PyDy writes a chain: each quantity from its parent's
    in a few terms), and the gravity vector g in the frame's axes. With R the frame's rotation in
    its parent's axes (angular velocity w_rel, in its axes) and o its origin in the parent's:

        w = R^T w_P + w_rel,                 v = R^T (v_P + w_P x o + o')
        alpha = R^T alpha_P - w_rel x R^T w_P + w_rel'
        a = R^T (a_P + alpha_P x o + w_P x o' + o'') - w_rel x v       (d/dt R^T = -[w_rel]x R^T)
    """

    def __init__(self, frames, kin, gravity):
        self.frames, self.kin = frames, kin
        n = len(kin.q)
        zero = [se.Integer(0)] * 3
        self.gravity = gravity
        self._state = {WORLD: (zero, zero, [zero] * n, [zero] * n, zero, zero, gravity)}
        self._pose: dict = {}

    def __call__(self, name: str):
        """(w, v, Jw, Jv, alpha, a, g) of the frame `name`."""
        out = self._state.get(name)
        if out is not None:
            return out
        from ..model._frames import angular_velocity, rotation_product

        frame = self.frames[name]
        kin = self.kin
        wP, vP, JwP, JvP, alP, aP, gP = self(frame.parent)
        R = se.DenseMatrix(3, 3, [kin.se(x) for x in rotation_product(frame.factors)])
        wr = angular_velocity(frame.factors, kin)
        o = [kin.se(x) for x in frame.origin]
        od = [kin.rate(x) for x in o]
        odd = _at_rest(od, kin)
        w = _add(_rotT(R, wP), wr)
        u = _add(vP, _cross(wP, o), od)
        v = _rotT(R, u)
        RwP = _rotT(R, wP)
        alpha = _add(_rotT(R, alP), [-x for x in _cross(wr, RwP)], _at_rest(wr, kin))
        udot = _add(aP, _cross(alP, o), _cross(wP, od), odd)
        a = _add(_rotT(R, udot), [-x for x in _cross(wr, v)])
        Jw, Jv = [], []
        for j, (qj, uj) in enumerate(zip(kin.q, kin.qd)):
            Jw.append(_add(_rotT(R, JwP[j]), [x.diff(uj) for x in wr]))
            Jv.append(_rotT(R, _add(JvP[j], _cross(JwP[j], o), [x.diff(qj) for x in o])))
        g = None if gP is None else _rotT(R, gP)
        out = self._state[name] = (w, v, Jw, Jv, alpha, a, g)
        return out

    def pose_at_zero(self, name: str):
        """(origin in world coordinates, R_world) of the frame at q = 0, t = 0 (SymPy, parameters only)."""
        out = self._pose.get(name)
        if out is None:
            import sympy

            from ..model._frames import chain

            # each frame's pose at zero, composed (not the world pose's large expressions, then zero)
            zero = {s: 0 for s in self.kin_symbols_sympy()}
            origin, R = sympy.zeros(3, 1), sympy.eye(3)
            for fr in chain(self.frames, name):
                origin = origin + R * sympy.Matrix(fr.origin).xreplace(zero)
                R = R * fr.rotation.xreplace(zero)
            out = self._pose[name] = (origin, R)
        return out

    def kin_symbols_sympy(self):
        import sympy

        return [sympy.Symbol(s.name) for s in (*self.kin.q, self.kin.t)]


def _at_rest(vec, kin):
    """d/dt of each expression of q, q_dot and t, at q_ddot = 0."""
    q, qd, t = kin.q, kin.qd, kin.t
    return [sum((x.diff(qj) * v for qj, v in zip(q, qd)), x.diff(t)) for x in vec]


def _local(element, motion: _FrameMotion, frame: str, kin, rng):
    """The element's centre in the axes of `frame`, c with position = o_frame + R_frame c, constant
    (parameters only), or None: c is read at q = 0, t = 0 and checked at random states."""
    import sympy

    from ..model._frames import frame_pose

    if len(element.position) != 3:
        return None
    # in SymEngine: a position down a chain of frames is a large tree of shared subexpressions
    position = [kin.se(x) for x in element.position]
    origin0, R0 = motion.pose_at_zero(frame)
    zero = {se.Symbol(s.name): se.Integer(0) for s in motion.kin_symbols_sympy()}
    p0 = sympy.Matrix([sympy.sympify(x.xreplace(zero)) for x in position])
    c = [sympy.nsimplify(x) if x.is_number else sympy.simplify(x) for x in (R0.T * (p0 - origin0))]
    if any(set(x.free_symbols) & set(motion.kin_symbols_sympy()) for x in c):
        return None
    origin, R = frame_pose(motion.frames, frame)
    cs = [kin.se(x) for x in c]
    residual = [position[i] - kin.se(origin[i]) - sum((kin.se(R[i, k]) * cs[k] for k in range(3)), se.Integer(0))
                for i in range(3)]
    symbols = sorted(set().union(*(r.free_symbols for r in residual)), key=str)
    for _ in range(2):
        point = {s: se.Float(float(x)) for s, x in zip(symbols, rng.uniform(0.3, 1.7, len(symbols)))}
        try:
            values = [abs(complex(r.xreplace(point).n())) for r in residual]
        except (RuntimeError, TypeError, ValueError):
            return None
        if not all(v <= 1e-9 for v in values):
            return None
    return [kin.se(x) for x in c]


def kane_form(model, kin) -> tuple[list, list, list]:
    """(M, f, quantities) of `model` (frozen snapshot) with its particles and bodies in Kane's form
    and the rest by Lagrange's operator, in SymEngine (trees sharing their subexpressions).
    `quantities` is [(name, [components], note)]: each frame's angular velocity and origin velocity
    (in its axes), then the mass-centre velocity of each element not fixed in a frame.

    A body in space (and a particle fixed in a frame) moves with its frame: its velocity and
    acceleration come from the frame's (``_FrameMotion``), in the frame's axes; other particles and
    bodies from their positions (world axes). Gravity acts on the Jacobians of the velocities when
    every particle and body is taken in Kane's form, else through V."""
    import numpy as np

    from ..model._elements import Gravity
    from ..model._frames import WORLD as _WORLD  # noqa: F401

    q, qd, t = kin.q, kin.qd, kin.t
    n = len(q)
    varying = set(q) | set(qd) | {t}
    M = [[se.Integer(0)] * n for _ in range(n)]
    f = [se.Integer(0)] * n
    T_rest = kin.se(model.T)
    V = kin.se(model.V)
    D = kin.se(model.D)
    Q = [kin.se(model.Q.get(c, 0)) for c in model.q]
    massive = [e for e in model.elements if isinstance(e, (Particle, RigidBody, RigidBody3D))]
    kane = [e for e in massive if _massive_kane(e, varying, kin)]
    gravities = [e for e in model.elements if isinstance(e, Gravity)]
    gravity_here = len(kane) == len(massive) and len(gravities) == 1
    g_world = None
    if gravity_here:
        (grav,) = gravities
        dim = len(massive[0].position) if massive else 3
        if grav.direction is not None:
            import sympy

            norm = sympy.sqrt(sum(c ** 2 for c in grav.direction))
            unit = [kin.se(c / norm) for c in grav.direction]
        else:
            unit = [se.Integer(0)] * (dim - 1) + [se.Integer(-1)]
        g_world = [kin.se(grav.g) * x for x in unit]
    frames = model.frames
    motion = _FrameMotion(frames, kin, g_world if g_world is not None and len(g_world) == 3 else None)
    kin.frame_motion = motion  # M by composite bodies (_derive) reads the same expressions
    rng = np.random.default_rng(2024)
    quantities = []
    listed_frames: set = set()

    def list_frame(name):
        if name in listed_frames or name == WORLD:
            return
        list_frame(frames[name].parent)
        listed_frames.add(name)
        w, v = motion(name)[:2]
        quantities.append((f"w_{name}", w, f"angular velocity of frame {name} (its axes)"))
        quantities.append((f"v_{name}", v, f"velocity of the origin of frame {name} (its axes)"))

    def add_translation(mass, Jv, acc, g):
        for i in range(n):
            for j in range(i, n):
                M[i][j] = M[i][j] + mass * sum((Jv[i][k] * Jv[j][k] for k in range(len(acc))), se.Integer(0))
            force = sum((Jv[i][k] * acc[k] for k in range(len(acc))), se.Integer(0))
            if g is not None:
                force = force - sum((Jv[i][k] * g[k] for k in range(len(acc))), se.Integer(0))
            f[i] = f[i] - mass * force

    def add_rotation(I, w, Jw, alpha):
        Iw = [sum((I[r][k] * w[k] for k in range(3)), se.Integer(0)) for r in range(3)]
        torque = [sum((I[r][k] * alpha[k] for k in range(3)), se.Integer(0)) for r in range(3)]
        torque = _add(torque, _cross(w, Iw))
        for i in range(n):
            for j in range(i, n):
                M[i][j] = M[i][j] + sum((Jw[i][r] * I[r][k] * Jw[j][k] for r in range(3) for k in range(3)),
                                        se.Integer(0))
            f[i] = f[i] - sum((Jw[i][r] * torque[r] for r in range(3)), se.Integer(0))

    for element in model.elements:
        if element in kane:
            mass = kin.se(element.mass)
            frame = element.frame if isinstance(element, RigidBody3D) else None
            c = None
            if frame is not None:
                c = _local(element, motion, frame, kin, rng)
            elif isinstance(element, Particle) and len(element.position) == 3 and frames:
                c, frame = _particle_frame(element, motion, frames, kin, rng)
            if c is not None:
                list_frame(frame)
                w, v, Jw, Jv, alpha, a, g = motion(frame)
                vG = _add(v, _cross(w, c))
                JvG = [_add(Jv[j], _cross(Jw[j], c)) for j in range(n)]
                aG = _add(a, _cross(alpha, c), _cross(w, vG))
                add_translation(mass, JvG, aG, g if gravity_here else None)
                if isinstance(element, RigidBody3D):
                    add_rotation([[kin.se(x) for x in row] for row in element.inertia], w, Jw, alpha)
                continue
            v = kin.velocity(element.position)
            quantities.append((f"v_{element.name}", v, f"velocity of the mass centre of {element.name} (world axes)"))
            Jv = [[x.diff(u) for x in v] for u in qd]
            gw = (g_world if gravity_here and g_world is not None and len(g_world) == len(v) else None)
            add_translation(mass, Jv, _at_rest(v, kin), gw)
            if isinstance(element, RigidBody):
                w = kin.rate(element.angle)
                quantities.append((f"w_{element.name}", [w], f"angular velocity of {element.name}"))
                I = kin.se(element.inertia)
                Jw = [w.diff(u) for u in qd]
                alpha = _at_rest([w], kin)[0]
                for i in range(n):
                    for j in range(i, n):
                        M[i][j] = M[i][j] + I * Jw[i] * Jw[j]
                    f[i] = f[i] - Jw[i] * I * alpha
            elif isinstance(element, RigidBody3D):
                w = element.omega(kin)
                quantities.append((f"w_{element.name}", w, f"angular velocity of {element.name} (its axes)"))
                I = [[kin.se(x) for x in row] for row in element.inertia]
                add_rotation(I, w, [[x.diff(u) for x in w] for u in qd], _at_rest(w, kin))
            continue
        if gravity_here and isinstance(element, Gravity):
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


def _particle_frame(element, motion: _FrameMotion, frames, kin, rng):
    """(c, frame) of a particle fixed in a frame (its position o + R c with c constant): the frames
    whose chain holds exactly the coordinates of its position are tried, the deepest first."""
    import sympy

    from ..model._frames import chain

    used = set().union(*(sympy.sympify(x).free_symbols for x in element.position))
    coordinates = {sympy.Symbol(s.name) for s in kin.q}
    wanted = used & coordinates
    candidates = []
    for name in frames:
        path = chain(frames, name)
        held = set()
        for fr in path:
            for x in fr.origin:
                held |= sympy.sympify(x).free_symbols & coordinates
            for fac in fr.factors:
                parts = [fac.angle] if fac.matrix is None else [x for row in fac.matrix for x in row]
                for x in parts:
                    held |= sympy.sympify(x).free_symbols & coordinates
        if held == wanted:
            candidates.append((len(path), name))
    for _, name in sorted(candidates, reverse=True):
        c = _local(element, motion, name, kin, rng)
        if c is not None:
            return c, name
    return None, None


def named_form(equations) -> NamedForm:
    """The :class:`NamedForm` of `equations` (an :class:`~lagrangian.equations.Equations`)."""
    model, core = equations.model, equations.core
    M, f, quantities = kane_form(model, _kinematics(model))
    n = len(f)
    G = core.G
    m = 0 if G is None else G.rows
    upper = [M[i][j] for i in range(n) for j in range(i, n)]
    rows = [G[k, j] for k in range(m) for j in range(n)]
    listed, (upper, fn, rows, cn, gn) = _name_all(model, quantities, [upper, list(f), rows, list(core.c),
                                                                      list(core.g)])
    Mn = [[None] * n for _ in range(n)]
    pos = 0
    for i in range(n):
        for j in range(i, n):
            Mn[i][j] = Mn[j][i] = upper[pos]
            pos += 1
    Gn = [rows[k * n: (k + 1) * n] for k in range(m)]
    return NamedForm(quantities=tuple(listed), M=tuple(tuple(r) for r in Mn), f=tuple(fn),
                     G=tuple(tuple(r) for r in Gn), c=tuple(cn), g=tuple(gn))


def _kinematics(model):
    from ..model._kinematics import Kinematics

    return Kinematics(model.q, [e for e in model.elements if isinstance(e, (Particle, RigidBody, RigidBody3D))])


def _name_all(model, quantities: list, groups: list[list], extra_taken=()) -> tuple[list, list[list]]:
    """Common subexpressions of the `quantities` ([(name, components, note)]) and of the expressions
    in `groups`, named: ([(name, expression, note)] in order of definition, the groups rewritten)."""
    defined = [x for _, vec, _ in quantities for x in vec]
    exprs = defined + [e for group in groups for e in group]
    taken = {s.name for s in (*model.q, *model.q_dot, *model.q_ddot, *model.parameters, *model.inputs)}
    taken |= {"t"} | {name for name, _, _ in quantities} | set(extra_taken)
    replacements, reduced = se.cse(exprs)
    temporaries = {lhs for lhs, _ in replacements}
    keep = {r for r in reduced[:len(defined)] if type(r) is se.Symbol and r in temporaries}
    replacements, reduced = _inlined(replacements, reduced, keep)
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
    out, pos = [], 0
    for group in groups:
        out.append(rest[pos:pos + len(group)])
        pos += len(group)
    return listed, out


# ------------------------------------------------------------------------ quasi-velocities
@dataclass(frozen=True)
class QuasiVelocityForm:
    """Lagrange's equations in quasi-velocities (the Boltzmann-Hamel / Poincare form, which Kane's
    method amounts to): each frame turned by three coordinates of its own (a spherical joint: three
    angles) has as speeds u its angular velocity relative to its parent, in its own axes,
    ``u_<frame>_x, _y, _z`` (for a frame on the world, its angular velocity); every other
    coordinate keeps its velocity. With q_dot = W(q) u (the kinematic equations, stated),

        M_u(q) u_dot = f_u(q, u, t),    M_u = W^T M W,    f_u = W^T (f - M (dW/dt) u),

    the equations of the same motion (the tests simulate both). SymEngine expressions, with the
    named quantities of :class:`NamedForm`.

    Attributes
    ----------
    speeds : tuple of str, shape (n,)
    kinematic : tuple of (velocity name, expression in q and u), shape (n,)
    quantities, M (n x n), f (n,)
    """

    speeds: tuple
    kinematic: tuple
    quantities: tuple
    M: tuple
    f: tuple
    W: tuple = ()

    def lines(self) -> list[str]:
        out = ["Speeds u: " + ", ".join(self.speeds), "", "Kinematic equations (q_dot = W(q) u):"]
        out += [f"  {name} = {expr}" for name, expr in self.kinematic]
        out += ["", f"Named quantities ({len(self.quantities)}, each in terms of those before it):"]
        out += [f"  {name} = {expr}" + (f"    # {note}" if note else "") for name, expr, note in self.quantities]
        out += ["", "M_u(q) u_dot = f_u(q, u, t):", "  M_u ="]
        out += ["    [" + ", ".join(str(x) for x in row) + "]" for row in self.M]
        out += ["  f_u ="] + [f"    {x}" for x in self.f]
        return out


def _inverse3(E):
    """The inverse of a 3x3 SymEngine matrix as adjugate / determinant, each in readable form (for
    Euler angles about x, y, z: det = cos(y)), or None when the determinant is identically 0."""
    from ._readable import readable

    def r(e):
        return se.sympify(readable(e))

    det = r(E.det())
    if det == 0:
        return None
    cof = [[r(E[(i + 1) % 3, (j + 1) % 3] * E[(i + 2) % 3, (j + 2) % 3]
              - E[(i + 1) % 3, (j + 2) % 3] * E[(i + 2) % 3, (j + 1) % 3]) for j in range(3)] for i in range(3)]
    return [[cof[j][i] / det for j in range(3)] for i in range(3)]


def quasi_velocity_form(equations) -> QuasiVelocityForm:
    """The :class:`QuasiVelocityForm` of `equations` (unconstrained; at least one frame turned by three
    coordinates of its own, else a ModelError says why)."""
    from ..errors import ModelError
    from ..model._frames import angular_velocity

    model = equations.model
    if equations.is_constrained:
        raise ModelError(f"quasi-velocities: model '{model.name}' has constraints; the quasi-velocity form is for "
                         "unconstrained models (derive it without --quasi-velocities)")
    kin = _kinematics(model)
    q, qd, n = kin.q, kin.qd, len(kin.q)
    names = [c.name for c in model.q]
    owner: dict = {}
    for fname, frame in model.frames.items():
        for fac in frame.factors:
            parts = [fac.angle] if fac.matrix is None else [x for row in fac.matrix for x in row]
            for x in parts:
                for s in kin.se(x).free_symbols:
                    if s in q:
                        owner.setdefault(s, set()).add(fname)
    W = [[se.Integer(0)] * n for _ in range(n)]
    speeds = [f"{c}_dot" for c in names]
    done = set()
    found = []
    for fname, frame in model.frames.items():
        mine = [s for s, frames in owner.items() if frames == {fname}]
        if len(mine) != 3 or any(m in done for m in mine):
            continue
        wr = angular_velocity(frame.factors, kin)
        idx = [q.index(s) for s in sorted(mine, key=q.index)]
        E = se.DenseMatrix(3, 3, [wr[r].diff(qd[j]) for r in range(3) for j in idx])
        if any(set(wr[r].free_symbols) & (set(qd) - {qd[j] for j in idx}) for r in range(3)):
            continue
        Einv = _inverse3(E)
        if Einv is None:
            continue
        for a, j in enumerate(idx):
            speeds[j] = f"u_{fname}_{_AXES[a]}"
            for b, k in enumerate(idx):
                W[j][k] = Einv[a][b]
        done |= set(mine)
        found.append(fname)
    if not found:
        raise ModelError(f"quasi-velocities: no frame of model '{model.name}' is turned by three coordinates of its "
                         "own (a spherical joint: three angles), so its speeds are its velocities; "
                         "derive it without --quasi-velocities")
    for j in range(n):
        if qd[j] not in {qd[i] for i in range(n) if q[i] in done}:
            W[j][j] = se.Integer(1)
    u = [se.Symbol(s) for s in speeds]
    qdot_u = [sum((W[j][k] * u[k] for k in range(n)), se.Integer(0)) for j in range(n)]
    to_u = dict(zip(qd, qdot_u))
    M, f, quantities = kane_form(model, kin)
    # f at q_dot = W u, minus M (dW/dt) u; then W^T (...), W^T M W
    fu_q = list(se.DenseMatrix(list(f)).xreplace(to_u))
    Wdot_u = [sum((sum((W[j][k].diff(q[i]) * qdot_u[i] for i in range(n)), se.Integer(0)) * u[k]
                   for k in range(n)), se.Integer(0)) for j in range(n)]
    rhs = [fu_q[i] - sum((M[i][j] * Wdot_u[j] for j in range(n)), se.Integer(0)) for i in range(n)]
    Mu = [[sum((W[a][i] * M[a][b] * W[b][j] for a in range(n) for b in range(n) if W[a][i] != 0 and W[b][j] != 0),
               se.Integer(0)) for j in range(n)] for i in range(n)]
    fu = [sum((W[a][i] * rhs[a] for a in range(n) if W[a][i] != 0), se.Integer(0)) for i in range(n)]
    quantities = [(name, list(se.DenseMatrix(vec).xreplace(to_u)), note) for name, vec, note in quantities]
    upper = [Mu[i][j] for i in range(n) for j in range(i, n)]
    listed, (upper, fn) = _name_all(model, quantities, [upper, fu], extra_taken=speeds)
    Mn = [[None] * n for _ in range(n)]
    pos = 0
    for i in range(n):
        for j in range(i, n):
            Mn[i][j] = Mn[j][i] = upper[pos]
            pos += 1
    kinematic = tuple((f"{names[j]}_dot", qdot_u[j]) for j in range(n))
    return QuasiVelocityForm(speeds=tuple(speeds), kinematic=kinematic, quantities=tuple(listed),
                             M=tuple(tuple(r) for r in Mn), f=tuple(fn), W=tuple(tuple(r) for r in W))


def _inlined(replacements: list, reduced: list, keep: set) -> tuple[list, list]:
    """The common subexpressions with the short ones written in place: a temporary whose text is
    short enough that writing it where it is used (uses x (length - a name's)) costs less than
    its own line (length + a line's overhead) is substituted, in order (so that what it uses is
    already written out). Fewer names, and a shorter text: cse names every repeated product of two
    factors."""
    uses: dict = {}
    for e in [rhs for _, rhs in replacements] + list(reduced):
        for s in e.free_symbols:
            uses[s] = uses.get(s, 0) + 1
    inline: dict = {}
    kept = []
    for lhs, rhs in replacements:
        here = {s: inline[s] for s in rhs.free_symbols if s in inline}
        if here:
            rhs = rhs.xreplace(here)
        size = len(str(rhs))
        if lhs not in keep and uses.get(lhs, 0) * (size - 3) <= size + 12:
            inline[lhs] = rhs
        else:
            kept.append((lhs, rhs))
    if inline and reduced:
        reduced = list(se.DenseMatrix(list(reduced)).xreplace(inline))
    return kept, reduced


def _prefix(taken: set) -> str:
    """The letter(s) of the common subexpressions' names: ``x`` unless a model name is ``x<digits>``."""
    for prefix in ("x", "z", "e", "xx"):
        if not any(re.fullmatch(rf"{prefix}[0-9]+", name) for name in taken):
            return prefix
    k = 1
    while any(re.fullmatch(rf"cse{k}_[0-9]+", name) for name in taken):
        k += 1
    return f"cse{k}_"
