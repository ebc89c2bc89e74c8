"""The command load: read a model file, a built-in example or a URDF, say what was built (coordinates,
joints, bodies, parameters, inputs, constraints, what the URDF import merged or left out), and optionally
write the equivalent model file (``--write model.toml``)."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from ..errors import ModelError

__all__ = ["register", "describe", "check_write", "write_model_file"]

_HELP = "a model file (.toml), a built-in example name (see `lagrangian examples`) or a URDF robot description (.urdf)"


def register(sub, fmt) -> None:
    p = sub.add_parser("load", help="read a model file or a URDF and say what it builds; --write saves a model file",
                       formatter_class=fmt,
                       description="Read a model (a model file, a built-in example or a URDF) and print what was "
                       "built: the coordinates in order, the joints with their types, axes and limits, the bodies "
                       "with their masses, the parameters, inputs and constraints, and what a URDF's import merged "
                       "or left out. --write saves the equivalent lagrangian model file (a URDF's model written as "
                       "[[joints]] and [[bodies]] tables; a model file or example as its own text), which "
                       "`lagrangian derive` reads into the same equations.",
                       epilog="Examples:\n  lagrangian load robot.urdf\n  lagrangian load robot.urdf --json\n"
                              "  lagrangian load robot.urdf --write robot.toml\n"
                              "  lagrangian load robot-arm-3-joints --write arm.toml --force")
    p.add_argument("model", help=_HELP)
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: model, source, kind, description, coordinates, velocities, joints, "
                        "frames, bodies, elements, parameters, derived_parameters, inputs, constraints, notes, "
                        "written")
    p.add_argument("--write", metavar="FILE.toml",
                   help="write the equivalent model file (atomically; an existing file only with --force)")
    p.add_argument("--force", action="store_true", help="let --write replace an existing file")
    p.add_argument("--floating-base", nargs="?", const="angles", choices=("angles", "quaternion"),
                   help="a URDF: give the root link 6 coordinates (a free body) instead of fixing it to the world, "
                        "turned by three angles (default) or by a unit quaternion (--floating-base quaternion: 7 "
                        "coordinates and a norm constraint, no singular posture)")
    p.set_defaults(handler=_cmd_load)


def _kind(source: str) -> str:
    if source.lower().endswith(".urdf"):
        return "urdf"
    if not source.endswith(".toml") and os.sep not in source and not Path(source).exists():
        return "example"
    return "model file"


def _cmd_load(args: argparse.Namespace) -> int:
    from ..io import load
    from ..io._urdf import load_urdf

    source = args.model
    kind = _kind(source)
    if args.floating_base and kind != "urdf":
        raise ModelError(f"--floating-base: '{source}' is not a URDF; the option gives a URDF's root link 6 "
                         "coordinates: remove it, or give a .urdf file")
    if args.write is not None:
        check_write(args.write, args.force)
    model = load_urdf(source, floating_base=args.floating_base) if args.floating_base else load(source)
    written = None
    if args.write is not None:
        text = _model_file_text(model, source, kind)
        write_model_file(args.write, text, args.force)
        written = args.write
    info = describe(model, source, kind)
    info["written"] = written
    if args.json:
        print(json.dumps(info, indent=2))
    else:
        print(_text(info))
    return 0


def _model_file_text(model, source: str, kind: str) -> str:
    """A URDF's model as a generated model file; a model file's or an example's own text."""
    if kind == "urdf":
        from ..io._urdf import model_file_text

        return model_file_text(model, source=Path(source).name)
    if kind == "example":
        from ..examples import example_source

        return example_source(source)
    return Path(source).read_text(encoding="utf-8")


def check_write(path: str, force: bool) -> None:
    """Refuse (OutputFileError) a --write path before anything is read or computed: a folder, a missing or
    read-only folder, something that is not a regular file, a name without .toml, or an existing file
    without --force (a symbolic link is then replaced itself, never written through); the checks of
    lg.write_model (io._write.check_model_path), worded for the command line."""
    from ..io._write import check_model_path

    check_model_path(path, force, label=f"--write {path}", who="lagrangian load", force_text="--force")


def write_model_file(path: str, text: str, force: bool = False) -> None:
    """Write `text` as the model file `path`, atomically (io._files), after :func:`check_write`."""
    from ..io._files import write_atomically

    check_write(path, force)
    write_atomically(path, text)


def _number(v):
    try:
        f = float(v)
    except (TypeError, ValueError):
        return str(v)
    return int(f) if f == int(f) and abs(f) < 1e15 else f


def describe(model, source: str, kind: str) -> dict:
    """What `model` holds, as plain data (the --json output; the text output prints it)."""
    from ..model._elements import Gravity, Particle, RigidBody, RigidBody3D

    joints = []
    for j in model.joints.values():
        entry = {"name": j.name, "type": j.type, "parent": j.parent, "child": j.child,
                 "coordinates": [c.name for c in j.coordinates]}
        if j.type in ("revolute", "prismatic", "cylindrical", "universal", "planar"):
            entry["axis"] = [[_number(c) for c in a] for a in j.axes] if j.type == "universal" else \
                [_number(c) for c in j.axes[0]]
        if j.type in ("spherical", "floating"):
            entry["parametrization"] = j.parametrization
            if j.sequence is not None:
                entry["sequence"] = j.sequence
            if getattr(j, "omega", None) is not None:
                entry["omega"] = list(j.omega)
        if any(p is not None for p in j.limits):
            entry["limits"] = [None if p is None else [_number(p[0]), _number(p[1])] for p in j.limits]
        for what in ("damping", "friction"):
            if getattr(j, what) is not None:
                entry[what] = [_number(c) for c in getattr(j, what)]
        joints.append(entry)
    children = {j.child for j in model.joints.values()}
    frames = [{"name": f.name, "parent": f.parent} for f in model.frames.values() if f.name not in children]
    bodies, elements = [], []
    for e in model.elements:
        if isinstance(e, RigidBody3D):
            bodies.append({"name": e.name, "mass": _number(e.mass), "frame": e.frame})
        elif isinstance(e, (RigidBody, Particle)):
            bodies.append({"name": e.name, "mass": _number(e.mass), "frame": None, "kind": e.kind})
        else:
            elements.append({"name": e.name, "kind": e.kind if not isinstance(e, Gravity) else "gravity"})
    return {
        "model": model.name, "source": source, "kind": kind, "description": model.description,
        "coordinates": [q.name for q in model.q], "velocities": [q.name for q in model.q_dot],
        "joints": joints, "frames": frames, "bodies": bodies, "elements": elements,
        "parameters": {p.name: (None if v is None else _number(v)) for p, v in model.parameters.items()
                       if p.name not in model.derived_parameters},
        "derived_parameters": {k: str(e) for k, e in model.derived_parameters.items()},
        "inputs": [u.name for u in model.inputs],
        "constraints": [{"name": c.name, "kind": c.kind, "expression": str(c.expression)} for c in model.constraints],
        "notes": list(getattr(model, "import_notes", ())),
    }


def _text(info: dict) -> str:
    kind = {"urdf": "the URDF", "example": "the built-in example", "model file": "the model file"}[info["kind"]]
    out = [f"{info['model']}: from {kind} {info['source']}"]
    if info["description"]:
        out.append(f"  {info['description']}")
    n = len(info["coordinates"])
    out.append(f"coordinates ({n}, in order): {', '.join(info['coordinates']) or 'none'}"
               + (f" (velocities {', '.join(info['velocities'])})" if n else ""))
    out.append(f"joints ({len(info['joints'])}):" if info["joints"] else "joints: none")
    for j in info["joints"]:
        parts = [f"  {j['name']}: {j['type']}, {j['parent']} -> {j['child']}"]
        if "axis" in j:
            parts.append(f"axis {j['axis']}")
        if "parametrization" in j:
            parts.append(j["parametrization"] + (f" {j['sequence']}" if "sequence" in j else ""))
        if "omega" in j:
            parts.append(f"initial omega {j['omega']} (rad/s, child axes)")
        if j["coordinates"]:
            parts.append(f"coordinates {', '.join(j['coordinates'])}")
        if "limits" in j:
            parts.append(f"limits {j['limits'][0] if len(j['limits']) == 1 else j['limits']}")
        for what in ("damping", "friction"):
            if what in j:
                parts.append(f"{what} {j[what][0] if len(set(map(str, j[what]))) == 1 else j[what]}")
        out.append(", ".join(parts))
    if info["frames"]:
        out.append("frames (besides the joints' child frames): "
                   + ", ".join(f"{f['name']} (in {f['parent']})" for f in info["frames"]))
    out.append(f"bodies ({len(info['bodies'])}):" if info["bodies"] else "bodies: none")
    for b in info["bodies"]:
        out.append(f"  {b['name']}: mass {b['mass']}" + (f", in frame {b['frame']}" if b["frame"] else
                                                         f" ({b.get('kind', 'body')})"))
    if info["elements"]:
        out.append("other elements: " + ", ".join(f"{e['name']} ({e['kind']})" for e in info["elements"]))
    params = [f"{k} = {v}" for k, v in info["parameters"].items()] + \
        [f"{k} = {v}" for k, v in info["derived_parameters"].items()]
    out.append(f"parameters: {', '.join(params) or 'none'}")
    out.append(f"inputs: {', '.join(info['inputs']) or 'none'}")
    out.append("constraints: " + (", ".join(f"{c['name']} ({c['kind']}): {c['expression']} = 0"
                                            for c in info["constraints"]) or "none"))
    if info["kind"] == "urdf":
        out.append("merged or left out:" + ("" if info["notes"] else " nothing"))
        out += [f"  {note}" for note in info["notes"]]
    if info["written"]:
        out.append(f"wrote the model file {info['written']} (lagrangian derive {info['written']} gives the same "
                   "equations)")
    return "\n".join(out)

