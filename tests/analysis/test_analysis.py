"""Equilibria, linearization, stability, modes, continuation and conserved quantities, against
closed forms and against independent derivations."""

import json
import math

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.analysis import continuation, equilibria, linearize, modes
from lagrangian.cli import main

S = sympy.Symbol


@pytest.fixture(scope="module")
def rotating():
    return lg.derive(lg.load("rotating-pendulum"))


def _model(name, coords, params):
    m = lg.Model(name)
    m.coordinate(*coords)
    for k, v in params.items():
        m.parameter(k, v)
    return m


# ----------------------------------------------------------------------------- equilibria
@pytest.mark.slow
def test_rotating_pendulum_below_critical_speed_has_two_equilibria(rotating):
    g, l = 9.81, 0.5
    found = equilibria(rotating, params={"Omega": 0.9 * math.sqrt(g / l)})
    assert [e.coordinates["theta"] for e in found] == [0.0, pytest.approx(math.pi)]
    assert [e.stability for e in found] == ["stable", "unstable"]  # Lagrange-Dirichlet at the bottom
    assert found[0].exact == {"theta": 0} and found[1].exact == {"theta": sympy.pi}


def test_rotating_pendulum_above_critical_speed_branch_cos_theta(rotating):
    g, l, Omega = 9.81, 0.5, 6.0
    found = equilibria(rotating, params={"Omega": Omega})
    theta = sorted(e.coordinates["theta"] for e in found)
    c = math.acos(g / (l * Omega**2))
    assert theta == pytest.approx([-c, 0.0, c, math.pi], abs=1e-12)
    side = [e for e in found if abs(e.coordinates["theta"]) not in (0.0, math.pi)]
    Om, gs, ls = S("Omega"), S("g"), S("l")
    for e in side:
        assert sympy.simplify(sympy.cos(e.exact["theta"]) - gs / (ls * Om**2)) == 0
        assert e.stable and e.stability == "stable"
        assert [sympy.simplify(c.lhs - c.rhs) for c in e.conditions] == [sympy.simplify(gs - Om**2 * ls)]
        # the frequency of small oscillations about the side branch: Omega sin(theta)
        assert max(z.imag for z in e.eigenvalues) == pytest.approx(Omega * math.sin(c), rel=1e-9)
    bottom = next(e for e in found if e.coordinates["theta"] == 0.0)
    assert bottom.stability == "unstable"
    assert max(z.real for z in bottom.eigenvalues) == pytest.approx(math.sqrt(Omega**2 - g / l), rel=1e-9)


@pytest.mark.slow
def test_energy_form_gives_the_same_equilibria(rotating):
    a = equilibria(rotating, params={"Omega": 6.0})
    b = equilibria(lg.derive(lg.load("rotating-pendulum-energy")), params={"Omega": 6.0})
    assert [dict(e.coordinates) for e in a] == [pytest.approx(dict(e.coordinates)) for e in b]
    assert [e.stability for e in a] == [e.stability for e in b]


def test_numerical_search_agrees_with_exact(rotating):
    exact = equilibria(rotating, params={"Omega": 6.0})
    numeric = equilibria(rotating, params={"Omega": 6.0}, exact=False)
    assert all(e.exact is None for e in numeric)
    assert [e.coordinates["theta"] for e in numeric] == pytest.approx([e.coordinates["theta"] for e in exact],
                                                                      abs=1e-10)


def test_cyclic_coordinate_is_a_family_and_angles_are_wrapped():
    found = equilibria(lg.derive(lg.load("cart-pendulum")))
    assert [e.coordinates["q2"] for e in found] == pytest.approx([-math.pi / 2, math.pi / 2])
    assert all(e.family == ("q1",) for e in found)
    assert [e.stable for e in found] == [True, False]
    assert found[0].exact["q2"] == -sympy.pi / 2  # 3 pi/2 wrapped into (-pi, pi]


def test_double_pendulum_four_equilibria_only_the_bottom_stable():
    found = equilibria(lg.derive(lg.load("double-pendulum")))
    points = [tuple(e.coordinates.values()) for e in found]
    pi = math.pi
    assert points == [pytest.approx(p) for p in [(0, 0), (0, pi), (pi, 0), (pi, pi)]]
    assert [e.stable for e in found] == [True, False, False, False]


def test_sliding_mass_pendulum_equilibrium_and_singular_points():
    found = equilibria(lg.derive(lg.load("sliding-mass-pendulum")))
    by_q = {tuple(round(v, 6) for v in e.coordinates.values()): e for e in found}
    hanging = by_q[(round(9.81 / 40, 6), 0.0)]
    assert hanging.exact["q1"] == S("g") * S("m") / S("k") and hanging.stability == "stable"
    # the mass at the pivot with the rod horizontal: an equilibrium where M is singular
    at_pivot = by_q[(0.0, round(math.pi / 2, 6))]
    assert at_pivot.stability == "undetermined (singular mass matrix)" and not at_pivot.stable
    assert at_pivot.linear_model is None and len(at_pivot.eigenvalues) == 0


def test_linear_system_has_its_static_deflection():
    m = _model("static", ["x"], {"k": 200.0, "m": 2.0, "g": 9.81, "c": 1.0})
    m.add_energy(T="m*x_dot**2/2", V="k*x**2/2 - m*g*x", D="c*x_dot**2/2")
    (e,) = equilibria(lg.derive(m))
    assert e.coordinates["x"] == pytest.approx(2.0 * 9.81 / 200.0)
    assert e.stability == "asymptotically stable"


def test_equilibria_with_an_input_value():
    m = _model("pushed", ["x"], {"k": 4.0, "m": 1.0})
    m.input("F")
    m.add_energy(T="m*x_dot**2/2", V="k*x**2/2")
    m.add_generalized_force("x", "F")
    (e,) = equilibria(lg.derive(m), inputs={"F": 2.0})
    assert e.coordinates["x"] == pytest.approx(0.5)


def test_equilibria_errors_name_the_problem(rotating):
    with pytest.raises(lg.ModelError, match=r"'Omeg' is not a parameter of the model \(did you mean 'Omega'\?\)"):
        equilibria(rotating, params={"Omeg": 3})
    with pytest.raises(lg.ModelError, match="the value of 'Omega' must be a finite number, got 'fast'"):
        equilibria(rotating, params={"Omega": "fast"})
    m = _model("driven", ["x"], {"k": 1.0})
    m.add_energy(T="x_dot**2/2", V="k*x**2/2")
    m.add_generalized_force("x", "sin(t)")
    with pytest.raises(lg.ModelError, match="at rest the equations still depend on the time t, so there is no "
                                            "equilibrium"):
        equilibria(lg.derive(m))


# ----------------------------------------------------------------------------- linearization
def test_cart_inverted_pendulum_upright_against_hand_derivation():
    eqs = lg.derive(lg.load("cart-pendulum"))
    lin = linearize(eqs, at={"q2": sympy.pi / 2})
    M1, M2, L, g = S("M1"), S("M2"), S("L"), S("g")
    # by hand: (M1+M2) q1'' - M2 L q2'' = F ; M2 L^2 q2'' - M2 L q1'' - M2 g L dq2 = 0
    A = sympy.Matrix([[0, 0, 1, 0], [0, 0, 0, 1], [0, M2 * g / M1, 0, 0], [0, (M1 + M2) * g / (M1 * L), 0, 0]])
    B = sympy.Matrix([0, 0, 1 / M1, 1 / (M1 * L)])
    sym = lin.symbolic
    assert sympy.simplify(sym.A - A) == sympy.zeros(4, 4)
    assert sympy.simplify(sym.B - B) == sympy.zeros(4, 1)
    assert sym.M == sympy.Matrix([[M1 + M2, -M2 * L], [-M2 * L, M2 * L**2]])
    assert sym.K == sympy.Matrix([[0, 0], [0, -M2 * g * L]])
    assert sym.input_matrix == sympy.Matrix([1, 0])
    values = {M1: 1.0, M2: 0.5, L: 1.0, g: 9.81}
    np.testing.assert_allclose(lin.A, np.array(A.subs(values), dtype=float), atol=1e-14)
    np.testing.assert_allclose(lin.B, np.array(B.subs(values), dtype=float), atol=1e-14)
    assert lin.stability == "unstable"
    assert lin.state_names == ("q1", "q2", "q1_dot", "q2_dot") and lin.input_names == ("F",)
    assert lin.is_equilibrium


def test_linearization_agrees_with_finite_differences_of_the_state_equations():
    """Two independent ways: derivatives of the residuals, and central differences of the numerical
    x' = f(t, x, u, p), at a moving, accelerating state with an input."""
    eqs = lg.derive(lg.load("cart-pendulum"))
    point = {"q1": 0.3, "q2": 0.7, "q1_dot": -0.4, "q2_dot": 1.1}
    lin = linearize(eqs, at=point, inputs={"F": 0.8})
    assert not lin.is_equilibrium
    nm = lg.compile(eqs)
    x0 = np.array([point[s] for s in nm.state_names])
    u0, p = np.array([0.8]), nm.parameter_values
    h = 1e-6
    A = np.column_stack([(nm.rhs(0, x0 + h * e, u0, p) - nm.rhs(0, x0 - h * e, u0, p)) / (2 * h)
                         for e in np.eye(4)])
    B = (nm.rhs(0, x0, u0 + h, p) - nm.rhs(0, x0, u0 - h, p)) / (2 * h)
    np.testing.assert_allclose(lin.A, A, atol=1e-7)
    np.testing.assert_allclose(lin.B[:, 0], B, atol=1e-7)


def test_gyroscopic_and_damping_parts_kept_apart():
    """A mass in a frame spinning at Omega with an isotropic spring and a damper: G = 2 m Omega [[0,-1],[1,0]],
    K = (k - m Omega^2) I, C = c I."""
    m = _model("spinning", ["x", "y"], {"m": 2.0, "Omega": 3.0, "k": 50.0, "c": 0.4})
    m.add_energy(T="m*((x_dot - Omega*y)**2 + (y_dot + Omega*x)**2)/2", V="k*(x**2 + y**2)/2",
                 D="c*(x_dot**2 + y_dot**2)/2")
    lin = linearize(lg.derive(m))
    np.testing.assert_allclose(lin.G, 2 * 2.0 * 3.0 * np.array([[0, -1], [1, 0]]), atol=1e-12)
    np.testing.assert_allclose(lin.C, 0.4 * np.eye(2), atol=1e-12)
    np.testing.assert_allclose(lin.K, (50.0 - 2.0 * 9.0) * np.eye(2), atol=1e-12)


def test_gyroscopic_stabilization_is_marginal_not_lagrange_dirichlet():
    # Omega^2 > k/m: the potential (centrifugal part included) is a maximum, yet the rotating-frame
    # motion stays bounded: eigenvalues +-i(sqrt(k/m) +- Omega)
    m = _model("spinning", ["x", "y"], {"m": 1.0, "Omega": 3.0, "k": 4.0})
    m.add_energy(T="m*((x_dot - Omega*y)**2 + (y_dot + Omega*x)**2)/2", V="k*(x**2 + y**2)/2")
    lin = linearize(lg.derive(m))
    assert np.all(np.linalg.eigvalsh(lin.K) < 0)
    assert sorted(abs(z.imag) for z in lin.eigenvalues) == pytest.approx([1, 1, 5, 5])
    assert lin.stability == "marginally stable" and lin.stable and lin.lagrange_dirichlet is False


@pytest.mark.slow
def test_to_control_keeps_names():
    lin = linearize(lg.derive(lg.load("cart-pendulum")), at={"q2": sympy.pi / 2})
    sys = lin.to_control()
    assert list(sys.state_labels) == ["q1", "q2", "q1_dot", "q2_dot"]
    assert list(sys.input_labels) == ["F"]
    np.testing.assert_array_equal(sys.A, lin.A)
    np.testing.assert_array_equal(sys.C, np.eye(4))


def test_linearize_at_singular_mass_matrix_gives_the_diagnosis():
    eqs = lg.derive(lg.load("cart-pendulum-massless"))
    with pytest.raises(lg.SingularMassMatrixError, match=r"the mass matrix is singular at the operating point "
                                                         r"\(q1 = 0, q2 = 1\.5708\)") as info:
        linearize(eqs, at={"q2": math.pi / 2})
    assert "no inertia" in info.value.diagnosis or "q1_dot" in info.value.diagnosis


def test_linearize_errors():
    eqs = lg.derive(lg.load("cart-pendulum"))
    with pytest.raises(lg.ModelError, match=r"\[at.q3\]: 'q3' is not a coordinate or velocity \(did you mean 'q2'\?\)"):
        linearize(eqs, at={"q3": 1})
    with pytest.raises(lg.ModelError, match="the operating point must give 2 coordinates or 4 state values"):
        linearize(eqs, at=[1, 2, 3])
    with pytest.raises(lg.ModelError, match=r"'G' is not an input of the model; the choices are F"):
        linearize(eqs, inputs={"G": 1})


# ----------------------------------------------------------------------------- modes
def test_fixed_fixed_three_mass_chain_closed_form_frequencies():
    m = _model("chain", ["x1", "x2", "x3"], {"m": 2.0, "k": 800.0})
    m.add_energy(T="m*(x1_dot**2 + x2_dot**2 + x3_dot**2)/2",
                 V="k*(x1**2 + (x2 - x1)**2 + (x3 - x2)**2 + x3**2)/2")
    result = modes(linearize(lg.derive(m)))
    expected = [2 * math.sqrt(800.0 / 2.0) * math.sin(j * math.pi / 8) for j in (1, 2, 3)]
    np.testing.assert_allclose(result.frequencies, expected, rtol=1e-12)
    np.testing.assert_allclose(result.frequencies_hz, np.array(expected) / (2 * math.pi), rtol=1e-12)
    Mm = np.eye(3) * 2.0
    np.testing.assert_allclose(result.shapes @ Mm @ result.shapes.T, np.eye(3), atol=1e-12)
    # the first shape is sin(j pi/4) along the chain; modal stiffness/mass = omega^2
    np.testing.assert_allclose(result.unit_shapes[0], [math.sqrt(2) / 2, 1, math.sqrt(2) / 2], rtol=1e-10)
    np.testing.assert_allclose(result.modal_stiffnesses / result.modal_masses, np.square(expected), rtol=1e-10)
    assert result.kinds == ("elastic",) * 3 and result.proportional_damping


def test_sliding_mass_pendulum_frequencies():
    """About q1 = mg/k, q2 = 0 the spring mode has omega^2 = k/m and the pendulum g/q1 = k/m too;
    with a disk of inertia I the pendulum mode becomes m g q1 / (m q1^2 + I)."""
    eqs = lg.derive(lg.load("sliding-mass-pendulum"))
    for k in (40.0, 90.0):
        result = modes(linearize(eqs, at={"q1": 9.81 / k, "q2": 0}, params={"k": k}))
        np.testing.assert_allclose(result.frequencies, [math.sqrt(k), math.sqrt(k)], rtol=1e-12)
    disk = lg.derive(lg.load("sliding-disk-pendulum"))
    p = {s.name: v for s, v in disk.parameters.items()}
    q1 = p["m"] * p["g"] / p["k"]
    result = modes(linearize(disk, at={"q1": q1}))
    pendulum = math.sqrt(p["m"] * p["g"] * q1 / (p["m"] * q1**2 + p["I"]))
    np.testing.assert_allclose(sorted(result.frequencies), sorted([pendulum, math.sqrt(p["k"] / p["m"])]),
                               rtol=1e-12)


def test_damped_oscillator_damping_ratio_and_eigenvalues():
    mass, c, k = 2.0, 0.6, 50.0
    m = _model("damped", ["x"], {"m": mass, "c": c, "k": k})
    m.add_energy(T="m*x_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2")
    lin = linearize(lg.derive(m))
    wd = math.sqrt(k / mass - (c / (2 * mass)) ** 2)
    np.testing.assert_allclose(sorted(lin.eigenvalues, key=lambda z: z.imag),
                               [complex(-c / (2 * mass), -wd), complex(-c / (2 * mass), wd)], rtol=1e-12)
    result = modes(lin)
    assert result.damping_ratios[0] == pytest.approx(c / (2 * math.sqrt(k * mass)), rel=1e-12)
    assert result.damped_frequencies[0] == pytest.approx(wd, rel=1e-12)
    assert lin.stability == "asymptotically stable"


def test_overdamped_mode_ratio_above_one():
    m = _model("overdamped", ["x"], {"m": 1.0, "c": 10.0, "k": 4.0})
    m.add_energy(T="m*x_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2")
    result = modes(linearize(lg.derive(m)))
    assert result.damping_ratios[0] == pytest.approx(10.0 / (2 * 2.0), rel=1e-10)
    assert result.damped_frequencies[0] == 0.0


def test_proportional_damping_check_and_rigid_mode():
    m = _model("two", ["x1", "x2"], {"k": 100.0, "c": 1.0})
    m.add_energy(T="(x1_dot**2 + x2_dot**2)/2", V="k*x1**2/2 + k*(x2 - x1)**2/2", D="c*x2_dot**2/2")
    assert not modes(linearize(lg.derive(m))).proportional_damping
    cart = modes(linearize(lg.derive(lg.load("cart-pendulum")), at={"q2": -math.pi / 2}))
    assert cart.kinds == ("rigid", "elastic") and cart.frequencies[0] == 0.0
    assert math.isnan(cart.damping_ratios[0])
    assert cart.unit_shapes[0].tolist() == [1.0, 0.0]


def test_undamped_modes_have_a_damping_ratio_of_exactly_zero(capsys):
    result = modes(linearize(lg.derive(lg.load("double-pendulum"))))
    assert result.damping_ratios.tolist() == [0.0, 0.0]  # not the eigenvalues' round-off (5e-17)
    assert main(["modes", "double-pendulum"]) == 0
    rows = capsys.readouterr().out.splitlines()[2:4]
    assert [row.split()[4] for row in rows] == ["0", "0"]  # mode, kind, f, omega, zeta


def test_unstable_mode_has_no_frequency():
    result = modes(linearize(lg.derive(lg.load("double-pendulum")), at={"theta1": math.pi}))
    assert result.kinds[-1] == "unstable" and math.isnan(result.frequencies[-1])
    assert json.loads(json.dumps(result.to_dict()))["frequencies_hz"][-1] is None


def test_modes_rejects_other_objects():
    with pytest.raises(TypeError, match=r"modes\(\) expects a LinearModel"):
        modes(lg.derive(lg.load("mck")))


# ----------------------------------------------------------------------------- continuation
@pytest.mark.slow
def test_rotating_pendulum_continuation_exact(rotating):
    result = continuation(rotating, "Omega", np.linspace(0, 8, 201))
    assert result.critical_values == pytest.approx((math.sqrt(9.81 / 0.5),))
    assert result.critical_exact == (sympy.sqrt(S("g") / S("l")),)
    exact = sorted(sympy.sstr(b.exact["theta"]) for b in result.branches)
    assert exact == ["-acos(g/(Omega**2*l))", "0", "acos(g/(Omega**2*l))", "pi"]
    bottom = next(b for b in result.branches if b.exact["theta"] == 0)
    Oc = math.sqrt(9.81 / 0.5)
    assert all(p.stable == (p.param < Oc) for p in bottom.points if abs(p.param - Oc) > 1e-9)
    side = next(b for b in result.branches if sympy.sstr(b.exact["theta"]) == "acos(g/(Omega**2*l))")
    assert side.params[0] == pytest.approx(Oc) and side.params[-1] == 8.0
    np.testing.assert_allclose(np.cos(side.coordinate("theta")), 9.81 / (0.5 * side.params**2), rtol=1e-12)


@pytest.mark.slow
def test_rotating_pendulum_continuation_numeric_agrees(rotating):
    result = continuation(rotating, "Omega", np.linspace(0, 8, 81), exact=False)
    assert len(result.branches) == 4
    assert result.critical_values == pytest.approx((math.sqrt(9.81 / 0.5),), rel=1e-8)
    assert result.critical_exact == (None,)
    for b in result.branches:
        theta = b.coordinate("theta")
        if np.ptp(theta) > 0:  # a side branch: cos theta = g / (l Omega^2)
            np.testing.assert_allclose(np.cos(theta), 9.81 / (0.5 * b.params**2), rtol=1e-9)


@pytest.mark.slow
def test_saddle_node_located_numerically():
    """V = x^4/4 - a x^2/2 + x/5: two equilibria are born where 4 a^3 = 27 (1/5)^2."""
    m = _model("saddle-node", ["x"], {"a": 1.0})
    m.add_energy(T="x_dot**2/2", V="x**4/4 - a*x**2/2 + x/5")
    result = continuation(lg.derive(m), "a", np.linspace(0, 2, 41), exact=False)
    assert result.critical_values == pytest.approx(((27 * 0.04 / 4) ** (1 / 3),), rel=1e-8)
    assert len(result.branches) == 3
    born = [b for b in result.branches if b.params[0] > 0]
    assert len(born) == 2 and sorted(b.stable.all() for b in born) == [False, True]


def test_pendulum_chain_has_two_to_the_n_equilibria_one_stable():
    found = equilibria(lg.derive(lg.load("pendulum-chain-4")))
    assert len(found) == 16 and sum(e.stable for e in found) == 1
    assert all(v in (0.0, pytest.approx(math.pi)) for e in found for v in e.coordinates.values())


def test_continuation_errors(rotating):
    with pytest.raises(lg.ModelError, match=r"'omega' is not a parameter of rotating-pendulum \(did you mean "
                                            r"'Omega'\?\); the parameters are m, l, g, Omega"):
        continuation(rotating, "omega", [0, 1])
    with pytest.raises(lg.ModelError, match="the values of Omega must be at least 2 finite numbers"):
        continuation(rotating, "Omega", [1.0])


@pytest.mark.slow
def test_bifurcation_diagram_draws_stable_solid_unstable_dashed(rotating):
    import matplotlib

    matplotlib.use("Agg")
    fig = continuation(rotating, "Omega", np.linspace(0, 8, 41)).plot()
    ax = fig.axes[0]
    styles = {line.get_linestyle() for line in ax.get_lines() if len(line.get_xdata()) > 2}
    assert styles == {"-", "--"}
    assert ax.get_xlabel() == "Omega" and ax.get_ylabel() == "theta (rad)"
    import matplotlib.pyplot as plt

    plt.close(fig)


# ----------------------------------------------------------------------------- conserved quantities
@pytest.mark.slow
def test_conserved_quantities_energy_and_cyclic_momentum():
    m = _model("free-cart", ["x", "th"], {"M": 1.0, "m": 0.5, "l": 1.0, "g": 9.81})
    m.add_particle("M", ["x", "0"], name="cart")
    m.add_particle("m", ["x + l*sin(th)", "-l*cos(th)"], name="bob")
    m.add_gravity("g")
    eqs = lg.derive(m)
    q = eqs.conserved_quantities
    assert set(q) == {"energy", "p_x"}
    M, mm, l, th, x_dot, th_dot = S("M"), S("m"), S("l"), S("th"), S("x_dot"), S("th_dot")
    assert sympy.simplify(q["p_x"] - ((M + mm) * x_dot + mm * l * sympy.cos(th) * th_dot)) == 0
    assert "p_x = " in eqs.text() and eqs.to_dict()["conserved_quantities"]["p_x"]
    traj = lg.simulate(eqs, 3.0, {"th": 1.0, "x_dot": 0.3}, rtol=1e-11, atol=1e-11)
    drift = traj.conserved_drift()
    assert set(drift) == {"energy", "p_x"} and max(drift.values()) < 1e-8
    assert traj.conserved()["p_x"][0] == pytest.approx((1.5) * 0.3)


def test_rotating_pendulum_conserves_the_jacobi_integral_not_the_energy(rotating):
    q = rotating.conserved_quantities
    assert list(q) == ["jacobi_integral"]
    m, l, g, Om, th, thd = (S(n) for n in ("m", "l", "g", "Omega", "theta", "theta_dot"))
    h = m * l**2 * thd**2 / 2 - m * l**2 * Om**2 * sympy.sin(th) ** 2 / 2 - m * g * l * sympy.cos(th)
    assert sympy.simplify(q["jacobi_integral"] - h) == 0


def test_damped_or_forced_models_conserve_nothing():
    assert lg.derive(lg.load("mck")).conserved_quantities == {}


# ----------------------------------------------------------------------------- CLI
def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.slow
def test_cli_equilibria_json_contract(capsys):
    code, out, _ = run(capsys, "equilibria", "rotating-pendulum", "--param", "Omega=6", "--json")
    assert code == 0
    data = json.loads(out)
    assert [round(d["coordinates"]["theta"], 6) for d in data] == [-0.994407, 0.0, 0.994407, 3.141593]
    assert [d["stable"] for d in data] == [True, False, True, False]
    assert all(isinstance(z, list) and len(z) == 2 for d in data for z in d["eigenvalues"])
    assert data[2]["exact"] == {"theta": "acos(g/(Omega**2*l))"}


def test_cli_linearize_json_contract(capsys):
    code, out, _ = run(capsys, "linearize", "cart-pendulum", "--at", "q1=0,q2=pi/2", "--input", "F=0", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["state_names"] == ["q1", "q2", "q1_dot", "q2_dot"] and data["input_names"] == ["F"]
    assert data["A"][2][1] == pytest.approx(0.5 * 9.81) and data["B"][3][0] == pytest.approx(1.0)
    assert data["M"] == [[1.5, -0.5], [-0.5, 0.5]] and data["K"][1][1] == pytest.approx(-0.5 * 9.81)
    assert data["C"] == [[0.0, 0.0], [0.0, 0.0]]


def test_cli_modes_json_contract_and_default_operating_point(capsys):
    code, out, _ = run(capsys, "modes", "mck", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["frequencies_hz"] == sorted(data["frequencies_hz"])
    assert data["frequencies_hz"] == pytest.approx([math.sqrt(50) / (2 * math.pi), math.sqrt(200) / (2 * math.pi)])
    assert len(data["shapes"]) == 2 and len(data["damping_ratios"]) == 2
    code, out, _ = run(capsys, "modes", "cart-pendulum")
    assert code == 0 and "about the stable equilibrium q1 = 0, q2 = -1.5708" in out and "rigid" in out


@pytest.mark.slow
def test_cli_sweep_json_and_plot(capsys, tmp_path):
    png = tmp_path / "omega.png"
    code, out, _ = run(capsys, "sweep", "rotating-pendulum", "--param", "Omega", "--from", "0", "--to", "8",
                       "--steps", "40", "--plot", str(png), "--json")
    assert code == 0
    data = json.loads(out)
    assert data["critical_values"] == pytest.approx([math.sqrt(9.81 / 0.5)])
    assert data["critical_values_exact"] == ["sqrt(g/l)"]
    assert len(data["branches"]) == 4 and set(data["branches"][0][0]) == {"param", "coordinates", "stable"}
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, out, _ = run(capsys, "sweep", "rotating-pendulum", "--param", "Omega", "--param", "l=1", "--from", "0",
                       "--to", "8", "--steps", "20")
    assert code == 0 and "sqrt(g/l) = 3.13209" in out


def test_cli_analysis_errors(capsys):
    code, _, err = run(capsys, "sweep", "rotating-pendulum", "--param", "Omega", "--param", "g", "--from", "0",
                       "--to", "1")
    assert code == 2 and "--param: name exactly one parameter to sweep (without a value), e.g. --param Omega; " \
                          "got Omega, g" in err
    code, _, err = run(capsys, "sweep", "rotating-pendulum", "--param", "Omega", "--from", "0", "--to", "1",
                       "--plot", "x.gif")
    assert code == 2 and "--plot x.gif: expected a file ending in .png, .pdf or .svg" in err
    code, _, err = run(capsys, "sweep", "rotating-pendulum", "--param", "Omega", "--from", "0", "--to", "1",
                       "--steps", "0")
    assert code == 2 and "--steps must be at least 1, got 0; for example --steps 200" in err
    code, _, err = run(capsys, "linearize", "cart-pendulum", "--at", "q9=1")
    assert code == 2 and "'q9' is not a coordinate or velocity" in err
    code, _, err = run(capsys, "linearize", "cart-pendulum-massless", "--at", "q2=pi/2")
    assert code == 1 and "the mass matrix is singular at the operating point" in err
    m = "no stable equilibrium to linearize about"
    code, _, err = run(capsys, "linearize", "cart-pendulum-massless")
    assert code == 2 and m in err and "give the operating point with --at, e.g. --at q1=0,q2=0" in err


# ----------------------------------------------------------------------------- the docs are current
def _doc_blocks():
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "analysis.md").read_text()
    return text, re.findall(r"```(\w*)\n(.*?)```", text, re.S)


@pytest.mark.slow
def test_analysis_doc_examples_run_and_print_what_the_doc_says(capsys, tmp_path, monkeypatch):
    import contextlib
    import io

    _, blocks = _doc_blocks()
    code = [body for lang, body in blocks if lang == "python"]
    printed = blocks[[b for _, b in blocks].index(code[0]) + 1][1]
    namespace = {}
    out = io.StringIO()
    monkeypatch.chdir(tmp_path)  # the blocks write files (torques.csv): in a temporary folder
    with contextlib.redirect_stdout(out):
        for body in code:
            exec(compile(body, "docs/analysis.md", "exec"), namespace)  # our own docs, not user input
    assert out.getvalue() == printed
    assert namespace["sweep"].critical_values == pytest.approx((4.4294469180700204,))
    assert str(namespace["lin"].symbolic.A) == ("Matrix([[0, 0, 1, 0], [0, 0, 0, 1], [0, M2*g/M1, 0, 0], "
                                                "[0, g*(M1 + M2)/(L*M1), 0, 0]])")
    # the console sessions
    monkeypatch.chdir(tmp_path)
    for _, body in blocks:
        if body.startswith("$ lagrangian"):
            command, expected = body.split("\n", 1)
            code_, got, _ = run(capsys, *command.split()[2:])
            assert code_ == 0 and got == expected


@pytest.mark.slow
def test_rich_display_in_notebooks(rotating):
    lin = linearize(lg.derive(lg.load("cart-pendulum")), at={"q2": sympy.pi / 2})
    latex = lin._repr_latex_()
    assert latex.startswith("$$") and r"\dot x = A x + B u" in latex and "14.715" in latex
    assert modes(lin)._repr_html_().startswith("<pre>mode  kind")
    (e, *_), sweep = equilibria(rotating), continuation(rotating, "Omega", [0.0, 1.0])
    assert "theta = 0: stable" in e._repr_html_()
    assert "no critical value of Omega in this range" in sweep._repr_html_()
