"""Every worked example of the seeds, against the equations printed in the seed.

Each seed example exists twice in the model zoo: built from elements (the slides' recipe:
bodies and positions) and from the textbook's energies. Both must give the textbook's equations.
"""

import math

import pytest
import sympy
from sympy import cos, sin

import lagrangian as lg

S = sympy.Symbol


def residuals(name):
    eqs = lg.derive(lg.load(name))
    return eqs, eqs.equations


# --------------------------------------------------------------- Preumont 1.7.3
q1, q2, q1d, q2d, q1dd, q2dd = (S(n) for n in ("q1", "q2", "q1_dot", "q2_dot", "q1_ddot", "q2_ddot"))
m, k, g, I, Mr, l = (S(n) for n in ("m", "k", "g", "I", "Mr", "l"))

# "d/dt(m q1^2 q2_dot) + m g q1 sin q2 = 0" and "m q1_ddot - m q1 q2_dot^2 - m g cos q2 + k q1 = 0"
SLIDING_Q1 = m * q1dd - m * q1 * q2d**2 - m * g * cos(q2) + k * q1
SLIDING_Q2 = m * q1**2 * q2dd + 2 * m * q1 * q1d * q2d + m * g * q1 * sin(q2)


@pytest.mark.parametrize("name", ["sliding-mass-pendulum", "sliding-mass-pendulum-energy"])
def test_pendulum_with_sliding_point_mass(name, same):
    eqs, (E1, E2) = residuals(name)
    same(E1, SLIDING_Q1, "equation of q1")
    same(E2, SLIDING_Q2, "equation of q2")
    same(eqs.T, m / 2 * (q1d**2 + q2d**2 * q1**2), "T*")
    same(eqs.V, -m * g * q1 * cos(q2) + k * q1**2 / 2, "V")


@pytest.mark.parametrize("name", ["sliding-disk-pendulum", "sliding-disk-pendulum-energy"])
def test_pendulum_with_sliding_disk(name, same):
    # the disk adds I q2_dot^2 / 2 to T*, so I q2_ddot to the equation of q2
    _, (E1, E2) = residuals(name)
    same(E1, SLIDING_Q1, "equation of q1")
    same(E2, SLIDING_Q2 + I * q2dd, "equation of q2")


@pytest.mark.parametrize("name", ["sliding-disk-heavy-rod", "sliding-disk-heavy-rod-energy"])
def test_sliding_disk_on_heavy_rod(name, same):
    # the rod adds I_O q2_dot^2/2 with I_O = Mr l^2/3, and -Mr g l cos(q2)/2 to V
    _, (E1, E2) = residuals(name)
    same(E1, SLIDING_Q1, "equation of q1")
    same(E2, SLIDING_Q2 + I * q2dd + Mr * l**2 / 3 * q2dd + Mr * g * l / 2 * sin(q2), "equation of q2")


# --------------------------------------------------------------- Preumont 1.7.4
th, thd, thdd, Om = S("theta"), S("theta_dot"), S("theta_ddot"), S("Omega")


@pytest.mark.parametrize("name", ["rotating-pendulum", "rotating-pendulum-energy"])
def test_rotating_pendulum(name, same):
    eqs, (E,) = residuals(name)
    # L = m/2 [(l th')^2 + (l Omega sin th)^2] + g m l cos th
    same(eqs.L, m / 2 * ((l * thd)**2 + (l * Om * sin(th))**2) + g * m * l * cos(th), "L")
    same(E, m * l**2 * thdd - m * l**2 * Om**2 * sin(th) * cos(th) + m * g * l * sin(th), "equation")
    # T0 = m/2 (l Omega sin th)^2 is the potential of the centrifugal forces
    same(eqs.centrifugal_forces[0], m * l**2 * Om**2 * sin(th) * cos(th), "centrifugal force")
    same(eqs.gyroscopic_matrix, sympy.zeros(1, 1), "no gyroscopic term")
    same(eqs.rheonomic_forces, sympy.zeros(1, 1), "T* of the elements depends on t only through T0")


def test_rotating_pendulum_elements_position_depends_on_time():
    eqs = lg.derive(lg.load("rotating-pendulum"))
    assert lg.t in eqs.model.elements[1].position[0].free_symbols
    assert not eqs.explicit_time  # the spin drops out of L: sin^2(Omega t) + cos^2(Omega t) = 1
    assert eqs.is_scleronomic
    assert lg.derive(lg.load("rotating-pendulum-energy")).is_conservative


# --------------------------------------------------------------- Preumont 1.7.1-1.7.2
def test_linear_mck_system_with_dissipation_function(same):
    m1, m2, k1, k2, c1, c2, f = (S(n) for n in ("m1", "m2", "k1", "k2", "c1", "c2", "f"))
    for name in ("mck", "mck-elements"):
        lin = lg.derive(lg.load(name)).linear
        assert lin is not None, name
        same(lin.M, sympy.diag(m1, m2), f"{name} M")
        same(lin.C, sympy.Matrix([[c1 + c2, -c2], [-c2, c2]]), f"{name} C")
        same(lin.K, sympy.Matrix([[k1 + k2, -k2], [-k2, k2]]), f"{name} K")
        same(lin.f, sympy.Matrix([0, f]), f"{name} f")


# --------------------------------------------------------------- Bona, slides 7-15
Mb, L, G = S("M"), S("L"), S("g")


@pytest.mark.parametrize("name", ["cart-pendulum-massless", "cart-pendulum-massless-energy"])
def test_cart_with_inverted_pendulum_point_mass_slide_11(name, same):
    eqs, (E1, E2) = residuals(name)
    # slide 7: K* = M/2 (q1'^2 + L^2 q2'^2 - 2 L sin q2 q1' q2'), P = M G L (1 + sin q2)
    same(eqs.T, Mb / 2 * (q1d**2 + L**2 * q2d**2 - 2 * L * sin(q2) * q1d * q2d), "K*")
    same(eqs.V, Mb * G * L * (1 + sin(q2)), "P")
    # slide 11
    same(E1, Mb * q1dd - Mb * L * sin(q2) * q2dd - Mb * L * cos(q2) * q2d**2, "equation 1")
    same(E2, Mb * L**2 * q2dd - Mb * L * sin(q2) * q1dd + Mb * G * L * cos(q2), "equation 2")
    # slide 14: H, C, G and det H
    same(eqs.mass_matrix, [[Mb, -Mb * L * sin(q2)], [-Mb * L * sin(q2), Mb * L**2]], "H")
    same(eqs.coriolis_matrix, [[0, -Mb * L * cos(q2) * q2d], [0, 0]], "C")
    same(eqs.potential_gradient, [0, Mb * G * L * cos(q2)], "G")
    same(eqs.mass_matrix.det(), Mb**2 * L**2 - Mb**2 * L**2 * sin(q2)**2, "det H")


@pytest.mark.parametrize("name", ["cart-pendulum", "cart-pendulum-energy"])
def test_cart_with_mass_and_force_slide_15(name, same):
    M1, M2, F = S("M1"), S("M2"), S("F")
    eqs, (E1, E2) = residuals(name)
    H = sympy.Matrix([[M1 + M2, -M2 * L * sin(q2)], [-M2 * L * sin(q2), M2 * L**2]])
    same(eqs.mass_matrix, H, "H of slide 15")
    same(eqs.mass_matrix.det(), M1 * M2 * L**2 + M2**2 * L**2 - M2**2 * L**2 * sin(q2)**2, "det H")
    same(E1, (M1 + M2) * q1dd - M2 * L * sin(q2) * q2dd - M2 * L * cos(q2) * q2d**2 - F, "equation 1")
    same(E2, M2 * L**2 * q2dd - M2 * L * sin(q2) * q1dd + M2 * G * L * cos(q2), "equation 2")
    same(eqs.input_matrix, [[1], [0]], "B")


@pytest.mark.parametrize("name", ["cart-pendulum-extended", "cart-pendulum-extended-energy"])
def test_cart_with_extended_pendulum_slide_12(name, same):
    Gz = S("Gamma_z")
    eqs, (E1, E2) = residuals(name)
    same(eqs.T, Mb / 2 * (q1d**2 + L**2 * q2d**2 - 2 * L * sin(q2) * q1d * q2d) + Gz / 2 * q2d**2, "K*")
    same(E1, Mb * q1dd - Mb * L * sin(q2) * q2dd - Mb * L * cos(q2) * q2d**2, "equation 1")
    same(E2, (Mb * L**2 + Gz) * q2dd - Mb * L * sin(q2) * q1dd + Mb * G * L * cos(q2), "equation 2")


def test_massless_cart_diagnosis_slides_14_15():
    report = lg.singularities(lg.derive(lg.load("cart-pendulum-massless")))
    assert report.singular and not report.everywhere
    assert sympy.simplify(report.det_mass_matrix - Mb**2 * L**2 * cos(q2)**2) == 0
    where = sorted(float(c.where["q2"]) for c in report.configurations)
    assert where == pytest.approx([-math.pi / 2, math.pi / 2])
    at_top = next(c for c in report.configurations if float(c.where["q2"]) > 0)
    # at q2 = pi/2 the cart sliding under a pendulum that stays still: q1_dot = L q2_dot
    v = at_top.null_velocity
    assert sympy.simplify(v["q1_dot"] / v["q2_dot"] - L) == 0
    assert at_top.still == ("particle 'pendulum'",)
    assert "q1 moves no mass of its own" in report.cause
    assert "give the body that q1 moves a mass" in report.fix
    assert "eliminate coordinate q1" in report.fix


def test_cart_with_mass_is_regular_slide_15():
    report = lg.singularities(lg.derive(lg.load("cart-pendulum")))
    assert not report.singular
    assert report.configurations == ()
    assert "regular" in report.text()


def test_extended_pendulum_inertia_removes_the_singularity():
    # det = M^2 L^2 cos^2 q2 + M Gamma_z > 0
    report = lg.singularities(lg.derive(lg.load("cart-pendulum-extended")))
    assert not report.singular
