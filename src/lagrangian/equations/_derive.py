"""derive(model) -> Equations: Lagrange's operator, done in SymEngine.

With L = T* - V, the i-th equation is the residual

    E_i = d/dt(dL/dq_dot_i) - dL/dq_i + dD/dq_dot_i - Q_i = 0,

and with d/dt by the chain rule (q, q_dot, q_ddot are plain symbols),

    M_ij = d2L/dq_dot_i dq_dot_j,
    f_i  = dL/dq_i - sum_j d2L/dq_dot_i dq_j q_dot_j - d2L/dq_dot_i dt - dD/dq_dot_i + Q_i,
    E_i  = sum_j M_ij q_ddot_j - f_i.

q_ddot is never solved for symbolically: the numeric layer solves M q_ddot = f.
"""

from __future__ import annotations

import symengine as se

from .._limits import MAX_COORDINATES, MAX_TERMS
from ..errors import ModelError, Problem
from ..model import Model
from ..model._constraints import HOLONOMIC
from ..model._elements import Gravity, Particle, RigidBody, RigidBody3D
from ..model._kinematics import Kinematics
from ._equations import Equations, SymbolicCore
from ._readable import expanded_terms_bound

__all__ = ["derive"]


def derive(model: Model) -> Equations:
    """Derive Lagrange's equations of `model`.

    Parameters
    ----------
    model : Model
        Checked first: every problem is reported at once as a :class:`ModelError`.

    Returns
    -------
    Equations
        Immutable: the residuals, the mass matrix M and forcing f with M q_ddot = f, and
        their parts (see :class:`Equations`).
    """
    if not isinstance(model, Model):
        raise TypeError(f"derive() expects a Model (lagrangian.load(...) or lagrangian.Model(...)), "
                        f"got {type(model).__name__}")
    model.validate()
    if len(model.q) > MAX_COORDINATES.value:
        raise ModelError([Problem(f"model '{model.name}' has {len(model.q)} coordinates, more than derive() takes: "
                                 f"{MAX_COORDINATES.how_to_raise()}", key="coordinates")])
    snapshot = model.copy()._freeze()
    massive = [e for e in snapshot.elements if isinstance(e, (Particle, RigidBody, RigidBody3D))]
    kin = Kinematics(snapshot.q, massive)

    T = kin.se(snapshot.T)
    V = kin.se(snapshot.V)
    D = kin.se(snapshot.D)
    Q = [kin.se(snapshot.Q.get(c, 0)) for c in snapshot.q]
    V_written = V  # V without gravity's, a sum over the positions (bounded as T's inputs, see _check_sizes)
    kinetic = []  # (element, its T*), for the momenta in Kane's form
    for element in snapshot.elements:
        c = element.contribute(kin)
        T, V, D = T + c.T, V + c.V, D + c.D
        kinetic.append((element, c.T))
        if not isinstance(element, Gravity):
            V_written = V_written + c.V
        if c.Q:
            Q = [a + b for a, b in zip(Q, c.Q)]

    _check_sizes(snapshot, V_written, D, Q, kin)
    L = T - V
    q, qd, t = kin.q, kin.qd, kin.t
    if expanded_terms_bound(T, KANE_ABOVE) > KANE_ABOVE:
        M, f = _kane_core(snapshot, kin)
        composite = _composite_mass_matrix(snapshot, kin, kinetic) if len(q) >= COMPOSITE_FROM else None
        if composite is not None:
            M = composite
        momenta = _kane_momenta(snapshot, kin, M, kinetic)
        if momenta is None:
            p = [L.diff(v) for v in qd]
        else:
            p, rest = momenta
            if composite is not None:  # T* = q_dot^T M_b q_dot / 2 + T_r, with M_b q_dot = p - dT_r/dq_dot
                half = se.Rational(1, 2)
                T = rest + half * sum((v * (pi - rest.diff(v)) for v, pi in zip(qd, p)), se.Integer(0))
                L = T - V
    else:
        p = [L.diff(v) for v in qd]
        M, f = _lagrange_core(L, D, Q, p, kin)
    g, G, w, c = _constraint_parts(snapshot, kin)
    core = SymbolicCore(q=tuple(q), qd=tuple(qd), t=t, T=T, V=V, D=D, Q=tuple(Q), L=L,
                        p=tuple(p), M=M, f=tuple(f), g=g, G=G, w=w, c=c)
    return Equations(model=snapshot, core=core)


#: T* (assembled from the bodies) whose expansion could have more terms than this is differentiated
#: in Kane's form (``_named.kane_form``: each frame's velocities from its parent's) instead of by
#: differentiating T* twice: a chain of rods in space (T* of three rods: millions of terms; six rods:
#: 21 s by Lagrange's operator). Equal to Lagrange's (tested); below it, Lagrange's operator as ever.
KANE_ABOVE = 100_000


def _lagrange_core(L, D, Q, p, kin: Kinematics):
    """(M, f) by Lagrange's operator on L, D and Q (p = dL/dq_dot)."""
    q, qd, t = kin.q, kin.qd, kin.t
    n = len(q)
    M = se.zeros(n, n)
    for i in range(n):
        for j in range(i, n):
            M[i, j] = p[i].diff(qd[j])
            if j != i:
                M[j, i] = M[i, j]
    f = []
    for i in range(n):
        fi = L.diff(q[i]) - p[i].diff(t) - D.diff(qd[i]) + Q[i]
        for j in range(n):
            fi = fi - p[i].diff(q[j]) * qd[j]
        f.append(fi)
    return M, f


def _kane_core(model: Model, kin: Kinematics):
    """(M, f) in Kane's form (see KANE_ABOVE)."""
    from ._named import kane_form

    rows, f, _ = kane_form(model, kin)
    n = len(f)
    return se.DenseMatrix(n, n, [x for row in rows for x in row]), list(f)


#: Models in Kane's form with at least this many coordinates get M by composite bodies (see
#: _composite_mass_matrix) where their bodies allow it: the same values in far smaller expressions.
COMPOSITE_FROM = 30


def _composite_mass_matrix(model: Model, kin: Kinematics, kinetic):
    """M of a tree of frames by composite bodies (the composite-rigid-body algorithm, symbolically), or
    None where the model is not such a tree: every particle and body of constant mass fixed in a frame,
    each coordinate in the definition (origin, rotation) of exactly one frame K_i.

    With col_i = (Jw_K[i], Jv_K[i]) the angular and origin velocity of frame K per unit q_dot_i (K's axes)
    and B_K the kinetic-energy form of everything carried by K and the frames below it (composite mass,
    first moment and inertia about K's origin, in K's axes, built from the children's):

        M_ij = B_K(col_i, col_j) with K the deeper of K_i, K_j when one hangs below the other, else 0,

    plus the Hessian of the rest of T* (as Kane's form adds it). Equal to Kane's sum over the bodies
    (tested), whose entries hold a term per body below: O(n^3) nodes for a chain against O(n^2)."""
    import numpy as np
    import sympy

    from ..model._frames import WORLD, rotation_product
    from ._named import _FrameMotion, _local, _massive_kane, _particle_frame

    q, qd, t = kin.q, kin.qd, kin.t
    n = len(q)
    frames = model.frames
    varying = set(q) | set(qd) | {t}
    motion = kin.frame_motion if kin.frame_motion is not None else _FrameMotion(frames, kin, None)
    rng = np.random.default_rng(2024)
    zero = se.Integer(0)
    own: dict = {}  # frame -> [mass, first moment (3), inertia about its origin (3x3)], its axes
    rest = kin.se(model.T)
    for element, T in kinetic:
        if not isinstance(element, (Particle, RigidBody, RigidBody3D)) or not _massive_kane(element, varying, kin):
            rest = rest + T
            continue
        if isinstance(element, RigidBody3D):
            frame, c = element.frame, _local(element, motion, element.frame, kin, rng)
        elif isinstance(element, Particle) and len(element.position) == 3 and frames:
            c, frame = _particle_frame(element, motion, frames, kin, rng)
        else:
            return None
        if c is None:
            return None
        m = kin.se(element.mass)
        I = ([[kin.se(x) for x in row] for row in element.inertia] if isinstance(element, RigidBody3D)
             else [[zero] * 3 for _ in range(3)])
        c2 = sum((x * x for x in c), zero)
        I_O = [[I[a][b] + m * ((c2 if a == b else 0) - c[a] * c[b]) for b in range(3)] for a in range(3)]
        acc = own.setdefault(frame, [zero, [zero] * 3, [[zero] * 3 for _ in range(3)]])
        acc[0] = acc[0] + m
        acc[1] = [acc[1][a] + m * c[a] for a in range(3)]
        acc[2] = [[acc[2][a][b] + I_O[a][b] for b in range(3)] for a in range(3)]
    # each coordinate's frame
    names = {s.name: j for j, s in enumerate(q)}
    home: dict = {}
    for name, frame in frames.items():
        parts = list(frame.origin)
        for f in frame.factors:
            parts += [f.angle] if f.matrix is None else [x for row in f.matrix for x in row]
        for s in set().union(*(sympy.sympify(x).free_symbols for x in parts)) if parts else ():
            if s.name in names:
                if names[s.name] in home:
                    return None
                home[names[s.name]] = name
    if len(home) != n:
        return None
    children: dict = {}
    for name, frame in frames.items():
        children.setdefault(frame.parent, []).append(name)
    composite: dict = {}

    def build(name):  # the composite of `name` and the frames below it, in its axes, about its origin
        mass, h, I = own.get(name, [zero, [zero] * 3, [[zero] * 3 for _ in range(3)]])
        for child in children.get(name, ()):
            mc, hc, Ic = build(child)
            fr = frames[child]
            R = [[kin.se(x) for x in row] for row in rotation_product(fr.factors).tolist()]
            o = [kin.se(x) for x in fr.origin]
            hr = [sum((R[a][k] * hc[k] for k in range(3)), zero) for a in range(3)]
            RI = [[sum((R[a][k] * Ic[k][b] for k in range(3)), zero) for b in range(3)] for a in range(3)]
            Ir = [[sum((RI[a][k] * R[b][k] for k in range(3)), zero) for b in range(3)] for a in range(3)]
            o2 = sum((x * x for x in o), zero)
            oh = sum((o[a] * hr[a] for a in range(3)), zero)
            I = [[I[a][b] + Ir[a][b] + mc * ((o2 if a == b else 0) - o[a] * o[b])
                  + ((2 * oh if a == b else 0) - o[a] * hr[b] - hr[a] * o[b]) for b in range(3)] for a in range(3)]
            h = [h[a] + mc * o[a] + hr[a] for a in range(3)]
            mass = mass + mc
        composite[name] = (mass, h, I)
        return composite[name]

    for top in children.get(WORLD, ()):
        build(top)

    def form(K, i, j):
        mass, h, I = composite[K]
        _, _, Jw, Jv = motion(K)[:4]
        wi, vi, wj, vj = Jw[i], Jv[i], Jw[j], Jv[j]
        out = sum((wi[a] * I[a][b] * wj[b] for a in range(3) for b in range(3)), zero)
        out = out + mass * sum((vi[a] * vj[a] for a in range(3)), zero)
        cross_j = [wj[1] * h[2] - wj[2] * h[1], wj[2] * h[0] - wj[0] * h[2], wj[0] * h[1] - wj[1] * h[0]]
        cross_i = [wi[1] * h[2] - wi[2] * h[1], wi[2] * h[0] - wi[0] * h[2], wi[0] * h[1] - wi[1] * h[0]]
        return out + sum((vi[a] * cross_j[a] + vj[a] * cross_i[a] for a in range(3)), zero)

    M = se.zeros(n, n)
    for i in range(n):
        for j in range(i, n):
            Ki, Kj = home[i], home[j]
            if Ki == Kj or Ki in _ancestors(frames, Kj):
                K = Kj
            elif Kj in _ancestors(frames, Ki):
                K = Ki
            else:
                continue
            entry = form(K, i, j)
            ri = rest.diff(qd[i])
            entry = entry + (ri.diff(qd[j]) if ri != 0 else zero)
            M[i, j] = M[j, i] = entry
    return M


def _ancestors(frames, name) -> set:
    out = set()
    while frames[name].parent in frames:
        name = frames[name].parent
        out.add(name)
    return out


def _kane_momenta(model: Model, kin: Kinematics, M, kinetic) -> tuple[list, se.Basic] | None:
    """p = dL/dq_dot of a model whose M is in Kane's form, from M: p = M q_dot + dT_r/dq_dot - H_r q_dot,
    with T_r the kinetic co-energy of what is not in Kane's form (the [energy] T, elements other than
    particles and bodies of constant mass) and H_r its Hessian in q_dot (M holds it). The particles and
    bodies in Kane's form have velocities J(q) q_dot when nothing of their motion depends on t, so their
    T* is q_dot^T M_b q_dot / 2 and its gradient M_b q_dot: the same p as differentiating T* (in
    SymEngine, a chain of 20 rods on spherical joints: 60 gradients of T* of its 60 positions take
    minutes, M q_dot milliseconds). Returns (p, T_r), or None when a motion depends on t (then p is T*'s
    gradient)."""
    from ._named import _massive_kane

    q, qd, t = kin.q, kin.qd, kin.t
    varying = set(q) | set(qd) | {t}
    rest = kin.se(model.T)
    for element, T in kinetic:
        if not (isinstance(element, (Particle, RigidBody, RigidBody3D)) and _massive_kane(element, varying, kin)):
            rest = rest + T
            continue
        parts = list(element.position)
        if isinstance(element, RigidBody):
            parts.append(element.angle)
        elif isinstance(element, RigidBody3D):
            for f in element.factors:
                parts += ([f.angle] if f.matrix is None
                          else [x for row in f.matrix for x in row] + list(getattr(f, "rate", None) or ()))
        if any(t in kin.se(x).free_symbols for x in parts):
            return None
    n = len(qd)
    out = []
    for i in range(n):
        ri = rest.diff(qd[i])
        pi = ri - sum((ri.diff(qd[j]) * qd[j] for j in range(n)), se.Integer(0)) if ri != 0 else ri
        out.append(sum((M[i, j] * qd[j] for j in range(n)), pi))
    return out, rest


def _check_sizes(model: Model, V, D, Q, kin: Kinematics) -> None:
    """Refuse, before any work on them, expressions whose expansion could have more terms than
    MAX_TERMS (counted on the tree, not by expanding: ``(x + y + z + w)**200`` has 1,373,701), since
    the equations' parts and readable forms expand them: every such expression is reported at once.

    T* is checked as written in [energy] T, and V without gravity's sum over the positions: the
    positions of bodies down a chain of frames are products of the frames' rotations (3^k terms
    at depth k, expanded), and T* of three rods in space, each on a spherical joint, could expand
    to millions of terms, which derive() never expands (the equations of such models are shown
    with named quantities, see ``_named``; the Jacobi integral is expanded only within the same
    budget)."""
    from ._readable import expanded_terms_bound

    limit = MAX_TERMS.value
    memo: dict = {}
    parts = [("energy.T", "T*", kin.se(model.T)), ("energy.V", "V", V), ("energy.D", "D", D)]
    parts += [(f"forces.{c}", f"Q[{c}]", Qi) for c, Qi in zip(model.q, Q)]
    parts += [(f"constraints[{k}]", f"constraint {k + 1}", kin.se(con.expression))
              for k, con in enumerate(model.constraints)]
    problems = [Problem(f"{name} could expand to more than {limit:,} terms (counted on its expression, e.g. a power "
                        "of a long sum): write it in a shorter form (fewer terms in a raised sum, a parameter for a "
                        f"repeated factor); {MAX_TERMS.how_to_raise()}", key=key)
                for key, name, e in parts if expanded_terms_bound(e, limit, memo) > limit]
    if problems:
        raise ModelError(problems)


def _constraint_parts(model: Model, kin: Kinematics):
    """(g, G, w, c) of the model's constraints (see SymbolicCore): G's rows are dg/dq for a
    holonomic constraint and the velocities' coefficients for a velocity constraint; w = G q_dot + b
    is the velocity residual (dg/dt for a holonomic one) and c = -(dw/dq q_dot + dw/dt), so that
    G q_ddot = c."""
    if not model.constraints:
        return (), None, (), ()
    q, qd, t = kin.q, kin.qd, kin.t
    G = se.zeros(len(model.constraints), len(q))
    g, w, c = [], [], []
    for k, con in enumerate(model.constraints):
        e = kin.se(con.expression)
        if con.kind == HOLONOMIC:
            rows = [e.diff(qj) for qj in q]
            wk = sum((r * v for r, v in zip(rows, qd)), e.diff(t))
        else:
            rows = [e.diff(v) for v in qd]
            wk = e
        for j, r in enumerate(rows):
            G[k, j] = r
        g.append(e)
        w.append(wk)
        c.append(-(sum((wk.diff(qj) * v for qj, v in zip(q, qd)), wk.diff(t))))
    return tuple(g), G, tuple(w), tuple(c)
