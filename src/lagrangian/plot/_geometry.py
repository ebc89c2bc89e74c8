"""The drawable geometry of a model: where each of its elements is, as numeric functions of (t, q).

Everything here comes from the model's own elements; nothing is invented. The rules, written
once (docs/plots.md repeats them):

* **Nodes** are the named points, particles and rigid bodies (their positions), plus the ends of
  springs and dampers given as positions.
* **Fixed nodes** (positions free of q and t) are drawn on the ground.
* **Rods** join two nodes whose distance never changes while at least one of them moves: a
  pendulum bob and its pivot, two bobs of a chain. The distance is compared at random
  configurations (q, t), not along the trajectory, so a system that happens to stay at rest
  grows no rods; with holonomic constraints, at random configurations that meet them (a
  four-bar's coupler joins its two joints, which the loop keeps at its length).
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
* **Visual shapes** (a URDF's ``<visual>`` boxes, cylinders and spheres, meshes as small markers, kept
  in ``model.visuals``): each is drawn as its outline (a box's edges, a cylinder's two end circles
  and four sides, a sphere's three great circles), fixed in its link's frame.
* **The ground**: a model with wheels rolls on the plane z = 0, which is drawn (a square grid).
* **The framing** (:func:`framing_of`): a drawing shows one box for the whole motion, unless the
  motion reaches more than :data:`FOLLOW_RATIO` times the mechanism's own size (the largest extent
  of its nodes at one instant, fixed ones included): a bicycle riding away, a cart pushed far. Then
  the box follows the mechanism's centre of mass (of its nodes' masses; their mean when massless),
  sized to hold every node at every instant. A point mass alone has no size, and is never followed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy

from .._util import did_you_mean
from ..errors import ModelError
from ..model._constraints import HOLONOMIC
from ..model._elements import Damper, Particle, Point, RigidBody, RigidBody3D, Spring
from ..model._frames import WORLD, frame_pose

__all__ = ["Scene", "Node", "SpatialBody", "BodyDrawing", "Framing", "scene_of", "check_drawable", "drawable_names",
           "framing_of", "ground_grid", "grid_step", "clip_line", "DISK_POINTS", "FOLLOW_RATIO", "VIEWS",
           "AXIS_LENGTH"]

_TRIG = (sympy.sin, sympy.cos, sympy.tan)
_SAMPLES = 7
#: Points of the outline of a disk.
DISK_POINTS = 48
#: A drawing follows the mechanism when its motion reaches more than this many times its own size.
FOLLOW_RATIO = 3.0
#: The length of a body's axes, as a fraction of the drawing's size (or of its largest disk's diameter).
AXIS_LENGTH = 0.2
#: The framings a drawing may ask for: "auto" (follow when the motion reaches far), "fixed", "follow".
VIEWS = ("auto", "fixed", "follow")


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
    ground : bool
        Whether the ground plane z = 0 is drawn (the model has wheels rolling on it).
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
    ground: bool = False
    visuals: tuple[str, ...] = ()  # the drawn visual shapes ("<frame> box"), see visual_outlines
    _visual_local: tuple = ()
    _visual_poses: object = None

    def visual_outlines(self, t, q) -> tuple[np.ndarray, ...]:
        """The outline of each visual shape (in `visuals` order) in world coordinates at times `t` (N,)
        and coordinates `q` (N, n): shape (N, k, 3) each, NaN rows between its strokes."""
        t, q = _times_and_coordinates(t, q)
        if not self.visuals:
            return ()
        flat = self._visual_poses(t, q)
        out = []
        for k, local in enumerate(self._visual_local):
            origin, R = flat[:, 12 * k:12 * k + 3], flat[:, 12 * k + 3:12 * k + 12].reshape(-1, 3, 3)
            out.append(origin[:, None, :] + np.einsum("nij,kj->nki", R, local))
        return tuple(out)

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

    def framed(self, t, q, frames, view: str = "auto") -> tuple[Framing, float, tuple[BodyDrawing, ...]]:
        """The framing of a drawing of the motion `t` (N,), `q` (N, n) shown at the samples `frames`
        (indices), decided on every sample (:func:`framing_of`) and widened to hold the bodies in
        space; the axes' length; and the bodies' drawings at those frames."""
        t, q = _times_and_coordinates(t, q)
        whole = framing_of(self.positions(t, q), [n.mass for n in self.nodes], view)
        length = self.axis_length(whole.size)
        drawings = self.body_drawings(t[frames], q[frames], length)
        framing = Framing(whole.follow, whole.centre[frames], whole.half, whole.size)
        for d in drawings:
            for part in (d.axes, d.disk):
                if part is not None:
                    framing = framing.including(part.reshape(len(frames), -1, 3))
        return framing, length, drawings

    def axis_length(self, size: float) -> float:
        """The length of the axes drawn for bodies in space, in a drawing of the given `size`: a fifth
        of it, or of the largest disk's diameter."""
        return AXIS_LENGTH * max([size] + [2 * b.radius for b in self.spatial if b.radius is not None])

    @property
    def bodies(self) -> tuple[int, ...]:
        """Indices of the rigid-body nodes."""
        return self._bodies


@dataclass(frozen=True, eq=False)
class Framing:
    """The box a drawing shows at each of its N instants (see :func:`framing_of`).

    Attributes
    ----------
    follow : bool
        Whether the box moves with the mechanism.
    centre : ndarray, shape (N, dim)
        The box's centre at each instant (one point, repeated, when it does not follow).
    half : ndarray, shape (dim,)
        The box's half-widths, without padding: what it frames is inside at every instant.
    size : float
        The drawing's scale for its details (the axes' length, the padding, a spring's width): the
        nodes' reach over the whole motion or, when following, the mechanism's own size.
    """

    follow: bool
    centre: np.ndarray
    half: np.ndarray
    size: float

    def including(self, points) -> Framing:
        """The framing widened to hold `points` too, shape (N, k, dim): what else is drawn at each instant."""
        points = np.asarray(points, dtype=float)
        if points.size == 0:
            return self
        if self.follow:
            half = np.maximum(self.half, np.abs(points - self.centre[:, None, :]).max(axis=(0, 1)))
            return Framing(True, self.centre, half, self.size)
        lo = np.minimum(self.centre[0] - self.half, points.min(axis=(0, 1)))
        hi = np.maximum(self.centre[0] + self.half, points.max(axis=(0, 1)))
        return Framing(False, np.broadcast_to((lo + hi) / 2, self.centre.shape), (hi - lo) / 2, self.size)


def framing_of(positions, masses, view: str = "auto") -> Framing:
    """How to frame nodes at `positions` (N, nodes, dim) with `masses` (nodes,): one box for the
    whole motion ("fixed"), a box that follows the centre of mass ("follow"), or ("auto") follow when
    the motion reaches more than FOLLOW_RATIO times the mechanism's own size. A mechanism without
    size (a point mass alone) is never followed.

    Raises
    ------
    ModelError
        `view` is not one of VIEWS.
    """
    if view not in VIEWS:
        raise ModelError(f"view {view!r}: choose one of {', '.join(VIEWS)} (auto follows a mechanism that "
                         "travels far, such as a bicycle riding away; fixed shows the whole motion in one box)")
    P = np.asarray(positions, dtype=float)
    flat = P.reshape(-1, P.shape[-1])
    lo, hi = flat.min(axis=0), flat.max(axis=0)
    own = float(np.ptp(P, axis=1).max()) if P.size else 0.0
    reach = float(np.max(hi - lo)) if P.size else 0.0
    follow = own > 0 and (view == "follow" or (view == "auto" and reach > FOLLOW_RATIO * own))
    if not follow:
        centre = np.broadcast_to((lo + hi) / 2, (len(P), P.shape[-1]))
        return Framing(False, centre, (hi - lo) / 2, reach or 1.0)
    w = np.asarray(masses, dtype=float)
    w = w / w.sum() if w.sum() > 0 else np.full(P.shape[1], 1.0 / P.shape[1])
    centre = np.einsum("i,kid->kd", w, P)
    return Framing(True, centre, np.abs(P - centre[:, None, :]).max(axis=(0, 1)), own)


def ground_grid(lo, hi) -> np.ndarray:
    """The lines of a square grid on the ground z = 0 inside the box [lo, hi] (3 components each),
    one after the other, NaN rows between them; shape (k, 3), empty when the box misses the ground.
    The spacing is :func:`grid_step` of the box's larger side."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if not lo[2] <= 0 <= hi[2]:
        return np.empty((0, 3))
    step = grid_step(float(np.max(hi[:2] - lo[:2])))
    rows = []
    for axis in (0, 1):
        other = 1 - axis
        for c in np.arange(np.ceil(lo[axis] / step - 1e-9), np.floor(hi[axis] / step + 1e-9) + 1) * step:
            a, b = np.zeros(3), np.zeros(3)
            a[axis] = b[axis] = c
            a[other], b[other] = lo[other], hi[other]
            rows += [a, b, np.full(3, np.nan)]
    return np.array(rows) if rows else np.empty((0, 3))


def grid_step(side: float) -> float:
    """The spacing of the ground's grid in a box of this side: 1, 2 or 5 times a power of ten, the
    smallest such at least a sixth of the side."""
    step = 10.0 ** np.floor(np.log10(side / 6))
    return float(step * next(f for f in (1, 2, 5, 10) if f * step >= side / 6 * (1 - 1e-12)))


def clip_line(point, direction, lo, hi) -> np.ndarray | None:
    """The part of the line point + s direction inside the box [lo, hi], as its two ends (2, dim),
    or None where the line misses the box."""
    point, direction = np.asarray(point, dtype=float), np.asarray(direction, dtype=float)
    s0, s1 = -np.inf, np.inf
    for p, d, a, b in zip(point, direction, lo, hi):
        if abs(d) < 1e-15:
            if not a <= p <= b:
                return None
            continue
        u, v = sorted(((a - p) / d, (b - p) / d))
        s0, s1 = max(s0, u), min(s1, v)
    if not s0 < s1:
        return None
    return np.array([point + s0 * direction, point + s1 * direction])


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
            extra = did_you_mean(name, names)
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
        holonomic = [c.expression for c in model.constraints if c.kind == HOLONOMIC]
        if holonomic:
            self.sample_t, self.sample_q = self._assembled(holonomic, rng)
        self.samples: list[np.ndarray] = []  # (S, dim) per node

    def _assembled(self, constraints, rng) -> tuple[np.ndarray, np.ndarray]:
        """Samples (t, q) that meet the holonomic constraints: random configurations moved onto
        g(q, t) = 0 by Gauss-Newton (least-norm steps); those that do not assemble are drawn again.
        A mechanism that assembles nowhere keeps the random samples."""
        g = [sympy.sympify(e).subs(self.subs) for e in constraints]
        G = sympy.Matrix(g).jacobian(self.coords)
        fg = sympy.lambdify([self.t, *self.coords], g, "numpy")
        fG = sympy.lambdify([self.t, *self.coords], G, "numpy")
        ts, qs = [], []
        for _ in range(20 * _SAMPLES):
            t, q = rng.uniform(0.3, 2.1), rng.uniform(-2.0, 2.0, len(self.coords))
            for _ in range(50):
                r = np.asarray(fg(t, *q), dtype=float)
                if not np.all(np.isfinite(r)) or np.max(np.abs(r)) < 1e-13:
                    break
                q = q - np.linalg.lstsq(np.asarray(fG(t, *q), dtype=float), r, rcond=None)[0]
            if np.all(np.isfinite(r)) and np.max(np.abs(np.asarray(fg(t, *q), dtype=float))) < 1e-12:
                ts.append(t)
                qs.append(q)
                if len(ts) == _SAMPLES:
                    return np.array(ts), np.array(qs)
        return self.sample_t, self.sample_q

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

    labels, local, visual_exprs = [], [], []
    for v in getattr(model, "visuals", ()) if dim == 3 else ():
        if v.frame != WORLD and v.frame not in model.frames:
            continue
        origin, R = frame_pose(model.frames, v.frame)
        labels.append(f"{v.frame} {v.kind}")
        local.append(outline_of(v.kind, v.size, v.origin, v.rpy))
        visual_exprs += [*b.numeric(origin), *b.numeric(R)]
    fvisual = sympy.lambdify(args, visual_exprs or [0], "numpy", cse=True)

    def visual_poses(t, q):
        return _columns(fvisual(t, *q.T), t)

    return Scene(dim, tuple(nodes), tuple(rods), tuple(springs), tuple(dampers), tuple(tracks), tuple(undrawn),
                 positions, angles, bodies, spatial, poses, ground=dim == 3 and bool(model.wheels),
                 visuals=tuple(labels), _visual_local=tuple(local), _visual_poses=visual_poses)


def outline_of(kind: str, size, origin=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The outline of a visual shape in its frame's axes, shape (k, 3), NaN rows between strokes: a
    "box" of edge lengths `size`, a "cylinder" (radius, length) along z, a "sphere" or "marker" of
    radius `size[0]`; placed at `origin` and turned by `rpy` (Rz(yaw) Ry(pitch) Rx(roll)) in the frame."""
    gap = np.full((1, 3), np.nan)
    phi = np.linspace(0.0, 2 * np.pi, 25)
    c, s, z = np.cos(phi), np.sin(phi), np.zeros_like(phi)
    if kind == "box":
        a, b, h = (x / 2 for x in size)
        loop = np.array([[-a, -b], [a, -b], [a, b], [-a, b], [-a, -b]])
        strokes = [np.column_stack([loop, np.full(5, -h)]), np.column_stack([loop, np.full(5, h)])]
        strokes += [np.array([[x, y, -h], [x, y, h]]) for x, y in loop[:4]]
    elif kind == "cylinder":
        r, h = size[0], size[1] / 2
        strokes = [np.column_stack([r * c, r * s, z - h]), np.column_stack([r * c, r * s, z + h])]
        strokes += [np.array([[r * x, r * y, -h], [r * x, r * y, h]]) for x, y in ((1, 0), (0, 1), (-1, 0), (0, -1))]
    else:  # a sphere or a marker
        r = size[0]
        strokes = [np.column_stack([r * c, r * s, z]), np.column_stack([r * c, z, r * s]),
                   np.column_stack([z, r * c, r * s])]
    points = np.vstack([row for stroke in strokes for row in (stroke, gap)][:-1])
    roll, pitch, yaw = rpy
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    R = (np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
         @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]]))
    return points @ R.T + np.asarray(origin, dtype=float)


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
