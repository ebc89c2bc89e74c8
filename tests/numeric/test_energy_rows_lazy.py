"""The output stage's energy_rows (the Jacobi integral at many output rows at once, vectorized) is compiled
lazily (issue 20): a new model's first compile is its rhs and energy alone; its first runs evaluate the
energy row by row (the same numbers bit for bit), and energy_rows is compiled where numba's cache on disk
already holds it, or once the rows evaluated one by one have cost about as much as its compile
(numeric/_fast.py: EnergyRows, ENERGY_ROWS_AFTER)."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.numeric import _fast
from lagrangian.numeric._fast import compile_numba, kernels


def _same(a, b) -> None:
    """Two Trajectories of the same run: every array bit for bit, the same counts."""
    for name in ("t", "x", "energy"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name
    assert a.stats == b.stats


def test_the_rule_is_rent_or_buy_at_about_the_compiles_cost():
    # a double pendulum's energy row by row costs about 28 ns a row, energy_rows' compile 0.6-0.8 s: the
    # switch comes after about 2.5e7 rows (12,000 runs of its 2001 outputs), not after the first run
    assert 1e7 <= _fast.ENERGY_ROWS_AFTER <= 5e7


def test_energy_rows_compiled_lazily(monkeypatch):
    # not on disk (as for a new model): the first runs evaluate the energy row by row and count the rows; past
    # ENERGY_ROWS_AFTER energy_rows is compiled and the next runs (the repeated call's prepared kernel call
    # included) pass its address to the kernel; every run's Trajectory the same bit for bit
    monkeypatch.setattr(_fast, "_cached_cfunc", lambda function: False)
    monkeypatch.setattr(_fast, "ENERGY_ROWS_AFTER", 5000)
    k = kernels()
    real, passed = k.dop853, []

    def dop853(model, *args):
        passed.append(model[5])  # energy_rows' address, as the kernel gets it
        return real(model, *args)

    monkeypatch.setattr(k, "dop853", dop853)
    eqs = lg.derive(lg.load("double-pendulum"))
    cm = compile_numba(eqs)
    assert cm.energy_rows is not None and cm.energy_rows_address == 0 and cm.energy_rows.rows == 0
    runs = [lg.simulate(eqs, rtol=1e-8, atol=1e-8) for _ in range(3)]
    assert len(runs[0].t) == 2001 and passed == [0, 0, 0]
    assert cm.energy_rows.rows == 3 * 2001 and cm.energy_rows_address != 0  # the switch (6003 >= 5000)
    runs += [lg.simulate(eqs, rtol=1e-8, atol=1e-8) for _ in range(2)]
    assert passed[3:] == [cm.energy_rows_address] * 2 and cm.energy_rows.rows == 3 * 2001
    for tr in runs[1:]:
        _same(tr, runs[0])
    # the run without the repeated call's shortcut (another output grid) takes it too
    other = lg.simulate(eqs, rtol=1e-8, atol=1e-8, t_end=5.0)
    assert passed[-1] == cm.energy_rows_address
    assert other.energy.tobytes() == np.array([cm.energy(t, x, [], cm.parameter_values)
                                               for t, x in zip(other.t, other.x)]).tobytes()


def test_energy_rows_counts_only_below_the_threshold(monkeypatch):
    monkeypatch.setattr(_fast, "_cached_cfunc", lambda function: False)
    monkeypatch.setattr(_fast, "ENERGY_ROWS_AFTER", 100)
    cm = compile_numba(lg.derive(lg.load("double-pendulum")))
    rows = _fast.EnergyRows(cm.energy_rows.function, cm.energy_rows.signature)
    assert rows.address == 0 and rows.count(60) == 0 and rows.compiled is None
    address = rows.count(40)
    assert address != 0 and address == rows.address == rows.compile() and rows.rows == 100


@pytest.mark.slow
def test_a_new_models_first_compile_leaves_energy_rows_out():
    # a model never compiled on this machine: its energy_rows is not in numba's cache, so compile_numba does
    # not compile it (the 0.6-0.8 s it would add); compiled once, a later process finds it on disk and
    # loads it at once
    from lagrangian.examples import example_source

    tag = f"{os.getpid()}{time.time_ns() % 10**9}"
    path = __import__("tempfile").mkdtemp()
    model = os.path.join(path, "new.toml")
    with open(model, "w") as fh:
        fh.write(example_source("double-pendulum").replace("theta", f"lazy{tag}_"))
    eqs = lg.derive(lg.load(model))
    cm = compile_numba(eqs)
    assert cm.energy_rows.address == 0 and not _fast._cached_cfunc(cm.energy_rows.function)
    first = lg.simulate(eqs, rtol=1e-8, atol=1e-8)
    assert cm.energy_rows.rows == len(first.t) and cm.energy_rows_address == 0
    assert cm.energy_rows.compile() != 0
    assert _fast._cached_cfunc(cm.energy_rows.function)
    again = _fast.EnergyRows(cm.energy_rows.function, cm.energy_rows.signature)  # as a new process makes it
    assert again.address != 0 and again.rows == 0
    _same(lg.simulate(eqs, rtol=1e-8, atol=1e-8), first)
