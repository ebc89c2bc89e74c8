"""One saddle-point algorithm (numeric._codegen_constrained): the NumPy transcription
(ConstrainedModel.solve/project), the numba module and the C backend give the same q_ddot, lambda
and projection, decide "singular" by the same measure at the same threshold, and the C backend
integrates constrained models as numba does."""

from __future__ import annotations

import importlib.util
import re

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.numeric._cbackend import c_compiler
from lagrangian.numeric._codegen_constrained import (
    EVENT_RATIO,
    SINGULAR_RATIO,
    compiled_project,
    compiled_solve,
    constrained_c,
    constrained_main,
)
from lagrangian.numeric._compiled import compile_equations
from lagrangian.numeric._constrained import ConstraintSingular, _factor, constrained_model

HAVE_C = importlib.util.find_spec("cffi") is not None and c_compiler() is not None
needs_c = pytest.mark.skipif(not HAVE_C, reason="the C backend needs cffi and a C compiler ($CC, cc or gcc)")
BACKENDS = ["numba"] + (["c"] if HAVE_C else [])


@pytest.fixture(scope="module")
def models():
    """name -> (Equations, ConstrainedModel, {backend: CompiledModel}, parameter values)."""
    out = {}
    for name in ("four-bar", "slider-crank", "knife-edge"):
        if name == "knife-edge":  # a velocity constraint (m = 1, no holonomic one)
            m = lg.Model("knife-edge", coordinates=["x", "y", "phi"], parameters={"m": 1.0, "J": 0.1})
            m.add_energy(T="m*(x_dot**2 + y_dot**2)/2 + J*phi_dot**2/2 + x*y_dot/3")
            m.add_velocity_constraint("x_dot*sin(phi) - y_dot*cos(phi) + x/5", name="blade")
            eq = lg.derive(m)
        else:
            eq = lg.derive(lg.load(name))
        nm = compile_equations(eq, "scipy")
        p = np.array(list(eq.parameters.values()), float)
        out[name] = eq, constrained_model(eq, nm), {b: compile_equations(eq, b) for b in BACKENDS}, p
    return out


def _states(eq, cm, p, count, off):
    """`count` states `off` away from the constraints (a consistent state moved at random)."""
    from lagrangian.numeric._constrained import consistent_state

    rng = np.random.default_rng(7)
    x0 = np.array([eq.model.simulation.get("initial", {}).get(s, 0.1) for s in eq.state_names], float)
    base = consistent_state(cm, x0, set(), p)
    return [base + off * rng.standard_normal(len(base)) + np.r_[np.zeros(eq.n), rng.standard_normal(eq.n)]
            for _ in range(count)]


@pytest.mark.parametrize("name", ["four-bar", "slider-crank", "knife-edge"])
def test_numpy_numba_and_c_solve_and_project_alike_at_random_states(models, name):
    eq, cm, fast, p = models[name]
    u = np.array([0.3, -1.2][:len(eq.inputs)])
    for x in _states(eq, cm, p, 5, 1e-3):
        qdd, lam = cm.solve(0.2, x, u, p)
        # the saddle-point equations themselves: M q_ddot = f + G^T lambda, G q_ddot = c
        M, f, G, c = cm.parts(0.2, x, u, p)
        assert np.allclose(M @ qdd, f + G.T @ lam, rtol=1e-12, atol=1e-12 * np.max(np.abs(f)))
        assert np.allclose(G @ qdd, c, rtol=1e-12, atol=1e-12 * np.max(np.abs(c)))
        projected = cm.project(0.2, x, p)
        for backend, model in fast.items():
            qdd_b, lam_b, measure = compiled_solve(model, 0.2, x, u, p)
            assert measure == pytest.approx(min(cm.measures(0.2, x, u, p)), rel=1e-12)
            np.testing.assert_allclose(qdd_b, qdd, rtol=1e-12, atol=1e-12 * np.max(np.abs(qdd)), err_msg=backend)
            np.testing.assert_allclose(lam_b, lam, rtol=1e-12, atol=1e-12 * np.max(np.abs(lam)), err_msg=backend)
            x_b, drift = compiled_project(model, 0.2, x, p)
            np.testing.assert_allclose(x_b, projected, rtol=1e-12, atol=1e-13, err_msg=backend)
            g, w = cm.residuals(0.2, x, p)
            assert drift[0] == pytest.approx(np.max(np.abs(g), initial=0.0), rel=1e-12)
        g, w = cm.residuals(0.2, projected, p)  # on the constraints after the projection
        assert np.max(np.abs(g), initial=0.0) < 1e-13 and np.max(np.abs(w)) < 1e-13


def test_at_m_0_the_measure_is_the_inertia_measure_of_m():
    """The algorithm without constraints is the unconstrained solve's: its measure is
    min_j D_j / M_jj of M's LDL^T factors, the inertia measure of NumericModel.solve."""
    from lagrangian.equations._singular import inertia_measure

    rng = np.random.default_rng(3)
    A = rng.standard_normal((4, 4))
    M = A @ A.T + 0.1 * np.eye(4)
    r, rho, *_ = _factor(M, np.zeros((0, 4)))
    assert rho == 1.0 and r == pytest.approx(inertia_measure(M), rel=1e-12)


def _slider_crank_at_the_dead_point(d):
    """The slider-crank with crank = rod (r = L = 0.35) at the crank angle pi/2 - d, on its branch
    ph = -th: as d -> 0 the slider reaches the crank's pivot and the rows of G become dependent
    (pin_y's gradient vanishes: the branches ph = -th and ph = pi + th cross)."""
    th = np.pi / 2 - d
    return np.array([th, -th, 0.7 * np.sin(d), 3.0, -3.0, -0.7 * np.cos(d) * 3.0])


def test_the_three_paths_say_singular_from_the_same_distance_on(models):
    eq, cm, fast, p = models["slider-crank"]
    p = p.copy()
    p[[s.name for s in eq.parameters].index("r")] = 0.35
    u = np.zeros(len(eq.inputs))
    distances = 3.0 * 10.0 ** -np.arange(1, 15)
    said = {"numpy": []}
    for d in distances:
        x = _slider_crank_at_the_dead_point(d)
        r_M, rho = cm.measures(0.0, x, u, p)
        assert r_M > 0.3 and (d > 0.01 or rho == pytest.approx(1.446 * d, rel=1e-2))  # rho_G falls with d
        try:
            cm.solve(0.0, x, u, p)
            said["numpy"].append(False)
        except ConstraintSingular as exc:
            assert not exc.mass and exc.ratio == rho
            said["numpy"].append(True)
        for backend, model in fast.items():
            _, _, measure = compiled_solve(model, 0.0, x, u, p)
            assert measure == pytest.approx(rho, rel=1e-3), backend  # the same quantity
            said.setdefault(backend, []).append(measure <= SINGULAR_RATIO)
    first = said["numpy"].index(True)
    assert distances[first] == pytest.approx(3e-13) and all(said["numpy"][first:]) and not any(said["numpy"][:first])
    for backend in fast:
        assert said[backend] == said["numpy"], backend


def test_a_dead_point_stops_each_backend_at_the_same_time():
    """A bob on a rod driven by x = sin(t) meets a dead point at t = pi/2 (the rod and the drive
    dependent): the measure crosses EVENT_RATIO at the same instant in every backend, and each
    says it is G that lost rank (the cond(M) test that told them apart before is gone)."""
    m = lg.Model("driven-rod", coordinates=["x", "y"], parameters={"g": 9.81})
    m.add_particle(1, ("x", "y"), name="bob")
    m.add_gravity("g")
    m.add_constraint("x**2 + y**2 - 1", name="rod")
    m.add_constraint("x - sin(t)", name="drive")
    eq = lg.derive(m)
    times, ys = {}, {}
    for backend in ["scipy", *BACKENDS]:
        with pytest.raises(lg.SimulationError, match=r"Jacobian G loses rank at t = 1\.5708") as caught:
            lg.simulate(eq, t_end=3.0, initial={"x": 0.0, "y": -1.0}, backend=backend)
        times[backend] = caught.value.time
        ys[backend] = float(re.search(r"\by = (\S+),", str(caught.value)).group(1))
    # rho_G = |y| / 2 here (M = I, G = [[2x, 2y], [1, 0]] with x^2 + y^2 = 1): each stops where it is EVENT_RATIO,
    # within 1.2e-7 of pi/2 (the integration error near the dead point), the backends within 1e-8 of each other
    for backend, y in ys.items():
        assert y == pytest.approx(-2 * EVENT_RATIO, rel=1e-4), backend
        assert times[backend] == pytest.approx(np.pi / 2, abs=2e-7) and abs(times[backend] - times["scipy"]) < 1e-8


def test_one_template_gives_the_numba_and_the_c_text_of_the_same_steps(models):
    eq = models["four-bar"][0]
    py, c = "\n".join(constrained_main(eq)), constrained_c(eq)
    for name in ("lg_ldl", "lg_lower", "lg_upper", "lg_qr", "lg_rt", "lg_qv", "lg_factor", "lg_saddle",
                 "lg_projection"):
        assert f"def {name}(" in py and f" {name}(" in c
    assert "1e-12" in py and "1e-12" in c  # SINGULAR_RATIO, written once
    assert "np.linalg" not in py and "cond(" not in py


def test_a_small_models_numba_rhs_calls_lg_saddle_after_all_its_parts(models):
    """f and c of the four-bar need a few statements of their own: nothing to overlap with the
    factorization, so M, f, G, c, then lg_saddle (numeric._codegen_constrained.SPLIT_MIN)."""
    py = "\n".join(constrained_main(models["four-bar"][0]))
    rhs = py.split("def rhs(")[1].split("\ndef ")[0]
    assert "r = lg_saddle(work)" in rhs and "lg_range" not in py and "lg_solve" not in py


@pytest.mark.slow
def test_the_bicycles_numba_rhs_factors_m_and_g_before_f_and_c_with_the_same_numbers():
    """The Whipple bicycle's f and c need hundreds of statements: numba's rhs factors M and G
    (lg_ldl, lg_range) before it evaluates them, then lg_solve; q_ddot, lambda and the measure are
    NumPy's (ConstrainedModel) and the C backend's (which calls lg_saddle after all the parts)."""
    eq = lg.derive(lg.load("whipple-bicycle"))
    py = "\n".join(constrained_main(eq))
    rhs = py.split("def rhs(")[1].split("\ndef ")[0]
    late = rhs.split("rho = lg_range(work)")[1]
    assert rhs.index("r = lg_ldl(work)") < rhs.index("rho = lg_range(work)")
    assert "r = lg_solve(work, min(r, rho))" in late and "lg_saddle" not in rhs
    assert sum(line.lstrip().startswith("c") for line in late.splitlines()) >= 64  # f and c's own statements
    assert " lg_saddle(work)" in constrained_c(eq) and "lg_range" not in constrained_c(eq)
    nm = compile_equations(eq, "scipy")
    cm = constrained_model(eq, nm)
    p = np.array(list(eq.parameters.values()), float)
    fast = {b: compile_equations(eq, b) for b in BACKENDS}
    x0 = np.array([lg.simulate(eq, t_end=0.01)[s][0] for s in eq.state_names])
    rng = np.random.default_rng(20)
    for _ in range(3):
        x = x0 + np.r_[1e-3 * rng.standard_normal(eq.n), rng.standard_normal(eq.n)]
        qdd, lam = cm.solve(0.2, x, np.zeros(0), p)
        for backend, model in fast.items():
            qdd_b, lam_b, measure = compiled_solve(model, 0.2, x, np.zeros(0), p)
            assert measure == pytest.approx(min(cm.measures(0.2, x, np.zeros(0), p)), rel=1e-12)
            np.testing.assert_allclose(qdd_b, qdd, rtol=1e-12, atol=1e-12 * np.max(np.abs(qdd)), err_msg=backend)
            np.testing.assert_allclose(lam_b, lam, rtol=1e-12, atol=1e-12 * np.max(np.abs(lam)), err_msg=backend)


@needs_c
@pytest.mark.parametrize("name", ["four-bar", "slider-crank"])
def test_the_c_backend_integrates_constrained_models_as_numba(name):
    eq = lg.derive(lg.load(name))
    a = lg.simulate(eq, t_end=1.0, rtol=1e-10, atol=1e-10)
    b = lg.simulate(eq, t_end=1.0, rtol=1e-10, atol=1e-10, backend="c")
    assert a.stats["backend"] == "numba" and b.stats["backend"] == "c"
    assert a.stats["nstep"] == b.stats["nstep"]
    np.testing.assert_allclose(b.x, a.x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(b.multipliers, a.multipliers, rtol=1e-10, atol=1e-10 * np.max(np.abs(a.multipliers)))
    assert b.stats["constraint_drift"]["position"] < 1e-10 and b.stats["constraint_drift"]["velocity"] < 1e-12


@pytest.mark.slow
def test_the_projection_reads_only_the_work_it_wrote():
    """A model with holonomic and velocity constraints (the rattleback: its contact, then two no-slip
    conditions) keeps g_h at P0 and G_h at H0 = P0 + m: the projection's finite test read
    P0 .. P0 + m_h (n + 1) instead, entries nobody wrote, so a work array's old contents decided
    whether it projected (a simulation's drift changed with the tests run before it). The same state
    projected with a work array of zeros and of NaN gives the same state, to the bit."""
    import sys
    from pathlib import Path

    from lagrangian.numeric._codegen_constrained import _calls, _pointer, work_size
    from lagrangian.numeric._fast import _address

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "model"))
    from test_rattleback import rattleback

    eqs = lg.derive(rattleback(-0.1))
    fast = compile_equations(eqs, "numba")
    start = lg.simulate(fast, 0.01, initial={"z": 0.02, "psi_dot": 2.0, "phi_dot": 0.05})
    x0 = np.array([start[s][0] for s in eqs.state_names]) + 1e-6  # off the constraints
    _, project_t, D = _calls()
    out = []
    for fill in (0.0, np.nan):
        x = x0.copy()
        u, p = np.zeros(1), np.array([float(v) for v in eqs.parameters.values()])
        work, drift = np.full(work_size(eqs.n, len(eqs.multipliers)), fill), np.zeros(2)
        project_t(_address(fast.project_c))(0.0, *(_pointer(a, D) for a in (x, u, p, work, drift)))
        out.append(x)
    assert np.array_equal(out[0], out[1]) and not np.array_equal(out[0], x0)
    _, _, g, w = compile_equations(eqs, "scipy").constraint_parts(0.0, out[1], np.zeros(0), p)
    assert np.max(np.abs(g)) < 1e-12 and np.max(np.abs(w)) < 1e-12  # projected onto both kinds
