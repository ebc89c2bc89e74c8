"""The one compiled run (numeric/_simulate._run_compiled): DOP853 with the projection onto the
constraints when m > 0 and none at m = 0, one rule for the rows a failed run keeps; and simulate()'s
front, which keeps per Equations what it would redo on every call (numeric/_cache.py)."""

from __future__ import annotations

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.numeric import output_times


def _driven_rod(with_input: bool = False):
    """A bob on a rod driven by x = sin(t): the rod and the drive become dependent at t = pi/2."""
    m = lg.Model("driven-rod", coordinates=["x", "y"], parameters={"g": 9.81})
    m.add_particle(1, ("x", "y"), name="bob")
    m.add_gravity("g")
    m.add_constraint("x**2 + y**2 - 1", name="rod")
    m.add_constraint("x - sin(t)", name="drive")
    if with_input:
        m.input("F")
        m.add_generalized_force("y", "F")
    return lg.derive(m)


def _failed(eq, **options):
    with pytest.raises(lg.SimulationError, match=r"the constraints' Jacobian G loses rank at t = 1\.5708") as caught:
        lg.simulate(eq, t_end=3.0, initial={"x": 0.0, "y": -1.0}, **options)
    return caught.value


def test_a_failed_compiled_constrained_run_keeps_the_rows_the_scipy_run_keeps():
    eq = _driven_rod()
    compiled, scipy = _failed(eq, backend="numba").partial, _failed(eq, backend="scipy").partial
    assert compiled.stats["backend"] == "numba" and scipy.stats["backend"] == "scipy"
    assert len(compiled.t) == len(scipy.t) == 158 and np.array_equal(compiled.t, scipy.t)
    # the exact motion x = sin(t), y = -cos(t) on both, to the tolerance
    assert np.allclose(compiled["x"], np.sin(compiled.t), atol=1e-7)
    assert np.allclose(compiled["y"], -np.cos(compiled.t), atol=1e-7)
    assert np.max(np.abs(compiled.x - scipy.x)) < 1e-6
    # lambda by the compiled run's rule equals SciPy's (NumPy's solve at the same rows), the energy too
    assert np.max(np.abs(compiled.multipliers - scipy.multipliers)) < 1e-4 * (1 + np.max(np.abs(scipy.multipliers)))
    assert np.max(np.abs(compiled.energy - scipy.energy)) < 1e-6
    # the rule of a failed compiled run, with or without constraints: its status is its error's
    assert compiled.stats["status"] is lg.Status.SINGULAR_CONSTRAINTS and compiled.partial
    assert compiled.stats["constraint_drift"]["position"] < 1e-9 and compiled.stats["nfev"] > 0


def test_a_failed_compiled_sampled_run_keeps_the_held_inputs():
    eq = _driven_rod(with_input=True)
    options = {"inputs": {"F": "-y_dot"}, "sample_time": 0.25}
    compiled, scipy = (_failed(eq, backend=b, **options).partial for b in ("numba", "scipy"))
    assert len(compiled.t) == len(scipy.t) == 158
    k = np.floor(compiled.t / 0.25 + 1e-9).astype(int)  # F held at -y_dot of its sample instant 0, 0.25, ...
    samples = np.array([compiled["y_dot"][round(0.25 * j / 0.01)] for j in range(7)])
    assert np.allclose(compiled["F"], -samples[k], atol=1e-12)
    assert np.max(np.abs(compiled["F"] - scipy["F"])) < 1e-6


def _oscillator():
    m = lg.Model("forced", coordinates=["x"], parameters={"k": 4.0})
    m.add_particle(1, ("x", 0), name="mass")
    m.add_energy(V="k*x**2/2")
    m.input("F")
    m.add_generalized_force("x", "F")
    return lg.derive(m)


def test_what_simulate_keeps_per_equations_never_changes_an_answer():
    eq = _oscillator()
    runs = [dict(t_end=1.0, dt=0.1, inputs={"F": 1.0}), dict(t_end=2.0, dt=0.1, inputs={"F": 1.0}),
            dict(t_end=2.0, dt=0.05, inputs={"F": "2*sin(t)"}), dict(t_end=1.0, dt=0.1, inputs={"F": 2.0}),
            dict(t_end=1.0, dt=0.1, inputs={"F": 1.0})]
    kept = [lg.simulate(eq, **r) for r in runs]  # one Equations: its names, grid and input programs kept
    fresh = [lg.simulate(_oscillator(), **r) for r in runs]  # a new Equations for each
    for a, b, r in zip(kept, fresh, runs):
        assert np.array_equal(a.t, b.t) and np.array_equal(a.x, b.x) and np.array_equal(a.u, b.u)
        assert np.array_equal(a.t, output_times(r["t_end"], r["dt"]))
    # x'' = F - 4 x from rest: x = F/4 (1 - cos 2t) for a constant F
    assert np.allclose(kept[3]["x"], 0.5 * (1 - np.cos(2 * kept[3].t)), atol=1e-8)
    assert np.array_equal(kept[0].x, kept[4].x) and not np.array_equal(kept[0].x, kept[3].x)
    assert output_times(1.0, 0.1).flags.writeable  # the public function still returns a new array
