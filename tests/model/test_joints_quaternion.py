"""The singularity-free spherical and floating joint: parametrization = "quaternion" (Euler parameters with the
unit-norm constraint, omega = 2 G(q) q_dot, the augmented inertia k (q . q_dot)^2 / 2).

Checked against: the rotation matrix and angular velocity of the three-angle joint (the quaternion of the
same rotation), the three-angle joint's motion away from its singular posture (the same rotation to 1e-9),
a symmetric free body's closed-form precession, the conserved energy and angular momentum through the
posture where the angles are singular, a falling floating body's closed form, and the drift of |q| kept by
the projection."""

import re

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.errors import ModelError, ModelFileError
from lagrangian.io import loads_model
from lagrangian.model._joints import quaternion_matrix, quaternion_rate

VALUES = dict(m=1.0, g=9.81, l=0.1, I1=0.02, I2=0.03, I3=0.01)


def _top(parametrization=None, gravity=True, values=VALUES, floating=False):
    """A rigid body on a spherical joint at its tip (a heavy top), or free (no gravity), or floating."""
    m = lg.Model("top")
    for k, v in values.items():
        m.parameter(k, v)
    m.add_joint("ball", "floating" if floating else "spherical", parametrization=parametrization)
    m.add_rigid_body("m", ["I1", "I2", "I3"], frame="ball", center=(0, 0, 0 if floating else "l"))
    if gravity:
        m.add_gravity("g")
    return m


def _qmul(a, b):
    a0, av, b0, bv = a[0], np.asarray(a[1:]), b[0], np.asarray(b[1:])
    return np.concatenate(([a0 * b0 - av @ bv], a0 * bv + b0 * av + np.cross(av, bv)))


def _quaternion_xyz(a, b, c):
    """The quaternion of Rx(a) Ry(b) Rz(c) (intrinsic x, y, z: the three-angle joint's default)."""
    qx = np.array([np.cos(a / 2), np.sin(a / 2), 0, 0])
    qy = np.array([np.cos(b / 2), 0, np.sin(b / 2), 0])
    qz = np.array([np.cos(c / 2), 0, 0, np.sin(c / 2)])
    return _qmul(_qmul(qx, qy), qz)


def _G(q):
    q0, q1, q2, q3 = q
    return np.array([[-q1, q0, q3, -q2], [-q2, -q3, q0, q1], [-q3, q2, -q1, q0]])


_e = sp.symbols("e0:4")
_R = sp.lambdify(_e, sp.Matrix(quaternion_matrix(_e)), "numpy")


def _Rxyz(a, b, c):
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    Rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    Ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    Rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


def test_the_matrix_and_the_angular_velocity_are_those_of_the_rotation():
    rng = np.random.default_rng(1)
    R_sym = sp.Matrix(quaternion_matrix(_e))
    for _ in range(5):
        a, b, c = rng.uniform(-3, 3, 3)
        q = _quaternion_xyz(a, b, c)
        R = np.array(_R(*q), float)
        assert np.allclose(R, _Rxyz(a, b, c), atol=1e-14)
        # omega = 2 G q_dot equals the vector of R^T R' for a q_dot tangent to the sphere
        w = rng.normal(size=3)
        qd = _G(q).T @ w / 2
        assert abs(q @ qd) < 1e-15
        dR = sum(np.array(R_sym.diff(s).subs(dict(zip(_e, q))), float) * v for s, v in zip(_e, qd))
        W = R.T @ dR
        assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], w, atol=1e-13)
        assert np.allclose(W + W.T, 0, atol=1e-13)
        rate = sp.lambdify([*_e, *(sp.Symbol(f"{s}_dot") for s in _e)], sp.Matrix(quaternion_rate(_e)))
        assert np.allclose(np.array(rate(*q, *qd), float).ravel(), w, atol=1e-14)


def test_the_joint_declares_four_coordinates_the_constraint_and_a_regular_mass_matrix():
    model = _top("quaternion")
    assert [c.name for c in model.q] == ["ball_q0", "ball_q1", "ball_q2", "ball_q3"]
    assert [(c.name, c.kind) for c in model.constraints] == [("ball_norm", "holonomic")]
    assert model.joints["ball"].parametrization == "quaternion" and model.joints["ball"].sequence is None
    assert model.simulation["initial"] == {"ball_q0": 1.0}
    eqs = lg.derive(model)
    M = sp.lambdify(model.q, eqs.mass_matrix.subs(eqs.parameters), "numpy")
    I_tip = np.diag([0.02 + 0.01, 0.03 + 0.01, 0.01])  # about the tip: I + m l^2 across the axis
    for q in (np.array([1.0, 0, 0, 0]), _quaternion_xyz(0.3, np.pi / 2, -1.0), _quaternion_xyz(2, -np.pi / 2, 1)):
        Mq = np.array(M(*q), float)
        # M = 4 G^T I_tip G + (k + 4 m l^2) q q^T (k = 4/3 tr(I_G) = 0.08): the body's inertia about the tip in the
        # tangent directions; along q the augmented inertia k and the centre's r(q) = R(q) c, homogeneous of degree 2
        assert np.allclose(Mq, 4 * _G(q).T @ I_tip @ _G(q) + (0.08 + 4 * 1.0 * 0.1**2) * np.outer(q, q), atol=1e-14)
        assert np.linalg.eigvalsh(Mq).min() > 0.03  # regular at the angles' singular posture too
    # the three-angle joint is singular there
    angles = lg.derive(_top())
    Ma = sp.lambdify(_top().q, angles.mass_matrix.subs(angles.parameters), "numpy")
    assert abs(np.linalg.det(np.array(Ma(0.3, np.pi / 2, -1.0), float))) < 1e-15


def _start(a, b, c, wa, wb, wc):
    """The quaternion state of the angle state (a, b, c, rates): q and q_dot = G^T omega / 2."""
    q = _quaternion_xyz(a, b, c)
    # omega in body axes of Rx(a) Ry(b) Rz(c) from the rates: Rz^T Ry^T (wa e_x) + Rz^T (wb e_y) + wc e_z
    Rz, Ry = _Rxyz(0, 0, c), _Rxyz(0, b, 0)
    w = Rz.T @ Ry.T @ np.array([wa, 0, 0]) + Rz.T @ np.array([0, wb, 0]) + np.array([0, 0, wc])
    return q, _G(q).T @ w / 2, w


def _initial(q, qd):
    return {**{f"ball_q{i}": v for i, v in enumerate(q)}, **{f"ball_q{i}_dot": v for i, v in enumerate(qd)}}


def _quaternions(traj):
    return np.array([traj[f"ball_q{i}"] for i in range(4)]).T, np.array([traj[f"ball_q{i}_dot"] for i in range(4)]).T


@pytest.mark.slow
def test_the_heavy_top_moves_as_with_three_angles_away_from_their_singular_posture():
    a0 = (0.3, 0.4, -0.2, 1.0, -2.0, 20.0)  # angles and rates; b stays within (-1.2, 1.2) for 0.6 s
    ta = lg.simulate(lg.derive(_top()), t_end=0.6, initial=dict(zip(
        ["ball_1", "ball_2", "ball_3", "ball_1_dot", "ball_2_dot", "ball_3_dot"], a0)), rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(ta["ball_2"])) < 1.2
    q, qd, _ = _start(*a0)
    tq = lg.simulate(lg.derive(_top("quaternion")), t_end=0.6, initial=_initial(q, qd), rtol=1e-12, atol=1e-12)
    Q, _ = _quaternions(tq)
    err = max(np.max(np.abs(np.array(_R(*Q[k]), float) - _Rxyz(ta["ball_1"][k], ta["ball_2"][k], ta["ball_3"][k])))
              for k in range(len(tq.t)))
    assert err < 1e-9


def _energy_momentum(Q, Qd, values, I_tip, gravity):
    E, L = [], []
    for q, qd in zip(Q, Qd):
        w = 2 * _G(q) @ qd
        R = np.array(_R(*q), float)
        V = values["m"] * values["g"] * (R @ [0, 0, values["l"]])[2] if gravity else 0.0
        E.append(w @ I_tip @ w / 2 + V)
        L.append(R @ I_tip @ w)
    return np.array(E), np.array(L)


@pytest.mark.slow
def test_the_heavy_top_through_the_singular_posture_conserves_energy_and_vertical_momentum():
    # start at b = pi/2 (the three angles' singular posture: their M is singular there) with b_dot != 0
    q, qd, _ = _start(0.2, np.pi / 2, 0.5, 0.7, 3.0, 15.0)
    tq = lg.simulate(lg.derive(_top("quaternion")), t_end=2.0, initial=_initial(q, qd), rtol=1e-11, atol=1e-11)
    Q, Qd = _quaternions(tq)
    sin_b = np.array([np.array(_R(*x), float)[0, 2] for x in Q])  # R = Rx Ry Rz: R[0, 2] = sin b
    assert sin_b[0] == pytest.approx(1.0, abs=1e-14) and sin_b.min() < 0.9  # it moves through it and away
    I_tip = np.diag([0.03, 0.04, 0.01])
    E, L = _energy_momentum(Q, Qd, VALUES, I_tip, gravity=True)
    assert np.max(np.abs(E - E[0])) < 1e-8 * abs(E[0])
    assert np.max(np.abs(L[:, 2] - L[0, 2])) < 1e-8 * np.max(np.abs(L))
    assert np.max(np.abs(np.sum(Q**2, axis=1) - 1)) < 1e-10  # the projection keeps |q| = 1
    assert np.max(np.abs(np.sum(Q * Qd, axis=1))) < 1e-9


@pytest.mark.slow
def test_a_symmetric_free_body_precesses_as_the_closed_form_through_every_posture():
    values = dict(m=1.0, g=0.0, l=0.0, I1=0.03, I2=0.03, I3=0.05)
    w0 = np.array([1.5, 0.0, 4.0])
    q0 = _quaternion_xyz(0.0, np.pi / 2, 0.0)  # the singular posture of the angles
    qd0 = _G(q0).T @ w0 / 2
    tq = lg.simulate(lg.derive(_top("quaternion", gravity=False, values=values)), t_end=3.0,
                     initial=_initial(q0, qd0), rtol=1e-11, atol=1e-11)
    Q, Qd = _quaternions(tq)
    W = np.array([2 * _G(q) @ qd for q, qd in zip(Q, Qd)])
    # Euler's equations of a symmetric body: w3 constant, (w1, w2) turning at Omega = (I3 - I1)/I1 * w3
    Omega = (0.05 - 0.03) / 0.03 * 4.0
    t = tq.t
    exact = np.array([1.5 * np.cos(Omega * t), 1.5 * np.sin(Omega * t), 4.0 + 0 * t]).T
    assert np.max(np.abs(W - exact)) < 1e-8
    I = np.diag([0.03, 0.03, 0.05])
    E, L = _energy_momentum(Q, Qd, values, I, gravity=False)
    assert np.max(np.abs(E - E[0])) < 1e-9 * E[0]
    assert np.max(np.abs(L - L[0])) < 1e-9 * np.linalg.norm(L[0])  # the whole angular momentum, in world axes
    assert np.max(np.abs(np.sum(Q**2, axis=1) - 1)) < 1e-10


@pytest.mark.slow
def test_a_floating_quaternion_body_falls_as_the_closed_form_while_it_tumbles():
    values = dict(m=2.0, g=9.81, l=0.0, I1=0.02, I2=0.03, I3=0.04)
    model = _top("quaternion", values=values, floating=True)
    assert [c.name for c in model.q] == ["ball_x", "ball_y", "ball_z", "ball_q0", "ball_q1", "ball_q2", "ball_q3"]
    q0 = _quaternion_xyz(0.1, np.pi / 2, 0.0)
    w0 = np.array([0.3, 5.0, 0.2])  # about the intermediate axis: it tumbles
    init = {**_initial(q0, _G(q0).T @ w0 / 2), "ball_x_dot": 0.5, "ball_z_dot": 2.0}
    tq = lg.simulate(lg.derive(model), t_end=1.0, initial=init, rtol=1e-11, atol=1e-11)
    t = tq.t
    assert np.max(np.abs(tq["ball_z"] - (2.0 * t - 9.81 * t**2 / 2))) < 1e-9
    assert np.max(np.abs(tq["ball_x"] - 0.5 * t)) < 1e-9
    Q, Qd = _quaternions(tq)
    E, L = _energy_momentum(Q, Qd, values, np.diag([0.02, 0.03, 0.04]), gravity=False)
    assert np.max(np.abs(E - E[0])) < 1e-9 * E[0] and np.max(np.abs(L - L[0])) < 1e-9 * np.linalg.norm(L[0])


#: The heavy top as a model file: {joint} adds keys to its joint, {simulation} to its [simulation] table.
_TOP_FILE = '''name = "top"
[parameters]
m = 1.0
g = 9.81
l = 0.1
I1 = 0.02
I2 = 0.03
I3 = 0.01
[[joints]]
name = "ball"
type = "spherical"
parametrization = "quaternion"
{joint}
[[bodies]]
mass = "m"
frame = "ball"
inertia = ["I1", "I2", "I3"]
center = ["0", "0", "l"]
[gravity]
g = "g"
[simulation]
t_end = 0.05
{simulation}
'''


def test_the_model_file_key_builds_the_same_joint():
    def text(simulation=""):  # the top with a rotational damper c
        top = _TOP_FILE.format(joint='damping = "c"', simulation=simulation)
        return top.replace("I3 = 0.01\n", "I3 = 0.01\nc = 0.05\n")

    a = loads_model(text())
    b = _top("quaternion")
    b.parameter("c", 0.05)
    with pytest.raises(ModelError):  # a model is built once: the damping goes in add_joint
        b.add_joint("ball", "spherical", parametrization="quaternion")
    b = lg.Model("top")
    for k, v in {**VALUES, "c": 0.05}.items():
        b.parameter(k, v)
    b.add_joint("ball", "spherical", parametrization="quaternion", damping="c")
    b.add_rigid_body("m", ["I1", "I2", "I3"], frame="ball", center=(0, 0, "l"))
    b.add_gravity("g")
    ea, eb = lg.derive(a), lg.derive(b)
    assert a.q == b.q and a.simulation["initial"] == {"ball_q0": 1.0}
    assert sp.expand(ea.mass_matrix - eb.mass_matrix) == sp.zeros(4, 4)
    assert sp.expand(ea.forcing - eb.forcing) == sp.zeros(4, 1)
    # the rotational damper: D = c |omega|^2 / 2 with omega = 2 G q_dot
    w = sp.Matrix(quaternion_rate(a.q))
    assert sp.expand(ea.D - sp.Symbol("c") * (w.T * w)[0] / 2) == 0
    # the file's own initial values replace the default q0 = 1
    c = loads_model(text("initial = { ball_q3 = 1.0 }"))
    assert c.simulation["initial"] == {"ball_q3": 1.0}


def _problems(text):
    with pytest.raises(ModelFileError) as info:
        loads_model(text)
    return str(info.value)


@pytest.mark.parametrize("table, match", [
    ('type = "spherical"\nparametrization = "quaternions"',
     r"\[joints\[0\]\.parametrization\].*unknown parametrization 'quaternions' \(did you mean 'quaternion'\?\); "
     r"expected \"angles\" \(three angles, the default\) or \"quaternion\""),
    ('type = "spherical"\nparametrization = 4', r"\[joints\[0\]\.parametrization\].*unknown parametrization 4;"),
    ('type = "spherical"\nparametrization = "__import__(\'os\')"',
     r"unknown parametrization \"__import__\('os'\)\""),
    ('type = "revolute"\nparametrization = "quaternion"',
     r"\[joints\[0\]\.parametrization\].*only spherical and floating joints have a parametrization"),
    ('type = "spherical"\nparametrization = "quaternion"\nsequence = "zyx"',
     r"\[joints\[0\]\.sequence\].*a quaternion spherical joint has no sequence of angles: remove sequence"),
    ('type = "spherical"\nparametrization = "quaternion"\nlimits = [[0, 1], [0, 1], [0, 1], [0, 1]]',
     r"\[joints\[0\]\.limits\].*a quaternion's components have no limits"),
    ('type = "spherical"\nparametrization = "quaternion"\ncoordinates = ["a", "b", "c"]',
     r"a spherical joint has 4 coordinates, got \['a', 'b', 'c'\]; give 4 names, e\.g\. \['j_q0', 'j_q1', "
     r"'j_q2', 'j_q3'\]"),
    ('type = "floating"\nparametrization = "quaternion"\nfriction = 1', r"a floating joint takes no friction"),
])
def test_parametrization_problems(table, match):
    message = _problems(f'name = "bad"\n[[joints]]\nname = "j"\n{table}\n')
    assert re.search(match, message, flags=re.DOTALL), message


def test_the_constraint_name_taken_is_refused_before_anything_is_added():
    m = lg.Model("m")
    m.coordinate("x")
    m.add_constraint("x", name="ball_norm")
    with pytest.raises(ModelError, match=r"a quaternion joint adds the constraint 'ball_norm' .* that name is taken"):
        m.add_joint("ball", "spherical", parametrization="quaternion")
    assert [c.name for c in m.q] == ["x"] and "ball" not in m.frames and not m.joints


def test_the_check_finds_no_singular_configuration_on_the_unit_sphere():
    # det M = 256/3 I3 (I1 + m l^2)(I2 + m l^2)(I1 + I2 + I3 + 3 m l^2) |q|^8 (k = 4/3 tr I_G) vanishes only at q = 0
    report = lg.singularities(lg.derive(_top("quaternion")))
    assert not report.singular and "ball_q0**2 + ball_q1**2 + ball_q2**2 + ball_q3**2" in str(report.det_mass_matrix)
    angles = lg.singularities(lg.derive(_top()))
    assert angles.singular and [c.condition for c in angles.configurations] == ["ball_2 = -pi/2", "ball_2 = pi/2"]


def test_the_element_name_taken_is_refused():
    m = lg.Model("m")
    x = m.coordinate("x")
    m.add_particle(1, (x, 0), name="ball_unit")
    with pytest.raises(ModelError, match=r"a quaternion joint adds the element 'ball_unit', but an element has that "
                                         r"name: rename the joint or the element"):
        m.add_joint("ball", "spherical", parametrization="quaternion")
    assert not m.joints and [c.name for c in m.q] == ["x"]


# ------------------------------------------------------------------ the augmented inertia's scale k = 4/3 tr(I_G)

def _with_unit_coefficient(model, k):
    """`model` with its augmented inertia's coefficient replaced by `k` (the value before the scaling: 1)."""
    from dataclasses import replace

    from lagrangian.model._joints import UnitQuaternion

    model._elements[:] = [replace(e, coefficient=sp.sympify(k)) if isinstance(e, UnitQuaternion) else e
                          for e in model._elements]
    return model


def test_the_augmented_inertia_is_four_thirds_of_the_trace_of_the_central_inertia_symbolically():
    model = _top("quaternion")
    (unit,) = [e for e in model.elements if e.kind == "unit quaternion"]
    I1, I2, I3 = sp.symbols("I1 I2 I3")
    assert sp.simplify(unit.coefficient - sp.Rational(4, 3) * (I1 + I2 + I3)) == 0 and unit.bodies == ("body1",)
    # a second body in the child frame and one hanging below a further joint add theirs; a body in another
    # branch (below no quaternion joint) adds nothing
    m = _top("quaternion", gravity=False)
    m.add_rigid_body(2.0, [[1, 0.5, 0], [0.5, 2, 0], [0, 0, 3]], frame="ball", name="second")
    m.add_joint("hinge", "revolute", parent="ball", origin=(0, 0, "l"))
    m.add_rigid_body(1.0, [4, 5, 6], frame="hinge", name="third")
    m.add_joint("other", "revolute")
    m.add_rigid_body(1.0, [7, 8, 9], frame="other", name="elsewhere")
    (unit,) = [e for e in m.elements if e.kind == "unit quaternion"]
    assert sp.simplify(unit.coefficient - sp.Rational(4, 3) * (I1 + I2 + I3 + 6 + 15)) == 0
    assert unit.bodies == ("body1", "second", "third")
    # two quaternion joints in series: each body scales its nearest one
    c = lg.Model("chain")
    c.add_joint("a", "spherical", parametrization="quaternion")
    c.add_rigid_body(1.0, [1, 1, 1], frame="a", name="A")
    c.add_joint("b", "spherical", parent="a", origin=(0, 0, 1), parametrization="quaternion")
    c.add_rigid_body(1.0, [2, 2, 2], frame="b", name="B")
    assert [(e.name, e.coefficient) for e in c.elements if e.kind == "unit quaternion"] == [("a_unit", 4),
                                                                                             ("b_unit", 8)]
    # a quaternion joint that carries no body keeps k = 1
    bare = lg.Model("bare")
    bare.add_joint("j", "spherical", parametrization="quaternion")
    assert [e.coefficient for e in bare.elements if e.kind == "unit quaternion"] == [1]


@pytest.mark.parametrize("mass, inertia, l", [
    (1e-3, (1e-6, 2e-6, 1.5e-6), 0.01),    # a small robot link
    (1e3, (1e4, 2e4, 1.5e4), 0.01),        # a heavy one
    (1.0, (0.02, 0.03, 0.01), 0.1),
])
def test_the_mass_matrix_is_conditioned_as_the_body_s_inertia_for_tiny_and_huge_bodies(mass, inertia, l):
    values = dict(m=mass, g=9.81, l=l, I1=inertia[0], I2=inertia[1], I3=inertia[2])
    I_tip = np.array([inertia[0] + mass * l**2, inertia[1] + mass * l**2, inertia[2]])
    bound = I_tip.max() / I_tip.min()  # cond of the inertia about the joint: M's tangent block is 4 G^T I_tip G
    rng = np.random.default_rng(11)
    conds = {}
    for k in (None, 1):  # scaled, and the old k = 1 (model units)
        model = _top("quaternion", values=values)
        if k is not None:
            _with_unit_coefficient(model, k)
        eqs = lg.derive(model)
        M = sp.lambdify(model.q, eqs.mass_matrix.subs(eqs.parameters), "numpy")
        conds[k] = []
        for _ in range(5):
            q = rng.normal(size=4)
            q /= np.linalg.norm(q)
            conds[k].append(np.linalg.cond(np.array(M(*q), float)))
    # along q: k + 4 m l^2 = 4 (mean I_G + m l^2), between the tangent eigenvalues: cond(M) = cond(I_tip)
    assert max(conds[None]) <= bound * (1 + 1e-9)
    if l != 0.1:
        assert min(conds[1]) > 1e4 * bound  # k = 1 in model units: 2e5 for the tiny body, 6e4 for the huge one


@pytest.mark.slow
def test_the_heavy_top_moves_as_with_the_augmented_inertia_in_model_units():
    # the scale of k changes M along q only: the motion and the multiplier are those of k = 1 (as before)
    q, qd, _ = _start(0.3, 0.4, -0.2, 1.0, -2.0, 20.0)
    runs = []
    for k in (None, 1):
        model = _top("quaternion")
        if k is not None:
            _with_unit_coefficient(model, k)
        runs.append(lg.simulate(lg.derive(model), t_end=0.6, initial=_initial(q, qd), rtol=1e-13, atol=1e-13))
    (Qa, Qda), (Qb, Qdb) = _quaternions(runs[0]), _quaternions(runs[1])
    assert np.max(np.abs(Qa - Qb)) < 1e-11 and np.max(np.abs(Qda - Qdb)) < 1e-10


# ------------------------------------------------------------------ lg.quaternion_rates(q, omega)

def test_quaternion_rates_is_the_closed_form_half_q_times_zero_omega():
    rng = np.random.default_rng(4)
    for _ in range(10):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        w = rng.normal(size=3) * 3
        qd = lg.quaternion_rates(q, w)
        assert qd.shape == (4,)
        assert np.allclose(qd, _qmul(q, np.concatenate(([0.0], w))) / 2, rtol=0, atol=1e-15)
        assert abs(q @ qd) < 1e-15 and np.allclose(2 * _G(q) @ qd, w, rtol=0, atol=1e-14)
    # lists, tuples and integers alike; the documented example
    assert lg.quaternion_rates((1, 0, 0, 0), [0, 0, 2]).tolist() == [0.0, 0.0, 0.0, 1.0]


@pytest.mark.parametrize("q, omega, match", [
    ([1, 0, 0], [0, 0, 1], r"\[q\]: q \(a quaternion\) has 4 numbers, e\.g\. \[1, 0, 0, 0\], got '\[1, 0, 0\]' "
                           r"of shape \(3,\)"),
    ([1, 0, 0, 0], [0, 1], r"\[omega\]: omega \(an angular velocity\) has 3 numbers, e\.g\. \[0, 0, 1\.5\]"),
    ("1000", [0, 0, 1], r"q \(a quaternion\) has 4 numbers, .* got '1000'"),
    ([1, 0, 0, 0], "__import__('os')", r"omega \(an angular velocity\) has 3 numbers, .* got \"__import__\('os'\)\""),
    ([1, 0, 0, float("nan")], [0, 0, 1], r"q \(a quaternion\) must be finite numbers, got \[1\.0, 0\.0, 0\.0, nan\]"),
    ([1, 0, 0, 0], [0, float("inf"), 1], r"omega \(an angular velocity\) must be finite numbers"),
    ([1, 0, 0, 0], None, r"omega \(an angular velocity\) has 3 numbers, .* got 'None'"),
    ([[1, 0, 0, 0]], [0, 0, 1], r"got '\[\[1, 0, 0, 0\]\]' of shape \(1, 4\)"),
    (np.zeros(10**6), [0, 0, 1], r"q \(a quaternion\) has 4 numbers, .* of shape \(1000000,\)"),
])
def test_quaternion_rates_problems(q, omega, match):
    with pytest.raises(ModelError, match=match):
        lg.quaternion_rates(q, omega)


@pytest.mark.slow
def test_a_free_body_started_with_quaternion_rates_turns_at_omega():
    values = dict(m=1.0, g=0.0, l=0.0, I1=0.03, I2=0.04, I3=0.05)
    q0 = _quaternion_xyz(0.4, -0.7, 1.2)
    w0 = np.array([1.0, -2.0, 3.0])
    traj = lg.simulate(lg.derive(_top("quaternion", gravity=False, values=values)), t_end=0.2,
                       initial=_initial(q0, lg.quaternion_rates(q0, w0)), rtol=1e-12, atol=1e-12)
    Q, Qd = _quaternions(traj)
    assert np.allclose(Q[0], q0, rtol=0, atol=1e-15)
    assert np.allclose(2 * _G(Q[0]) @ Qd[0], w0, rtol=0, atol=1e-13)  # the body's angular velocity at t = 0
    # and Euler's equations' first step: the angular momentum in world axes is that of w0 all along
    L = [np.array(_R(*q), float) @ np.diag([0.03, 0.04, 0.05]) @ (2 * _G(q) @ qd) for q, qd in zip(Q, Qd)]
    L0 = np.array(_R(*q0), float) @ np.diag([0.03, 0.04, 0.05]) @ w0
    assert np.max(np.abs(np.array(L) - L0)) < 1e-10


# ------------------------------------------------------------------ the initial angular velocity: omega



def _start_of(traj):
    Q, Qd = _quaternions(traj)
    return Q[0], Qd[0]


@pytest.mark.slow
def test_omega_in_the_joint_table_starts_the_body_turning_at_omega_in_its_own_axes():
    q0 = _quaternion_xyz(0.3, 1.2, -0.4)
    initial = "initial = { " + ", ".join(f"ball_q{i} = {float(v)!r}" for i, v in enumerate(q0)) + " }"
    model = loads_model(_TOP_FILE.format(joint="omega = [1.5, -2.0, 20.0]", simulation=initial))
    assert model.joints["ball"].omega == (1.5, -2.0, 20.0)
    traj = lg.simulate(lg.derive(model), rtol=1e-12, atol=1e-12)
    q, qd = _start_of(traj)
    assert np.allclose(q, q0, rtol=0, atol=1e-15)
    assert np.allclose(qd, _qmul(q0, [0.0, 1.5, -2.0, 20.0]) / 2, rtol=0, atol=1e-14)  # q (x) (0, omega) / 2
    assert np.allclose(2 * _G(q) @ qd, [1.5, -2.0, 20.0], rtol=0, atol=1e-13)  # the body's omega at t = 0
    # the same joint in Python; a quaternion given by the caller turns at omega from there
    py = lg.Model("top")
    for k, v in VALUES.items():
        py.parameter(k, v)
    py.add_joint("ball", "spherical", parametrization="quaternion", omega=(1.5, -2.0, 20.0))
    py.add_rigid_body("m", ["I1", "I2", "I3"], frame="ball", center=(0, 0, "l"))
    py.add_gravity("g")
    traj = lg.simulate(lg.derive(py), t_end=0.05, initial={"ball_q0": 0.0, "ball_q3": 1.0})
    q, qd = _start_of(traj)
    assert q.tolist() == [0.0, 0.0, 0.0, 1.0] and np.allclose(2 * _G(q) @ qd, [1.5, -2.0, 20.0], atol=1e-13)
    # rates given (by the caller or the file) are kept instead of omega
    traj = lg.simulate(lg.derive(py), t_end=0.05, initial={"ball_q1_dot": 0.5})
    q, qd = _start_of(traj)
    assert np.allclose(qd, [0, 0.5, 0, 0], atol=1e-15)


def test_omega_is_written_and_read_back(tmp_path):
    model = loads_model(_TOP_FILE.format(joint="omega = [0, 1, 20]", simulation=""))
    back = lg.load(str(lg.write_model(model, tmp_path / "top.toml")))
    assert back.joints["ball"].omega == (0.0, 1.0, 20.0)


@pytest.mark.parametrize("joint, match", [
    ("omega = [0, 1]", r"\[joints\[0\]\.omega\].*expected the initial angular velocity as 3 numbers \[wx, wy, wz\] "
                       r"\(rad/s, in the child's own axes\), got \[0, 1\]"),
    ("omega = [0, 1, 2, 3]", r"expected the initial angular velocity as 3 numbers"),
    ('omega = ["__import__(\'os\')", 0, 0]', r"expected the initial angular velocity as 3 numbers .* got "
                                             r"\[\"__import__\('os'\)\", 0, 0\]"),
    ('omega = "20"', r"expected the initial angular velocity as 3 numbers .* got '20'"),
    ("omega = [true, 0, 0]", r"expected the initial angular velocity as 3 numbers"),
    ("omega = [nan, 0, 0]", r"the initial angular velocity must be finite numbers, got \[nan, 0, 0\]"),
    ("omega = [0, 0, inf]", r"must be finite numbers"),
    ('omeag = [0, 0, 1]', r"\[joints\[0\]\.omeag\].*did you mean 'omega'"),
])
def test_omega_problems(joint, match):
    message = _problems(_TOP_FILE.format(joint=joint, simulation=""))
    assert re.search(match, message, flags=re.DOTALL), message


def test_omega_on_a_joint_of_three_angles_or_a_hinge_is_refused():
    m = lg.Model("m")
    with pytest.raises(ModelError, match=r"\[joint 'ball'\.omega\]: omega is the initial angular velocity of a "
                                         r"quaternion joint .* or give the coordinates' rates in the initial values"):
        m.add_joint("ball", "spherical", omega=[0, 0, 1])
    with pytest.raises(ModelError, match=r"omega is the initial angular velocity of a quaternion joint"):
        m.add_joint("hinge", "revolute", omega=[0, 0, 1])
    assert not m.joints and not m.q


# ------------------------------------------------------------------ the initial quaternion: one rule

def test_an_all_zero_quaternion_is_one_clear_error_in_simulate_check_and_the_cli(tmp_path, capsys):
    from lagrangian.cli import main

    eqs = lg.derive(_top("quaternion"))
    expected = (r"\[initial\]: the initial quaternion of joint 'ball' \(ball_q0 = 0; the components not given are 0\) "
                r"is zero, which is no rotation: give a unit quaternion, e\.g\. ball_q0 = 1 for the joint frame's "
                r"axes, or ball_q0 = 0, ball_q3 = 1 for a half turn about z \(leave all four out for the identity\)")
    with pytest.raises(ModelError, match=expected):
        lg.simulate(eqs, t_end=0.01, initial={"ball_q0": 0})
    with pytest.raises(ModelError, match=r"\[initial\.ball_q1\]: the value of 'ball_q1' must be a finite number"):
        lg.simulate(eqs, t_end=0.01, initial={"ball_q1": float("nan"), "ball_q2": 1.0})
    path = tmp_path / "top.toml"
    path.write_text(_TOP_FILE.format(joint="", simulation="initial = { ball_q0 = 0.0 }"))
    in_file = r"top\.toml:23 \[simulation\.initial\]" + expected[len(r"\[initial\]"):]
    for command in ("check", "load"):  # the model file's own values: refused when it is read, with its line
        assert main([command, str(path)]) == 2
        err = capsys.readouterr().err
        assert re.search(in_file, err) and "Traceback" not in err, err
    with pytest.raises(ModelFileError, match=r"\[simulation\.initial\]: the initial quaternion of joint 'ball'"):
        loads_model(_TOP_FILE.format(joint="", simulation="initial = { ball_q0 = 0, ball_q2 = 0.0 }"))
    path.write_text(_TOP_FILE.format(joint="", simulation=""))
    assert main(["simulate", str(path), "--initial", "ball_q0=0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("lagrangian simulate: error:") and re.search(expected, err)


def test_unset_components_and_a_non_unit_quaternion():
    from lagrangian.model._joints import quaternion_start

    model = _top("quaternion")
    assert quaternion_start(model, {}) == ({"ball_q0": 1.0, "ball_q1": 0.0, "ball_q2": 0.0, "ball_q3": 0.0}, [])
    assert quaternion_start(model, {"ball_q0": 1.0}, {"ball_q2": 1})[0] == {"ball_q0": 0.0, "ball_q1": 0.0,
                                                                            "ball_q2": 1.0, "ball_q3": 0.0}
    values, notes = quaternion_start(model, {"ball_q1": 3.0, "ball_q3": -4.0})
    assert values == {"ball_q0": 0.0, "ball_q1": 0.6, "ball_q2": 0.0, "ball_q3": -0.8}
    assert notes == ["The initial quaternion of joint 'ball' (ball_q1 = 3, ball_q3 = -4; the components not given "
                     "are 0) has length 5: it was scaled to unit length, (0, 0.6, 0, -0.8)."]
    with pytest.raises(ModelError, match=r"ball_q0 = 'x'.* is not finite"):
        quaternion_start(model, {}, {"ball_q0": "x"})


@pytest.mark.slow
def test_check_and_simulate_start_from_the_same_state():
    # q0 alone, not a unit: before, the consistent-state search gave an arbitrary axis, and check another
    text = _TOP_FILE.format(joint="", simulation="initial = { ball_q0 = 0.5, ball_q2 = 0.5, ball_q1_dot = 0.3 }")
    eqs = lg.derive(loads_model(text))
    report = lg.constraint_singularities(eqs)
    traj = lg.simulate(eqs, rtol=1e-12, atol=1e-12)
    q, qd = _start_of(traj)
    r = np.sqrt(0.5)
    assert np.allclose(q, [r, 0, r, 0], rtol=0, atol=1e-15)
    assert [report.initial[f"ball_q{i}"] for i in range(4)] == pytest.approx(q.tolist(), abs=1e-15)
    assert any("has length 0.707107: it was scaled to unit length, (0.707107, 0, 0.707107, 0)" in n
               for n in report.notes)
    assert abs(q @ qd) < 1e-14 and qd[1] == pytest.approx(0.3, abs=1e-15)  # tangent rates kept
    # the same from the caller's values, and from a whole state array
    traj = lg.simulate(eqs, initial={"ball_q0": 2.0, "ball_q2": 2.0}, rtol=1e-12, atol=1e-12)
    assert np.allclose(_start_of(traj)[0], [r, 0, r, 0], rtol=0, atol=1e-15)
    traj = lg.simulate(eqs, initial=[0, 0, 0, 3.0, 0, 0, 0, 0], rtol=1e-12, atol=1e-12)
    assert _start_of(traj)[0].tolist() == [0.0, 0.0, 0.0, 1.0]


def test_the_playground_starts_a_quaternion_by_the_same_rule():
    import json

    from lagrangian.serve._tasks import simulate_task
    from lagrangian.errors import LagrangianError

    text = _TOP_FILE.format(joint="omega = [0, 0, 3]", simulation="initial = { ball_q0 = 1.0 }")
    reply = simulate_task(json.dumps({"model": text, "t_end": 0.01, "initial": {"ball_q1": 2.0}}).encode())
    columns = json.loads(reply.body)["columns"]
    q = np.array([columns[f"ball_q{i}"][0] for i in range(4)])
    qd = np.array([columns[f"ball_q{i}_dot"][0] for i in range(4)])
    assert reply.status == 200 and q.tolist() == [0.0, 1.0, 0.0, 0.0]  # the file's q0 = 1 replaced as a whole
    assert np.allclose(2 * _G(q) @ qd, [0, 0, 3], rtol=0, atol=1e-13)
    with pytest.raises(LagrangianError, match=r"the initial quaternion of joint 'ball' \(ball_q0 = 0; .*\) is zero"):
        simulate_task(json.dumps({"model": text, "t_end": 0.01, "initial": {"ball_q0": 0.0}}).encode())
