"""Input and output: model files (a safe expression parser and one-pass checks), loading by name."""

from __future__ import annotations

import os
import re
from pathlib import Path

from .._util import did_you_mean, shown_value
from ..errors import ModelFileError, Problem
from ..model._expr import parse_expression
from ._write import write_model

__all__ = ["load", "parse_expression", "load_model_file", "loads_model", "load_urdf", "write_model"]


def load_model_file(path):
    from ._modelfile import load_model_file as _load

    return _load(path)


def loads_model(text: str, *, source: str = "<string>"):
    from ._modelfile import loads_model as _loads

    return _loads(text, source=source)


def load_urdf(path: str | os.PathLike, *, floating_base: bool = False, gravity: float | None = 9.81):
    """A Model from a URDF robot description: each moving joint a joint of the model (its coordinate
    named after it, in the file's order), each link a rigid body in its frame, fixed joints merged.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.urdf`` file (at most 10 MiB; no DOCTYPE or ENTITY declarations; meshes never opened).
    floating_base : bool, optional
        Give the root link 6 coordinates (``floating_base_x`` .. ``floating_base_3``) instead of
        fixing it to the world.
    gravity : float or None, optional
        The value of the parameter ``g``, gravity along -z (default 9.81); None for none.

    Raises
    ------
    ModelFileError
        Every problem of the file, each with what to do (mimic joints, cycles, bad inertia, ...).

    Examples
    --------
    >>> arm = lg.load_urdf("ur5_robot.urdf")  # doctest: +SKIP
    >>> [c.name for c in arm.q]  # doctest: +SKIP
    ['shoulder_pan_joint', 'shoulder_lift_joint', 'elbow_joint', 'wrist_1_joint', 'wrist_2_joint', 'wrist_3_joint']
    """
    from ._urdf import load_urdf as _load

    return _load(path, floating_base=floating_base, gravity=gravity)


def _cut(text: str, limit: int = 80) -> str:
    """`text` cut to `limit` characters for a message (a name of 5000 characters is not repeated whole)."""
    return text if len(text) <= limit else text[:limit - 3] + "..."


def load(source: str | os.PathLike):
    """A Model from a built-in example name (``"cart-pendulum"``, ``"pendulum-chain-5"``), the
    path of a TOML model file, or the path of a URDF robot description (``.urdf``: see
    :func:`lagrangian.io._urdf.load_urdf`, which takes the options).

    Raises
    ------
    ModelFileError
        The file has problems (all of them are listed), or there is no such file or example.
    """
    from ..examples import example_names, example_source

    text = None
    if not isinstance(source, (str, os.PathLike)):
        raise ModelFileError([Problem(f"load() takes the path of a model file or the name of a built-in example "
                                      f"(text or a pathlib.Path), got {type(source).__name__} {shown_value(source)}; "
                                      "for example lagrangian.load('double-pendulum')")])
    if str(source).lower().endswith(".urdf"):  # a robot description: io._urdf
        from ._urdf import load_urdf

        return load_urdf(source)
    if str(source).lower().endswith(".xacro"):
        raise ModelFileError([Problem(
            f"'{source}' is a xacro file, a template that expands to a URDF: expand it first (with ROS: "
            "xacro robot.urdf.xacro > robot.urdf) and load the .urdf")], file=str(source))
    if isinstance(source, str) and not source.endswith(".toml") and os.sep not in source:
        text = example_source(source)
        if text is not None:
            return loads_model(text, source=f"<example {source}>")
    path = Path(source)
    try:
        exists = path.exists()
    except OSError:  # a name too long for a path (ENAMETOOLONG): no such file
        exists = False
    if exists or str(source).endswith(".toml") or os.sep in str(source):
        return load_model_file(path)
    family = re.match(r"(pendulum-chain|spring-mass-damper-chain)-(-?[0-9]+)\Z", str(source))
    if family:
        raise ModelFileError([Problem(
            f"'{source}': a {family.group(1)} has 1 to 200 elements; choose n in that range, "
            f"e.g. {family.group(1)}-5")])
    extra = did_you_mean(source, example_names(), 0.5, sentence=True)
    raise ModelFileError([Problem(
        f"'{_cut(str(source))}' is neither a model file nor a built-in example.{extra} "
        "Run `lagrangian examples` to list the examples, or give the path of a .toml model file.")])
