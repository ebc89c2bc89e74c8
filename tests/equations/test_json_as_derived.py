"""The JSON of a model too large to expand (issue 22: the bicycle's ``derive --json`` and /api/derive
in about 2 s instead of 10): the entries of M, f, the equations, the constraints and the conserved
quantities printed as derived by SymEngine (SymPy syntax), equal to the derived expressions; the
same keys in the same order as for any model; small models as before (tests/model pin them)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import symengine as se

import lagrangian as lg

MODELS = Path(__file__).resolve().parents[1] / "models"
KEYS = ["name", "coordinates", "velocities", "accelerations", "parameters", "inputs", "mass_matrix", "forcing",
        "equations", "kinetic_coenergy", "potential_energy", "dissipation", "generalized_forces", "linear",
        "conserved_quantities", "constraints", "multipliers"]


def assert_same(pairs, points: int = 3, seed: int = 5):
    """Each (text, SymEngine expression) equal at random points (all symbols in 0.3 .. 1.7)."""
    a = [se.sympify(x) for x, _ in pairs]
    b = [se.sympify(y) for _, y in pairs]
    symbols = sorted(set().union(*(e.free_symbols for e in a + b)), key=str)
    fa, fb = (se.Lambdify(symbols, exprs, real=True, cse=True) for exprs in (a, b))
    rng = np.random.default_rng(seed)
    for _ in range(points):
        x = rng.uniform(0.3, 1.7, len(symbols))
        got, want = (np.asarray(f(x), float).ravel() for f in (fa, fb))
        assert np.all(np.isfinite(want))
        assert np.allclose(got, want, rtol=1e-11, atol=1e-11 * (1 + np.abs(want).max()))


def _residuals(eqs):
    core, n = eqs.core, eqs.n
    qdd = [se.Symbol(a.name) for a in eqs.accelerations]
    lam = [se.Symbol(m.name) for m in eqs.multipliers]
    return [sum((core.M[i, j] * qdd[j] for j in range(n)), se.Integer(0)) - core.f[i]
            - sum((core.G[k, i] * lam[k] for k in range(len(lam))), se.Integer(0)) for i in range(n)]


def _check(eqs):
    d = json.loads(eqs.to_json())
    assert list(d) == KEYS
    core, n = eqs.core, eqs.n
    pairs = [(d["mass_matrix"][i][j], core.M[i, j]) for i in range(n) for j in range(n)]
    pairs += [(d["forcing"][i], core.f[i]) for i in range(n)]
    pairs += list(zip(d["equations"], _residuals(eqs)))
    h = eqs._jacobi_se
    pairs += [(v, h) for k, v in d["conserved_quantities"].items() if k in ("energy", "jacobi_integral")]
    for k, c in enumerate(d["constraints"]):
        pairs += [(c["expression"], core.g[k]), (c["acceleration"], core.c[k])]
        pairs += [(c["jacobian"][j], core.G[k, j]) for j in range(n)]
    assert_same(pairs)
    return d


@pytest.fixture(scope="module")
def chain3():
    return lg.derive(lg.load(str(MODELS / "spatial-chain-3.toml")))


def test_spatial_chain_json_keys_and_entries_as_derived(chain3):
    """Quick: the keys, and M's corner and f's first entry are SymEngine's text of the derived ones."""
    assert chain3.too_large_to_expand
    d = chain3.to_dict()
    assert list(d) == KEYS
    assert d["mass_matrix"][0][0] == str(chain3.core.M[0, 0])
    assert d["forcing"][0] == str(chain3.core.f[0])
    assert d["equations"][0] == str(_residuals(chain3)[0])  # M q_ddot - f, built as the derivation does


@pytest.mark.slow
def test_spatial_chain_json_is_printed_as_derived_and_equal(chain3):
    eqs = chain3
    d = _check(eqs)
    assert set(d["conserved_quantities"]) == set(eqs.conserved_quantities)
    assert d["constraints"] == [] and d["multipliers"] == []
    # the small entries are the same readable text as for any model
    assert d["potential_energy"] == str(eqs.readable(eqs.core.V))


def test_small_model_json_unchanged_by_the_derived_path():
    eqs = lg.derive(lg.load("double-pendulum"))
    assert not eqs.too_large_to_expand
    d = eqs.to_dict()
    assert list(d) == KEYS
    assert d["mass_matrix"][0][0] == str(eqs.mass_matrix[0, 0])  # the readable form, SymPy's printer


@pytest.mark.slow
def test_bicycle_json_is_printed_as_derived_and_equal():
    eqs = lg.derive(lg.load("whipple-bicycle"))
    d = _check(eqs)
    assert [c["name"] for c in d["constraints"]] == [c.name for c in eqs.model.constraints]
    assert [c["kind"] for c in d["constraints"]] == [c.kind for c in eqs.model.constraints]
    assert d["multipliers"] == [m.name for m in eqs.multipliers]
