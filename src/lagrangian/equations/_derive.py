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
        p = _kane_momenta(snapshot, kin, M, kinetic)
        if p is None:
            p = [L.diff(v) for v in qd]
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


def _kane_momenta(model: Model, kin: Kinematics, M, kinetic) -> list | None:
    """p = dL/dq_dot of a model whose M is in Kane's form, from M: p = M q_dot + dT_r/dq_dot - H_r q_dot,
    with T_r the kinetic co-energy of what is not in Kane's form (the [energy] T, elements other than
    particles and bodies of constant mass) and H_r its Hessian in q_dot (M holds it). The particles and
    bodies in Kane's form have velocities J(q) q_dot when nothing of their motion depends on t, so their
    T* is q_dot^T M_b q_dot / 2 and its gradient M_b q_dot: the same p as differentiating T* (in
    SymEngine, a chain of 20 rods on spherical joints: 60 gradients of T* of its 60 positions take
    minutes, M q_dot milliseconds). None when a motion depends on t (then p is T*'s gradient)."""
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
    return out


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
