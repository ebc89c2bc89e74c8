"""The compiled kernels as a module (numeric/_kernels_numba.py): DOP853's named coefficients are
SciPy's table, entry for entry, and satisfy the method's invariants; the integrators take their
problem as a few small tuples; and the output stage (the inputs and the Jacobi integral at the
output times, evaluated in the compiled loop) gives the numbers of the second pass it replaces."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.numeric._fast import (
    compile_numba,
    inputs_and_energy,
    kernels,
    run_dop853,
)
from lagrangian.numeric._inputs import constant_programs


def _tableau():
    from scipy.integrate._ivp import dop853_coefficients as c

    return c.A, c.C, c.E3, c.E5, c.D


def test_the_named_coefficients_are_scipys_table_entry_for_entry():
    A, C, E3, E5, D = _tableau()
    K = vars(kernels())
    named = {name for name in K if name[:1] in "ACDE" and name[1:2].isdigit()}
    expected = set()
    for s in range(1, 16):
        assert K[f"C{s}"] == C[s]
        for j in range(s):
            if A[s, j] != 0.0:
                assert K[f"A{s}_{j}"] == A[s, j], (s, j)
                expected.add(f"A{s}_{j}")
        expected.add(f"C{s}")
    for prefix, row in (("E5", E5), ("E3", E3)):
        for j in np.nonzero(row)[0]:
            assert K[f"{prefix}_{j}"] == row[j]
            expected.add(f"{prefix}_{j}")
    for r in range(4):
        for j in np.nonzero(D[r])[0]:
            assert K[f"D{r + 3}_{j}"] == D[r, j]
            expected.add(f"D{r + 3}_{j}")
    assert named == expected  # a constant for every non-zero coefficient, and no other


def test_the_tableau_s_invariants():
    """Row sums of the stages equal their nodes (c_s = sum_j a_sj), the solution's weights sum to 1
    and the error estimators annihilate constants (their weights sum to 0)."""
    K = vars(kernels())
    for s in range(1, 16):
        row = [v for name, v in K.items() if name.startswith(f"A{s}_")]
        assert sum(row) == pytest.approx(K[f"C{s}"], abs=4e-16 * sum(map(abs, row))), s  # to rounding
    assert K["C12"] == 1.0
    for prefix in ("E5", "E3"):
        row = [v for name, v in K.items() if name.startswith(prefix + "_")]
        assert sum(row) == pytest.approx(0.0, abs=4e-16 * sum(map(abs, row)))


def test_the_integrators_take_a_few_small_tuples():
    K = kernels()
    assert len(inspect.signature(K.dop853.py_func).parameters) == 9  # was 35
    assert len(inspect.signature(K.dop853_batch.py_func).parameters) == 10  # was 21
    assert len(inspect.signature(K.variational.py_func).parameters) == 9  # was 16


def test_the_kernels_are_the_module_s_own_text():
    """kernels() loads a copy of _kernels_numba.py (named by its hash) from the cache folder: the
    project's own code, nothing generated from a model."""
    from pathlib import Path

    from lagrangian.numeric import _kernels

    text = (Path(_kernels.__file__).with_name("_kernels_numba.py")).read_text(encoding="utf-8")
    assert _kernels.kernel_source() == text
    assert Path(kernels().__file__).read_text(encoding="utf-8") == text


@pytest.mark.parametrize("name, inputs", [
    ("double-pendulum", {}),
    ("cart-pendulum", {"F": "where(q1 > 0, clip(-3*q1_dot, -1, 1), 2.5*sign(sin(t))) - 41*(q2 - pi/2)"}),
])
def test_the_output_stage_in_the_loop_equals_the_second_pass(name, inputs):
    from lagrangian.model._expr import parse_expression
    from lagrangian.numeric._inputs import programs

    eqs = lg.derive(lg.load(name))
    cm = compile_numba(eqs)
    names = {"t": eqs.t, **{s.name: s for s in (*eqs.coordinates, *eqs.velocities, *eqs.parameters)}}
    laws = [parse_expression(inputs[u.name], names, feedback=True) for u in eqs.inputs]
    prog = (programs(laws, eqs.t, list(eqs.parameters), states=(*eqs.coordinates, *eqs.velocities))
            if inputs else constant_programs(np.zeros(len(cm.input_names))))
    assert prog.nswitch == (2 if inputs else 0)
    x0 = np.array([0.3, 1.4, 0.0, 0.0]) if name == "cart-pendulum" else np.array([2.0, 2.5, 0.0, 0.0])
    times = np.linspace(0.0, 3.0, 301)
    raw = run_dop853(cm, x0, times, cm.parameter_values, prog, 1e-9, 1e-9)
    assert raw.status == 0 and raw.u.shape == (301, len(cm.input_names)) and raw.energy.shape == (301,)
    U, E = inputs_and_energy(cm, times, raw.x, cm.parameter_values, prog)  # the second pass, as before
    assert np.array_equal(raw.u, U) and np.array_equal(raw.energy, E)
    assert inputs_and_energy(cm, times, raw.x, cm.parameter_values, prog, run=raw)[1] is not None
    off = run_dop853(cm, x0, times, cm.parameter_values, prog, 1e-9, 1e-9, outputs=False)
    assert off.u is None and off.energy is None
    assert np.array_equal(off.x, raw.x) and off.nfev == raw.nfev  # the same steps either way
    if name == "double-pendulum":  # conservative: the Jacobi integral is the energy, conserved
        assert np.ptp(raw.energy) < 1e-6 * abs(raw.energy[0])


def test_the_output_stage_covers_the_rows_before_an_event_stop():
    eqs = lg.derive(lg.load("double-pendulum"))
    tr = lg.simulate(eqs, 5.0, {"theta1": 0.5, "theta2": 0.0}, events={"a": "theta1"}, stop_on="a")
    assert tr.stats["stopped_by"] == "a" and len(tr.t) < 501
    cm = compile_numba(eqs)
    p = cm.parameter_values
    E = [cm.energy(t, x, [], p) for t, x in zip(tr.t, tr.x)]
    assert np.allclose(tr.energy, E, rtol=1e-14, atol=1e-14)
