"""URDF import: a robot description (XML) -> the :class:`~lagrangian.Model` a user would write with joints.

A URDF file is data: it is parsed with :mod:`xml.etree.ElementTree` after refusing any document
type declaration (``<!DOCTYPE``, ``<!ENTITY``: the entity-expansion attacks need them) and any file
larger than :data:`MAX_BYTES`; nothing in it is executed, imported or opened (meshes included), and
its names enter the model only through the model's own name rules.

What is read
------------
- ``<link>``: its ``<inertial>`` (``<mass value>``, ``<inertia ixx .. izz>`` about the centre of mass
  in the axes of ``<origin xyz rpy>``). A link without ``<inertial>`` is massless.
- ``<joint>`` of type ``revolute``, ``continuous`` (a revolute joint without limits), ``prismatic``,
  ``fixed``, ``floating`` and ``planar`` (with its axis along x, y or z): ``<origin xyz rpy>``
  (rpy: R = Rz(yaw) Ry(pitch) Rx(roll)), ``<axis xyz>`` (default 1 0 0), ``<limit lower upper>``
  (recorded on the joint) and ``<dynamics damping friction>`` (a viscous damper and Coulomb friction).
- Each moving joint becomes :meth:`Model.add_joint`, its child link's frame the joint's child frame;
  its coordinate is named after the joint (see :func:`coordinate_name`), in the file's order, its
  velocity ``<joint>_dot``. A fixed joint makes a constant frame, and its child link's inertia is
  merged into the link it hangs from (one rigid body per moving link: mass, centre of mass and
  inertia combined by the parallel-axis theorem).
- The root link is fixed to ``world`` unless ``floating_base=True`` (a floating joint
  ``floating_base`` with coordinates ``floating_base_x`` .. ``floating_base_3``), or
  ``floating_base="quaternion"`` (its rotation by a unit quaternion ``floating_base_q0`` .. ``_q3``
  with the constraint ``floating_base_norm``: no singular posture; see :mod:`lagrangian.model._joints`).
- Gravity: a parameter ``g`` (default 9.81) along -z of the world (URDF does not carry it).
- ``<visual>`` geometry (box, cylinder, sphere; a mesh as a small marker, its file never opened) is
  kept in ``model.visuals`` for drawing.

Not taken, with an error that says what to do: ``<mimic>`` (a closed loop of joints: remove the
mimic joint, or make it a fixed joint), a joint graph that is not a tree (cycles, two parents, two
roots), ``planar`` joints whose axis is not x, y or z. ``<transmission>`` elements describe actuators
(an effort's path to a joint), not the rigid-body dynamics: they are ignored, and said so in the
model's description. ``<gazebo>``, ``<material>`` and ``<collision>`` are ignored.
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sympy

from ..errors import ModelError, ModelFileError, Problem

__all__ = ["load_urdf", "loads_urdf", "MAX_BYTES", "coordinate_name", "VisualShape"]

#: The largest URDF read (bytes): a 7-joint arm's file is about 15 kB, a humanoid's a few hundred.
MAX_BYTES = 10 * 2 ** 20

#: The joint types read, and the model's joint type of each.
_TYPES = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": "fixed",
          "floating": "floating", "planar": "planar"}

#: Characters a URDF name may have besides letters, digits and "_": each becomes "_".
_MAPPED = "-./:"
_NAME_CHARS = re.compile(r"[A-Za-z0-9_\-./:]+\Z")

#: The name of the floating base joint (and the prefix of its coordinates).
FLOATING_BASE = "floating_base"


@dataclass(frozen=True)
class VisualShape:
    """A shape drawn for a link: `kind` "box" (size: 3 edge lengths), "cylinder" (radius, length, along
    z), "sphere" (radius) or "marker" (a mesh, drawn as a small sphere of `size[0]`), placed at
    `origin` (xyz) with `rpy` in the axes of the link's `frame`; `mesh` the file name it stands for."""

    frame: str
    kind: str
    size: tuple
    origin: tuple = (0.0, 0.0, 0.0)
    rpy: tuple = (0.0, 0.0, 0.0)
    mesh: str | None = None


@dataclass
class _Link:
    name: str
    frame: str
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # about the com, link axes
    line: int | None = None


@dataclass
class _Joint:
    name: str
    type: str
    parent: str
    child: str
    xyz: tuple = (0.0, 0.0, 0.0)
    rpy: tuple = (0.0, 0.0, 0.0)
    axis: tuple = (1.0, 0.0, 0.0)
    limits: tuple | None = None
    damping: float = 0.0
    friction: float = 0.0
    coordinate: str = ""
    line: int | None = None


def coordinate_name(name: str, kind: str = "joint") -> tuple[str | None, str | None]:
    """(the model's name for the URDF name `name`, None) or (None, why it is refused).

    Renamed: each of ``- . / :`` becomes ``_`` and a leading digit gets ``q_`` before it (``"arm/joint-1"``
    -> ``"arm_joint_1"``). Refused: any other character (spaces, quotes, parentheses: ``__import__('os')``),
    a name starting with ``__``, and the names the model keeps for itself (``t``, ``pi``, the functions,
    Python keywords, names ending in ``_dot`` or ``_ddot``)."""
    from ..model._symbols import check_name

    if not isinstance(name, str) or not name:
        return None, f"a {kind} needs a name (name=\"...\")"
    if len(name) > 200:
        return None, f"the {kind} name is {len(name)} characters long: at most 200"
    if not _NAME_CHARS.match(name):
        bad = sorted({c for c in name if not (c.isascii() and (c.isalnum() or c in "_" + _MAPPED))})
        shown = " ".join(repr(c) for c in bad[:5])
        return None, (f"the {kind} name {name!r} has the characters {shown}: a name may have letters, digits and "
                      f"_ - . / : only; rename the {kind} in the URDF")
    if name.startswith("__"):
        return None, f"the {kind} name {name!r} starts with '__': rename the {kind} in the URDF"
    out = "".join("_" if c in _MAPPED else c for c in name)
    if out[0].isdigit():
        out = "q_" + out
    why = check_name(out, "coordinate")
    if why is not None:
        return None, f"the {kind} name {name!r} cannot name a coordinate: {why}; rename the {kind} in the URDF"
    return out, None


def load_urdf(path: str | os.PathLike, *, floating_base: bool = False, gravity: float | None = 9.81):
    """Read a URDF file into a :class:`~lagrangian.Model` (see the module docstring).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.urdf`` file.
    floating_base : bool or str, optional
        Give the root link 6 coordinates (a free body) instead of fixing it to the world: True or
        ``"angles"`` (three angles), or ``"quaternion"`` (a unit quaternion, 7 coordinates).
    gravity : float or None, optional
        The value of the parameter ``g`` (gravity along -z); None for no gravity.

    Raises
    ------
    ModelFileError
        Listing every problem of the file (each with its line), or why it cannot be read.
    """
    file = Path(path)
    source = str(file)
    if not file.is_file():
        raise ModelFileError([Problem(f"no such URDF file '{source}': check the path")], file=source)
    try:
        size = file.stat().st_size
        if size > MAX_BYTES:
            raise ModelFileError([Problem(_too_large(size))], file=source)
        with open(file, "rb") as fh:
            data = fh.read(MAX_BYTES + 1)
    except OSError as exc:
        raise ModelFileError([Problem(f"cannot read the URDF file: {exc.strerror or exc}")], file=source) from None
    return loads_urdf(data, source=source, floating_base=floating_base, gravity=gravity,
                      default_name=file.stem or "robot", folder=file.parent)


def _too_large(size: int) -> str:
    return (f"the URDF file has {size} bytes, more than the {MAX_BYTES} read: a robot's description is a few "
            "hundred kB at most; check that this is the right file")


def loads_urdf(text: str | bytes, *, source: str = "<string>", floating_base: bool = False,
               gravity: float | None = 9.81, default_name: str = "robot", folder: str | os.PathLike | None = None):
    """Read a model from the text of a URDF file (str or bytes); see :func:`load_urdf`. `folder` is the
    folder relative mesh paths are checked against (never opened)."""
    if isinstance(text, str):
        raw = text.encode("utf-8")
    elif isinstance(text, (bytes, bytearray)):
        raw = bytes(text)
    else:
        raise TypeError(f"loads_urdf() expects the text of a URDF file (str or bytes), got {type(text).__name__}")
    if len(raw) > MAX_BYTES:
        raise ModelFileError([Problem(_too_large(len(raw)))], file=source)
    head = raw.lower()
    for marker in (b"<!doctype", b"<!entity"):
        at = head.find(marker)
        if at >= 0:
            line = raw[:at].count(b"\n") + 1
            raise ModelFileError([Problem(
                f"the URDF has a {marker[2:].decode().upper()} declaration: document types and entities are "
                "refused (they can expand to gigabytes, or read other files); a URDF needs neither: remove it",
                line=line)], file=source)
    try:
        root = ET.fromstring(raw)
    except ET.ParseError as exc:
        line = exc.position[0] if getattr(exc, "position", None) else None
        raise ModelFileError([Problem(f"the URDF is not well-formed XML: {exc}; fix the XML there", line=line)],
                             file=source) from None
    return _Builder(root, source, floating_base, gravity, default_name, folder, raw).build()


class _Builder:
    def __init__(self, root, source, floating_base, gravity, default_name, folder, raw=b""):
        self.root = root
        self.raw = raw
        self.source = source
        self.floating_base, self.base_parametrization = _floating_base(floating_base)
        self.gravity = gravity
        self.default_name = default_name
        self.folder = None if folder is None else Path(folder).resolve()
        self.problems: list[Problem] = []
        self.notes: list[str] = []  # also in the model's description
        self.merges: list[str] = []  # links merged, fixed to the world or massless
        self.link_names = {el.get("name") for el in root.findall("link")}  # a joint to a link with problems: no
        # second error

    def problem(self, key, message, line=None):
        if line is None and key:  # the line of <link name="..."> or <joint name="..."> (ElementTree keeps none)
            match = re.match(r"(link|joint) '(.*?)'", key)
            if match:
                at = self.raw.find(f'<{match.group(1)} name="{match.group(2)}"'.encode())
                line = self.raw[:at].count(b"\n") + 1 if at >= 0 else None
        self.problems.append(Problem(message, key=key, line=line))

    def raise_if_problems(self):
        if self.problems:
            raise ModelFileError(sorted(self.problems, key=lambda p: p.line or 0), file=self.source)

    # -- numbers --------------------------------------------------------------------------------
    def floats(self, el, attr, n, key, default=None):
        text = el.get(attr)
        if text is None:
            if default is None:
                self.problem(key, f"missing attribute {attr}=\"...\" ({n} number{'s' if n > 1 else ''})")
            return default
        parts = text.split()
        try:
            values = tuple(float(p) for p in parts)
        except ValueError:
            self.problem(key, f"{attr}=\"{text[:60]}\": expected {n} number{'s' if n > 1 else ''}")
            return default
        if len(values) != n:
            self.problem(key, f"{attr}=\"{text[:60]}\": expected {n} number{'s' if n > 1 else ''}, got {len(values)}")
            return default
        if not all(math.isfinite(v) and abs(v) < 1e100 for v in values):
            self.problem(key, f"{attr}=\"{text[:60]}\": every number must be finite (and below 1e100)")
            return default
        return values

    def origin(self, el, key):
        o = el.find("origin")
        if o is None:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        return (self.floats(o, "xyz", 3, f"{key}.origin", (0.0, 0.0, 0.0)),
                self.floats(o, "rpy", 3, f"{key}.origin", (0.0, 0.0, 0.0)))

    # -- reading --------------------------------------------------------------------------------
    def build(self):
        from ..model._model import Model

        root = self.root
        if root.tag != "robot":
            raise ModelFileError([Problem(f"the root element is <{root.tag[:40]}>, expected <robot>: this is not a "
                                          "URDF file")], file=self.source)
        name = root.get("name") or self.default_name
        links: dict[str, _Link] = {}
        frames: dict[str, str] = {}
        for el in root.findall("link"):
            link = self.read_link(el, frames)
            if link is not None:
                if link.name in links:
                    self.problem(f"link '{link.name}'", "two links have this name: give each link its own name")
                else:
                    links[link.name] = link
        joints: list[_Joint] = []
        coords: dict[str, str] = {}
        for el in root.findall("joint"):
            j = self.read_joint(el, links, coords)
            if j is not None:
                if any(o.name == j.name for o in joints):
                    self.problem(f"joint '{j.name}'", "two joints have this name: give each joint its own name")
                else:
                    joints.append(j)
        if root.find("transmission") is not None:
            self.notes.append("<transmission> elements ignored (actuators, not rigid-body dynamics)")
        visuals = self.read_visuals(root, links)
        if not links:
            self.problem("robot", "the URDF has no <link>: a robot needs at least one")
        self.raise_if_problems()
        base = self.tree(links, joints)
        self.raise_if_problems()
        model = Model(name)
        try:
            self.make(model, links, joints, base)
        except ModelError as exc:  # pragma: no cover - the checks above should leave nothing to the model
            raise ModelFileError(exc.problems, file=self.source) from None
        model.visuals = tuple(visuals)
        model.import_notes = tuple(self.notes + self.merges)  # what lagrangian load reports
        note = f"Imported from the URDF {Path(self.source).name}"
        model.description = note + ("; " + "; ".join(self.notes) if self.notes else "")
        return model

    def read_link(self, el, frames):
        raw = el.get("name")
        line = getattr(el, "sourceline", None)
        frame, why = coordinate_name(raw, "link")
        key = f"link '{raw}'"
        if why:
            self.problem(key, why)
            return None
        if frame in frames:
            self.problem(key, f"the link names '{frames[frame]}' and '{raw}' both become '{frame}' (- . / : become "
                              "_): rename one of them in the URDF")
            return None
        frames[frame] = raw
        link = _Link(raw, frame, line=line)
        inertial = el.find("inertial")
        if inertial is None:
            return link
        m = inertial.find("mass")
        if m is None or m.get("value") is None:
            self.problem(key, "its <inertial> has no <mass value=\"...\"/>: give the link's mass in kg (or remove "
                              "<inertial> for a massless link)")
            return None
        mass = self.floats(m, "value", 1, f"{key}.mass")
        if mass is None:
            return None
        if mass[0] < 0:
            self.problem(f"{key}.mass", f"the mass is {mass[0]:g}: a mass is at least 0")
            return None
        xyz, rpy = self.origin(inertial, f"{key}.inertial")
        i = inertial.find("inertia")
        if i is None:
            self.problem(key, "its <inertial> has no <inertia ixx=.. ixy=.. ixz=.. iyy=.. iyz=.. izz=../>: give the "
                              "inertia tensor about the centre of mass")
            return None
        c = {}
        for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
            v = self.floats(i, a, 1, f"{key}.inertia")
            if v is None:
                return None
            c[a] = v[0]
        inertia = np.array([[c["ixx"], c["ixy"], c["ixz"]], [c["ixy"], c["iyy"], c["iyz"]],
                            [c["ixz"], c["iyz"], c["izz"]]])
        ev = np.linalg.eigvalsh(inertia)
        scale = max(abs(ev).max(), 1e-300)
        tol = 1e-9 * scale
        if ev[0] < -tol:
            self.problem(f"{key}.inertia", f"the inertia tensor has the principal moment {ev[0]:.6g} < 0 "
                                           f"(principal moments {', '.join(f'{e:.6g}' for e in ev)}): it must be "
                                           "positive semi-definite; check the signs of ixy, ixz, iyz (URDF gives "
                                           "the tensor's entries, the products of inertia with their sign)")
            return None
        if ev[0] + ev[1] < ev[2] - tol:
            self.problem(f"{key}.inertia", f"the principal moments {', '.join(f'{e:.6g}' for e in ev)} break the "
                                           "triangle inequality (each at most the sum of the other two): no body "
                                           "has this inertia; check the values")
            return None
        if mass[0] == 0 and scale > 0 and ev[2] > 0:
            self.problem(f"{key}.mass", "the mass is 0 but the inertia is not: give the link's mass")
            return None
        R = _rpy_matrix(rpy)
        link.mass = mass[0]
        link.com = np.array(xyz)
        link.inertia = (R @ inertia @ R.T + (R @ inertia @ R.T).T) / 2
        return link

    def read_joint(self, el, links, coords):
        raw = el.get("name")
        line = getattr(el, "sourceline", None)
        cname, why = coordinate_name(raw, "joint")
        key = f"joint '{raw}'"
        if why:
            self.problem(key, why)
            return None
        type_ = el.get("type")
        if type_ not in _TYPES:
            self.problem(f"{key}.type", f"unknown joint type {type_!r}: the URDF types read are "
                                        f"{', '.join(_TYPES)}")
            return None
        if el.find("mimic") is not None:
            other = el.find("mimic").get("joint")
            self.problem(key, f"a <mimic> joint (following '{other}') closes a loop of joints, which this importer "
                              "does not take: remove the mimic joint and its child link, or make it a fixed joint "
                              "(type=\"fixed\"), or write the coupling as a constraint in a model file")
            return None
        ends = []
        for tag in ("parent", "child"):
            e = el.find(tag)
            link = None if e is None else e.get("link")
            if link is None:
                self.problem(f"{key}.{tag}", f"missing <{tag} link=\"...\"/>")
            elif link not in links:
                if link not in self.link_names:
                    self.problem(f"{key}.{tag}", f"no link is named '{link}'; the links are "
                                                 f"{', '.join(list(links)[:10])}")
                link = None
            ends.append(link)
        if None in ends:
            return None
        xyz, rpy = self.origin(el, key)
        axis_el = el.find("axis")
        axis = (1.0, 0.0, 0.0) if axis_el is None else self.floats(axis_el, "xyz", 3, f"{key}.axis", None)
        if axis is None:
            return None
        norm = math.sqrt(sum(a * a for a in axis))
        if _TYPES[type_] not in ("fixed", "floating") and norm < 1e-12:
            self.problem(f"{key}.axis", "the axis is the zero vector: give its direction, e.g. xyz=\"0 0 1\"")
            return None
        axis = tuple(a / norm for a in axis) if norm > 0 else axis
        if type_ == "planar" and sum(abs(a) > 1e-12 for a in axis) != 1:
            self.problem(f"{key}.axis", "a planar joint is read with its normal along x, y or z of the joint "
                                        "frame only: turn the joint's origin (rpy) so that the normal is one of "
                                        "them")
            return None
        j = _Joint(raw, _TYPES[type_], ends[0], ends[1], xyz, rpy, axis, line=line)
        limit = el.find("limit")
        if limit is not None and type_ in ("revolute", "prismatic") and limit.get("lower") is not None \
                and limit.get("upper") is not None:
            lo = self.floats(limit, "lower", 1, f"{key}.limit", (None,))[0]
            hi = self.floats(limit, "upper", 1, f"{key}.limit", (None,))[0]
            if lo is not None and hi is not None:
                if lo > hi:
                    self.problem(f"{key}.limit", f"lower = {lo:g} is above upper = {hi:g}: swap them")
                elif lo < hi:
                    j.limits = (lo, hi)
        dyn = el.find("dynamics")
        if dyn is not None and j.type in ("revolute", "prismatic"):
            for attr in ("damping", "friction"):
                v = self.floats(dyn, attr, 1, f"{key}.dynamics", (0.0,))[0]
                if v < 0:
                    self.problem(f"{key}.dynamics", f"{attr} = {v:g}: it is at least 0")
                    v = 0.0
                setattr(j, attr, v)
        if j.type != "fixed":
            if cname in coords:
                self.problem(key, f"the joint names '{coords[cname]}' and '{raw}' both become '{cname}' (- . / : "
                                  "become _): rename one of them in the URDF")
                return None
            coords[cname] = raw
        j.coordinate = cname
        return j

    def read_visuals(self, root, links):
        out = []
        for el in root.findall("link"):
            link = links.get(el.get("name"))
            if link is None:
                continue
            for k, vis in enumerate(el.findall("visual")):
                key = f"link '{link.name}'.visual[{k}]"
                xyz, rpy = self.origin(vis, key)
                geo = vis.find("geometry")
                shape = None if geo is None else next(iter(geo), None)
                if shape is None:
                    continue
                if shape.tag == "box":
                    size = self.floats(shape, "size", 3, f"{key}.box")
                    kind = "box"
                elif shape.tag == "cylinder":
                    r = self.floats(shape, "radius", 1, f"{key}.cylinder")
                    h = self.floats(shape, "length", 1, f"{key}.cylinder")
                    size = None if r is None or h is None else (r[0], h[0])
                    kind = "cylinder"
                elif shape.tag == "sphere":
                    size = self.floats(shape, "radius", 1, f"{key}.sphere")
                    kind = "sphere"
                elif shape.tag == "mesh":
                    mesh = shape.get("filename") or ""
                    if not self.mesh_inside(mesh, key):
                        continue
                    out.append(VisualShape(link.frame, "marker", (0.02,), xyz, rpy, mesh))
                    continue
                else:
                    continue
                if size is not None:
                    if any(s <= 0 for s in size):
                        self.problem(key, f"a {kind}'s sizes are positive, got {' '.join(f'{s:g}' for s in size)}")
                        continue
                    out.append(VisualShape(link.frame, kind, tuple(size), xyz, rpy))
        return out

    def mesh_inside(self, mesh: str, key: str) -> bool:
        """Whether a mesh's file name is a package:// URI or a path inside the URDF's folder (it is never
        opened either way); a path outside it is a problem."""
        if mesh.startswith("package://"):
            rest = mesh[len("package://"):]
            if ".." not in Path(rest).parts:
                return True
        elif not mesh.startswith(("file:", "/", "\\")) and ":" not in mesh[:3] and ".." not in Path(mesh).parts:
            return True
        self.problem(key, f"the mesh '{mesh[:80]}' is outside the URDF's folder: meshes are never opened (they are "
                          "drawn as markers), but a path out of the folder is refused; give a path inside the folder "
                          "or a package:// URI")
        return False

    # -- the tree -------------------------------------------------------------------------------
    def tree(self, links, joints):
        """The root link; problems for two parents, cycles and two roots."""
        parent_of: dict[str, _Joint] = {}
        for j in joints:
            if j.child in parent_of:
                self.problem(f"joint '{j.name}'", f"the link '{j.child}' is the child of the joints "
                                                  f"'{parent_of[j.child].name}' and '{j.name}': the joints of a URDF "
                                                  "form a tree (each link has at most one parent joint)")
            else:
                parent_of[j.child] = j
        for j in joints:  # cycles
            seen = [j.child]
            link = j.parent
            while link in parent_of and link not in seen:
                seen.append(link)
                link = parent_of[link].parent
            if link in seen and link == j.child:
                loop = " -> ".join(seen[::-1] + [seen[-1]]) if len(seen) > 1 else link
                self.problem(f"joint '{j.name}'", f"the joints form a cycle through the links {loop}: a URDF's "
                                                  "joints form a tree; a closed loop is not read (write it as a "
                                                  "model file with a constraint)")
                break
        roots = [n for n in links if n not in parent_of]
        if len(roots) > 1 and not self.problems:
            self.problem("robot", f"the links {', '.join(roots[:6])} have no parent joint: a URDF has one root link; "
                                  "connect the others with joints (a fixed joint for a rigid attachment)")
        if not roots and not self.problems:
            self.problem("robot", "every link has a parent joint: the joints form a cycle and there is no root link")
        return roots[0] if len(roots) == 1 else None

    # -- the model ------------------------------------------------------------------------------
    def make(self, model, links, joints, base):
        from ..model._frames import WORLD

        children: dict[str, list[_Joint]] = {}
        for j in joints:
            children.setdefault(j.parent, []).append(j)
        from ..model._joints import default_coordinates

        moving = [j for j in joints if j.type != "fixed"]
        # coordinates in the file's order of the joints (a planar or floating joint's: <name>_x, ...)
        names_of = {j.name: list(default_coordinates(j.coordinate, j.type, _planar_normal(j.axis)))
                    for j in moving}
        names = [n for j in moving for n in names_of[j.name]]
        if self.floating_base:
            names = list(default_coordinates(FLOATING_BASE, "floating",
                                             parametrization=self.base_parametrization)) + names
        seen: set[str] = set()
        for n in names:
            if n in seen:
                raise ModelFileError([Problem(f"two joints' coordinates are both named '{n}' (a planar or floating "
                                              "joint's coordinates are <name>_x, ..., the floating base's "
                                              f"{FLOATING_BASE}_x, ...): rename one of the joints in the URDF")],
                                     file=self.source)
            seen.add(n)
        if names:
            model.coordinate(*names)
        gname = None
        if self.gravity is not None:
            gname = "g" if "g" not in seen else "g_gravity"
            model.parameter(gname, float(self.gravity))
        # frames, parents first
        root_frame = links[base].frame
        if self.floating_base:
            model.add_joint(FLOATING_BASE, "floating", child=root_frame if root_frame != WORLD else "base",
                            parametrization=self.base_parametrization)
            root_frame = root_frame if root_frame != WORLD else "base"
        elif root_frame != WORLD:
            model.add_frame(root_frame)
        anchor = {base: base}  # link -> the link whose frame it moves with (through fixed joints)
        offset = {base: (np.eye(3), np.zeros(3))}  # link -> (R, p) of its frame in the anchor's
        frame_of = {base: root_frame}
        merged_by: dict[str, str] = {}  # link -> the fixed joint that merges it into its parent's body
        order = []
        stack = [base]
        while stack:
            link = stack.pop(0)
            for j in children.get(link, []):
                order.append(j)
                stack.append(j.child)
        for j in order:
            frame = links[j.child].frame
            if frame == WORLD:
                frame = "world_link"
            frame_of[j.child] = frame
            rotation = _rpy_steps(j.rpy)
            origin = tuple(_number(v) for v in j.xyz)
            if j.type == "fixed":
                model.add_joint(j.coordinate, "fixed", parent=frame_of[j.parent], child=frame, origin=origin,
                                rotation=rotation)
                R0 = _rpy_matrix(j.rpy)
                Ra, pa = offset[j.parent]
                anchor[j.child] = anchor[j.parent]
                offset[j.child] = (Ra @ R0, pa + Ra @ np.array(j.xyz))
                merged_by[j.child] = j.name
                continue
            axis = _axis(j.axis)
            kwargs = {}
            if j.type in ("revolute", "prismatic"):
                kwargs = {"limits": j.limits, "damping": _number(j.damping) if j.damping else None,
                          "friction": _number(j.friction) if j.friction else None}
            if j.type == "planar":
                axis = _planar_normal(j.axis)
                if max(j.axis) <= 0:
                    self.notes.append(f"planar joint '{j.name}': its normal taken as +{axis}")
            elif j.type == "floating":
                axis = None
            model.add_joint(j.coordinate, j.type, parent=frame_of[j.parent], child=frame, origin=origin,
                            rotation=rotation, axis=axis, coordinates=names_of[j.name], **kwargs)
            anchor[j.child] = j.child
            offset[j.child] = (np.eye(3), np.zeros(3))
        # bodies: the links that move together, merged
        groups: dict[str, list[str]] = {}
        for link in [base] + [j.child for j in order]:
            groups.setdefault(anchor[link], []).append(link)
        for head, members in groups.items():
            for n in members[1:]:
                if links[n].mass > 0 or head != base or self.floating_base:
                    self.merges.append(f"link '{n}' merged into link '{head}' (fixed joint '{merged_by[n]}')")
            if head == base and not self.floating_base:
                fixed_mass = sum(links[n].mass for n in members)
                if fixed_mass > 0:
                    self.merges.append(f"link '{head}' is fixed to the world: its {fixed_mass:g} kg (with the links "
                                      "merged into it) never move and are left out")
                continue  # fixed to the world: no kinetic energy, a constant potential
            mass, com, inertia = _merge([(links[n], *offset[n]) for n in members])
            if mass <= 0:
                self.merges.append(f"link '{head}' has no mass: no body (it carries the links below it)")
                continue
            model.add_rigid_body(_number(mass), [[_number(x) for x in row] for row in inertia], frame=frame_of[head],
                                 center=tuple(_number(c) for c in com), name=links[head].frame)
        if gname is not None:
            model.add_gravity(model.symbol(gname), direction=(0, 0, -1))


def _floating_base(value) -> tuple[bool, str | None]:
    """(whether the root link floats, its parametrization) of load_urdf's floating_base."""
    from .._util import did_you_mean

    if value is False or value is None:
        return False, None
    if value is True or value == "angles":
        return True, None
    if value == "quaternion":
        return True, "quaternion"
    extra = did_you_mean(value, ["angles", "quaternion"]) if isinstance(value, str) else ""
    raise ModelError(f"floating_base={value!r}{extra}: expected False (the root link fixed to the world), True or "
                     "\"angles\" (a floating base turned by three angles), or \"quaternion\" (by a unit quaternion: "
                     "no singular posture)")


def _planar_normal(axis) -> str:
    """The letter of the unit axis a planar joint's normal is along."""
    return "xyz"[int(np.argmax(np.abs(axis)))]


def _merge(parts):
    """(mass, centre of mass, inertia about it) of links rigidly joined: parts (link, R, p) with the link's
    frame at R, p in the common frame."""
    mass = sum(link.mass for link, _, _ in parts)
    if mass <= 0:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    coms = [(link.mass, p + R @ link.com, R @ link.inertia @ R.T) for link, R, p in parts]
    com = sum(m * c for m, c, _ in coms) / mass
    inertia = np.zeros((3, 3))
    for m, c, I in coms:
        d = c - com
        inertia += I + m * (d @ d * np.eye(3) - np.outer(d, d))
    return mass, com, (inertia + inertia.T) / 2


def _number(x: float):
    """A float as a SymPy number: an integer when it is one, else a Float."""
    x = float(x)
    if x == int(x) and abs(x) < 1e15:
        return sympy.Integer(int(x))
    return sympy.Float(x)


def _angle(a: float):
    """An angle, exact when it is within 1e-12 of a multiple of pi/12 (URDF writes pi/2 as 1.5707963267948966)."""
    k = round(a / (math.pi / 12))
    if abs(a - k * math.pi / 12) < 1e-12:
        return sympy.pi * sympy.Rational(k, 12)
    return sympy.Float(a)


def _rpy_steps(rpy):
    """URDF's rpy as rotations about the frame's own axes: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    return [(axis, _angle(a)) for axis, a in (("z", y), ("y", p), ("x", r)) if a != 0] or None


def _rpy_matrix(rpy) -> np.ndarray:
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return Rz @ Ry @ Rx


def _axis(axis):
    """A unit axis: exact integers when it is +-x, +-y or +-z."""
    rounded = [round(a) for a in axis]
    if sum(abs(r) for r in rounded) == 1 and all(abs(a - r) < 1e-12 for a, r in zip(axis, rounded)):
        return tuple(rounded)
    return tuple(float(a) for a in axis)


# --------------------------------------------------------------------------- writing the model file

def model_file_text(model, *, source: str | None = None) -> str:
    """The lagrangian model file (TOML) of `model`, as the URDF import builds it: ``coordinates``,
    ``[parameters]``, ``[[frames]]``, ``[[joints]]`` (with their limits, damping, friction and end stops),
    ``[[bodies]]`` in space and ``[gravity]``. Read back (:func:`lagrangian.load`), it gives a model with the
    same coordinates and the same equations (a body's centre is written in its frame's axes, computed from
    its world position; checked at a second posture).

    Raises
    ------
    ModelError
        For what this writer does not write (other elements, explicit energies, constraints other than a
        quaternion joint's, wheels, parameters without a value), naming each.
    """
    from .._codetext import toml_string
    from .._version import __version__
    from ..errors import ModelError
    from ..model._elements import Gravity, RigidBody3D
    from ..model._frames import WORLD

    joints = model.joints
    owned = set()
    for j in joints.values():
        n = len(j.coordinates)
        suffixes = [""] + [f"_{i + 1}" for i in range(n)]
        owned |= {f"{j.name}_{what}{s}" for what in ("damping", "friction", "upper_stop", "lower_stop") for s in
                  suffixes} | {f"{j.name}_unit"}
    problems = []
    bodies, gravity = [], None
    for e in model.elements:
        if e.name in owned:
            continue
        if isinstance(e, RigidBody3D) and e.shape is None:
            bodies.append(e)
        elif isinstance(e, Gravity):
            gravity = e
        else:
            problems.append(Problem(f"the {e.kind} '{e.name}' is not written by this writer (it writes what the "
                                    "URDF import builds: joints, frames, rigid bodies in space and gravity): write "
                                    "it in the model file by hand", key=f"{e.kind} '{e.name}'"))
    norms = {f"{j.name}_norm" for j in joints.values() if j.parametrization == "quaternion"}
    problems += [Problem(f"the constraint '{c.name}' is not written by this writer: add it as a [[constraints]] "
                         "table by hand", key=f"constraint '{c.name}'")
                 for c in model.constraints if c.name not in norms]
    if model.wheels:
        problems.append(Problem("wheels are not written by this writer: add them as [[wheels]] tables by hand",
                                key="wheels"))
    if any(x != 0 for x in (model.T, model.V, model.D)) or any(v != 0 for v in model.Q.values()):
        problems.append(Problem("explicit energies and forces ([energy], [forces]) are not written by this writer: "
                                "add them by hand", key="energy"))
    values = model.parameters
    problems += [Problem(f"the parameter '{p}' has no value: give it one before writing the model file",
                         key=f"parameters.{p}") for p, v in values.items() if v is None]
    sim, initial = _simulation_values(model, problems)
    if problems:
        raise ModelError(problems)

    def string(text: str) -> str:
        return toml_string(text)  # a TOML basic string (not JSON's: its surrogate pairs are not TOML's)

    def value(e) -> str:
        e = sympy.sympify(e)
        if e.is_Integer:
            return str(int(e))
        if isinstance(e, sympy.Float):
            return repr(float(e))
        return string(_ExactPrinter().doprint(e))

    def vector(v) -> str:
        return "[" + ", ".join(value(x) for x in v) + "]"

    def axis_text(a) -> str:
        letter = {(1, 0, 0): "x", (0, 1, 0): "y", (0, 0, 1): "z"}.get(tuple(sympy.sympify(c) for c in a))
        return string(letter) if letter else vector(a)

    def rotation(factors) -> list[str]:
        if len(factors) == 1 and factors[0].matrix is not None:
            return ["matrix = [" + ", ".join(vector(r) for r in factors[0].matrix) + "]"]
        if not factors:
            return []
        return ["rotation = [" + ", ".join(f"[{axis_text(f.axis)}, {value(f.angle)}]" for f in factors) + "]"]

    lines = [f"# Generated by lagrangian {__version__}" + (f" from {_comment(source)}" if source else ""),
             "# lagrangian load reads it back into the same model (the same coordinates and equations)."]
    for note in getattr(model, "import_notes", ()):
        lines.append(f"# {_comment(note)}")
    if getattr(model, "visuals", ()):
        lines.append("# The URDF's <visual> shapes are not written (a model file draws bodies by their frames).")
    lines += [f"name = {string(model.name)}"]
    if model.description:
        lines.append(f"description = {string(model.description)}")
    lines.append("coordinates = [" + ", ".join(string(q.name) for q in model.q) + "]")
    if model.inputs:
        lines.append("inputs = [" + ", ".join(string(u.name) for u in model.inputs) + "]")
    derived = model.derived_parameters
    if values or derived:
        lines += ["", "[parameters]"]
        lines += [f"{p.name} = {value(v)}" for p, v in values.items() if p.name not in derived]
        lines += [f"{k} = {string(_ExactPrinter().doprint(e))}" for k, e in derived.items()]
    children = {j.child for j in joints.values()}
    for frame in model.frames.values():
        if frame.name in children:
            continue
        lines += ["", "[[frames]]", f"name = {string(frame.name)}"]
        if frame.parent != WORLD:
            lines.append(f"parent = {string(frame.parent)}")
        if any(sympy.sympify(c) != 0 for c in frame.origin):
            lines.append(f"origin = {vector(frame.origin)}")
        lines += rotation(frame.factors)
    for j in joints.values():
        lines += ["", "[[joints]]", f"name = {string(j.name)}", f"type = {string(j.type)}"]
        if j.parent != WORLD:
            lines.append(f"parent = {string(j.parent)}")
        if j.child != j.name:
            lines.append(f"child = {string(j.child)}")
        if any(sympy.sympify(c) != 0 for c in j.origin):
            lines.append(f"origin = {vector(j.origin)}")
        lines += rotation(j.factors)
        if j.type in ("revolute", "prismatic", "cylindrical"):
            lines.append(f"axis = {axis_text(j.axes[0])}")
        elif j.type == "universal":
            lines.append(f"axis = [{axis_text(j.axes[0])}, {axis_text(j.axes[1])}]")
        elif j.type == "planar":
            lines.append(f"axis = {axis_text(j.axes[0])}")
        elif j.parametrization == "quaternion":
            lines.append('parametrization = "quaternion"')
            if getattr(j, "omega", None) is not None:
                lines.append("omega = [" + ", ".join(repr(float(w)) for w in j.omega) + "]")
        elif j.sequence is not None:
            lines.append(f"sequence = {string(j.sequence)}")
        if j.coordinates:
            lines.append("coordinates = [" + ", ".join(string(c.name) for c in j.coordinates) + "]")
        if any(p is not None for p in j.limits):
            pairs = [None if p is None else f"[{value(p[0])}, {value(p[1])}]" for p in j.limits]
            lines.append("limits = " + (pairs[0] if len(pairs) == 1 else "[" + ", ".join(p or "[]" for p in pairs)
                                        + "]"))
        if j.limit_stiffness is not None:
            lines.append(f"limit_stiffness = {value(j.limit_stiffness)}")
        for what in ("damping", "friction"):
            per = getattr(j, what)
            if per is None:
                continue
            one = j.type == "spherical" or len(set(per)) == 1
            lines.append(f"{what} = " + (value(per[0]) if one else vector(per)))
    for b in bodies:
        center = _center_in_frame(model, b)
        lines += ["", "[[bodies]]", f"name = {string(b.name)}", f"mass = {value(b.mass)}",
                  f"frame = {string(b.frame)}",
                  "inertia = [" + ", ".join(vector(row) for row in b.inertia) + "]"]
        if center is not None:
            if any(c != 0 for c in center):
                lines.append(f"center = {vector(center)}")
        else:
            lines += [f"center = {vector(b.position)}", 'center_frame = "world"']
    if gravity is not None:
        lines += ["", "[gravity]", f"g = {value(gravity.g)}"]
        if gravity.direction is not None:
            lines.append(f"direction = {vector(gravity.direction)}")
    for j in joints.values():  # a quaternion joint's default q0 = 1 comes back with the joint
        if j.parametrization == "quaternion" and initial == {j.coordinates[-4].name: 1.0}:
            initial = {}
    if sim or initial:
        lines += ["", "[simulation]"] + [f"{k} = {repr(float(v))}" for k, v in sim.items()]
        if initial:
            lines.append("initial = { " + ", ".join(f"{k} = {repr(float(v))}" for k, v in initial.items()) + " }")
    return "\n".join(lines) + "\n"


def _simulation_values(model, problems) -> tuple[dict, dict]:
    """The [simulation] values the writer writes (t_end, dt, rtol, atol and the initial values, as floats), each
    checked: a finite number, and an initial value's name a coordinate or velocity of the model (nothing else
    reaches the file: a key is written bare, so it must be one of the model's names)."""
    import numbers

    from .._util import did_you_mean

    def number(v, key):
        if isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(float(v)):
            return float(v)
        problems.append(Problem(f"expected a finite number, got {v!r}: give a number before writing the model "
                                "file", key=key))
        return None

    simulation = model.simulation or {}
    sim = {k: number(simulation[k], f"simulation.{k}") for k in ("t_end", "dt", "rtol", "atol")
           if simulation.get(k) is not None}
    states = [q.name for q in model.q] + [q.name for q in model.q_dot]
    initial = {}
    given = simulation.get("initial") or {}
    if not isinstance(given, dict):
        problems.append(Problem(f"expected a mapping of coordinate and velocity names to numbers, got {given!r}",
                                key="simulation.initial"))
        given = {}
    for k, v in given.items():
        name = getattr(k, "name", k)
        if name not in states:
            problems.append(Problem(f"{str(name)[:80]!r} is not a coordinate or velocity of the model"
                                    f"{did_you_mean(str(name), states)}: remove it from model.simulation['initial'] "
                                    "before writing the model file", key="simulation.initial"))
        else:
            initial[name] = number(v, f"simulation.initial.{name}")
    return sim, initial


def _comment(text: str) -> str:
    """Text for one comment line: control characters (newlines) as spaces."""
    return "".join(c if c.isprintable() else " " for c in str(text))[:500]


class _ExactPrinter(sympy.printing.str.StrPrinter):
    """SymPy's text, with each Float as Python's shortest repr (which reads back to the same double)."""

    def _print_Float(self, expr):
        return repr(float(expr))


def _center_in_frame(model, body):
    """The centre of mass of `body` in its frame's axes, from its world position: R^T (p - o) at q = 0, t = 0,
    kept where it is constant (the same at a second posture, to 1e-12 relative); None otherwise."""
    from ..model._frames import frame_pose
    from ..model._symbols import t

    origin, R = frame_pose(model.frames, body.frame)
    local = R.T * (sympy.Matrix(body.position) - sympy.Matrix(origin))
    zero = {q: 0 for q in model.q}
    zero[t] = 0
    for j in model.joints.values():  # a quaternion's reference posture is q0 = 1
        if j.parametrization == "quaternion":
            zero[j.coordinates[-4]] = 1
    center = [sympy.nsimplify(sympy.simplify(c.xreplace(zero)), rational=False) if not c.xreplace(zero).is_number
              else c.xreplace(zero) for c in local]
    values = {p: sympy.Float(v) for p, v in model.parameters.items() if v is not None}
    rng = np.random.default_rng(7)
    at = {q: sympy.Float(v) for q, v in zip(model.q, rng.uniform(-2, 2, len(model.q)))}
    at[t] = sympy.Float(0.3)
    for j in model.joints.values():  # a quaternion on its unit sphere
        if j.parametrization == "quaternion":
            e = j.coordinates[-4:]
            norm = sympy.sqrt(sum(at[c] ** 2 for c in e))
            at.update({c: at[c] / norm for c in e})
    for c, c0 in zip(local, center):
        a = complex(sympy.sympify(c).xreplace(at).xreplace(values).evalf())
        b = complex(sympy.sympify(c0).xreplace(values).evalf())
        if abs(a - b) > 1e-12 * (1 + abs(b)):
            return None
    return [sympy.Float(float(c)) if c.is_number and not c.is_Integer and not c.is_Rational else c for c in center]
