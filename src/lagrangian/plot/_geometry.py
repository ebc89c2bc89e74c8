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
* **Bodies in space** (:class:`SpatialBody`) are drawn at their centre of mass, as particles, and
  with their frame: its three axes from its origin, the link that carries the body (from the
  origin of the frame's parent, when that is a frame, to the frame's origin, then to the centre;
  each segment only where its length never changes, nonzero: a body centred on its frame's
  origin hangs from the parent's origin), and their shape if they have one:
  a disk is the circle of its radius about the centre, across its body axis.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

import numpy as np
import sympy

from ..errors import ModelError
from ..model._elements import Damper, Particle, Point, RigidBody, RigidBody3D, Spring
from ..model._frames import WORLD, frame_pose

__all__ = ["Scene", "Node", "SpatialBody", "BodyDrawing", "scene_of", "check_drawable", "drawable_names",
           "DISK_POINTS"]

_TRIG = (sympy.sin, sympy.cos, sympy.tan)
_SAMPLES = 7
#: Points of the outline of a disk.
DISK_POINTS = 48


@dataclass(frozen=True)
class Node:
    """A drawn point: `kind` is "point", "particle", "body", "pivot" (hidden) or "end"."""

    name: str
    kind: str
    mass: float = 0.0
    inertia: float = 0.0
    fixed: bool = False
    slider: bool = False


@dataclass(frozen=True)
class SpatialBody:
    """A body in space as drawn: `name`, `node` (the index of its centre's node), `frame` (its
    frame's name), `link` (the number of points of the polyline that carries it, its centre last:
    1 when there is no link), and its disk's `radius` (None: no shape) and `axis` (0, 1, 2: x, y, z)."""

    name: str
    node: int
    frame: str
    link: int
    radius: float | None = None
    axis: int = 2


@dataclass(frozen=True, eq=False)
class BodyDrawing:
    """Where a body in space is drawn at N times, in world coordinates.

    Attributes
    ----------
    origin : ndarray, shape (N, 3)
        Its frame's origin.
    rotation : ndarray, shape (N, 3, 3)
        Its frame's axes (the columns) in world axes, R_world.
    axes : ndarray, shape (N, 3, 2, 3)
        The segment of each axis x, y, z: from the origin to origin + length * R e_i.
    link : ndarray, shape (N, k, 3)
        The polyline that carries the body (see :class:`SpatialBody`), its centre of mass last.
    disk : ndarray, shape (N, DISK_POINTS, 3), or None
        The outline of its disk (not closed: the last point is not the first), if it has one.
    """

    origin: np.ndarray
    rotation: np.ndarray
    axes: np.ndarray
    link: np.ndarray
    disk: np.ndarray | None


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
    spatial : tuple of SpatialBody
        The bodies in space (their centres are nodes too); :meth:`body_drawings` places them.
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
    spatial: tuple[SpatialBody, ...] = ()
    _poses: object = None

    def index(self, name: str) -> int:
        """Index of the node named `name`."""
        for i, node in enumerate(self.nodes):
            if node.name == name:
                return i
        raise KeyError(name)

    def positions(self, t, q) -> np.ndarray:
        """Node positions, shape (N, len(nodes), dim), for times `t` (N,) and coordinates `q` (N, n)."""
        return self._positions(*_times_and_coordinates(t, q))

    def angles(self, t, q) -> np.ndarray:
        """Rotation angle of each rigid body node, shape (N, number of bodies), in `bodies` order."""
        return self._angles(*_times_and_coordinates(t, q))

    def body_drawings(self, t, q, axis_length: float) -> tuple[BodyDrawing, ...]:
        """Where each body in space is drawn (in `spatial` order) at times `t` (N,) and coordinates
        `q` (N, n); its axes are `axis_length` long."""
        t, q = _times_and_coordinates(t, q)
        if not self.spatial:
            return ()
        flat = self._poses(t, q)
        out, k = [], 0
        for body in self.spatial:
            origin = flat[:, k:k + 3]
            R = flat[:, k + 3:k + 12].reshape(-1, 3, 3)
            link = flat[:, k + 12:k + 12 + 3 * body.link].reshape(-1, body.link, 3)
            k += 12 + 3 * body.link
            ends = origin[:, None, :] + axis_length * np.swapaxes(R, 1, 2)  # (N, axis, 3): origin + L R e_i
            axes = np.stack([np.broadcast_to(origin[:, None, :], ends.shape), ends], axis=2)
            disk = None
            if body.radius is not None:
                u, v = R[:, :, (body.axis + 1) % 3], R[:, :, (body.axis + 2) % 3]
                phi = 2 * np.pi * np.arange(DISK_POINTS) / DISK_POINTS
                disk = link[:, -1, None, :] + body.radius * (np.cos(phi)[None, :, None] * u[:, None, :]
                                                             + np.sin(phi)[None, :, None] * v[:, None, :])
            out.append(BodyDrawing(origin, R, axes, link, disk))
        return tuple(out)

    @property
    def bodies(self) -> tuple[int, ...]:
        """Indices of the rigid-body nodes."""
        return self._bodies


def _times_and_coordinates(t, q) -> tuple[np.ndarray, np.ndarray]:
    t = np.atleast_1d(np.asarray(t, dtype=float))
    return t, np.asarray(q, dtype=float).reshape(len(t), -1)


def _columns(cols, t) -> np.ndarray:
    """The values of lambdified expressions (constants broadcast to the times `t`), shape (N, len(cols))."""
    return np.stack([np.broadcast_to(np.asarray(c, dtype=float), t.shape) for c in cols], axis=1)


def _rigid(a, b) -> bool:
    """Whether two sampled points (S, dim) stay at one nonzero distance."""
    d = np.linalg.norm(a - b, axis=1)
    return bool(d.min() > 1e-9 and np.ptp(d) <= 1e-9 * (1 + d.mean()))


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
        return _columns(f(t, *q.T), t)

    def numeric(self, position) -> tuple:
        """`position` with the parameters' values substituted."""
        return tuple(sympy.sympify(c).subs(self.subs) for c in position)

    def sampled(self, position) -> np.ndarray:
        return self.evaluate(position, self.sample_t, self.sample_q)

    def add(self, node, position) -> int:
        position = self.numeric(position)
        pos = self.sampled(position)
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
        pos = b.sampled(pivot)
        if b.same_as(pos) is not None:
            continue
        if _rigid(b.samples[i], pos):
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
                pos = b.sampled(pad(b.numeric(end)))
                j = b.same_as(pos)
                ends.append(j if j is not None else b.add(Node(f"{e.name} end {k + 1}", "end"), pad(end)))
        else:
            length = b.sampled(b.numeric((e.length,)))[:, 0]
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
            if _rigid(b.samples[i], b.samples[j]):
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
        return _columns(fpos(t, *q.T), t).reshape(len(t), count, dim)

    bodies = tuple(i for i, nd in enumerate(nodes) if nd.kind == "body")
    body_angles = [sympy.sympify(e.angle).subs(b.subs) for e in elements if isinstance(e, RigidBody)]
    fang = sympy.lambdify(args, body_angles or [0], "numpy")

    def angles(t, q):
        if not bodies:
            return np.zeros((len(t), 0))
        return _columns(fang(t, *q.T), t)

    spatial, pose_exprs = _spatial_bodies(model, b, index_of)
    fpose = sympy.lambdify(args, pose_exprs or [0], "numpy", cse=True)

    def poses(t, q):
        return _columns(fpose(t, *q.T), t)

    return Scene(dim, tuple(nodes), tuple(rods), tuple(springs), tuple(dampers), tuple(tracks), tuple(undrawn),
                 positions, angles, bodies, spatial, poses)


def _spatial_bodies(model, b: _Builder, index_of) -> tuple[tuple[SpatialBody, ...], list]:
    """The bodies in space, and the expressions of their poses, body after body: the frame's origin
    (3), its rotation R_world (9, by rows) and the points of its link (3 each, the centre last)."""
    out, exprs = [], []
    for e in model.elements:
        if not isinstance(e, RigidBody3D):
            continue
        origin, R = frame_pose(model.frames, e.frame)
        origin = b.numeric(origin)
        parent = model.frames[e.frame].parent
        starts = [origin] + ([b.numeric(frame_pose(model.frames, parent)[0])] if parent != WORLD else [])
        link = [b.numeric(e.position)]
        for start in starts:  # back from the centre: a segment where its length never changes
            if _rigid(b.sampled(start), b.sampled(link[0])):
                link.insert(0, start)
        radius, axis = None, 2
        if e.shape is not None:
            radius, axis = float(sympy.sympify(e.shape.radius).subs(b.subs)), "xyz".index(e.shape.axis)
        out.append(SpatialBody(e.name, index_of[e.name], e.frame, len(link), radius, axis))
        exprs += [*origin, *b.numeric(R), *(c for point in link for c in point)]
    return tuple(out), exprs


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
