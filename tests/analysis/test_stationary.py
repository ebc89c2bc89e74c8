"""Equilibria that are right or absent: the traps (forces that never vanish, roots at infinity,
non-isolated and degenerate roots, singular points, forces that underflow), each against what is
true of it."""

import json
import math

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.analysis import equilibria
from lagrangian.cli import main

S = sympy.Symbol


def derived(name, coords, T, V, params=None, **kw):
    return lg.derive(lg.Model(name, coordinates=coords, parameters=params or {}, T=T, V=V, **kw))


ATWOOD = dict(coords=["x"], T="m1*x_dot**2/2 + m2*x_dot**2/2 + J*(x_dot/r)**2/2", V="-(m1 - m2)*g*x",
              params={"m1": 2.0, "m2": 1.0, "J": 0.1, "r": 0.2, "g": 9.81})
INCLINE = dict(coords=["s"], T="3/4*m*s_dot**2", V="-m*g*s*sin(alpha)",
               params={"m": 1.0, "g": 9.81, "alpha": 0.3})


# ----------------------------------------------------------------------------- forces that never vanish
def test_atwood_machine_has_no_equilibrium_and_says_why():
    found = equilibria(derived("atwood", **ATWOOD))
    assert found == () and len(found) == 0
    assert found.notes == ("dV/dx = -g*(m1 - m2) is never 0 (-9.81 with these values; an equilibrium needs "
                           "g*(m1 - m2) = 0)",)
    assert found.text("atwood").startswith("Equilibria of atwood: none.\n  dV/dx = -g*(m1 - m2) is never 0")


def test_balanced_atwood_machine_rests_anywhere():
    (e,) = equilibria(derived("atwood", **ATWOOD), params={"m2": 2.0})
    assert e.family == ("x",) and e.coordinates == {"x": 0.0}
    assert [sympy.simplify(c.lhs - S("g") * (S("m1") - S("m2"))) for c in e.conditions] == [0]
    assert "[exists when g*(m1 - m2) = 0]" in e.text()


def test_disk_rolling_down_an_incline_has_no_equilibrium_unless_level():
    eqs = derived("incline", **INCLINE)
    found = equilibria(eqs)
    assert not found and found.notes[0].startswith("dV/ds = -g*m*sin(alpha) is never 0 (-2.89905 with these values")
    (level,) = equilibria(eqs, params={"alpha": 0.0})
    assert level.family == ("s",)


def test_a_constant_input_force_on_the_cart_leaves_no_equilibrium():
    eqs = lg.derive(lg.load("cart-pendulum"))
    found = equilibria(eqs, inputs={"F": 1.0})
    assert not found
    assert found.notes == ("the generalized force on q1 at rest, F, is never 0 (1 with these values)",)
    assert len(equilibria(eqs, inputs={"F": 0.0})) == 2


def test_cli_equilibria_of_the_atwood_machine(tmp_path, capsys):
    path = tmp_path / "atwood.toml"
    path.write_text('name = "atwood"\ncoordinates = ["x"]\n[parameters]\nm1 = 2.0\nm2 = 1.0\nJ = 0.1\nr = 0.2\n'
                    'g = 9.81\n[energy]\nT = "m1*x_dot**2/2 + m2*x_dot**2/2 + J*(x_dot/r)**2/2"\n'
                    'V = "-(m1 - m2)*g*x"\n')
    assert main(["equilibria", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == []
    assert main(["equilibria", str(path)]) == 0
    out = capsys.readouterr().out
    assert out == ("Equilibria of atwood: none.\n  dV/dx = -g*(m1 - m2) is never 0 (-9.81 with these values; "
                   "an equilibrium needs g*(m1 - m2) = 0)\n")
    assert "any x" not in out


# ----------------------------------------------------------------------------- roots at infinity
@pytest.mark.slow
def test_kepler_problem_has_no_equilibrium_and_reports_no_runaway_point():
    eqs = lg.derive(lg.load("kepler"))
    for exact in (True, False):
        found = equilibria(eqs, exact=exact)
        assert not found
        assert any(n.startswith("the numerical search from ") and n.endswith(" starting points found none")
                   for n in found.notes)
        assert any("ran away towards r = +-infinity" in n for n in found.notes)
    assert "SymPy finds no solution of -m*mu/r**2 = 0" in equilibria(eqs).notes


@pytest.mark.slow
def test_forces_that_vanish_only_at_infinity():
    assert not equilibria(derived("drift", ["x"], "x_dot**2/2", "exp(-x)"))
    # -2 x exp(-x**2) underflows to 0 (and so does its derivative) for |x| > 27: not roots
    found = equilibria(derived("well", ["x"], "x_dot**2/2", "-exp(-x**2)"))
    assert [e.coordinates["x"] for e in found] == [0.0] and found[0].stability == "stable"
    found = equilibria(derived("well", ["x"], "x_dot**2/2", "-exp(-x**2)"), exact=False)
    assert [e.coordinates["x"] for e in found] == [pytest.approx(0.0, abs=1e-9)]


# ----------------------------------------------------------------------------- non-isolated roots
def test_mexican_hat_ring_is_one_set_of_equilibria():
    found = equilibria(derived("hat", ["x", "y"], "(x_dot**2 + y_dot**2)/2", "a*(x**2 + y**2 - 1)**2", {"a": 1.0}))
    assert len(found) == 2
    top, ring = sorted(found, key=lambda e: e.dimension)
    assert top.coordinates == {"x": 0.0, "y": 0.0} and top.isolated and top.stability == "unstable"
    assert not ring.isolated and ring.dimension == 1 and ring.along == ()
    assert math.hypot(*ring.coordinates.values()) == pytest.approx(1.0, abs=1e-10)
    assert ring.stability == "stable"  # across the ring: K = 8a in the radial direction
    assert "(non-isolated: on a curve of equilibria)" in ring.text()
    assert ring.to_dict()["isolated"] is False and ring.to_dict()["dimension"] == 1


@pytest.mark.slow
def test_a_parabola_of_equilibria_is_not_any_x():
    (e,) = equilibria(derived("valley", ["x", "y"], "(x_dot**2 + y_dot**2)/2", "(y - x**2)**2"))
    assert e.dimension == 1 and e.along == ()  # tangent to the x axis at 0, but y = x**2 elsewhere
    assert e.coordinates["y"] == pytest.approx(e.coordinates["x"] ** 2, abs=1e-12)


@pytest.mark.slow
def test_a_sphere_of_equilibria_is_one_set_of_dimension_two():
    found = equilibria(derived("shell", ["x", "y", "z"], "(x_dot**2 + y_dot**2 + z_dot**2)/2",
                               "(x**2 + y**2 + z**2 - 1)**2"))
    assert sorted(e.dimension for e in found) == [0, 2]


def test_free_particle_in_polar_coordinates_rests_at_every_radius():
    (e,) = equilibria(derived("free", ["r", "phi"], "m/2*(r_dot**2 + r**2*phi_dot**2)", "0", {"m": 1.0}))
    assert e.family == ("phi",) and e.along == ("r",) and not e.isolated
    assert "(non-isolated: any r)" in e.text()


# ----------------------------------------------------------------------------- degenerate and singular points
@pytest.mark.parametrize("V, stability", [("x**4", "stable"), ("x**3", "unstable"), ("-x**4", "unstable"),
                                          ("x**6 + x**5", "unstable"), ("(1 - cos(x))**2", "stable")])
def test_degenerate_equilibrium_decided_by_the_first_nonzero_derivative(V, stability):
    found = equilibria(derived("flat", ["x"], "x_dot**2/2", V))
    e = next(e for e in found if e.coordinates["x"] == 0.0)
    assert e.stability == stability and e.stable == (stability == "stable")
    assert e.linear_model.K[0, 0] == 0.0  # the linearization alone says nothing


def test_degenerate_equilibrium_without_exact_root_is_undetermined_not_unstable():
    (e,) = equilibria(derived("flat", ["x"], "x_dot**2/2", "x**4"), exact=False)
    assert e.stability == "undetermined (degenerate: the linearization does not decide)" and not e.stable
    # the linearization itself has a defective zero eigenvalue and calls itself unstable
    assert e.linear_model.stability == "unstable"


@pytest.mark.slow
def test_rotating_pendulum_at_its_critical_speed_is_stable_at_the_bottom():
    eqs = lg.derive(lg.load("rotating-pendulum"))
    bottom = next(e for e in equilibria(eqs, params={"Omega": math.sqrt(9.81 / 0.5)}) if e.coordinates["theta"] == 0)
    assert bottom.stability == "stable"  # f = -m g l theta**3/2 + ...: restoring, of order 3


def test_origin_of_polar_coordinates_is_a_singular_point():
    (e,) = equilibria(derived("well", ["r", "phi"], "m/2*(r_dot**2 + r**2*phi_dot**2)", "k*r**2/2",
                              {"m": 1.0, "k": 2.0}))
    assert e.coordinates == {"r": 0.0, "phi": 0.0} and e.stability == "undetermined (singular mass matrix)"
    assert not e.stable and e.linear_model is None


@pytest.mark.slow
def test_the_zoo_has_no_notes_and_the_same_answers():
    for name, count in [("double-pendulum", 4), ("rotating-pendulum", 2), ("mck", 1), ("cart-pendulum", 2),
                        ("sliding-mass-pendulum", 4), ("pendulum-chain-3", 8), ("spherical-pendulum", 2)]:
        found = equilibria(lg.derive(lg.load(name)))
        assert len(found) == count and found.notes == (), name


def test_equilibria_are_roots_to_the_scale_of_the_forces():
    eqs = lg.derive(lg.load("pendulum-chain-3"))
    nm = lg.compile(eqs, backend="scipy")
    for e in equilibria(eqs, params={"g": 1e-6}):  # tiny forces: the tolerance scales with them
        f, _ = nm.static(0.0, np.array(list(e.coordinates.values())), np.zeros(0), np.array([1.0, 1.0, 1e-6]))
        assert np.abs(f).max() <= 1e-18


def test_a_search_sympy_did_not_solve_says_there_may_be_others():
    found = equilibria(lg.derive(lg.load("pendulum-chain-5")))
    assert len(found) == 32  # every 0/pi combination is a start
    assert found.notes == ("found by a numerical search from 176 starting points, SymPy not having solved for "
                           "the equilibria: there may be others",)
    assert found.text("chain").endswith("\n  note: " + found.notes[0])
