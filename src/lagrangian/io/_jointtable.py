"""The ``[[joints]]`` tables of a model file (read by :mod:`lagrangian.io._modelfile`'s reader).

.. code-block:: toml

    [[joints]]
    name = "shoulder"                # required: an identifier
    type = "revolute"                # required: revolute, prismatic, cylindrical, universal, spherical,
                                     # planar, fixed or floating
    parent = "world"                 # optional: "world" (default), a [[frames]] table or another joint's child
    child = "upper_arm"              # optional: the frame the joint creates (default: the joint's name)
    origin = ["0", "0", "h"]         # optional: the joint frame's origin in the parent's axes
    rotation = [["x", "pi/2"]]       # optional: its constant rotation (as in [[frames]]; or matrix = ...,
    rpy = [0, 0, "pi/2"]             #   or rpy = [roll, pitch, yaw] as in URDF: Rz(yaw) Ry(pitch) Rx(roll))
    axis = "z"                       # optional: "x", "y", "z" or [ax, ay, az] (universal: two of them)
    coordinates = ["q1"]             # optional: the joint's coordinate names (default: from its name)
    limits = ["-pi/2", "pi/2"]       # optional: [lower, upper] (one pair per coordinate), recorded ...
    limit_stiffness = "k_stop"       # ... and enforced by one-sided springs of this stiffness, if given
    damping = "c"                    # optional: viscous damping, D = c q_dot**2 / 2 (per coordinate: a list)
    friction = "F"                   # optional: Coulomb friction, Q = -F sign(q_dot)
    sequence = "xyz"                 # spherical and floating joints: the angle sequence, or
    parametrization = "quaternion"   #   four Euler parameters with a unit-norm constraint (no singular posture)
    omega = [0, 0, 20]               # a quaternion joint: its initial angular velocity (rad/s, the child's axes)

A joint's coordinates are declared by the joint (``coordinates = [...]`` at the top of the file may
list them too, to fix their order; it may be left out when joints declare them all). Joints are
built with the ``[[frames]]`` tables, parents first, before the elements: a joint's parent is
``world``, a ``[[frames]]`` table or another joint's child, and a ``[[frames]]`` table may hang
from a joint's child frame (a tool frame), in any order of the tables; bodies, points and loads
may be placed in a joint's child frame.
"""

from __future__ import annotations

from typing import Any, Mapping

from ..errors import ModelError

__all__ = ["JOINT_KEYS", "declare_joint_coordinates", "read_joints"]

#: The keys of a [[joints]] table.
JOINT_KEYS = ("name", "type", "parent", "child", "origin", "rotation", "matrix", "rpy", "axis", "coordinates",
              "limits", "limit_stiffness", "damping", "friction", "sequence", "parametrization", "omega")


def _names(table: Mapping[str, Any]) -> list[str]:
    from ..model._joints import JOINT_TYPES, default_coordinates

    name, type_ = table.get("name"), table.get("type")
    if not isinstance(name, str) or not name.isidentifier() or type_ not in JOINT_TYPES:
        return []
    given = table.get("coordinates")
    if isinstance(given, str):
        return [given]
    if isinstance(given, list):
        return [c for c in given if isinstance(c, str)]
    axis, sequence, pz = table.get("axis"), table.get("sequence"), table.get("parametrization")
    return list(default_coordinates(name, type_, axis if isinstance(axis, str) else None,
                                    sequence if isinstance(sequence, str) else None,
                                    pz if isinstance(pz, str) else None))


def declare_joint_coordinates(reader, value: object) -> None:
    """Declare the coordinates the joints name (before any expression is read, so that expressions may
    use them); names that cannot be declared are left for :func:`read_joints` to report."""
    from ..model._symbols import check_name

    if not isinstance(value, list):
        return
    model = reader.model
    for table in value:
        if not isinstance(table, dict):
            continue
        for name in _names(table):
            if check_name(name, "coordinate") is None and name not in model._all_names():
                model.coordinate(name)


def read_joints(reader, value: object) -> None:
    """Build the [[joints]] tables in the file's order, each problem recorded under its key
    (``joints[0].axis``). The model file's reader builds them with the [[frames]] tables instead,
    parents first (:func:`joint_child`, :func:`build_joint`), so that the order of the tables does not matter."""
    for entry in reader.element_tables("joints", value):
        build_joint(reader, entry)


def joint_child(table: Mapping[str, Any]) -> str | None:
    """The name of the frame a [[joints]] table creates (its child, default its name), or None."""
    child = table.get("child", table.get("name"))
    return child if isinstance(child, str) else None


def build_joint(reader, entry, parent: str | None = None) -> bool:
    """Build one [[joints]] table (under `parent` in place of its own, when given: a stand-in for a parent
    that cannot be built, whose problem is reported elsewhere); whether the joint was added."""
    key, table = entry.key, entry.table
    for name in table:
        if name not in JOINT_KEYS:
            reader.unknown_key(f"{key}.{name}", name, JOINT_KEYS, "[[joints]]")
    missing = [k for k in ("name", "type") if k not in table]
    for k in missing:
        example = 'name = "shoulder"' if k == "name" else 'type = "revolute"'
        reader.problem(f"{key}.{k}", f"missing required key '{k}': write {example}")
    if missing:
        return False
    name = table["name"]
    if not isinstance(name, str):
        reader.problem(f"{key}.name", f"expected a joint's name, an identifier in quotes such as "
                                      f"\"shoulder\", got {name!r}")
        return False
    kwargs: dict[str, Any] = {}
    before = len(reader.problems)
    for k in ("parent", "child", "axis", "coordinates", "sequence", "parametrization", "omega"):
        if k in table:
            kwargs[k] = table[k]
    if parent is not None:
        kwargs["parent"] = parent
    if "origin" in table:
        origin = reader.vector(table["origin"], f"{key}.origin")
        if origin is not None and len(origin) != 3:
            reader.problem(f"{key}.origin", f"a joint's origin has 3 components (x, y, z), got {len(origin)}")
            origin = None
        kwargs["origin"] = origin
    given = [k for k in ("rotation", "matrix", "rpy") if k in table]
    if len(given) > 1:
        reader.problem(f"{key}.{given[1]}", f"give the joint frame's rotation one way: {' or '.join(given)}, "
                                            "not both: remove one of them")
    elif given == ["rotation"]:
        kwargs["rotation"] = reader.rotation_steps(table["rotation"], f"{key}.rotation")
    elif given == ["matrix"]:
        kwargs["rotation"] = reader.matrix3(table["matrix"], f"{key}.matrix", "rotation matrix")
    elif given == ["rpy"]:
        rpy = table["rpy"]
        if not isinstance(rpy, list) or len(rpy) != 3:
            reader.problem(f"{key}.rpy", f"expected [roll, pitch, yaw] (3 angles, radians), got {rpy!r}")
        else:
            angles = [reader.expr(a, f"{key}.rpy[{i}]") for i, a in enumerate(rpy)]
            if all(a is not None for a in angles):
                kwargs["rotation"] = [(axis, a) for axis, a in zip("zyx", angles[::-1]) if a != 0] or None
    if "limit_stiffness" in table:
        kwargs["limit_stiffness"] = reader.expr(table["limit_stiffness"], f"{key}.limit_stiffness")
    for k in ("damping", "friction"):
        if k in table:
            v = table[k]
            if isinstance(v, list):
                kwargs[k] = [reader.expr(x, f"{key}.{k}[{i}]") for i, x in enumerate(v)]
            else:
                kwargs[k] = reader.expr(v, f"{key}.{k}")
    if "limits" in table:
        kwargs["limits"] = _limits(reader, table["limits"], f"{key}.limits")
    if len(reader.problems) > before or any(v is None for k, v in kwargs.items()
                                            if k not in ("sequence", "parametrization", "omega")):
        entry.ok = False
        if isinstance(table.get("child", name), str):
            reader.frame_names.setdefault(table.get("child", name), None)
        return False
    try:
        reader.model.add_joint(name, table["type"], **kwargs)
    except ModelError as exc:
        prefix = f"joint '{name}'"
        for p in exc.problems:
            k, message = p.key or prefix, p.message
            if p.key is None and message.startswith(prefix + "."):  # "joint 'j'.axis: ..." from a Model method
                field, _, message = message[len(prefix) + 1:].partition(": ")
                k = f"{prefix}.{field}"
            k = key + k[len(prefix):] if k.startswith(prefix) else k
            reader.problem(k, message)
        entry.ok = False
        if isinstance(table.get("child", name), str):
            reader.frame_names.setdefault(table.get("child", name), None)
        return False
    child = table.get("child", name)
    reader.frame_keys[child] = key
    reader.key_map[f"frame '{child}'"] = (key, {"rotation": given[0] if given else "rotation"})
    reader.frame_names.setdefault(child, None)
    return True


def _limits(reader, value, key):
    """[lower, upper] or a list of them (or of false/[] for none), as expressions; None after a problem."""
    if not isinstance(value, list):
        reader.problem(key, f"expected [lower, upper], or one such pair per coordinate, got {value!r}")
        return None
    if len(value) == 2 and not any(isinstance(v, list) for v in value):
        lo, hi = (reader.expr(v, f"{key}[{i}]") for i, v in enumerate(value))
        return None if lo is None or hi is None else [lo, hi]
    out = []
    for i, pair in enumerate(value):
        if pair == [] or pair is False:
            out.append(None)
        elif isinstance(pair, list) and len(pair) == 2:
            lo, hi = (reader.expr(v, f"{key}[{i}][{j}]") for j, v in enumerate(pair))
            if lo is None or hi is None:
                return None
            out.append([lo, hi])
        else:
            reader.problem(f"{key}[{i}]", f"expected [lower, upper] (or [] for none), got {pair!r}")
            return None
    return out
