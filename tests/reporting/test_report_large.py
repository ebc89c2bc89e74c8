"""The report of a model too large to expand (issue 22: report whipple-bicycle): the Jacobi integral
written as q_dot^T M q_dot / 2 - L0 with the readable M, the constraints' g, G, c as the equations
give them (readable once, not again), the singular configuration of M diagnosed with the compiled
M(q): each equal to the derived expressions."""

from __future__ import annotations

import numpy as np
import pytest
import symengine as se

import lagrangian as lg


def _same(a, b, points: int = 3, seed: int = 3):
    a = [se.sympify(x) for x in a]
    b = [se.sympify(y) for y in b]
    symbols = sorted(set().union(*(e.free_symbols for e in a + b)), key=str)
    fa, fb = (se.Lambdify(symbols, exprs, real=True, cse=True) for exprs in (a, b))
    rng = np.random.default_rng(seed)
    for _ in range(points):
        x = rng.uniform(0.3, 1.7, len(symbols))
        got, want = (np.asarray(f(x), float).ravel() for f in (fa, fb))
        assert np.all(np.isfinite(want))
        assert np.allclose(got, want, rtol=1e-11, atol=1e-11 * (1 + np.abs(want).max()))


@pytest.fixture(scope="module")
def bicycle():
    eqs = lg.derive(lg.load("whipple-bicycle"))
    return eqs, lg.report(eqs, equilibria=False)


@pytest.mark.slow
def test_bicycle_report_jacobi_integral_equals_the_derived_one(bicycle):
    eqs, rep = bicycle
    assert eqs.too_large_to_expand
    _same([rep.expression("h")], [eqs._jacobi_se])


@pytest.mark.slow
def test_bicycle_report_constraints_equal_the_derived_ones(bicycle):
    eqs, rep = bicycle
    core, n = eqs.core, eqs.n
    g = [rep.math(f"constraint[{c.name}]").lhs for c in eqs.model.constraints]  # g = 0
    G = rep.expression("constraint-jacobian")
    c = rep.expression("c")
    m = len(g)
    _same([*g, *(G[k, j] for k in range(m) for j in range(n)), *c],
          [*core.g, *(core.G[k, j] for k in range(m) for j in range(n)), *core.c])


@pytest.mark.slow
def test_bicycle_singular_configuration_is_a_zero_of_the_inertia(bicycle):
    """The diagnosed direction has no inertia at the configuration found (M v = 0 there, to the six
    digits the direction is printed with)."""
    from lagrangian.equations._singular import singularities
    from lagrangian.numeric._compiled import compile_equations

    eqs, _ = bicycle
    conf = singularities(eqs).configurations[0]
    q = np.array([float(conf.where[c.name]) for c in eqs.coordinates])
    v = np.array([float(conf.null_velocity.get(d.name, 0)) for d in eqs.velocities])
    nm = compile_equations(eqs)
    M = nm.mass_matrix(0.0, np.concatenate((q, np.zeros(eqs.n))), np.zeros(len(eqs.inputs)), nm.parameter_values)
    assert np.max(np.abs(v)) == 1.0
    assert np.linalg.norm(M @ v) <= 1e-5 * np.linalg.norm(M) * np.linalg.norm(v)


@pytest.mark.slow
def test_bicycle_report_matrix_form_and_equations_equal_the_derived_ones(bicycle):
    """M, C, f and each Lagrange equation as the report shows them (derived parts made readable only
    where cheap) equal the derived expressions, and C is the Christoffel form of Equations.coriolis_matrix."""
    eqs, rep = bicycle
    core, n = eqs.core, eqs.n
    M, C, f = rep.expression("M"), rep.expression("C"), rep.expression("f")
    _same([M[i, j] for i in range(n) for j in range(n)], [core.M[i, j] for i in range(n) for j in range(n)])
    _same(list(f), list(core.f))
    _same([C[i, j] for i in range(n) for j in range(n)], list(eqs.coriolis_matrix))
    residuals = [rep.math(f"equation[{q.name}]").lhs for q in eqs.coordinates]
    _same(residuals, list(eqs._residuals_se))



@pytest.mark.slow
def test_bicycle_report_prints_expressions_up_to_its_own_limit(bicycle):
    """A model too large to expand is printed up to LARGE_MODEL_NODES nodes per expression (its larger
    ones, 20 to 70 KB of MathML each, took most of the printing time); the others up to MAX_NODES."""
    from lagrangian.reporting._build import LARGE_MODEL_NODES
    from lagrangian.reporting._printing import MAX_NODES, too_large

    _, rep = bicycle
    assert rep.max_nodes == LARGE_MODEL_NODES < MAX_NODES
    html = rep.to_html()
    assert f"(expression too large to print: more than {LARGE_MODEL_NODES} nodes; " in html
    for block in rep.math_blocks():
        shown = f'<div class="math" data-key="{block.key}">' in html
        assert shown == (too_large(block.parts(), LARGE_MODEL_NODES) is None), block.key
    assert lg.report("cart-pendulum", equilibria=False).max_nodes == MAX_NODES
