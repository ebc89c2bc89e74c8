"""Writing a model as a model file: :func:`write_model` (``lg.write_model``), what ``lagrangian load --write``
does for a URDF.

The text is :func:`lagrangian.io._urdf.model_file_text`'s: ``coordinates``, ``[parameters]``, ``[[frames]]``,
``[[joints]]``, ``[[bodies]]`` in space, ``[gravity]`` and ``[simulation]``; read back by :func:`lagrangian.load`
it gives the same coordinates and equations. Every name and piece of free text in it is a TOML string
(:func:`lagrangian._codetext.toml_string`) or a checked identifier: nothing in a model can end a string early or
add a table. The file is written atomically (:func:`lagrangian.io._files.write_atomically`: a complete new file
or none), and an existing file is replaced only with ``force=True`` (a symbolic link then itself, never its
target).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from ..errors import OutputFileError

__all__ = ["write_model", "check_model_path"]


def check_model_path(path, force: bool, *, label: str | None = None, who: str = "write_model",
                     force_text: str = "force=True") -> str:
    """The path as a str, or OutputFileError before anything is computed: not a str or path, a folder, a
    missing or read-only folder, something that is not a regular file or a link, a name without ``.toml``,
    or an existing file without `force`. `label` starts each message (default ``write_model(<path>)``), `who`
    names the caller and `force_text` the way to pass force (``lagrangian load --write`` passes its own)."""
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)):
        raise OutputFileError(f"{who}: the path is a str or pathlib.Path such as 'model.toml', got {path!r}",
                              path=repr(path))
    path = os.fspath(path)
    label = label or f"{who}({path!r})"
    if "\0" in path:
        raise OutputFileError(f"{label}: a path cannot hold a NUL character; give a file name such as model.toml",
                              path=path)
    if os.path.isdir(path):
        raise OutputFileError(f"{label}: it is a directory; give a file name such as "
                              f"{os.path.join(path, 'model.toml')}", path=path)
    if not path.endswith(".toml"):
        example = f"--write {Path(path).stem or 'model'}.toml" if who == "lagrangian load" else \
            f"{who}(model, {(Path(path).stem or 'model') + '.toml'!r})"
        raise OutputFileError(f"{label}: a model file's name ends in .toml (lagrangian load and derive read it by "
                              f"that); for example {example}", path=path)
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        st = None
    if st is not None:
        if not (stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode)):
            raise OutputFileError(f"{label}: it is not a regular file; choose another path", path=path)
        if not force:
            what = "a symbolic link" if stat.S_ISLNK(st.st_mode) else "a file"
            raise OutputFileError(f"{label}: {what} is there already and {who} never replaces one without "
                                  f"{force_text}: choose another name, or pass {force_text} to replace it"
                                  + (" (the link itself, not its target)" if stat.S_ISLNK(st.st_mode) else ""),
                                  path=path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise OutputFileError(f"{label}: the folder {folder} does not exist; create it or choose another path",
                              path=path)
    if not os.access(folder, os.W_OK):
        raise OutputFileError(f"{label}: the folder {folder} is not writable; choose another path", path=path)
    return path


def write_model(model, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write `model` as a lagrangian model file (TOML) that :func:`lagrangian.load` reads back into the same
    coordinates and equations.

    Parameters
    ----------
    model : Model
        A model built with joints, frames, rigid bodies in space and gravity (what the URDF import builds,
        :func:`lagrangian.load_urdf`, or the same written in Python): its parameters, their values, the
        joints' limits, damping, friction and end stops, and the ``[simulation]`` defaults are written.
    path : str or os.PathLike
        The file to write; its name ends in ``.toml``.
    force : bool, optional
        Replace an existing file (a symbolic link: the link itself, never its target). Default False: an
        existing file is never replaced.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    OutputFileError
        Before anything is computed: a folder, a missing or read-only folder, a name without ``.toml``, an
        existing file without ``force=True``.
    ModelError
        The model holds what this writer does not write (other elements such as particles or springs,
        explicit energies, constraints other than a quaternion joint's, wheels, a parameter without a value),
        each named; nothing is written.

    Examples
    --------
    >>> arm = lg.load_urdf("ur5_robot.urdf")  # doctest: +SKIP
    >>> lg.write_model(arm, "ur5.toml")  # doctest: +SKIP
    PosixPath('ur5.toml')
    >>> eqs = lg.derive(lg.load("ur5.toml"))  # the same equations  # doctest: +SKIP
    """
    from ..model._model import Model
    from ._files import write_atomically
    from ._urdf import model_file_text

    if not isinstance(force, bool):
        raise TypeError(f"write_model: force is True or False, got {force!r}")
    path = check_model_path(path, force)
    if not isinstance(model, Model):
        raise TypeError(f"write_model: expected a lagrangian Model (lg.load(...), lg.Model(...)), got "
                        f"{type(model).__name__}")
    text = model_file_text(model)
    check_model_path(path, force)  # (again: a file may have appeared meanwhile)
    write_atomically(path, text)
    return Path(path)
