"""The C of a large model (numeric/_codegen.large_model: M and f past SHARED_FROM tree nodes, spatial chains of 5 rods
and more) in c_source's split form: each statement list written once, in static helpers of at most
C_HELPER_STATEMENTS statements that pass their values through a work array; lg_lagrange_parts compiled as a library
of its own on first use; backend "auto" takes C for such a model (numba's compile of it grows faster than linearly).
The thresholds are forced low here so that the 3-rod chain takes the new path; the 5-rod chain takes it by default."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.numeric import _codegen
from lagrangian.numeric._cbackend import c_compiler

cffi = pytest.importorskip("cffi", reason="the C backend needs cffi")
if c_compiler() is None:
    pytest.skip("no C compiler ($CC, cc or gcc) for the C backend", allow_module_level=True)

CHAIN3 = Path(__file__).resolve().parents[1] / "models" / "spatial-chain-3.toml"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _build(source: str, folder: Path, name: str):
    """lib of `source` compiled at -O0 (quick: the generators are compared here), the four functions declared."""
    src, so = folder / f"{name}.c", folder / f"{name}.so"
    src.write_text(source)
    run = subprocess.run([*c_compiler().split(), "-O0", "-shared", "-fPIC", "-o", str(so), str(src), "-lm"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[:2000]
    ffi = cffi.FFI()
    ffi.cdef(_codegen.C_DECLARATIONS)
    return ffi, ffi.dlopen(str(so))


def _values(ffi, lib, n, t, x, p):
    """rhs (its ratio and dx), M, f, the energy, pm and F of the library at (t, x, p)."""
    x = np.ascontiguousarray(x, dtype=float)
    p = np.ascontiguousarray(p, dtype=float)
    u = np.zeros(1)
    dx, work, M, f = np.zeros(2 * n), np.zeros(n * n + 2 * n), np.zeros(n * n), np.zeros(n)
    pm, F = np.zeros(n), np.zeros(n)
    ptr = lambda a: ffi.cast("double *", a.ctypes.data)  # noqa: E731
    r = lib.lg_rhs(t, ptr(x), ptr(u), ptr(p), ptr(dx), ptr(work))
    lib.lg_mass_forcing(t, ptr(x), ptr(u), ptr(p), ptr(M), ptr(f))
    e = lib.lg_energy(t, ptr(x), ptr(u), ptr(p))
    if hasattr(lib, "lg_lagrange_parts"):
        lib.lg_lagrange_parts(t, ptr(x), ptr(u), ptr(p), ptr(pm), ptr(F))
    return {"ratio": r, "dx": dx, "M": M.reshape(n, n), "f": f, "energy": e, "pm": pm, "F": F}


def _split(monkeypatch, helpers: int):
    monkeypatch.setattr(_codegen, "SHARED_FROM", 0)  # every model is large
    monkeypatch.setattr(_codegen, "C_HELPER_STATEMENTS", helpers)


@pytest.mark.parametrize("helpers", [7, pytest.param(60, marks=pytest.mark.slow)])
def test_the_split_c_of_the_three_rod_chain_gives_the_full_forms_numbers(tmp_path, monkeypatch, helpers):
    """The 3-rod chain (9 coordinates: the unrolled LDL^T) in the split form against the four functions written out
    (the C every model had): rhs, M, f, the energy, dL/dq_dot and F at random states, to 1e-12 (bit for bit here)."""
    eqs = lg.derive(lg.load(str(CHAIN3)))
    assert not _codegen.large_model(eqs)
    full = _codegen.c_source(eqs)
    _split(monkeypatch, helpers)
    split = _codegen.c_source(eqs)
    assert _codegen.large_model(eqs) and "lg_mf_" not in full
    # each statement list once: the helpers of M and f, of the energy and of the Lagrangian's parts
    defined = re.findall(r"^static void (lg_(mf|energy|lagrange_parts)_\d+)\(", split, re.M)
    assert {kind for _, kind in defined} == {"mf", "energy", "lagrange_parts"}
    for name, _ in defined:  # each helper called once by each caller, and at most `helpers` statements long
        body = split.split(f"static void {name}(", 1)[1].split("\n}\n", 1)[0]
        assert len(re.findall(r"^    double c\d+ = ", body, re.M)) <= helpers
    assert split.count("    lg_mf_0(t, x, u, p, w);") == 2  # rhs and mass_forcing fill M and f by the same helpers
    assert len([1 for _, kind in defined if kind == "mf"]) > 2
    n = eqs.n
    a, b = _build(full, tmp_path, "full"), _build(split, tmp_path, "split")
    rng = np.random.default_rng(11)
    p = np.array([1.0, 0.2, 0.5, 6.0, 1.5, 9.8, 0.9, 0.9, 0.9])
    for _ in range(6):
        x = rng.uniform(-1.5, 1.5, 2 * n)
        va, vb = _values(*a, n, 0.3, x, p), _values(*b, n, 0.3, x, p)
        for key in va:
            ref = np.asarray(va[key])
            assert np.all(np.isfinite(ref))
            np.testing.assert_allclose(vb[key], ref, rtol=1e-12, atol=1e-12 * max(1.0, float(np.max(np.abs(ref)))),
                                       err_msg=key)


def test_auto_compiles_a_large_model_in_c_with_lagrange_parts_on_first_use(monkeypatch):
    """backend "auto" (compile and simulate) takes C for a large model; the main library has no lg_lagrange_parts,
    which the variational integrator builds in a library of its own; the numbers are SymEngine's (the NumPy model)
    and numba's."""
    _split(monkeypatch, 60)
    eqs = lg.derive(lg.load(str(CHAIN3)))
    cm = lg.compile(eqs)
    assert cm.backend == "c" and "lg_mf_3(" in cm.source and "lg_lagrange_parts" not in cm.source
    nm = lg.compile(eqs, "scipy")
    p = nm.parameter_values
    rng = np.random.default_rng(5)
    for _ in range(4):
        x = rng.uniform(-1.2, 1.2, 2 * eqs.n)
        for name in ("rhs", "mass_matrix", "forcing", "energy"):
            ref = np.asarray(getattr(nm, name)(0.0, x, [], p))
            np.testing.assert_allclose(getattr(cm, name)(0.0, x, [], p), ref, rtol=1e-11, atol=1e-11, err_msg=name)
    run = lg.simulate(eqs, t_end=1.0, rtol=1e-11, atol=1e-11)
    assert run.stats["backend"] == "c"
    energy = np.asarray(run.energy)
    assert np.ptp(np.asarray(run.x), axis=0).max() > 0.5  # it moved
    assert abs(energy[-1] - energy[0]) <= 1e-8 * max(1.0, abs(energy[0]))  # no damping: h conserved
    second = cm._second()
    assert second._lagrange_parts is None  # not built yet
    var_c = lg.simulate(eqs, t_end=0.05, method="variational", step=1e-4)
    assert second._lagrange_parts is not None and len(second._keep) == 4  # built, in a library of its own
    assert var_c.stats["backend"] == "c"
    h = np.asarray(var_c.energy)  # the midpoint variational integrator keeps h to O(step^2)
    assert np.ptp(np.asarray(var_c.x), axis=0).max() > 0.01 and np.ptp(h) <= 1e-4 * max(1.0, abs(h[0]))


def test_a_second_process_finds_the_large_models_library_without_generating_it(cache, monkeypatch):
    """The index entry (the fingerprint of the equations) gives the library's key: a new process (the cache of this
    one emptied) loads it without generating the source; a changed stored source is generated and compiled again."""
    from lagrangian.numeric import _cache, _cbackend

    _split(monkeypatch, 60)
    eqs = lg.derive(lg.load(str(CHAIN3)))
    first = lg.compile(eqs, "c")
    calls = []
    original = _cbackend.c_source
    monkeypatch.setattr(_cbackend, "c_source", lambda *a, **k: calls.append(1) or original(*a, **k))
    _cache.CACHE.pop(eqs, None)
    again = lg.compile(eqs, "c")
    assert again is not first and again.key == first.key and calls == []
    x = np.linspace(-0.5, 0.7, 2 * eqs.n)
    np.testing.assert_array_equal(again.rhs(0.0, x, [], again.parameter_values),
                                  first.rhs(0.0, x, [], first.parameter_values))
    Path(first.path).write_text(first.source.replace("w[0]", "w[1]", 1))  # tampered: not used
    _cache.CACHE.pop(eqs, None)
    third = lg.compile(eqs, "c")
    assert calls == [1] and third.key == first.key and "w[1]" not in third.source.split("w[0]", 1)[0][-20:]


def test_names_reach_the_split_c_only_through_the_escaping_layer(tmp_path, monkeypatch):
    """Names that are code in the split form: a parameter and a coordinate named like C and Python (the Python API
    takes any name); the C text holds none of them raw, it compiles with -Wall -Wextra -pedantic -Werror as the export
    and gives the NumPy model's numbers."""
    _split(monkeypatch, 1)
    m = lg.Model("evil */ #include <stdio.h>")
    q = m.coordinate("pow")
    m.parameter("E", 2.0)
    m.parameter("NAN", 0.5)
    m.parameter("w", 3.0)
    m.add_particle("E", ("NAN*sin(pow)", "-w*cos(pow)"))
    m.add_gravity(9.81)
    eqs = lg.derive(m)
    assert str(q) == "pow"
    source = _codegen.c_source(eqs, quiet=True)
    assert "lg_mf_1(" in source
    code = source.split("*/", 1)[1]  # (the header comment names the model, escaped by comment_text)
    assert "#include <stdio.h>" not in code and "double E " not in code and "double w " not in code
    assert not re.search(r"double (pow|NAN|E|w) =", code)
    src = tmp_path / "evil.c"
    src.write_text(source)
    build = subprocess.run([*c_compiler().split(), "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O1",
                            "-shared", "-fPIC", "-o", str(tmp_path / "evil.so"), str(src), "-lm"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr[:2000]
    ffi = cffi.FFI()
    ffi.cdef(_codegen.C_DECLARATIONS)
    lib = ffi.dlopen(str(tmp_path / "evil.so"))
    from lagrangian.numeric import _compiled

    shared = _compiled._numeric_model(eqs)  # the SciPy backend's shared statements, the same names
    x0 = np.array([0.1, 0.2])
    shared.rhs(0.0, x0, [], shared.parameter_values), shared.energy(0.0, x0, [], shared.parameter_values)  # built
    monkeypatch.setattr(_compiled, "_shared_function", lambda *a: None)
    nm = _compiled._numeric_model(eqs)  # SymEngine's Lambdify
    p = nm.parameter_values
    for x in ([0.3, -0.7], [2.0, 1.5]):
        got = _values(ffi, lib, 1, 0.0, x, p)
        np.testing.assert_allclose(got["dx"], nm.rhs(0.0, x, [], p), rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(got["energy"], nm.energy(0.0, x, [], p), rtol=1e-13)
        np.testing.assert_allclose(shared.rhs(0.0, x, [], p), nm.rhs(0.0, x, [], p), rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(shared.energy(0.0, x, [], p), nm.energy(0.0, x, [], p), rtol=1e-13)
    assert shared._groups["dynamics"].fun.__name__ == "<lambda>"


def test_the_export_of_a_large_model_builds_warning_free(tmp_path, monkeypatch):
    """export_c of a model in the split form (its static helpers, its work arrays, lg_lagrange_parts' on the heap
    past C_STACK_VALUES) builds with -std=c99 -Wall -Wextra -pedantic -Werror, and its rhs is the model's."""
    from lagrangian.export import export_c

    _split(monkeypatch, 40)
    monkeypatch.setattr(_codegen, "C_STACK_VALUES", 50)  # every work array on the heap
    eqs = lg.derive(lg.load(str(CHAIN3)))
    export_c(eqs, tmp_path)
    files = sorted(str(f) for f in tmp_path.glob("*.c"))
    assert "malloc(" in (tmp_path / "spatial_chain_3.c").read_text()
    build = subprocess.run([*c_compiler().split(), "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O1",
                            "-o", str(tmp_path / "demo"), *files, "-lm"], capture_output=True, text=True)
    assert build.returncode == 0, build.stderr[:3000]
    run = subprocess.run([str(tmp_path / "demo")], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[:2000]


@pytest.mark.slow
def test_the_five_rod_chain_is_large_and_its_split_c_gives_the_numpy_models_numbers(cache, monkeypatch):
    """5 rods in space (15 coordinates: the loop LDL^T; 2.1e7 tree nodes) take the split form by default and backend
    "auto" takes C: rhs, M, f and the energy are SymEngine's (the NumPy model by SymEngine's cse and Lambdify, not by
    the shared statements it takes for a large model) at random states to 1e-12."""
    from lagrangian.numeric import _compiled

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from spatial_chain import chain_text

    from lagrangian.io import loads_model

    eqs = lg.derive(loads_model(chain_text(5)))
    assert _codegen.large_model(eqs)
    cm = lg.compile(eqs)
    assert cm.backend == "c" and "lg_mf_1(" in cm.source
    monkeypatch.setattr(_compiled, "_shared_function", lambda *a: None)
    nm = _compiled._numeric_model(eqs)
    p = nm.parameter_values
    rng = np.random.default_rng(2)
    for _ in range(3):
        x = rng.uniform(-1.2, 1.2, 2 * eqs.n)
        for name in ("rhs", "mass_matrix", "forcing", "energy"):
            ref = np.asarray(getattr(nm, name)(0.0, x, [], p))
            scale = max(1.0, float(np.max(np.abs(ref))))
            np.testing.assert_allclose(getattr(cm, name)(0.0, x, [], p), ref, rtol=1e-12, atol=1e-12 * scale,
                                       err_msg=name)


def test_the_numpy_model_of_a_large_model_evaluates_its_shared_statements(monkeypatch):
    """The SciPy backend's M, f and energy of a large model come from the code generator's shared statement list run
    as Python (not SymEngine's cse over the whole expressions: 65 s at 8 rods): the same numbers as the cse path's
    (the 3-rod chain forced large) at random states, and its SciPy run keeps the energy."""
    from lagrangian.numeric import _compiled

    eqs = lg.derive(lg.load(str(CHAIN3)))
    reference = _compiled._numeric_model(eqs)  # SymEngine's (the chain is small)
    _split(monkeypatch, 60)
    shared = _compiled._numeric_model(eqs)
    assert _compiled._shared_function(eqs, [eqs.core.f[0]]) is not None
    rng = np.random.default_rng(4)
    p = reference.parameter_values
    for _ in range(4):
        x = rng.uniform(-1.3, 1.3, 2 * eqs.n)
        for name in ("mass_matrix", "forcing", "energy", "rhs"):
            ref = np.asarray(getattr(reference, name)(0.1, x, [], p))
            np.testing.assert_allclose(getattr(shared, name)(0.1, x, [], p), ref, rtol=1e-12,
                                       atol=1e-12 * max(1.0, float(np.max(np.abs(ref)))), err_msg=name)
    assert shared._groups["dynamics"].fun.__name__ == "<lambda>"  # (SymEngine's is a Lambdify object)
    run = lg.simulate(eqs, t_end=0.3, backend="scipy", rtol=1e-10, atol=1e-10)
    assert run.stats["backend"] == "scipy"
    energy = np.asarray(run.energy)
    assert abs(energy[-1] - energy[0]) <= 1e-7 * max(1.0, abs(energy[0]))


def test_auto_runs_a_large_model_without_a_c_compiler_on_the_scipy_backend(monkeypatch):
    """Without a C compiler, "auto" takes the SciPy backend for a large model (numba's compile of one grows faster
    than linearly: hours at 20 rods), the numbers the same; simulate_batch, whose lanes need compiled code, numba."""
    import lagrangian.numeric._cbackend as cbackend

    monkeypatch.setattr(_codegen, "SHARED_FROM", 0)  # every model is large
    monkeypatch.setattr(cbackend, "c_compiler", lambda: None)
    eqs = lg.derive(lg.load("double-pendulum"))
    nm = lg.compile(eqs)
    assert type(nm).__name__ == "NumericModel"
    run = lg.simulate(eqs, t_end=0.5)
    assert run.stats["backend"] == "scipy"
    monkeypatch.undo()
    reference = lg.simulate(lg.derive(lg.load("double-pendulum")), t_end=0.5)
    assert reference.stats["backend"] == "numba"
    np.testing.assert_allclose(np.asarray(run.x)[-1], np.asarray(reference.x)[-1], rtol=1e-6, atol=1e-6)


@pytest.mark.slow  # numba compiles the shared-statement form of the double pendulum
def test_simulate_batch_of_a_large_model_without_a_c_compiler_runs_on_numba(monkeypatch):
    import lagrangian.numeric._cbackend as cbackend

    monkeypatch.setattr(_codegen, "SHARED_FROM", 0)
    monkeypatch.setattr(cbackend, "c_compiler", lambda: None)
    eqs = lg.derive(lg.load("double-pendulum"))
    batch = lg.simulate_batch(eqs, initial={"theta1": [0.1, 0.2]}, t_end=0.5)
    assert batch.backend == "numba"
    one = lg.simulate(eqs, t_end=0.5, initial={"theta1": 0.2})
    np.testing.assert_allclose(np.asarray(batch.final)[1], np.asarray(one.x)[-1], rtol=1e-6, atol=1e-6)
