"""Joints (model._joints): each type's frame, coordinates and elements, checked against the same system
written frame by frame or by hand; the errors a user can hit."""

import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.errors import ModelError


def _same(a, b):
    """M and f of two derivations agree symbolically."""
    assert a.model.q == b.model.q
    assert sp.simplify(a.mass_matrix - b.mass_matrix) == sp.zeros(*a.mass_matrix.shape)
    assert sp.simplify(a.forcing - b.forcing) == sp.zeros(*a.forcing.shape)


def _params(model, **values):
    return [model.parameter(k, v) for k, v in values.items()]


def test_two_link_planar_arm_with_joints_equals_frame_by_frame():
    def build(with_joints):
        m = lg.Model("arm2")
        _params(m, m1=1.0, m2=2.0, l1=0.5, l2=0.4, g=9.81, c=0.1)
        if with_joints:
            m.add_joint("shoulder", "revolute", child="upper", axis="z", coordinates="q1")
            m.add_joint("elbow", "revolute", parent="upper", child="fore", origin=("l1", 0, 0), coordinates="q2",
                        damping="c")
        else:
            m.coordinate("q1", "q2")
            m.add_frame("upper", rotation=[("z", "q1")])
            m.add_frame("fore", parent="upper", origin=("l1", 0, 0), rotation=[("z", "q2")])
            m.add_damper("c", length="q2")
        m.add_rigid_body("m1", ["m1*l1**2/12"] * 3, frame="upper", center=("l1/2", 0, 0))
        m.add_rigid_body("m2", ["m2*l2**2/12"] * 3, frame="fore", center=("l2/2", 0, 0))
        m.add_gravity("g", direction=(0, -1, 0))
        return lg.derive(m)

    a, b = build(True), build(False)
    _same(a, b)
    # and the textbook planar form: M11 = I1 + I2 + m1 l1^2/4 + m2 (l1^2 + l2^2/4 + l1 l2 cos q2)
    m1, m2, l1, l2, q2 = sp.symbols("m1 m2 l1 l2 q2")
    M11 = m1 * l1 ** 2 / 3 + m2 * (l1 ** 2 + l2 ** 2 / 3 + l1 * l2 * sp.cos(q2))
    assert sp.simplify(a.mass_matrix[0, 0] - M11) == 0
    assert sp.simplify(a.mass_matrix[1, 1] - m2 * l2 ** 2 / 3) == 0


def test_robot_arm_3_with_joints_equals_the_frame_by_frame_example():
    _same(lg.derive(lg.load("robot-arm-3-joints")), lg.derive(lg.load("robot-arm-3")))


def test_prismatic_joint_on_a_turntable():
    """A bead of mass m on a rod turning about z (revolute), sliding along it (prismatic): the
    classical T = m (r_dot^2 + r^2 phi_dot^2)/2 + I phi_dot^2/2."""
    m = lg.Model("bead")
    mass, I = _params(m, m=2.0, I=0.3)
    m.add_joint("turn", "revolute", child="rod", coordinates="phi")
    m.add_joint("slide", "prismatic", parent="rod", child="bead", axis="x", coordinates="r")
    m.add_rigid_body("I", ["I", "I", "I"], frame="rod")
    m.add_rigid_body("m", [0, 0, 0], frame="bead")
    eqs = lg.derive(m)
    r = m.q[1]
    rd, phid = sp.Symbol("r_dot"), sp.Symbol("phi_dot")
    T = mass * (rd ** 2 + r ** 2 * phid ** 2) / 2 + I * phid ** 2 / 2
    assert m.q == (sp.Symbol("phi"), sp.Symbol("r"))
    assert sp.simplify(eqs.mass_matrix - sp.hessian(T, (phid, rd))) == sp.zeros(2, 2)
    assert sp.simplify(eqs.forcing[1] - mass * r * phid ** 2) == 0  # the centrifugal force


def test_cylindrical_joint_is_a_revolute_and_a_prismatic_joint_about_one_axis():
    def build(cylindrical):
        m = lg.Model("cyl")
        _params(m, m=1.5, a=0.2, g=9.81)
        if cylindrical:
            j = m.add_joint("c", "cylindrical", axis=[1, 0, 1], origin=(0.1, 0, 0))
            assert [s.name for s in j.coordinates] == ["c_angle", "c_slide"]
        else:
            m.coordinate("c_angle", "c_slide")
            e = (sp.sqrt(2) / 2, 0, sp.sqrt(2) / 2)
            m.add_frame("c", origin=tuple(0.1 * (i == 0) + e[i] * sp.Symbol("c_slide") for i in range(3)),
                        rotation=[(list(e), "c_angle")])
        m.add_rigid_body("m", [0.1, 0.2, 0.3], frame="c", center=("a", 0, 0))
        m.add_gravity("g")
        return lg.derive(m)

    _same(build(True), build(False))


def test_universal_joint_equals_two_revolute_frames():
    def build(universal):
        m = lg.Model("u")
        _params(m, m=1.0, l=0.5, g=9.81)
        if universal:
            m.add_joint("u", "universal", axis=["x", "y"], rotation=[("x", "pi")])
        else:
            m.coordinate("u_1", "u_2")
            m.add_frame("u", rotation=[("x", "pi"), ("x", "u_1"), ("y", "u_2")])
        m.add_rigid_body("m", [0.01, 0.02, 0.03], frame="u", center=(0, 0, "l"))
        m.add_gravity("g")
        return lg.derive(m)

    _same(build(True), build(False))


def test_spherical_joint_with_euler_angles_is_the_heavy_top():
    """A spherical joint with the sequence zxz and a body on it: the example heavy-top (frames)."""
    m = lg.Model("top")
    for k, v in dict(m=1.0, l=0.1, g=9.81, I1=0.02, I3=0.01).items():
        m.parameter(k, v)
    m.add_joint("tip", "spherical", child="body", sequence="zxz", coordinates=["phi", "theta", "psi"])
    m.add_rigid_body("m", ["I1 - m*l**2", "I1 - m*l**2", "I3"], frame="body", center=(0, 0, "l"))
    m.add_gravity("g")
    a = lg.derive(m)
    b = lg.derive(lg.load("heavy-top"))
    order = [a.model.q.index(c) for c in b.model.q]  # heavy-top lists theta, phi, psi
    Ma = a.mass_matrix.extract(order, order)
    fa = a.forcing.extract(order, [0])
    assert sp.simplify(Ma - b.mass_matrix) == sp.zeros(3, 3)
    assert sp.simplify(fa - b.forcing) == sp.zeros(3, 1)


def test_spherical_joint_default_sequence_and_where_it_is_singular():
    from lagrangian.model._joints import singular_angle

    m = lg.Model("ball")
    m.parameter("m", 1.0)
    j = m.add_joint("ball", "spherical")
    assert j.sequence == "xyz" and [c.name for c in j.coordinates] == ["ball_1", "ball_2", "ball_3"]
    m.add_rigid_body("m", [1, 2, 3], frame="ball")
    M = lg.derive(m).mass_matrix
    det = sp.simplify(M.det())
    assert det.subs(m.q[1], sp.pi / 2) == 0 and det.subs(m.q[1], 0) != 0
    assert "+-pi/2" in singular_angle("xyz") and "0 or pi" in singular_angle("zxz")


def test_spherical_joint_rotational_damping_is_the_torque_minus_c_omega():
    """D = c |omega|^2 / 2: the generalized force is -c W^T omega, W the map omega = W(q) q_dot."""
    m = lg.Model("ball")
    m.parameter("c", 0.7)
    j = m.add_joint("ball", "spherical", damping="c", sequence="zyx")
    m.add_rigid_body(1, [1, 1, 1], frame="ball")
    eqs = lg.derive(m)
    a, b, _ = j.coordinates
    ad, bd, cd = (sp.Symbol(f"{q.name}_dot") for q in j.coordinates)
    # body-axes angular velocity of Rz(a) Ry(b) Rx(c), by hand
    c3 = j.coordinates[2]
    w = sp.Matrix([cd - ad * sp.sin(b),
                   bd * sp.cos(c3) + ad * sp.cos(b) * sp.sin(c3),
                   -bd * sp.sin(c3) + ad * sp.cos(b) * sp.cos(c3)])
    W = w.jacobian([ad, bd, cd])
    damping = -sp.Symbol("c") * W.T * w
    # the body is a unit sphere (I = 1): M = W^T W, and the forcing without damping is the gyroscopic part
    m0 = lg.Model("ball0")
    m0.add_joint("ball", "spherical", sequence="zyx")
    m0.add_rigid_body(1, [1, 1, 1], frame="ball")
    f0 = lg.derive(m0).forcing
    assert sp.simplify(eqs.forcing - f0 - damping) == sp.zeros(3, 1)


def test_planar_joint_is_a_free_body_in_a_plane():
    m = lg.Model("puck")
    mass, I = _params(m, m=2.0, I=0.5)
    j = m.add_joint("p", "planar", axis="y")
    assert [c.name for c in j.coordinates] == ["p_z", "p_x", "p_angle"]
    m.add_rigid_body("m", ["I", "I", "I"], frame="p")
    eqs = lg.derive(m)
    assert sp.simplify(eqs.mass_matrix - sp.diag(mass, mass, I)) == sp.zeros(3, 3)


def test_floating_joint_is_a_free_body():
    m = lg.Model("free")
    mass, g = _params(m, m=2.0, g=9.81)
    j = m.add_joint("base", "floating")
    assert len(j.coordinates) == 6 and j.coordinates[0].name == "base_x"
    m.add_rigid_body("m", [1, 2, 3], frame="base")
    m.add_gravity("g")
    eqs = lg.derive(m)
    M0 = eqs.mass_matrix.subs({c: 0 for c in m.q})
    assert M0 == sp.diag(mass, mass, mass, 1, 2, 3)
    f = eqs.forcing.subs({c: 0 for c in m.q} | {sp.Symbol(f"{c.name}_dot"): 0 for c in m.q})
    assert list(f) == [0, 0, -mass * g, 0, 0, 0]


def test_fixed_joint_makes_a_constant_frame():
    m = lg.Model("fixed")
    m.parameter("m", 1.0)
    m.add_joint("hinge", "revolute", axis="x", coordinates="q")
    j = m.add_joint("mount", "fixed", parent="hinge", origin=(0, 0, 1), rotation=[("y", "pi/2")])
    assert j.coordinates == () and m.q == (sp.Symbol("q"),)
    m.add_rigid_body("m", [0, 0, 0], frame="mount")
    M = lg.derive(m).mass_matrix
    assert sp.simplify(M[0, 0] - sp.Symbol("m")) == 0  # a point mass at distance 1 from the axis


def test_damping_friction_and_limits_of_a_revolute_joint():
    m = lg.Model("hinge")
    c, F = _params(m, c=0.3, F=0.2)
    j = m.add_joint("q", "revolute", damping="c", friction="F", limits=("-pi/2", "pi/2"))
    m.add_rigid_body(1, [1, 1, 1], frame="q")
    eqs = lg.derive(m)
    qd = sp.Symbol("q_dot")
    assert sp.simplify(eqs.forcing[0] - (-c * qd - F * sp.sign(qd))) == 0
    assert j.limits == ((-sp.pi / 2, sp.pi / 2),)
    assert {e.name for e in m.elements} >= {"q_damping", "q_friction"}


def test_a_coordinate_declared_before_is_used_by_the_joint():
    m = lg.Model("x")
    q = m.coordinate("a")
    m.add_joint("j", "revolute", coordinates=["a"])
    assert m.q == (q,)


def test_model_copy_keeps_joints_apart():
    m = lg.Model("x")
    m.add_joint("j", "revolute")
    c = m.copy()
    c.add_joint("k", "revolute", parent="j")
    assert list(m.joints) == ["j"] and list(c.joints) == ["j", "k"]


@pytest.mark.parametrize("kwargs, match", [
    (dict(type="revolut"), r"unknown joint type 'revolut' \(did you mean 'revolute'\?\)"),
    (dict(type="revolute", child="world"), r"the frame 'world' exists already .*give it a new name"),
    (dict(type="revolute", parent="nowhere"), r"no frame is named 'nowhere'"),
    (dict(type="universal", axis=["x", "x"]), r"the two axes of a universal joint are parallel"),
    (dict(type="universal", axis="x"), r"a universal joint has two axes"),
    (dict(type="revolute", coordinates=["a", "b"]), r"a revolute joint has 1 coordinate, got \['a', 'b'\]"),
    (dict(type="spherical", sequence="xxy"), r"expected three axes among x, y, z"),
    (dict(type="spherical", axis="z"), r"a spherical joint turns about three axes"),
    (dict(type="revolute", sequence="xyz"), r"only spherical and floating joints have a sequence"),
    (dict(type="planar", axis=[1, 1, 0]), r"a planar joint's axis is its plane's normal"),
    (dict(type="fixed", axis="z"), r"a fixed joint has no axis"),
    (dict(type="fixed", damping=1), r"a fixed joint has no coordinates and so no damping"),
    (dict(type="revolute", damping=-1), r"a damping coefficient is at least 0"),
    (dict(type="revolute", damping=float("nan")), r"expected a finite number"),
    (dict(type="revolute", damping="q_other"), r"unknown name 'q_other'"),
    (dict(type="revolute", damping="k*t"), r"a joint's damping is a constant: write it with parameters and numbers, "
                                           r"not t"),
    (dict(type="revolute", limits=(1, -1)), r"the lower limit 1 is not below the upper limit -1"),
    (dict(type="revolute", limits=(1, 2, 3)), r"expected \[lower, upper\]"),
    (dict(type="spherical", friction=1), r"a spherical joint takes no Coulomb friction"),
    (dict(type="spherical", damping=[1, 2, 3]), r"a spherical joint's damping is one coefficient"),
    (dict(type="floating", damping=1), r"a floating joint takes no damping"),
    (dict(type="revolute", coordinates=["t"]), r"'t' is reserved"),
    (dict(type="revolute", coordinates=["__import__('os')"]), r"is not a valid coordinate name"),
    (dict(type="revolute", origin=(0, 0)), r"a joint's origin has 3 components"),
])
def test_joint_errors(kwargs, match):
    m = lg.Model("x")
    m.parameter("k", 1.0)
    with pytest.raises(ModelError, match=match):
        m.add_joint("j", **kwargs)
    assert m.q == () and m.frames == {} and m.joints == {}  # all or nothing


def test_joint_name_errors():
    m = lg.Model("x")
    with pytest.raises(ModelError, match=r"a joint's name must be an identifier"):
        m.add_joint("__import__('os')", "revolute")
    m.add_joint("j", "revolute")
    with pytest.raises(ModelError, match=r"two joints have this name"):
        m.add_joint("j", "revolute", child="other")
    with pytest.raises(ModelError, match=r"the coordinate 'j' is the joint 'j''s already"):
        m.add_joint("k", "revolute", coordinates=["j"])
    m.parameter("p", 1.0)
    with pytest.raises(ModelError, match=r"'p' is already a parameter"):
        m.add_joint("p", "revolute")


def test_limits_with_a_stiffness_are_one_sided_springs():
    m = lg.Model("stop")
    m.parameter("k", 1000.0)
    j = m.add_joint("q", "revolute", limits=(-0.5, 1.0), limit_stiffness="k")
    m.add_rigid_body(1, [1, 1, 1], frame="q")
    f = lg.derive(m).forcing[0]
    q, qd = sp.Symbol("q"), sp.Symbol("q_dot")
    at = {sp.Symbol("k"): 1000, qd: 0}
    assert float(f.subs(at | {q: 1.1})) == pytest.approx(-100.0)
    assert float(f.subs(at | {q: 0.3})) == 0.0
    assert float(f.subs(at | {q: -0.7})) == pytest.approx(200.0)
    assert j.limit_stiffness == sp.Symbol("k")


@pytest.mark.parametrize("kwargs, match", [
    (dict(limit_stiffness=10), r"a limit stiffness needs limits"),
    (dict(limits=(0, 1), limit_stiffness=-1), r"a limit stiffness is positive"),
])
def test_limit_stiffness_errors(kwargs, match):
    m = lg.Model("x")
    with pytest.raises(ModelError, match=match):
        m.add_joint("j", "revolute", **kwargs)


@pytest.mark.slow
@pytest.mark.parametrize("n", [6])
def test_robot_arm_n_with_joints_equals_the_generated_frame_by_frame_arm(n):
    """robot-arm-<n> rebuilt with Model.add_joint (motor torques as generalized forces on the joints'
    coordinates): the same M and f at random states (numerically: n links are too many for simplify)."""
    import numpy as np

    from lagrangian.examples import ARM_AXES

    ref = lg.load(f"robot-arm-{n}")
    m = lg.Model(f"robot-arm-{n}-joints")
    for p, v in ref.parameters.items():
        m.parameter(p.name, v)
    for k in range(1, n + 1):
        m.input(f"tau{k}")
    axes = [ARM_AXES[k] if k < len(ARM_AXES) else ("y", "x")[k % 2] for k in range(n)]
    for k in range(1, n + 1):
        origin = (0, 0, 0) if k == 1 else ((0, 0, "h") if k == 2 else ("l", 0, 0))
        m.add_joint(f"j{k}", "revolute", parent="world" if k == 1 else f"link{k - 1}", child=f"link{k}",
                    origin=origin, axis=axes[k - 1], coordinates=f"q{k}")
        m.add_generalized_force(f"q{k}", f"tau{k}")
    for e in ref.elements:
        if isinstance(e, lg.model.RigidBody3D):
            m.add_rigid_body(e.mass, e.inertia, frame=e.frame, center=e.position, center_frame="world", name=e.name)
    m.add_gravity("g")
    a, b = (lg.compile(lg.derive(x), backend="scipy") for x in (m, ref))
    assert a.state_names == b.state_names and a.input_names == b.input_names
    rng = np.random.default_rng(3)
    for _ in range(3):
        x, u = rng.uniform(-2, 2, 2 * n), rng.uniform(-1, 1, n)
        np.testing.assert_allclose(a.mass_matrix(0, x, u, a.parameter_values),
                                   b.mass_matrix(0, x, u, b.parameter_values), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(a.forcing(0, x, u, a.parameter_values),
                                   b.forcing(0, x, u, b.parameter_values), rtol=1e-11, atol=1e-12)
