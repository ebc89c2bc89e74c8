"""A state-feedback design saved as a JSON file, and read back for one model only.

``lagrangian lqr ... --save design.json`` writes the :class:`~lagrangian.control.StateFeedback`
(its ``to_dict``: the gain K, the operating point x0 and the inputs u0, the state and input names,
the closed-loop eigenvalues, ...) with the model's name, the parameter values of the design, the
coordinates whose error is wrapped, and a fingerprint of the equations and of those values;
``lagrangian simulate MODEL --controller design.json`` reads it back with :func:`read_design`,
which refuses, with one clear message each, a file that is not such a design (not JSON, too large,
wrong shapes, numbers that are not finite or too large, names that are not the model's) and a
design made for another model or with other parameter values (the fingerprint differs).

The law is made again from K, x0 and u0 (``StateFeedback.law``), never read from the file's text.
"""

from __future__ import annotations

import hashlib
import json
import math
import numbers
import os
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np

from .._limits import MAX_MAGNITUDE
from .._util import read_only
from ..errors import ModelError
from ._feedback import StateFeedback

__all__ = ["DESIGN_FORMAT", "MAX_DESIGN_BYTES", "MAX_GAIN", "design_fingerprint", "design_json", "read_design"]

#: The value of a design file's "format" key.
DESIGN_FORMAT = "lagrangian-state-feedback"
#: The largest design file read (bytes): a design of 100 coordinates and 100 inputs is about 1 MB.
MAX_DESIGN_BYTES = 4_000_000
#: The largest magnitude of a gain, an operating point or an input value read from a design file.
MAX_GAIN = 1e12


def design_fingerprint(equations, params: Mapping[str, float]) -> str:
    """A hash of the equations (the model's name, the names, every expression of the matrix form
    and of the constraints) and of the parameter values `params` (name to number: the model's
    values with the overrides of the design)."""
    core = equations.core
    h = hashlib.sha256()
    names = (equations.model.name, equations.state_names, tuple(u.name for u in equations.inputs),
             tuple(p.name for p in equations.parameters))
    h.update(repr(names).encode())
    for e in (*core.M, *core.f, core.L, core.D, *core.Q, *core.g, *core.w, *core.c):
        h.update(str(e).encode())
        h.update(b"|")
    if core.G is not None:
        h.update(str(list(core.G)).encode())
    h.update(repr(sorted((k, float(v)) for k, v in params.items())).encode())
    return h.hexdigest()[:32]


def design_json(feedback: StateFeedback, equations, params: Mapping[str, float], wrap: Sequence[str] = ()) -> str:
    """The text of a design file: ``feedback.to_dict(wrap)`` with "format", "parameters" (the values
    of the design), "wrap" and "fingerprint" (:func:`design_fingerprint`)."""
    out = {"format": DESIGN_FORMAT, **feedback.to_dict(wrap), "wrap": list(wrap),
           "parameters": {k: float(v) for k, v in params.items()},
           "fingerprint": design_fingerprint(equations, params)}
    return json.dumps(out, indent=2) + "\n"


def _fail(path: str, what: str) -> ModelError:
    return ModelError(f"{path} is not a usable design: {what}")


def _read_text(path: str) -> str:
    try:
        size = os.path.getsize(path)
        if size > MAX_DESIGN_BYTES:
            raise _fail(path, f"the file has {size} bytes, more than the {MAX_DESIGN_BYTES} a design file may have; "
                              "give the file written by `lagrangian lqr ... --save` (or `place ... --save`)")
        with open(path, "rb") as fh:
            data = fh.read(MAX_DESIGN_BYTES + 1)
    except FileNotFoundError:
        raise ModelError(f"--controller {path}: no such file; write one with `lagrangian lqr MODEL --at ... "
                         f"--save {path}`") from None
    if len(data) > MAX_DESIGN_BYTES:  # a file that grew, or a stream
        raise _fail(path, f"more than the {MAX_DESIGN_BYTES} bytes a design file may have; give the file written by "
                          "`lagrangian lqr ... --save`")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise _fail(path, "it is not JSON text (not UTF-8); give the file written by `lagrangian lqr ... --save`") \
            from None


def _matrix(d: dict, key: str, shape: tuple[int, int], path: str, bound: float) -> np.ndarray:
    value = d.get(key)
    rows, cols = shape
    if (not isinstance(value, list) or len(value) != rows
            or any(not isinstance(r, list) or len(r) != cols for r in value)):
        got = (f"{len(value)} rows" if isinstance(value, list) else type(value).__name__) if value is not None \
            else "nothing"
        raise _fail(path, f"\"{key}\" must be a {rows} x {cols} matrix (a list of {rows} rows of {cols} numbers), "
                          f"got {got}")
    for r in value:
        for v in r:
            _number(v, f"an entry of \"{key}\"", path, bound)
    return np.array(value, dtype=float).reshape(shape)


def _number(v, what: str, path: str, bound: float = MAX_GAIN) -> float:
    if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(v):
        raise _fail(path, f"{what} must be a finite number, got {v!r}")
    if abs(v) > bound:
        raise _fail(path, f"{what} is {float(v):g}, too large: at most {bound:g} in magnitude")
    return float(v)


def _names(d: dict, key: str, allowed: Sequence[str], path: str, kind: str) -> tuple[str, ...]:
    value = d.get(key)
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise _fail(path, f"\"{key}\" must be a list of names, got {type(value).__name__}")
    unknown = [v for v in value if v not in allowed]
    if unknown:
        raise _fail(path, f"\"{key}\" names {', '.join(repr(u[:40]) for u in unknown[:5])}, not "
                          f"{kind} of the model; its {kind}s are {', '.join(allowed)}")
    if len(set(value)) != len(value):
        raise _fail(path, f"\"{key}\" names a {kind} twice")
    return tuple(value)


def _values(d: dict, key: str, names: tuple[str, ...], path: str) -> dict[str, float]:
    value = d.get(key)
    if not isinstance(value, dict) or sorted(value) != sorted(names):
        raise _fail(path, f"\"{key}\" must give a number for each of {', '.join(names)} (and no other)")
    return {k: _number(value[k], f"\"{key}\" of '{k}'", path) for k in names}


def read_design(path: str, equations, params: Mapping[str, float]) -> tuple[StateFeedback, tuple[str, ...]]:
    """Read a design file for `equations` simulated with the parameter values `params` (name to
    number, every parameter); returns the StateFeedback and the wrapped coordinates.

    Raises
    ------
    ModelError
        The file is missing, too large, not JSON, not a design, has wrong shapes, numbers that are
        not finite or larger than MAX_GAIN, names that are not the model's; or the design is for
        another model or for other parameter values (its fingerprint differs).
    """
    text = _read_text(path)
    try:
        d = json.loads(text)
    except (ValueError, RecursionError):
        raise _fail(path, "it is not JSON; give the file written by `lagrangian lqr ... --save`") from None
    if not isinstance(d, dict) or d.get("format") != DESIGN_FORMAT:
        raise _fail(path, f"it is JSON but not a state-feedback design (its \"format\" is not \"{DESIGN_FORMAT}\"); "
                          "give the file written by `lagrangian lqr ... --save`")
    model = equations.model.name
    if d.get("model") != model:
        shown = d.get("model") if isinstance(d.get("model"), str) else "?"
        raise _fail(path, f"it was designed for the model '{shown[:80]}', not '{model}'; design one for it with "
                          f"`lagrangian lqr {model} --at ... --save {path}`")
    saved = d.get("parameters")
    if isinstance(saved, dict):
        changed = [f"{k} = {saved.get(k)!r} in the design, {v!r} now" for k, v in params.items()
                   if saved.get(k) != v]
        if changed:
            raise _fail(path, f"it was designed with other parameter values ({'; '.join(changed[:5])}); design "
                              "again with these values (lagrangian lqr ... --param ... --save), or simulate with the "
                              "design's (--param)")
    if d.get("fingerprint") != design_fingerprint(equations, params):
        raise _fail(path, f"its fingerprint differs from the equations of '{model}' with these parameter values: the "
                          f"model changed since the design was saved; design again with `lagrangian lqr {model} "
                          f"--at ... --save {path}`")
    method = d.get("method")
    if method not in ("lqr", "place"):
        raise _fail(path, f"\"method\" must be \"lqr\" or \"place\", got {method!r}")
    states = _names(d, "state_names", equations.state_names, path, "state")
    inputs = _names(d, "input_names", [u.name for u in equations.inputs], path, "input")
    if not states or len(states) % 2 or not inputs:
        raise _fail(path, "it needs an even number of states (coordinates, then velocities) and at least one input")
    nx, m = len(states), len(inputs)
    K = _matrix(d, "K", (m, nx), path, MAX_GAIN)
    x0 = _values(d, "operating_point", states, path)
    u0 = _values(d, "inputs", inputs, path)
    sample_time = d.get("sample_time")
    if sample_time is not None:
        sample_time = _number(sample_time, "\"sample_time\"", path)
        if not sample_time > 0:
            raise _fail(path, f"\"sample_time\" must be a positive number of seconds or null, got {sample_time!r}")
    wrap = _names(d, "wrap", states[:nx // 2], path, "coordinate") if d.get("wrap") is not None else ()
    eig = []
    for key in ("closed_loop_eigenvalues", "open_loop_eigenvalues"):
        z = _matrix(d, key, (nx, 2), path, MAX_MAGNITUDE)
        eig.append(read_only(z[:, 0] + 1j * z[:, 1], complex))
    extra = {}
    if method == "lqr":
        extra = {key: read_only(_matrix(d, key, shape, path, MAX_MAGNITUDE), float)
                 for key, shape in (("Q", (nx, nx)), ("R", (m, m)), ("P", (nx, nx)))}
    feedback = StateFeedback(K=read_only(K, float), state_names=states, input_names=inputs,
                             operating_point=MappingProxyType(x0), input_values=MappingProxyType(u0),
                             eigenvalues=eig[0], open_loop=eig[1], method=method, sample_time=sample_time,
                             model_name=model, **extra)
    return feedback, wrap
