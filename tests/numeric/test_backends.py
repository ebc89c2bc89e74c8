"""Backends (numba, C, the portable NumPy/SciPy one) against the symbolic equations at random
states; the generated code's argument order; the disk cache; backend choice and its errors."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.numeric._cbackend import c_compiler

import importlib.util

HAVE_C = importlib.util.find_spec("cffi") is not None and c_compiler() is not None

COMPILED = ["numba"] + (["c"] if HAVE_C else [])
MODELS = ["double-pendulum", "cart-pendulum", "rotating-pendulum", "mck", "pendulum-chain-3",
          "sliding-disk-heavy-rod", "cart-pendulum-massless"]


@pytest.fixture(scope="module")
def equations():
    return {name: lg.derive(lg.load(name)) for name in MODELS}


def symbolic(eqs, t, x, u, p):
    """(M, f, q_ddot, h) from the symbolic equations, by substitution."""
    values = {eqs.t: t}
    values.update(zip(eqs.coordinates, x[: eqs.n]))
    values.update(zip(eqs.velocities, x[eqs.n:]))
    values.update(zip(eqs.inputs, u))
    values.update(zip(eqs.parameters, p))
    M = np.array(eqs.mass_matrix.subs(values).evalf(), dtype=float)
    f = np.array(eqs.forcing.subs(values).evalf(), dtype=float).ravel()
    L = eqs.L
    h = sum(v * sympy.diff(L, v) for v in eqs.velocities) - L
    return M, f, np.linalg.solve(M, f), float(h.subs(values).evalf())


@pytest.mark.parametrize("backend", COMPILED + ["scipy"])
@pytest.mark.parametrize("name", MODELS)
def test_backend_matches_symbolic_equations_at_random_states(equations, name, backend):
    eqs = equations[name]
    nm = lg.compile(eqs, backend=backend)
    assert nm.state_names == eqs.state_names
    rng = np.random.default_rng(abs(hash((name, backend))) % 2**32)
    p = nm.parameter_values
    for _ in range(4):
        t = float(rng.uniform(0, 2))
        x = rng.uniform(-1, 1, 2 * eqs.n)
        u = rng.uniform(-1, 1, len(eqs.inputs))
        M, f, qdd, h = symbolic(eqs, t, x, u, p)
        scale = 1 + np.max(np.abs(f))
        assert np.allclose(nm.mass_matrix(t, x, u, p), M, rtol=1e-12, atol=1e-12 * np.max(np.abs(M)))
        assert np.allclose(nm.forcing(t, x, u, p), f, rtol=1e-12, atol=1e-12 * scale)
        rhs = nm.rhs(t, x, u, p)
        assert np.array_equal(rhs[: eqs.n], x[eqs.n:])
        cond = np.linalg.cond(M)
        assert np.allclose(rhs[eqs.n:], qdd, rtol=1e-11 * cond, atol=1e-11 * cond * (1 + np.max(np.abs(qdd))))
        assert nm.energy(t, x, u, p) == pytest.approx(h, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("backend", COMPILED)
def test_compiled_solve_reports_a_singular_mass_matrix(equations, backend):
    eqs = equations["cart-pendulum-massless"]
    nm = lg.compile(eqs, backend=backend)
    q2 = eqs.state_names.index("q2")
    x = np.zeros(4)
    x[q2] = -math.pi / 2
    qdd, measure = nm.solve(0.0, x, [], nm.parameter_values)
    assert measure < 1e-12
    assert np.all(np.isnan(nm.rhs(0.0, x, [], nm.parameter_values)[2:]))
    x[q2] = 0.3
    qdd, measure = nm.solve(0.0, x, [], nm.parameter_values)
    portable = lg.compile(eqs, backend="scipy")
    assert measure == pytest.approx(portable.singular_ratio(0.0, x, [], nm.parameter_values), rel=1e-12)
    assert nm.singular_ratio(0.0, x, [], nm.parameter_values) == pytest.approx(measure, rel=1e-12)


def test_generated_code_documents_its_argument_order(equations):
    nm = lg.compile(equations["mck"], backend="numba")
    source = nm.source
    assert "Arguments, in this order, of every function below:" in source
    assert "x : float64[4], the state [x1, x2, x1_dot, x2_dot]" in source
    assert "u : float64[1], the inputs [f]" in source
    assert "p : float64[" in source and "the parameters [" in source
    assert "def rhs(t, x_, u_, p_, dx_, work_):" in source
    assert os.path.basename(nm.path).startswith("lagrangian_") and nm.key in nm.path
    if HAVE_C:
        c = lg.compile(equations["mck"], backend="c")
        text = open(c.path).read()
        assert "x : float64[4], the state [x1, x2, x1_dot, x2_dot]" in text
        assert "double lg_rhs(double t, double *x, double *u, double *p, double *dx, double *work)" in text


def test_compile_is_cached_per_equations_and_backend(equations):
    eqs = equations["double-pendulum"]
    assert lg.compile(eqs, backend="numba") is lg.compile(eqs, backend="numba")
    # the default is the fastest backend (simulate(lg.compile(eqs)) was silently about 100x slower on SciPy)
    assert lg.compile(eqs) is lg.compile(eqs, backend="numba")
    assert lg.compile(eqs, backend="scipy") is not lg.compile(eqs, backend="numba")


@pytest.mark.slow
@pytest.mark.subprocess
def test_a_second_process_compiles_nothing():
    # a model of its own (a parameter name no other test uses), compiled in one process, then
    # loaded from the disk cache by a second one: numba reports a cache hit for every function
    script = textwrap.dedent("""
        import lagrangian as lg
        from lagrangian.numeric._fast import kernels
        m = lg.Model("cache-probe", coordinates=["z"], parameters={"kz_cache_probe": 3.0},
                     T="z_dot**2/2", V="kz_cache_probe*z**2/2")
        tr = lg.simulate(m, 1.0, {"z": 1.0}, backend="numba")
        cm = lg.compile(lg.derive(m), backend="numba")
        hits = sum(kernels().dop853.stats.cache_hits.values())
        print(cm.rhs_c.cache_hits, cm.energy_c.cache_hits, hits, tr.stats["backend"])
    """)
    from lagrangian.numeric._codegen import cache_dir

    folder = cache_dir()  # the kernels are compiled there already (by the tests before)
    env = dict(os.environ, LAGRANGIAN_CACHE_DIR=str(folder))
    for f in folder.glob("lagrangian_*.py"):  # no module for this model yet: the first run compiles it
        if "kz_cache_probe" in f.read_text():
            for g in (folder / "__pycache__").glob(f"{f.stem}.*"):
                g.unlink()
            f.unlink()
    runs = [subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env) for _ in range(2)]
    for r in runs:
        assert r.returncode == 0, r.stderr
    first = runs[0].stdout.split()
    second = runs[1].stdout.split()
    assert first[:2] == ["0", "0"] and first[3] == "numba"
    assert second[:2] == ["1", "1"] and int(second[2]) >= 1


# ------------------------------------------------------------------- choice of backend
def oscillator():
    return lg.Model("forced", coordinates=["x"], parameters={"m": 1.0, "k": 4.0, "c": 0.3}, inputs=["F"],
                    T="m*x_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2", Q={"x": "F"})


def test_auto_is_compiled_and_falls_back_to_scipy_for_python_functions():
    model = oscillator()
    a = lg.simulate(model, 2.0, {"x": 1.0}, inputs={"F": "sin(2*t)"})
    b = lg.simulate(model, 2.0, {"x": 1.0}, inputs={"F": lambda t: math.sin(2 * t)})
    assert a.stats["backend"] == "numba" and b.stats["backend"] == "scipy"
    assert a.stats["method"] == b.stats["method"] == "DOP853"
    assert np.max(np.abs(a.x - b.x)) <= 1e-12
    c = lg.simulate(model, 2.0, {"x": 1.0}, inputs={"F": "sin(2*t)"}, method="RK45")
    assert c.stats["backend"] == "scipy"  # SciPy's other methods run in SciPy


@pytest.mark.parametrize("backend", COMPILED + ["scipy"])
def test_every_backend_simulates_alike(backend):
    model = oscillator()
    ref = lg.simulate(model, 3.0, {"x": 1.0}, inputs={"F": "0.5*cos(3*t) + k/8"}, backend="scipy", rtol=1e-10,
                      atol=1e-10)
    tr = lg.simulate(model, 3.0, {"x": 1.0}, inputs={"F": "0.5*cos(3*t) + k/8"}, backend=backend, rtol=1e-10,
                     atol=1e-10)
    assert tr.stats["backend"] == backend
    assert np.max(np.abs(tr.x - ref.x)) <= 1e-12
    assert np.array_equal(tr.u, ref.u) or np.max(np.abs(tr.u - ref.u)) <= 1e-15
    assert np.max(np.abs(tr.energy - ref.energy)) <= 1e-12


def test_error_unknown_backend():
    with pytest.raises(ModelError, match=r"unknown backend 'numbaa' \(did you mean 'numba'\?\); choose one of auto"):
        lg.simulate(oscillator(), 1.0, backend="numbaa")
    with pytest.raises(ModelError, match=r"unknown backend 'fortran'; choose one of numba, c, scipy"):
        lg.compile(lg.derive(oscillator()), backend="fortran")


def test_error_python_function_input_on_an_explicit_compiled_backend():
    with pytest.raises(ModelError, match=r"an input is a Python function, which compiled code cannot call: give it "
                                         r"as an expression string"):
        lg.simulate(oscillator(), 1.0, inputs={"F": lambda t: 1.0}, backend="numba")


def test_error_variational_on_scipy():
    with pytest.raises(ModelError, match=r"method 'variational' runs in compiled code only"):
        lg.simulate(oscillator(), 1.0, method="variational", backend="scipy")


def test_error_variational_with_python_function_or_t_eval():
    with pytest.raises(ModelError) as info:
        lg.simulate(oscillator(), 1.0, method="variational", inputs={"F": lambda t: 0.0}, t_eval=[0, 1.0])
    text = str(info.value)
    assert "method 'variational' outputs every dt" in text
    assert "cannot call a Python function" in text


def test_error_bad_step():
    with pytest.raises(ModelError, match=r"step must be a positive number, got -0.1"):
        lg.simulate(oscillator(), 1.0, method="variational", step=-0.1)


def test_the_default_compile_is_the_compiled_model_that_simulate_runs_compiled(equations):
    """lg.compile(eqs) defaulted to the SciPy backend while simulate defaulted to numba, so
    simulate(lg.compile(eqs)) ran on SciPy, about 100x slower; now it is numba's model."""
    eqs = equations["double-pendulum"]
    nm = lg.compile(eqs)
    assert nm.backend == "numba"
    traj = lg.simulate(nm, 1.0, {"theta1": 0.5})
    assert traj.stats["backend"] == "numba"


def test_every_backend_gives_a_constrained_model_s_state_equations():
    """NumericModel.rhs of a constrained model was M^-1 f (the bob of the Cartesian pendulum fell
    freely: y'' = -9.81); now the saddle-point solution, as the compiled model gives it."""
    eqs = lg.derive(lg.load("cartesian-pendulum"))
    x = np.array([0.6, -0.8, 0.3, 0.225])
    portable, compiled = lg.compile(eqs, backend="scipy"), lg.compile(eqs)
    p = portable.parameter_values
    a, b = portable.rhs(0.0, x, [], p), compiled.rhs(0.0, x, [], p)
    assert np.allclose(a, b, rtol=1e-12, atol=1e-12)
    # on the unit rod from the origin: radial acceleration -|v|^2 (free fall gave +7.848), tangential
    # gravity's part -g 0.6 along the tangent (0.8, 0.6)
    assert a[2] * 0.6 - a[3] * 0.8 == pytest.approx(-(0.3**2 + 0.225**2), abs=1e-12)
    assert a[2] * 0.8 + a[3] * 0.6 == pytest.approx(-9.81 * 0.6, abs=1e-12)


@pytest.mark.skipif(not HAVE_C, reason="the C backend needs cffi and a C compiler")
def test_a_large_source_is_compiled_at_o1_with_the_same_numbers(monkeypatch, tmp_path):
    """gcc -O2's register allocation grows faster than linearly with a function's length (the 5-rod spatial
    chain: about 600 s); a source past LARGE_SOURCE characters is compiled at -O1, a separate cache entry,
    with the same numbers (no fast-math either way)."""
    from lagrangian.numeric import _cbackend, _fast
    from lagrangian.numeric._codegen import c_source

    eqs = lg.derive(lg.load("double-pendulum"))
    source = c_source(eqs)
    assert len(source) < _cbackend.LARGE_SOURCE
    assert _cbackend.compiler_flags(source)[0] == "-O2"
    assert _cbackend.compiler_flags("x" * (_cbackend.LARGE_SOURCE + 1))[0] == "-O1"
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path))
    o2 = lg.simulate(eqs, backend="c", t_end=2.0)
    _fast._CACHE.pop(eqs, None)
    monkeypatch.setattr(_cbackend, "LARGE_SOURCE", 0)
    o1 = lg.simulate(eqs, backend="c", t_end=2.0)
    libraries = sorted(p.name for p in tmp_path.glob("lagrangian_c_*.so"))
    assert len(libraries) == 2  # two flags, two entries
    np.testing.assert_array_equal(o1.x, o2.x)
    np.testing.assert_array_equal(o1.energy, o2.energy)
