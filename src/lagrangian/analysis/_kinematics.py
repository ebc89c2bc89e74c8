"""kinematics(model, point=... | frame=...): the position, velocity and Jacobian of a named point,
particle, body or frame, symbolic (readable SymPy expressions) and numeric (one compiled evaluator).

The conventions, written once here:

* ``position`` p(q, t): world coordinates (2 components for a planar model's point, 3 in space).
* ``jacobian`` J = dp/dq (d x n), so that the velocity is ``v = J q_dot + dp/dt`` (dp/dt is zero
  unless the model prescribes a motion in time).
* A frame (and a body in space, by its frame) adds its ``rotation`` R (its axes in world axes, the
  columns of R), its ``angular_velocity`` omega in world axes, the same in its own axes
  (``angular_velocity_body`` = R^T omega), and the ``angular_jacobian`` J_w = d omega/d q_dot
  (3 x n, world axes): Pinocchio's LOCAL_WORLD_ALIGNED Jacobian is [J; J_w] of the frame's origin.
* A planar rigid body adds its ``angle`` and angular velocity (one component, about the axis normal
  to the plane) and the angular Jacobian (1 x n): the rows [x, y, angle] of a planar arm's Jacobian.

Angular velocities are derived from the rotations (model._frames.angular_velocity), never given.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
import symengine as se
import sympy

from .._util import did_you_mean, named_values, read_only, real_number
from ..equations import Equations
from ..equations._readable import readable_many, text as _text
from ..errors import ModelError, Problem
from ..model import Model
from ..model._elements import Particle, Point, RigidBody, RigidBody3D
from ..model._frames import WORLD, angular_velocity, frame_pose, world_factors
from ..model._kinematics import Kinematics as _Rates

__all__ = ["kinematics", "Kinematics", "KinematicsValues"]


@dataclass(frozen=True)
class KinematicsValues:
    """The numbers of a :class:`Kinematics` at one state, or at N states (a leading axis N).

    Attributes
    ----------
    position, velocity : ndarray, shape (d,) or (N, d)
    jacobian : ndarray, shape (d, n) or (N, d, n)
    rotation : ndarray, shape (3, 3) or (N, 3, 3), or None (a point)
    angle : ndarray, shape () or (N,), or None (a planar body's angle; None otherwise)
    angular_velocity : ndarray, shape (3,) or (1,) (planar), with a leading N, or None
    angular_velocity_body : ndarray, shape (3,), with a leading N, or None (a frame)
    angular_jacobian : ndarray, shape (3, n) or (1, n), with a leading N, or None
    """

    name: str
    coordinates: tuple[str, ...]
    position: np.ndarray
    velocity: np.ndarray
    jacobian: np.ndarray
    rotation: np.ndarray | None = None
    angle: np.ndarray | None = None
    angular_velocity: np.ndarray | None = None
    angular_velocity_body: np.ndarray | None = None
    angular_jacobian: np.ndarray | None = None

    def to_dict(self) -> dict:
        """{name, coordinates, position, velocity, jacobian, ...}: lists of numbers, the parts
        that exist (a point has no rotation)."""
        out: dict = {"name": self.name, "coordinates": list(self.coordinates)}
        for key in ("position", "velocity", "jacobian", "rotation", "angle", "angular_velocity",
                    "angular_velocity_body", "angular_jacobian"):
            value = getattr(self, key)
            if value is not None:
                out[key] = np.asarray(value).tolist()
        return out

    def text(self) -> str:
        def fmt(a) -> str:
            a = np.asarray(a)
            if a.ndim == 0:
                return f"{float(a):.10g}"
            if a.ndim == 1:
                return "[" + ", ".join(f"{float(v):.10g}" for v in a) + "]"
            return "[" + ", ".join(fmt(r) for r in a) + "]"

        lines = []
        for key in ("position", "velocity", "jacobian", "rotation", "angle", "angular_velocity",
                    "angular_velocity_body", "angular_jacobian"):
            value = getattr(self, key)
            if value is not None:
                lines.append(f"  {key} = {fmt(value)}")
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class Kinematics:
    """The kinematics of one named point, particle, body or frame of a model (immutable; returned by
    :func:`kinematics`). See the module docstring for the conventions.

    Attributes
    ----------
    name : str
    kind : str
        "point", "particle", "body" (planar or in space: its centre of mass) or "frame".
    coordinates : tuple of sympy.Symbol, shape (n,)
    position, velocity : tuple of sympy.Expr, shape (d,)
        World coordinates; d = 2 for a planar model, 3 in space.
    jacobian : sympy.ImmutableMatrix, shape (d, n)
        dp/dq: v = J q_dot + dp/dt.
    rotation : sympy.ImmutableMatrix, shape (3, 3), or None
        A frame's (or a body in space's) axes in world axes.
    angle : sympy.Expr or None
        A planar body's angle.
    angular_velocity : tuple of sympy.Expr, or None
        In world axes (3 components; 1 for a planar body).
    angular_velocity_body : tuple of sympy.Expr, or None
        A frame's, in its own axes.
    angular_jacobian : sympy.ImmutableMatrix, or None
        d angular_velocity/d q_dot (3 x n, or 1 x n for a planar body).
    """

    model_name: str
    name: str
    kind: str
    coordinates: tuple
    position: tuple
    velocity: tuple
    jacobian: sympy.ImmutableMatrix
    rotation: sympy.ImmutableMatrix | None = None
    angle: sympy.Expr | None = None
    angular_velocity: tuple | None = None
    angular_velocity_body: tuple | None = None
    angular_jacobian: sympy.ImmutableMatrix | None = None
    _values: Mapping = field(default_factory=dict, repr=False)  # the model's parameter values
    _parts: tuple = field(default=(), repr=False)  # ((key, shape, SymEngine expressions), ...)
    _args: tuple = field(default=(), repr=False)
    _evaluator: list = field(default_factory=list, repr=False)  # built on first use

    @property
    def n(self) -> int:
        return len(self.coordinates)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(self._values)

    def _fun(self):
        if not self._evaluator:
            exprs = [e for _, _, part in self._parts for e in part]
            self._evaluator.append(se.Lambdify(list(self._args), exprs, cse=True, real=True))
        return self._evaluator[0]

    def at(self, q, q_dot=None, *, params: Mapping | None = None, t=0.0) -> KinematicsValues:
        """The numbers at the configuration `q` and velocities `q_dot`.

        Parameters
        ----------
        q : array_like, shape (n,) or (N, n)
            Coordinates, in the model's order (or a mapping of coordinate names to values).
        q_dot : array_like, shape (n,) or (N, n), optional
            Velocities (default 0; or a mapping of names ``<q>_dot`` to values).
        params : mapping of str to float, optional
            Parameter values that replace the model's.
        t : float or array_like, shape (N,)
            Time (for models that contain t).

        Returns
        -------
        KinematicsValues
            Arrays of the shapes above, with a leading axis N when `q` is 2-dimensional.
        """
        names = [c.name for c in self.coordinates]
        q = _state_array(q, names, "q")
        single = q.ndim == 1
        q = np.atleast_2d(q)
        rows = q.shape[0]
        qd = np.zeros_like(q) if q_dot is None else np.atleast_2d(_state_array(q_dot, [f"{s}_dot" for s in names],
                                                                               "q_dot"))
        if qd.shape != q.shape:
            raise ModelError(f"q_dot has shape {qd.shape[1:] if single else qd.shape}, q has "
                             f"{q.shape[1:] if single else q.shape}: give one velocity per coordinate (and as many "
                             "rows)")
        tt = np.broadcast_to(np.asarray(t, dtype=float), (rows,)) if np.ndim(t) else np.full(rows, _time(t))
        if not np.all(np.isfinite(tt)):
            raise ModelError("t: the time must be finite numbers")
        p = _parameters(self._values, params)
        args = np.column_stack((tt, q, qd, np.broadcast_to(p, (rows, len(p)))))
        out = np.asarray(self._fun()(args), dtype=float).reshape(rows, -1)
        parts, k = {}, 0
        for key, shape, exprs in self._parts:
            size = len(exprs)
            block = out[:, k:k + size].reshape((rows, *shape))
            parts[key] = read_only(block[0] if single else block)
            k += size
        return KinematicsValues(self.name, tuple(names), **parts)

    # ---------------------------------------------------------------- output
    def to_dict(self) -> dict:
        """{model, name, kind, coordinates, position, velocity, jacobian, ...}: the symbolic forms as
        strings (SymPy syntax), the parts that exist."""
        out: dict = {"model": self.model_name, "name": self.name, "kind": self.kind,
                     "coordinates": [c.name for c in self.coordinates],
                     "position": [_text(e) for e in self.position], "velocity": [_text(e) for e in self.velocity],
                     "jacobian": _rows(self.jacobian)}
        if self.rotation is not None:
            out["rotation"] = _rows(self.rotation)
        if self.angle is not None:
            out["angle"] = _text(self.angle)
        if self.angular_velocity is not None:
            out["angular_velocity"] = [_text(e) for e in self.angular_velocity]
        if self.angular_velocity_body is not None:
            out["angular_velocity_body"] = [_text(e) for e in self.angular_velocity_body]
        if self.angular_jacobian is not None:
            out["angular_jacobian"] = _rows(self.angular_jacobian)
        return out

    def text(self) -> str:
        """The symbolic forms as plain text."""
        what = {"frame": "frame", "body": "body", "particle": "particle", "point": "point"}[self.kind]
        lines = [f"Kinematics of the {what} '{self.name}' of {self.model_name} (world axes; J = d position/dq, "
                 "velocity = J q_dot + d position/dt)"]
        lines.append("  position = [" + ", ".join(_text(e) for e in self.position) + "]")
        lines.append("  velocity = [" + ", ".join(_text(e) for e in self.velocity) + "]")
        lines.append("  jacobian =")
        lines += ["    [" + ", ".join(_text(x) for x in self.jacobian.row(r)) + "]" for r in range(self.jacobian.rows)]
        if self.rotation is not None:
            lines.append("  rotation (the frame's axes in world axes, as columns) =")
            lines += ["    [" + ", ".join(_text(x) for x in self.rotation.row(r)) + "]" for r in range(3)]
        if self.angle is not None:
            lines.append(f"  angle = {_text(self.angle)}")
        if self.angular_velocity is not None:
            lines.append("  angular_velocity (world axes) = [" + ", ".join(_text(e) for e in self.angular_velocity)
                         + "]")
        if self.angular_velocity_body is not None:
            lines.append("  angular_velocity_body (the frame's axes) = ["
                         + ", ".join(_text(e) for e in self.angular_velocity_body) + "]")
        if self.angular_jacobian is not None:
            lines.append("  angular_jacobian (d angular_velocity/d q_dot) =")
            lines += ["    [" + ", ".join(_text(x) for x in self.angular_jacobian.row(r)) + "]"
                      for r in range(self.angular_jacobian.rows)]
        return "\n".join(lines)

    __str__ = text

    def __repr__(self) -> str:
        return f"<Kinematics of the {self.kind} {self.name!r} of {self.model_name!r}>"


def _rows(matrix) -> list[list[str]]:
    return [[_text(x) for x in matrix.row(r)] for r in range(matrix.rows)]


def _time(t) -> float:
    value = real_number(t)
    if value is None:
        raise ModelError(f"t: the time must be a finite number, got {t!r}")
    return value


def _state_array(values, names: list[str], what: str) -> np.ndarray:
    """q or q_dot as an array (n,) or (N, n); a mapping by name (missing names 0)."""
    if isinstance(values, Mapping):
        problems: list[Problem] = []
        given = named_values(values, tuple(names), f"a name of {what}", what, problems)
        if problems:
            raise ModelError(problems)
        return np.array([given.get(name, 0.0) for name in names], dtype=float)
    try:
        a = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{what}: expected numbers, shape ({len(names)},) or (N, {len(names)}) in the order "
                         f"{', '.join(names)}, got {values!r}") from None
    if a.ndim not in (1, 2) or a.shape[-1] != len(names):
        raise ModelError(f"{what}: expected shape ({len(names)},) or (N, {len(names)}) (one column per coordinate: "
                         f"{', '.join(names)}), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ModelError(f"{what}: every value must be a finite number (no NaN or infinity)")
    return a


def _parameters(values: Mapping[str, float | None], params: Mapping | None) -> np.ndarray:
    problems: list[Problem] = []
    names = tuple(values)
    given = named_values(params, names, "a parameter of the model", "params", problems)
    out = []
    for name, default in values.items():
        v = given.get(name, default)
        if v is None and f"params.{name}" not in {p.key for p in problems}:
            problems.append(Problem(f"parameter '{name}' has no value: give one in the model or pass "
                                    f"params={{'{name}': ...}} (--param {name}=... on the command line)",
                                    key=f"params.{name}"))
        out.append(np.nan if v is None else float(v))
    if problems:
        raise ModelError(problems)
    return np.array(out, dtype=float)


def _named_things(model: Model) -> tuple[dict, dict]:
    """({name: element} of the points, particles and bodies; {name: frame})."""
    located = {e.name: e for e in model.elements if isinstance(e, (Point, Particle, RigidBody, RigidBody3D))}
    return located, model.frames


def kinematics(system, point: str | None = None, *, frame: str | None = None) -> Kinematics:
    """The position, velocity and Jacobian of a named point (or the orientation and angular
    velocity of a frame), symbolic and numeric.

    Parameters
    ----------
    system : Model or Equations
        The model (no derivation is needed) or its equations.
    point : str
        The name of a point, particle or body (a body's centre of mass; a planar body adds its angle
        and angular velocity, a body in space its frame's orientation).
    frame : str
        The name of a frame (its origin and its axes); give `point` or `frame`, not both.

    Returns
    -------
    Kinematics
        Readable SymPy forms (``position``, ``velocity``, ``jacobian``, ...), ``.at(q, q_dot, params=...)``
        for the numbers (one compiled evaluator, vectorised over states), ``.text()``, ``.to_dict()``.

    Examples
    --------
    >>> import lagrangian as lg
    >>> tip = lg.kinematics(lg.load("double-pendulum"), "bob2")
    >>> tip.at([0.0, 0.0]).position.tolist()
    [0.0, -2.0]
    """
    if isinstance(system, Equations):
        model = system.model
    elif isinstance(system, Model):
        model = system
    else:
        raise TypeError(f"kinematics() expects a Model or Equations (lagrangian.load(...), lagrangian.derive(...)), "
                        f"got {type(system).__name__}")
    if (point is None) == (frame is None):
        raise ModelError("kinematics(): give a point (point='tip': a point, particle or body) or a frame "
                         "(frame='link2'), exactly one of them")
    located, frames = _named_things(model)
    if point is not None:
        if not isinstance(point, str) or point not in located:
            choices = ", ".join(located) or "none (add a point with m.add_point(...), or a [[points]] table)"
            raise ModelError(f"point '{point}': model '{model.name}' has no point, particle or body of that "
                             f"name{did_you_mean(point, located)}; the choices are {choices}"
                             + (f" (and the frames {', '.join(frames)}: frame=...)" if frames else ""))
        return _of_element(model, located[point])
    if not isinstance(frame, str) or (frame not in frames and frame != WORLD):
        choices = ", ".join(frames) or "none (add one with m.add_frame(...), or a [[frames]] table)"
        raise ModelError(f"frame '{frame}': model '{model.name}' has no frame of that name"
                         f"{did_you_mean(frame, list(frames))}; the frames are {choices}"
                         + (f" (and the points, particles and bodies {', '.join(located)}: point=...)"
                            if located else ""))
    return _of_frame(model, frame)


def _state_names(model: Model) -> frozenset[str]:
    return frozenset(s.name for s in (*model.q, *model.q_dot, model.t))


def _of_element(model: Model, element) -> Kinematics:
    rates = _Rates(model.q)
    position = [rates.se(c) for c in element.position]
    extra: dict = {}
    if isinstance(element, RigidBody):
        angle = rates.se(element.angle)
        extra = {"angle": [angle], "angular": [rates.rate(angle)]}
    elif isinstance(element, RigidBody3D):
        extra = _rotation_parts(model, element.frame, rates)
    kind = {Point: "point", Particle: "particle"}.get(type(element), "body")
    return _build(model, element.name, kind, position, rates, extra)


def _rotation_parts(model: Model, frame: str, rates) -> dict:
    _, R = frame_pose(model.frames, frame)
    R_se = se.DenseMatrix(3, 3, [rates.se(x) for x in R])
    body = angular_velocity(world_factors(model.frames, frame), rates)
    world = R_se * se.DenseMatrix(3, 1, body)
    return {"rotation": list(R_se), "angular": [world[i] for i in range(3)], "angular_body": list(body)}


def _of_frame(model: Model, frame: str) -> Kinematics:
    rates = _Rates(model.q)
    if frame == WORLD:
        origin = (0, 0, 0)
    else:
        origin, _ = frame_pose(model.frames, frame)
    position = [rates.se(c) for c in origin]
    return _build(model, frame, "frame", position, rates, _rotation_parts(model, frame, rates))


def _build(model: Model, name: str, kind: str, position: list, rates, extra: dict) -> Kinematics:
    q, qd = rates.q, rates.qd
    n = len(q)
    velocity = [rates.rate(c) for c in position]
    jac = [c.diff(qj) for c in position for qj in q]
    parts = [("position", (len(position),), position), ("velocity", (len(position),), velocity),
             ("jacobian", (len(position), n), jac)]
    if "rotation" in extra:
        parts.append(("rotation", (3, 3), extra["rotation"]))
    if "angle" in extra:
        parts.append(("angle", (), extra["angle"]))
    if "angular" in extra:
        w = extra["angular"]
        parts.append(("angular_velocity", (len(w),), w))
        if "angular_body" in extra:
            parts.append(("angular_velocity_body", (3,), extra["angular_body"]))
        parts.append(("angular_jacobian", (len(w), n), [wi.diff(v) for wi in w for v in qd]))
    state = _state_names(model)
    flat = [e for _, _, exprs in parts for e in exprs]
    shown = iter(readable_many(flat, state=state, collect_on=model.q_dot))
    symbolic = {key: [next(shown) for _ in exprs] for key, _, exprs in parts}

    def matrix(key, shape):
        return sympy.ImmutableMatrix(shape[0], shape[1], symbolic[key])

    values = {p.name: v for p, v in model.parameters.items()}
    args = (se.Symbol(model.t.name), *q, *qd, *(se.Symbol(p) for p in values))
    sym = {key: shape for key, shape, _ in parts}
    # the numbers are those of the forms shown (exact zeros stay zeros)
    parts = [(key, shape, [se.sympify(e) for e in symbolic[key]]) for key, shape, _ in parts]
    return Kinematics(
        model.name, name, kind, model.q, tuple(symbolic["position"]), tuple(symbolic["velocity"]),
        matrix("jacobian", sym["jacobian"]),
        rotation=matrix("rotation", (3, 3)) if "rotation" in sym else None,
        angle=symbolic["angle"][0] if "angle" in sym else None,
        angular_velocity=tuple(symbolic["angular_velocity"]) if "angular_velocity" in sym else None,
        angular_velocity_body=(tuple(symbolic["angular_velocity_body"]) if "angular_velocity_body" in sym
                               else None),
        angular_jacobian=matrix("angular_jacobian", sym["angular_jacobian"]) if "angular_jacobian" in sym else None,
        _values=values, _parts=tuple(parts), _args=args)

