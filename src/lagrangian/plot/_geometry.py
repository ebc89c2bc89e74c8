"""The drawable geometry of a model: where each of its elements is, as numeric functions of (t, q).

Everything here comes from the model's own elements; nothing is invented. The rules, written
once (docs/plots.md repeats them):

* **Nodes** are the named points, particles and rigid bodies (their positions), plus the ends of
  springs and dampers given as positions.
* **Fixed nodes** (positions free of q and t) are drawn on the ground.
* **Rods** join two nodes whose distance never changes while at least one of them moves: a
  pendulum bob and its pivot, two bobs of a chain. The distance is compared at random
  configurations (q, t), not along the trajectory, so a system that happens to stay at rest
  grows no rods.
* **Hidden pivots**: the position of a particle or body with its terms that hold a trigonometric
  function of a coordinate removed is the point it turns about, e.g. (q1, L) for the pendulum
  at (q1 + L cos q2, L + L sin q2). When that point is not already a node and the element stays
  at a constant distance from it, it becomes a pivot node; the rod rule then joins it to the
  element and to whatever it is rigidly fixed on (the cart at (q1, 0)).
* **Springs and dampers** are drawn between their two points (`between`); one given by its
  `length` only is drawn between the one pair of nodes whose distance equals |length| (or
  between a node and the origin), and not drawn when there is no such pair (a torsional spring).
* **Tracks**: a particle, body or point (or a hidden pivot not fixed on one) that moves along a
  straight line (d position/dq constant, of rank 1, free of t) is drawn on a guide line; such
  particles and points are drawn as blocks (carts, sliders; a massless cart is a point).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

import numpy as np
import sympy

from ..errors import ModelError
from ..model._elements import Damper, Particle, Point, RigidBody, RigidBody3D, Spring

__all__ = ["Scene", "Node", "scene_of", "check_drawable", "drawable_names"]

_TRIG = (sympy.sin, sympy.cos, sympy.tan)
_SAMPLES = 7


@dataclass(frozen=True)
class Node:
    """A drawn point: `kind` is "point", "particle", "body", "pivot" (hidden) or "end"."""

    name: str
    kind: str
    mass: float = 0.0
    inertia: float = 0.0
    fixed: bool = False
    slider: bool = False


@dataclass(frozen=True, eq=False)
class Scene:
    """What to draw and where: node positions and body angles as functions of (t, q).

    Attributes
    ----------
    dim : int
        2 (planar) or 3 (spatial).
    nodes : tuple of Node
    rods : tuple of (int, int)
        Pairs of node indices.
    springs, dampers : tuple of (str, int, int)
        Name and the node indices of the two ends.
    tracks : tuple of (ndarray, ndarray)
        A point on each guide line and its unit direction.
    undrawn : tuple of str
        Elements that could not be drawn, with the reason.
    """

    dim: int
    nodes: tuple[Node, ...]
    rods: tuple[tuple[int, int], ...]
    springs: tuple[tuple[str, int, int], ...]
    dampers: tuple[tuple[str, int, int], ...]
    tracks: tuple[tuple[np.ndarray, np.ndarray], ...]
    undrawn: tuple[str, ...]
    _positions: object
    _angles: object
    _bodies: tuple[int, ...]

    def index(self, name: str) -> int:
        """Index of the node named `name`."""
        for i, node in enumerate(self.nodes):
            if node.name == name:
                return i
        raise KeyError(name)

    def positions(self, t, q) -> np.ndarray:
        """Node positions, shape (N, len(nodes), dim), for times `t` (N,) and coordinates `q` (N, n)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q = np.asarray(q, dtype=float).reshape(len(t), -1)
        return self._positions(t, q)

    def angles(self, t, q) -> np.ndarray:
        """Rotation angle of each rigid body node, shape (N, number of bodies), in `bodies` order."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q = np.asarray(q, dtype=float).reshape(len(t), -1)
        return self._angles(t, q)

    @property
    def bodies(self) -> tuple[int, ...]:
        """Indices of the rigid-body nodes."""
        return self._bodies


def _positioned(model):
    return [e for e in model.elements if isinstance(e, (Point, Particle, RigidBody, RigidBody3D))]


def drawable_names(model) -> list[str]:
    """Names of the model's points, particles and rigid bodies (what `trace` may name)."""
    return [e.name for e in _positioned(model)]


def check_drawable(model, trace=()) -> None:
    """Raise a ModelError when `model` has no geometry to draw, or `trace` names an unknown element."""
    elements = _positioned(model)
    if not elements:
        raise ModelError(
            f"model '{model.name}' cannot be drawn: it is described by its energies (T, V, D) only, and an "
            "animation needs the positions of its parts. Describe it with elements instead: particles, rigid "
            "bodies, points, springs and dampers with positions as functions of the coordinates (see "
            "docs/model-files.md; e.g. the built-in 'cart-pendulum' is the element form of "
            "'cart-pendulum-energy').")
    names = [e.name for e in elements]
    for name in trace:
        if name not in names:
            hint = difflib.get_close_matches(str(name), names, n=1)
            extra = f" (did you mean '{hint[0]}'?)" if hint else ""
            raise ModelError(f"trace '{name}': model '{model.name}' has no point, particle or rigid body of that "
                             f"name{extra}; the names are {', '.join(names)}")


def _parameter_values(model, values) -> dict:
    out = {}
    for p, v in model.parameters.items():
        v = (values or {}).get(p.name, v)
        if v is None:
            raise ModelError(f"parameter '{p.name}' has no value, so model '{model.name}' cannot be drawn: "
                             f"give params={{'{p.name}': ...}}")
        out[p] = float(v)
    return out


def _has_trig_of(expr, coords) -> bool:
    return any(f.args[0].free_symbols & coords for f in expr.atoms(*_TRIG))


def _pivot_of(position, coords) -> tuple | None:
    """The position with its terms holding a trigonometric function of a coordinate removed."""
    out, changed = [], False
    for c in position:
        terms = sympy.Add.make_args(sympy.expand(c))
        kept = [term for term in terms if not _has_trig_of(term, coords)]
        changed |= len(kept) != len(terms)
        out.append(sympy.Add(*kept))
    return tuple(out) if changed else None


def _line_direction(position, coords, tsym):
    """Unit direction when the position moves along a fixed straight line (d r/dq constant, rank 1,
    no t); else None."""
    if any(sympy.diff(c, tsym) != 0 for c in position):
        return None
    J = sympy.Matrix([[sympy.diff(c, qk) for qk in coords] for c in position])
    if J.free_symbols & (set(coords) | {tsym}):
        return None
    return J


class _Builder:
    def __init__(self, model, values):
        self.model = model
        self.coords = list(model.q)
        self.cset = set(self.coords)
        self.t = model.t
        self.subs = _parameter_values(model, values)
        self.exprs: list[tuple] = []  # position of each node (sympy, with parameters substituted)
        self.nodes: list[Node] = []
        rng = np.random.default_rng(20240611)
        n = len(self.coords)
        self.sample_t = rng.uniform(0.3, 2.1, _SAMPLES)
        self.sample_q = rng.uniform(-2.0, 2.0, (_SAMPLES, n))
        self.samples: list[np.ndarray] = []  # (S, dim) per node

    def evaluate(self, position, t, q) -> np.ndarray:
        """Position at times t (N,) and coordinates q (N, n): shape (N, len(position))."""
        f = sympy.lambdify([self.t, *self.coords], list(position), "numpy")
        cols = f(t, *q.T)
        return np.stack([np.broadcast_to(np.asarray(c, dtype=float), t.shape) for c in cols], axis=1)

    def add(self, node, position) -> int:
        position = tuple(sympy.sympify(c).subs(self.subs) for c in position)
        pos = self.evaluate(position, self.sample_t, self.sample_q)
        self.nodes.append(node)
        self.exprs.append(position)
        self.samples.append(pos)
        return len(self.nodes) - 1

    def same_as(self, pos) -> int | None:
        for i, s in enumerate(self.samples):
            if s.shape == pos.shape and np.allclose(s, pos, rtol=1e-10, atol=1e-10):
                return i
        return None

    def is_fixed(self, i) -> bool:
        s = self.samples[i]
        return bool(np.allclose(s, s[0], rtol=1e-10, atol=1e-12))


def scene_of(model, params=None) -> Scene:
    """The drawable scene of `model` (see the module docstring for the rules).

    Parameters
    ----------
    model : Model
    params : mapping of str to float, optional
        Parameter values (default: the model's).

    Raises
    ------
    ModelError
        The model has no positioned elements (it is given by its energies only).
    """
    check_drawable(model)
    b = _Builder(model, params)
    elements = _positioned(model)
    dim = max(len(e.position) for e in elements)

    def pad(position):
        return tuple(position) + (sympy.Integer(0),) * (dim - len(position))

    index_of: dict[str, int] = {}
    for e in elements:
        # a body in space is drawn at its centre of mass, as a particle is
        kind = {Point: "point", Particle: "particle", RigidBody: "body", RigidBody3D: "particle"}[type(e)]
        mass = float(sympy.sympify(getattr(e, "mass", 0)).subs(b.subs)) if kind != "point" else 0.0
        inertia = float(sympy.sympify(e.inertia).subs(b.subs)) if kind == "body" else 0.0
        index_of[e.name] = b.add(Node(e.name, kind, mass, inertia), pad(e.position))
    massive = [index_of[e.name] for e in elements if isinstance(e, (Particle, RigidBody, RigidBody3D))]

    # hidden pivots
    for i in massive:
        pivot = _pivot_of(b.exprs[i], b.cset)
        if pivot is None:
            continue
        pos = b.evaluate(pivot, b.sample_t, b.sample_q)
        if b.same_as(pos) is not None:
            continue
        d = np.linalg.norm(b.samples[i] - pos, axis=1)
        if d.min() > 1e-9 and np.ptp(d) <= 1e-9 * (1 + d.mean()):
            b.add(Node(f"{b.nodes[i].name} pivot", "pivot"), pivot)

    # springs and dampers
    origin = None
    springs, dampers, undrawn = [], [], []
    for e in model.elements:
        if not isinstance(e, (Spring, Damper)):
            continue
        ends = None
        if e.ends is not None:
            ends = []
            for k, (end, name) in enumerate(zip(e.ends, e.between or (None, None))):
                if name is not None and name in index_of:
                    ends.append(index_of[name])
                    continue
                pos = b.evaluate(pad(tuple(sympy.sympify(c).subs(b.subs) for c in end)), b.sample_t, b.sample_q)
                j = b.same_as(pos)
                ends.append(j if j is not None else b.add(Node(f"{e.name} end {k + 1}", "end"), pad(end)))
        else:
            length = b.evaluate((sympy.sympify(e.length).subs(b.subs),), b.sample_t, b.sample_q)[:, 0]
            ends = _pair_with_length(b, np.abs(length))
            if ends is None:
                if origin is None:
                    zero = np.zeros((_SAMPLES, dim))
                    origin = b.same_as(zero)
                    if origin is None:
                        origin = b.add(Node("origin", "point"), (sympy.Integer(0),) * dim)
                ends = _pair_with_length(b, np.abs(length), only=origin)
        if ends is None:
            undrawn.append(f"{e.kind} '{e.name}': its length {e.length} is not the distance between two of the "
                           "model's points (a torsional one, or one without named ends)")
            continue
        (springs if isinstance(e, Spring) else dampers).append((e.name, ends[0], ends[1]))

    # rods: constant, nonzero distance, not both fixed
    fixed = [b.is_fixed(i) for i in range(len(b.nodes))]
    rods = []
    for i in range(len(b.nodes)):
        for j in range(i + 1, len(b.nodes)):
            if fixed[i] and fixed[j]:
                continue
            if b.nodes[i].kind == "end" or b.nodes[j].kind == "end":
                continue
            d = np.linalg.norm(b.samples[i] - b.samples[j], axis=1)
            if d.min() > 1e-9 and np.ptp(d) <= 1e-9 * (1 + d.mean()):
                rods.append((i, j))

    # tracks (and sliders)
    tracks, nodes = [], list(b.nodes)
    on_track: set[int] = set()
    order = massive + [i for kind in ("point", "pivot") for i in range(len(b.nodes)) if b.nodes[i].kind == kind]
    for i in order:
        if fixed[i]:
            continue
        if b.nodes[i].kind == "pivot" and any(j in on_track for r in rods if i in r for j in r if j != i):
            continue
        J = _line_direction(b.exprs[i], b.coords, b.t)
        if J is None:
            continue
        Jn = np.array(J.evalf(), dtype=float)
        if np.linalg.matrix_rank(Jn, tol=1e-12) != 1:
            continue
        col = Jn[:, np.argmax(np.linalg.norm(Jn, axis=0))]
        direction = col / np.linalg.norm(col)
        if direction[np.argmax(np.abs(direction))] < 0:
            direction = -direction
        point = b.samples[i][0]
        on_track.add(i)
        if b.nodes[i].kind in ("particle", "point"):
            nodes[i] = Node(nodes[i].name, nodes[i].kind, nodes[i].mass, nodes[i].inertia, False, True)
        if not any(abs(abs(direction @ d0) - 1) < 1e-12 and
                   np.linalg.norm((point - p0) - ((point - p0) @ d0) * d0) < 1e-9 for p0, d0 in tracks):
            tracks.append((point, direction))
    nodes = [Node(n.name, n.kind, n.mass, n.inertia, f, n.slider) for n, f in zip(nodes, fixed)]

    args = [b.t, *b.coords]
    flat = [c for pos in b.exprs for c in pos]
    fpos = sympy.lambdify(args, flat, "numpy", cse=True)
    count = len(b.exprs)

    def positions(t, q):
        cols = fpos(t, *q.T)
        out = np.stack([np.broadcast_to(np.asarray(c, dtype=float), t.shape) for c in cols], axis=1)
        return out.reshape(len(t), count, dim)

    bodies = tuple(i for i, nd in enumerate(nodes) if nd.kind == "body")
    body_angles = [sympy.sympify(e.angle).subs(b.subs) for e in elements if isinstance(e, RigidBody)]
    fang = sympy.lambdify(args, body_angles or [0], "numpy")

    def angles(t, q):
        if not bodies:
            return np.zeros((len(t), 0))
        cols = fang(t, *q.T)
        return np.stack([np.broadcast_to(np.asarray(c, dtype=float), t.shape) for c in cols], axis=1)

    return Scene(dim, tuple(nodes), tuple(rods), tuple(springs), tuple(dampers), tuple(tracks), tuple(undrawn),
                 positions, angles, bodies)


def _pair_with_length(b: _Builder, length: np.ndarray, only: int | None = None):
    """The first pair of nodes (i, j) whose distance equals `length` at every sample."""
    count = len(b.nodes)
    for i in range(count):
        for j in range(i + 1, count):
            if only is not None and only not in (i, j):
                continue
            d = np.linalg.norm(b.samples[i] - b.samples[j], axis=1)
            if np.allclose(d, length, rtol=1e-9, atol=1e-12):
                return (i, j)
    return None
