"""The code generator's walks over expressions visit each shared subexpression once (numeric/_codegen): a spatial
chain's positions share subexpressions down the chain, and a walk over them as trees grows exponentially with the
depth (numba_source of a 6-rod chain took 157 s of CPU in SymEngine's atoms() and str(), 4 s with these walks)."""

from __future__ import annotations

import symengine as se

from lagrangian.numeric import _codegen


def _shared(depth):
    """An expression of `depth` levels, each using the level below three times: 3^depth nodes as a tree."""
    x, y = se.symbols("x y")
    e = x
    for k in range(depth):
        e = se.sin(e) * e + se.cos(e + y) + k
    return e


def test_atoms_and_tree_size_agree_with_the_tree_walk_where_it_is_cheap():
    e = _shared(4)
    assert _codegen._atoms([e], se.sin, se.cos) == e.atoms(se.sin, se.cos)
    assert _codegen._atoms([e, se.Symbol("z")], se.Symbol) == {*e.atoms(se.Symbol), se.Symbol("z")}

    def tree(e):
        return 1 + sum(tree(a) for a in e.args)

    assert _codegen._tree_size([e], 10**9) == tree(e)
    assert _codegen._tree_size([e, e], 10**9) == 2 * tree(e)
    assert _codegen._tree_size([e], 100) == 101  # counting stops past the bound


def test_walks_of_a_deeply_shared_expression_finish():
    e = _shared(60)  # 3^60 nodes as a tree: a tree walk would never finish
    assert len(_codegen._atoms([e], se.sin)) == 60
    assert _codegen._tree_size([e], 20000) == 20001
    assert _codegen._steps(e) is e  # no Piecewise: kept as it is


def test_steps_rewrites_each_shared_one_sided_term_once():
    x = se.Symbol("x")
    step = se.Piecewise((x**2, se.StrictLessThan(x, 1)), (se.Integer(0), se.true))
    e = step
    for _ in range(12):  # 2^12 occurrences of the Piecewise as a tree
        e = e * e + e
    out = _codegen._steps(e)
    assert not _codegen._atoms([out], se.Piecewise)
    s = _codegen._STEP(1 - x)
    expected = x**2 * s
    for _ in range(12):
        expected = expected * expected + expected
    assert out == expected
