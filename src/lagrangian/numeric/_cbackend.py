"""The C backend: the model's functions generated in C (see _codegen.c_source; a constrained
model's saddle-point right-hand side and projection from _codegen_constrained), compiled by the
system's C compiler into a shared library in the cache directory, and loaded with cffi. The
compiled integrators (the same numba kernels as the numba backend) call them through their
addresses, so no Python runs per step either way.

Needs cffi (``pip install lagrangian[c]``) and a C compiler (``$CC``, ``cc`` or ``gcc``).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
import threading

import numpy as np

from ..equations import Equations
from ..errors import ModelError
from . import _codegen
from ._codegen import C_DECLARATIONS, c_source, cache_dir, fingerprint, source_key, store

__all__ = ["compile_c", "c_compiler"]


def c_compiler() -> str | None:
    """The C compiler to use ($CC, cc or gcc on PATH), or None."""
    for name in (os.environ.get("CC"), "cc", "gcc"):
        if name and shutil.which(name.split()[0]):
            return name
    return None


#: The compiler's flags (part of the cache key).
_FLAGS = ("-O2", "-shared", "-fPIC")
#: A source longer than this (characters) is compiled with _LARGE_FLAGS: -O2's register allocation grows
#: faster than linearly with a function's length. The 5-rod spatial chain's 720 KB source: -O2 about
#: 600 s of gcc (loaded machine), -O1 41 s, -O0 1.5 s; one right-hand side 3.4, 3.5 and 8.6 us.
LARGE_SOURCE = 256 * 1024
_LARGE_FLAGS = ("-O1", "-shared", "-fPIC")


def compiler_flags(source: str) -> tuple[str, ...]:
    """The flags `source` is compiled with: -O2, or -O1 for a source past LARGE_SOURCE characters (as fast to
    run, and an order of magnitude faster to compile there)."""
    return _FLAGS if len(source) <= LARGE_SOURCE else _LARGE_FLAGS


def compile_c(equations: Equations):
    """The CompiledModel of `equations` with its functions in C (cached per content hash).

    A large model's source (c_source's split form) holds lg_rhs, lg_mass_forcing and lg_energy; its
    lg_lagrange_parts (the variational integrator's: the 20-rod spatial chain's 26 MB of C) is generated and
    compiled as a library of its own when first used. A second process finds the library by the fingerprint of
    the equations (as the numba backend its module: :func:`_codegen.model_module`), without generating the source."""
    from ._fast import _CACHE, _LOCK, CompiledModel

    with _LOCK:
        per = _CACHE.setdefault(equations, {})
        if "c" in per:
            return per["c"]
    try:
        import cffi
    except ImportError:
        raise ModelError("backend 'c' needs cffi: pip install 'lagrangian[c]' (or use backend='numba')") from None
    cc = c_compiler()
    if cc is None:
        raise ModelError("backend 'c' needs a C compiler: install gcc (or set $CC), or use backend='numba'")

    def main_source() -> str:
        source = c_source(equations, functions=_MAIN)
        if equations.is_constrained:  # the saddle-point rhs and the projection, from numba's template
            from ._codegen_constrained import constrained_c

            source += "\n" + constrained_c(equations)
        return source

    declarations = C_DECLARATIONS
    if equations.is_constrained:
        from ._codegen_constrained import C_DECLARATIONS as constrained_declarations

        declarations += constrained_declarations
    src, key, ffi, lib = _library(equations, "main", main_source, declarations, cc, cffi)
    values = np.array([np.nan if v is None else v for v in equations.parameters.values()], dtype=float)
    cm = CompiledModel(equations, "c", equations.state_names, tuple(u.name for u in equations.inputs),
                       tuple(p.name for p in equations.parameters), values, str(src), key,
                       lib.lg_constrained_rhs if equations.is_constrained else lib.lg_rhs, lib.lg_energy,
                       lib.lg_project if equations.is_constrained else None)
    per["c-second"] = _Second(equations, ffi, lib, src, cc, cffi)
    with _LOCK:
        return per.setdefault("c", cm)


#: The functions of the main library (a small model's source has all four: c_source's `functions`).
_MAIN = ("rhs", "mass_forcing", "energy")


class _Second:
    """mass_forcing and lagrange_parts of the C backend (what the variational integrator calls): from the main
    library, or lagrange_parts from a library of its own, built on first use, for a source without it."""

    def __init__(self, equations, ffi, lib, src, cc, cffi):
        self.mass_forcing = lib.lg_mass_forcing
        self._args = (equations, cc, cffi)
        self._keep = [ffi, lib]
        self._lagrange_parts = lib.lg_lagrange_parts if "lg_lagrange_parts(" in src.read_text() else None

    @property
    def lagrange_parts(self):
        with _SECOND_LOCK:  # (built once when two threads ask at once)
            if self._lagrange_parts is None:
                equations, cc, cffi = self._args
                _, _, ffi, lib = _library(equations, "lagrange-parts",
                                          lambda: c_source(equations, functions=("lagrange_parts",)),
                                          _PARTS_DECLARATION, cc, cffi)
                self._keep += [ffi, lib]
                self._lagrange_parts = lib.lg_lagrange_parts
            return self._lagrange_parts


_SECOND_LOCK = threading.Lock()


_PARTS_DECLARATION = "void lg_lagrange_parts(double t, double *x, double *u, double *p, double *pm, double *F);\n"


def _library(equations: Equations, part: str, make_source, declarations: str, cc: str, cffi):
    """(source path, key, ffi, lib): the shared library of the source `make_source()` gives, compiled once per
    content hash. An index entry named by the fingerprint of `equations`, `part` and the compiler gives the key of a
    library built before: used when its stored source still hashes to it (so that a cached run of a large model
    does not generate its source), else the source is generated, written and compiled again."""
    folder = cache_dir()
    salt = ("c-" + part, cc, f"{_codegen.SHARED_FROM}:{_codegen.C_HELPER_STATEMENTS}")  # (tests change them)
    index = folder / f"lagrangian_index_{fingerprint(equations, *salt)}.txt"
    source = None
    try:
        key = index.read_text().strip()
        src = folder / f"lagrangian_c_{key}.c"
        if re.fullmatch(r"[0-9a-f]{32}", key) and (folder / f"lagrangian_c_{key}.so").exists():
            stored = src.read_text(encoding="utf-8")
            if source_key(stored, "c", cc, *compiler_flags(stored)) == key:
                source = stored
    except (OSError, UnicodeDecodeError):
        pass
    if source is None:
        source = make_source()
    flags = compiler_flags(source)
    key = source_key(source, "c", cc, *flags)
    src = folder / f"lagrangian_c_{key}.c"
    lib_path = folder / f"lagrangian_c_{key}.so"
    store(src, source)
    if not lib_path.exists():  # the library is stored only once the compiler built it
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".so", dir=folder)
        os.close(fd)
        cmd = [*cc.split(), *flags, "-o", tmp, str(src), "-lm"]
        run = subprocess.run(cmd, capture_output=True, text=True)
        if run.returncode != 0:
            os.unlink(tmp)
            raise ModelError(f"backend 'c': the C compiler failed on {src}:\n{run.stderr.strip()[:2000]}\n"
                             "use backend='numba'")
        os.replace(tmp, lib_path)
    store(index, key)
    ffi = cffi.FFI()
    ffi.cdef(declarations)
    try:
        lib = ffi.dlopen(str(lib_path))
    except OSError:  # a broken entry is removed, never reused
        lib_path.unlink(missing_ok=True)
        raise
    return src, key, ffi, lib
