"""Steady motions (relative equilibria) against closed forms: the conical pendulum, circular Kepler
orbits, the heavy symmetric top; and each one checked by simulating it."""

import json
import math

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.cli import main

S = sympy.Symbol


@pytest.fixture(scope="module")
def spherical():
    return lg.derive(lg.load("spherical-pendulum"))


@pytest.fixture(scope="module")
def kepler():
    return lg.derive(lg.load("kepler"))


@pytest.fixture(scope="module")
def top():
    return lg.derive(lg.load("heavy-top"))


def _imag_parts(motion):
    return sorted(abs(z.imag) for z in motion.eigenvalues if abs(z.imag) > 0)


# ----------------------------------------------------------------------------- the spherical pendulum
@pytest.mark.parametrize("Omega", [3.5, 4.0, 7.0])
@pytest.mark.slow
def test_conical_pendulum_closed_form(spherical, Omega):
    g, l = 9.81, 1.0
    found = lg.steady_motions(spherical, {"phi_dot": Omega})
    cones = [s for s in found if 0 < abs(s.coordinates["theta"]) < 3]
    assert len(cones) == 2
    theta0 = math.acos(g / (l * Omega**2))
    for s in cones:
        assert abs(s.coordinates["theta"]) == pytest.approx(theta0, rel=1e-12)
        assert s.velocities == {"theta_dot": 0.0, "phi_dot": Omega}
        assert s.momenta["p_phi"] == pytest.approx(l**2 * math.sin(theta0) ** 2 * Omega, rel=1e-12)
        assert sympy.simplify(sympy.cos(s.exact["theta"]) - S("g") / (S("l") * S("phi_dot") ** 2)) == 0
        # small oscillations about the cone: omega**2 = Omega**2 (1 + 3 cos**2 theta0); the rest are zeros
        assert _imag_parts(s) == pytest.approx([Omega * math.sqrt(1 + 3 * math.cos(theta0) ** 2)] * 2, rel=1e-10)
        assert all(z.real == 0 for z in s.eigenvalues) and len(s.eigenvalues) == 4
        assert s.stability == "stable" and s.stable  # Routh: the amended potential has a minimum


@pytest.mark.slow
def test_below_the_critical_rate_only_the_poles_remain(spherical):
    found = lg.steady_motions(spherical, {"phi_dot": 2.0})  # 4 < g/l: no cone
    assert [s.coordinates["theta"] for s in found] == [0.0, pytest.approx(math.pi)]
    # at the poles of spherical coordinates M is singular (sin(pi)**2 = 1.5e-32 in floating point)
    assert all(s.stability == "undetermined (singular mass matrix)" for s in found)


@pytest.mark.slow
def test_the_rotating_pendulum_seen_from_its_spin(spherical):
    """The seed's rotating pendulum (Preumont Fig. 1.9) turns at the prescribed rate Omega; with the
    rotation free, the spherical pendulum turning at that rate has its equilibria as steady motions."""
    rotating = lg.derive(lg.load("rotating-pendulum"))
    for Omega in (3.0, 6.0, 9.0):
        prescribed = sorted(e.coordinates["theta"] for e in lg.equilibria(rotating, params={"Omega": Omega}))
        free = sorted(s.coordinates["theta"] for s in lg.steady_motions(spherical, {"phi_dot": Omega},
                                                                          params={"l": 0.5}))
        assert free == pytest.approx(prescribed, abs=1e-12)


@pytest.mark.slow
def test_a_steady_motion_stays_steady_when_simulated(spherical):
    (cone,) = [s for s in lg.steady_motions(spherical, {"phi_dot": 5.0}) if 0 < s.coordinates["theta"] < 3]
    traj = lg.simulate(spherical, t_end=5.0, initial={**cone.coordinates, **cone.velocities}, rtol=1e-12, atol=1e-12)
    assert np.abs(traj["theta"] - cone.coordinates["theta"]).max() < 1e-9
    assert np.abs(traj["phi_dot"] - 5.0).max() < 1e-9


# ----------------------------------------------------------------------------- Kepler
@pytest.mark.parametrize("omega", [0.5, 1.0, 2.0])
def test_circular_kepler_orbits(kepler, omega):
    mu = 3.0
    (orbit,) = lg.steady_motions(kepler, {"phi_dot": omega}, params={"mu": mu})
    r = orbit.coordinates["r"]
    assert r**3 * omega**2 == pytest.approx(mu, rel=1e-12)
    assert _imag_parts(orbit) == pytest.approx([omega, omega], rel=1e-10)  # the radial frequency is omega
    assert orbit.stability == "stable"


@pytest.mark.slow
def test_circular_orbit_at_a_fixed_angular_momentum(kepler):
    m, mu, h = 2.0, 3.0, 1.5
    (orbit,) = lg.steady_motions(kepler, momenta={"p_phi": h}, params={"m": m, "mu": mu})
    assert orbit.coordinates["r"] == pytest.approx(h**2 / (m**2 * mu), rel=1e-12)
    assert orbit.momenta["p_phi"] == pytest.approx(h, rel=1e-12)
    w = orbit.velocities["phi_dot"]
    assert orbit.coordinates["r"] ** 3 * w**2 == pytest.approx(mu, rel=1e-12)
    assert sympy.simplify(orbit.exact["r"] - S("p_phi") ** 2 / (S("m") ** 2 * S("mu"))) == 0
    assert sympy.simplify(orbit.exact_velocities["phi_dot"] - S("m") ** 3 * S("mu") ** 2 / S("p_phi") ** 3) == 0


@pytest.mark.slow
def test_no_angular_momentum_no_orbit(kepler):
    found = lg.steady_motions(kepler, momenta={"p_phi": 0.0})
    assert not found and any("ran away towards r" in n for n in found.notes)


# ----------------------------------------------------------------------------- the heavy top
def _precession_residual(top_params, theta, Omega, omega3):
    I1, I3, m, g, l = (top_params[k] for k in ("I1", "I3", "m", "g", "l"))
    return I1 * Omega**2 * math.cos(theta) - I3 * omega3 * Omega + m * g * l


@pytest.mark.slow
def test_heavy_top_steady_precession_at_given_rates(top):
    params = {k.name: v for k, v in top.parameters.items()}
    Omega, spin = 2.0, 50.0
    found = [s for s in lg.steady_motions(top, {"phi_dot": Omega, "psi_dot": spin})
             if 0 < abs(s.coordinates["theta"]) < 3]
    assert len(found) == 2
    for s in found:
        theta = s.coordinates["theta"]
        omega3 = spin + Omega * math.cos(theta)
        assert _precession_residual(params, theta, Omega, omega3) == pytest.approx(0, abs=1e-12)
        assert s.momenta["p_psi"] == pytest.approx(params["I3"] * omega3, rel=1e-12)


@pytest.mark.slow
def test_heavy_top_steady_precession_at_a_given_spin_momentum(top):
    params = {k.name: v for k, v in top.parameters.items()}
    Omega, p_psi = 2.0, 0.5  # I3 omega3 = p_psi: cos(theta) = (p_psi Omega - m g l) / (I1 Omega**2)
    found = [s for s in lg.steady_motions(top, {"phi_dot": Omega}, momenta={"p_psi": p_psi})
             if 0 < abs(s.coordinates["theta"]) < 3]
    assert [abs(s.coordinates["theta"]) for s in found] == pytest.approx(
        [math.acos((p_psi * Omega - 9.81 * 0.1) / (0.02 * 4))] * 2, rel=1e-12)
    for s in found:
        omega3 = p_psi / params["I3"]
        assert _precession_residual(params, s.coordinates["theta"], Omega, omega3) == pytest.approx(0, abs=1e-12)
        assert s.velocities["psi_dot"] + Omega * math.cos(s.coordinates["theta"]) == pytest.approx(omega3)
        traj = lg.simulate(top, t_end=2.0, initial={**s.coordinates, **s.velocities}, rtol=1e-12, atol=1e-12)
        assert np.abs(traj["theta"] - s.coordinates["theta"]).max() < 1e-8


@pytest.mark.slow
def test_eigenvalues_agree_with_finite_differences_of_the_state_equations(top):
    (s, *_) = [s for s in lg.steady_motions(top, {"phi_dot": 2.0, "psi_dot": 50.0}) if 0 < s.coordinates["theta"] < 3]
    f = lg.compile(top)  # x' = f(t, x, u, p), independent of the analysis' symbolic derivatives
    p = np.array(f.parameter_values, dtype=float)
    x0 = np.array([*s.coordinates.values(), *s.velocities.values()])
    n = len(x0)
    A = np.zeros((n, n))
    for j in range(n):
        h = 1e-6 * (1 + abs(x0[j]))
        e = np.zeros(n)
        e[j] = h
        A[:, j] = (f.rhs(0.0, x0 + e, np.zeros(0), p) - f.rhs(0.0, x0 - e, np.zeros(0), p)) / (2 * h)
    lam = np.linalg.eigvals(A)
    scale = np.abs(lam).max()
    for z in s.eigenvalues:  # each one is an eigenvalue of the finite-difference A, to its accuracy
        assert np.abs(lam - z).min() <= 1e-5 * scale
    for z in lam:
        assert np.abs(np.asarray(s.eigenvalues) - z).min() <= 1e-5 * scale


# ----------------------------------------------------------------------------- CLI and errors
@pytest.mark.slow
def test_cli_steady_json_contract(capsys):
    assert main(["steady", "spherical-pendulum", "--velocity", "phi_dot=4", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert isinstance(data, list) and len(data) == 4
    for item in data:
        assert {"coordinates", "velocities", "stable", "eigenvalues"} <= set(item)
        assert item["velocities"] == {"theta_dot": 0.0, "phi_dot": 4.0}
        assert all(len(z) == 2 for z in item["eigenvalues"])
    cones = [d for d in data if 0 < abs(d["coordinates"]["theta"]) < 3]
    assert [d["stable"] for d in cones] == [True, True]
    assert cones[0]["exact"]["theta"] == "-acos(g/(l*phi_dot**2))"


@pytest.mark.slow
def test_cli_steady_text_and_momentum(capsys):
    assert main(["steady", "kepler", "--momentum", "p_phi=1"]) == 0
    assert capsys.readouterr().out == (
        "Steady motions of kepler with p_phi = 1 (1):\n"
        "  r = p_phi**2/(m**2*mu) = 1, phi = 0 (any phi); phi_dot = m**3*mu**2/p_phi**3 = 1: stable\n")
    assert main(["steady", "kepler", "--momentum", "p_phi=0"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("Steady motions of kepler with p_phi = 0: none.\n")


@pytest.mark.parametrize("args, message", [
    (["spherical-pendulum", "--velocity", "theta_dot=1"],
     "[theta_dot]: theta is not cyclic (L depends on theta), so it cannot move at a constant rate in a "
     "steady motion; the cyclic coordinates' velocities are phi_dot"),
    (["spherical-pendulum", "--velocity", "phi_dt=1"],
     "[phi_dt]: 'phi_dt' is not a velocity of the model (did you mean 'phi_dot'?); the cyclic coordinates' "
     "velocities are phi_dot"),
    (["kepler", "--momentum", "p_r=1"], "[p_r]: r is not cyclic"),
    (["kepler", "--velocity", "phi_dot=1", "--momentum", "p_phi=2"],
     "[p_phi]: both phi_dot and p_phi are given: fix either the rate of phi or its momentum, not both"),
    (["double-pendulum", "--velocity", "theta1_dot=1"],
     "double-pendulum has no cyclic coordinate (one absent from L with no force on it), so its only steady "
     "motions are its equilibria (lagrangian equilibria)"),
    (["kepler", "--velocity", "phi_dot"],
     "--velocity 'phi_dot': expected NAME=VALUE, for example --velocity phi_dot=4"),
    (["kepler", "--velocity", "phi_dot=fast"], "--velocity phi_dot: 'fast' is not a number"),
    (["kepler", "--param", "mu=1", "--param", "nu=2", "--velocity", "phi_dot=1"],
     "[params.nu]: 'nu' is not a parameter of the model (did you mean 'mu'?)"),
])
def test_cli_steady_errors(capsys, args, message):
    assert main(["steady", *args]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_api_errors_collect_every_problem(kepler):
    with pytest.raises(lg.ModelError) as info:
        lg.steady_motions(kepler, {"r_dot": 1.0, "phi_dot": math.inf}, params={"mux": 1.0})
    text = str(info.value)
    assert "3 problems" in text and "r is not cyclic" in text
    assert "the value of 'phi_dot' must be a finite number" in text
    assert "'mux' is not a parameter of the model" in text
