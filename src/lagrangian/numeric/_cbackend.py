"""The C backend: the model's functions generated in C (see _codegen.c_source; a constrained
model's saddle-point right-hand side and projection from _codegen_constrained), compiled by the
system's C compiler into a shared library in the cache directory, and loaded with cffi. The
compiled integrators (the same numba kernels as the numba backend) call them through their
addresses, so no Python runs per step either way.

Needs cffi (``pip install lagrangian[c]``) and a C compiler (``$CC``, ``cc`` or ``gcc``).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import types

import numpy as np

from ..equations import Equations
from ..errors import ModelError
from ._codegen import C_DECLARATIONS, c_source, cache_dir, source_key, store

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
    """The CompiledModel of `equations` with its functions in C (cached per content hash)."""
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
    source, declarations = c_source(equations), C_DECLARATIONS
    if equations.is_constrained:  # the saddle-point rhs and the projection, from numba's template
        from ._codegen_constrained import C_DECLARATIONS as constrained_declarations
        from ._codegen_constrained import constrained_c

        source += "\n" + constrained_c(equations)
        declarations += constrained_declarations
    flags = compiler_flags(source)
    key = source_key(source, "c", cc, *flags)
    folder = cache_dir()
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
    ffi = cffi.FFI()
    ffi.cdef(declarations)
    try:
        lib = ffi.dlopen(str(lib_path))
    except OSError:  # a broken entry is removed, never reused
        lib_path.unlink(missing_ok=True)
        raise
    values = np.array([np.nan if v is None else v for v in equations.parameters.values()], dtype=float)
    cm = CompiledModel(equations, "c", equations.state_names, tuple(u.name for u in equations.inputs),
                       tuple(p.name for p in equations.parameters), values, str(src), key,
                       lib.lg_constrained_rhs if equations.is_constrained else lib.lg_rhs, lib.lg_energy,
                       lib.lg_project if equations.is_constrained else None)
    per["c-second"] = types.SimpleNamespace(mass_forcing=lib.lg_mass_forcing,
                                            lagrange_parts=lib.lg_lagrange_parts, _keep=(ffi, lib))
    with _LOCK:
        return per.setdefault("c", cm)
