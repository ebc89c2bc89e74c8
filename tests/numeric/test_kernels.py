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


@pytest.mark.parametrize("name", ["double-pendulum", "cart-pendulum", "mck", "kepler"])
def test_energy_rows_gives_the_energy_of_each_row_bit_for_bit(name):
    # the generated energy_rows (the output stage's energy, vectorized over the rows) against the energy
    # row by row: the same operations in the same order, so the same numbers; a row with an angle past the
    # sin/cos polynomial's bound (1e5) or not finite is left to the energy (libm's sin and cos)
    eqs = lg.derive(lg.load(name))
    cm = compile_numba(eqs)
    address = cm.energy_rows.compile()  # (compiled lazily: see test_energy_rows_compiled_lazily)
    assert address != 0 and cm.energy_rows_address == address
    rng = np.random.default_rng(3)
    n, m = cm.n, len(cm.input_names)
    X = rng.uniform(-3.0, 3.0, (203, 2 * n))
    X[7, 0], X[100, n - 1], X[150, n], X[151, n] = 2e5, -3e7, np.nan, np.inf  # (energy: a function of q_dot)
    times = np.linspace(0.0, 2.0, len(X))
    prog = constant_programs(np.full(m, 0.7))
    p = cm.parameter_values
    E = {}
    for er in (cm.energy_rows_address, 0):
        E[er] = np.empty(len(X))
        U = np.empty((len(X), m))
        kernels().energies((cm.energy_address, er), times, X, p, prog.ops, prog.args, prog.starts, prog.nstack,
                           E[er], U, np.zeros(max(1, m), np.int64))
        assert np.all(U == 0.7)
    assert np.array_equal(E[cm.energy_rows_address], E[0], equal_nan=True)
    assert np.isfinite(E[0][7]) and np.isfinite(E[0][100]) and np.isnan(E[0][150])
    assert E[0][5] == pytest.approx(cm.energy(times[5], X[5], np.full(m, 0.7), p), rel=1e-15)


def test_the_output_stage_in_blocks_of_rows_equals_the_energy_row_by_row():
    # dop853 evaluates the outputs' energy OUTPUT_BLOCK rows at a time (and the rest at the end): every
    # count of rows, fewer than a block, a block and some, gives the energy of each row
    from lagrangian.numeric._kernels_numba import OUTPUT_BLOCK

    eqs = lg.derive(lg.load("double-pendulum"))
    cm = compile_numba(eqs)
    assert cm.energy_rows.compile() != 0  # (compiled lazily: see test_energy_rows_compiled_lazily)
    p = cm.parameter_values
    x0 = np.array([2.0, 2.5, 0.0, 0.0])
    for rows in (2, OUTPUT_BLOCK - 1, OUTPUT_BLOCK, OUTPUT_BLOCK + 1, 3 * OUTPUT_BLOCK + 5):
        times = np.linspace(0.0, 2.0, rows)
        raw = run_dop853(cm, x0, times, p, constant_programs([]), 1e-9, 1e-9)
        E = [cm.energy(t, x, [], p) for t, x in zip(times, raw.x)]
        assert raw.status == 0 and np.array_equal(raw.energy, E)


def test_a_larger_model_has_no_energy_rows():
    # past ENERGY_ROWS_MAX coordinates the energy is a small part of a run: no energy_rows (compiled for
    # nothing), the kernels call the energy row by row
    from lagrangian.numeric._codegen import ENERGY_ROWS_MAX, numba_source

    assert "def energy_rows(" not in numba_source(lg.derive(lg.load(f"pendulum-chain-{ENERGY_ROWS_MAX + 1}")))
    assert "def energy_rows(" in numba_source(lg.derive(lg.load(f"pendulum-chain-{ENERGY_ROWS_MAX}")))


def test_the_interpolants_coefficients_written_out_in_dop853_are_the_functions_lines():
    # dop853 has _dense_coefficients' lines written out where a step with outputs needs them (a call, or
    # numba's inlining, costs a sixth of the output stage): the two must stay the same text
    from pathlib import Path

    from lagrangian.numeric import _kernels

    text = (Path(_kernels.__file__).with_name("_kernels_numba.py")).read_text(encoding="utf-8")
    start = text.index("def _dense_coefficients(")
    body = text[text.index("    # stage 13\n", start):text.index("\n\n\n", start)]
    written = "\n".join(("        " + line) if line.strip() else line for line in body.split("\n"))
    dop = text[text.index("def dop853("):text.index("def _single_run(")]
    # (the body: the three stages and the coefficients, now one call of _coefficients, LANES states at a time)
    assert len(body.splitlines()) > 20 and written in dop
    assert [f"_ptr(K, {s} * nx)" in body for s in (13, 14, 15)] == [True] * 3 and "_coefficients(" in body


def _special_values(rng, shape):
    """Random doubles of all sizes with signed zeros, subnormals, infinities and NaN among them."""
    a = rng.standard_normal(shape) * 10.0 ** rng.integers(-300, 300, shape)
    special = np.array([0.0, -0.0, 5e-324, -5e-324, np.inf, -np.inf, np.nan, 1.0, -1.0])
    mask = rng.random(shape) < 0.2
    a[mask] = rng.choice(special, mask.sum())
    return a


@pytest.mark.parametrize("nx", [1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 40])
def test_the_dense_output_four_states_at_a_time_has_the_float_formulas_bits(nx):
    # the interpolant's coefficients and its value at an output are computed LANES (4) states at a time as
    # <4 x double> (the intrinsics emit the formulas' operations in their order, no fast-math); every lane,
    # and the states past the last whole block of 4, must have the bits of the same formula on Python floats
    from numba import njit

    k = kernels()
    assert k.LANES == 4

    @njit
    def dense(K, y, ynew, h, s, F, out):
        n = y.shape[0]
        k._coefficients(k._ptr(K, 0), n, k._ptr(y, 0), k._ptr(ynew, 0), h, k._ptr(F, 0))
        k._interpolate(k._ptr(F, 0), n, k._ptr(y, 0), s, 1.0 - s, k._ptr(out, 0))

    rng = np.random.default_rng(nx)
    for trial in range(6):
        K, y, ynew = _special_values(rng, (16, nx)), _special_values(rng, nx), _special_values(rng, nx)
        if trial % 2:  # ordinary numbers too (the special ones make most results NaN)
            K, y, ynew = rng.standard_normal((16, nx)), rng.standard_normal(nx), rng.standard_normal(nx)
        h, s = float(rng.uniform(1e-3, 1.0)), float(rng.uniform(0.0, 1.0))
        F, out = np.full((7, nx), 7.0), np.full(nx, 7.0)
        dense(K, y, ynew, h, s, F, out)
        for i in range(nx):
            col = [float(K[j, i]) for j in (0, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)]
            expected = k.coefficients(h, float(ynew[i]) - float(y[i]), *col)
            assert _same_bits(F[:, i], expected), (trial, i)
            value = k.interpolant(float(y[i]), *(float(f) for f in F[:, i]), s, 1.0 - s)
            assert _same_bits(out[i:i + 1], [value]), (trial, i)
        # and the rows of dop853 (_dense_row) equal the one-state-at-a-time _dense it stands for
        X, row = np.empty((2, nx)), np.empty(nx)
        k._dense(0.0, h, y, F, s * h, row)
        _dense_row_of(k)(0.0, h, y, F, s * h, X, 1)
        assert _same_bits(X[1], row)


def _same_bits(a, b) -> bool:
    """The same doubles bit for bit (signed zeros told apart), NaN where the other is NaN (of any sign and
    payload: the processor's, as the operands' order in an addition, which the compiler may swap, decides)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    nan = np.isnan(a)
    return bool((nan == np.isnan(b)).all()) and a[~nan].tobytes() == b[~nan].tobytes()


def _dense_row_of(k):
    from numba import njit

    @njit
    def call(t, h, y, F, tq, X, j):
        k._dense_row(t, h, y, F, tq, X, j)

    return call


def test_the_dense_output_uses_four_lane_vectors():
    # the coefficients' and the rows' arithmetic is <4 x double> in dop853's compiled code (numba's own loop
    # vectorizer would take 8 states at a time: a double pendulum's 4 ran one by one)
    k = kernels()
    from numba import njit

    @njit
    def dense(K, y, ynew, h, s, F, out):
        n = y.shape[0]
        k._coefficients(k._ptr(K, 0), n, k._ptr(y, 0), k._ptr(ynew, 0), h, k._ptr(F, 0))
        k._interpolate(k._ptr(F, 0), n, k._ptr(y, 0), s, 1.0 - s, k._ptr(out, 0))

    dense(np.ones((16, 4)), np.ones(4), np.ones(4), 0.1, 0.5, np.empty((7, 4)), np.empty(4))
    llvm = dense.inspect_llvm(dense.signatures[0])
    assert llvm.count("fmul <4 x double>") >= 4 * 12 + 7 and llvm.count("fadd <4 x double>") >= 7
