"""SymEngine's Lambdify (LLVM, with common subexpressions), the compiled code kept on disk.

``se.Lambdify(args, exprs, cse=True, real=True)`` compiles with LLVM (SymEngine's default backend
where it has one) at optimisation level 3: 0.16 s of CPU for the bicycle's M, f, G and c, 0.4 s in
all for its report, paid again by every process. :func:`lambdify` is that call, and keeps the
machine code it made (SymEngine's own ``dumps``, what pickling an LLVMDouble stores) in the compile
cache's folder ($LAGRANGIAN_CACHE_DIR or ~/.cache/lagrangian, ``lambdify/``), so that the next
process loads the same code instead of compiling it again: the same function, the same numbers bit
for bit (loaded, not compiled anew). Small functions (compiled in about 10 ms or less) are not kept.

The key of an entry is a SHA-256 of what defines the function exactly: the argument names and the
expressions after SymEngine's common-subexpression elimination as text (linear in the size of the
shared expression, where the expressions printed whole can be exponential; each float written by its
exact value, as SymEngine prints 15 digits), with SymEngine's version, the machine and its
processor's features (the code is native). Where that text would not define the function exactly,
nothing is kept and the call compiles as before: a name that is not an identifier, or one that the
text's own names (x0, x1, ... of the elimination, _float_... of the floats) could be mistaken for.
Without LLVM (the lambda backend), or where the folder cannot be written, the call is SymEngine's as
it is.

An entry is read only when it is a regular file of this user's, not writable by others, whose header
(the function's shape and the SHA-256 of the code) is what this call expects: machine code from the
cache is run, as numba's cached kernels are, so the folder must be the user's own.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import platform
import re
import stat
import sys
from pathlib import Path

import symengine as se

__all__ = ["lambdify"]

#: The format of an entry (a change makes a new key).
_FORMAT = "lagrangian-lambdify-2"
#: The names SymEngine's cse gives the subexpressions.
_CSE_NAME = re.compile(r"x\d+\Z")
#: The prefix of the names that stand for the floats in the text of the key.
_FLOAT = "_float_"
#: The prefix of the names that stand for the arguments (by their place) in the text of the key.
_ARG = "_arg_"
#: An entry larger than this is not read (the bicycle's largest: about 50 KB).
_MAX_BYTES = 64 << 20
#: The function whose arguments hold the parts of a definition for one xreplace.
_ALL = se.Function("_all")
#: A function whose text (see _definition) is shorter than this is not kept: it compiles in about 10 ms
#: or less (about 6 us a character, the bicycle's), loading it would save little, and the folder would
#: fill with the small functions of every model met.
_WORTH_KEEPING = 2000


def lambdify(args, exprs):
    """``symengine.Lambdify(args, exprs, cse=True, real=True)``, its LLVM code loaded from the cache
    where an earlier process compiled the same function (see the module), else compiled and kept."""
    args, exprs = list(args), list(exprs)
    text = _definition(args, exprs)
    path = None if text is None else _entry(text)
    if path is not None:
        hit = _load(path, len(args), len(exprs))
        if hit is not None:
            return hit
    f = se.Lambdify(args, exprs, cse=True, real=True)
    if path is not None and type(f).__name__ == "LLVMDouble" and len(text) >= _WORTH_KEEPING:
        _store(path, f)
    return f


def _definition(args, exprs) -> str | None:
    """The text that defines the function (argument names; the common subexpressions and the reduced
    expressions, one a line; each float by its exact hexadecimal value), or None where it would not define
    it exactly (see the module)."""
    try:
        reps, reduced = se.cse(exprs)
    except (RuntimeError, TypeError, ValueError):
        return None
    names = [str(a) for a in args]
    if len(set(names)) != len(names) or not all(isinstance(a, se.Symbol) for a in args):
        return None
    parts = [e for _, e in reps] + list(reduced)
    free = set()
    floats = set()
    for e in parts:
        free |= {str(s) for s in e.free_symbols}
        floats |= e.atoms(se.RealDouble)
    # every name is an argument's, an identifier that the elimination's names and the floats' cannot be
    # taken for
    if not (free - {str(s) for s, _ in reps} <= set(names)
            and all(n.isidentifier() and not _CSE_NAME.match(n) and not n.startswith((_FLOAT, _ARG)) for n in names)):
        return None
    if any(float(v) == 0.0 for v in floats):  # 0.0 and -0.0 are one key of the mapping below
        return None
    exact = {v: se.Symbol(_FLOAT + float(v).hex().replace("-", "m").replace("+", "p").replace(".", "_"))
             for v in floats}
    # each argument by its place: a name printed alike with a constant or function (an argument `pi`, `E`
    # or `I`) cannot make two definitions one text
    exact.update({a: se.Symbol(f"{_ARG}{k}") for k, a in enumerate(args)})
    if exact and parts:
        # one xreplace of all the parts as the arguments of one function (each call converts the mapping to
        # SymEngine's: the bicycle's 900 parts took 0.05 s that way); the same expressions
        replaced = _ALL(*parts).xreplace(exact).args
        reps = [(s, e) for (s, _), e in zip(reps, replaced)]
        reduced = list(replaced[len(reps):])
    lines = [json.dumps(names)]
    lines += [f"{s}={e}" for s, e in reps]
    lines += [str(e) for e in reduced]
    return "\n".join(lines)


@functools.lru_cache(maxsize=1)
def _machine() -> str:
    """The machine the code runs on: its architecture, and on Linux its processor's features."""
    flags = ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.startswith(("flags", "Features", "model name")):
                    flags += line
                if line.strip() == "":
                    break
    except OSError:
        pass
    return "|".join((platform.machine(), platform.system(), sys.byteorder, flags))


def _entry(text: str) -> Path | None:
    h = hashlib.sha256()
    h.update("|".join((_FORMAT, se.__version__, _machine())).encode())
    h.update(b"\0")
    h.update(text.encode("utf-8"))
    folder = Path(os.environ.get("LAGRANGIAN_CACHE_DIR") or Path.home() / ".cache" / "lagrangian")
    return folder / "lambdify" / f"{h.hexdigest()[:40]}.bin"


def _header(args_size: int, out_size: int) -> list:
    """The shape part of what an LLVMDouble of `args_size` arguments and `out_size` outputs pickles."""
    return [args_size, out_size, [[out_size]], True, 1, "C", [0, out_size]]


def _load(path: Path, args_size: int, out_size: int):
    try:
        st = os.lstat(path)
        if not stat.S_ISREG(st.st_mode) or st.st_size > _MAX_BYTES or st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            return None
        if hasattr(os, "getuid") and st.st_uid != os.getuid():
            return None
        with open(path, "rb") as fh:
            data = fh.read(_MAX_BYTES + 1)
    except OSError:
        return None
    line, _, code = data.partition(b"\n")
    try:
        header = json.loads(line)
    except (ValueError, UnicodeDecodeError, RecursionError):
        return None
    if not (isinstance(header, dict) and header.get("shape") == _header(args_size, out_size)
            and header.get("sha256") == hashlib.sha256(code).hexdigest() and code):
        return None
    from symengine.lib.symengine_wrapper import llvm_loading_func

    import numpy as np

    shape = _header(args_size, out_size)
    try:
        return llvm_loading_func(shape[0], shape[1], [tuple(s) for s in shape[2]], shape[3], shape[4], shape[5],
                                 shape[6], np.float64, code)
    except (RuntimeError, TypeError, ValueError):
        return None


def _store(path: Path, f) -> None:
    """Keep f's code at `path`, atomically; nothing (silently) where that fails: it only saves time."""
    from ..io._files import write_atomically

    try:
        state = f.__reduce__()[1]
        shape = [state[0], state[1], [list(s) for s in state[2]], state[3], state[4], state[5], list(state[6])]
        code = state[8]
        if shape != _header(state[0], state[1]) or not isinstance(code, bytes):
            return
        head = json.dumps({"shape": shape, "sha256": hashlib.sha256(code).hexdigest()}).encode()
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomically(path, head + b"\n" + code)
    except (OSError, AttributeError, IndexError, TypeError, ValueError):
        pass
