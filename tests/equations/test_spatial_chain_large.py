"""Chains of rods in space deep enough that their world positions, written out, would be astronomically
large (PyDy's 3D n-body pendulum without contact, as benchmarks/spatial_chain.py builds it): the poses
composed in halves, the momenta from M, and the equations against Pinocchio (an independent rigid-body
library: CRBA and RNEA) at random states; energy conserved in simulation."""

from __future__ import annotations

import numpy as np
import pytest
import symengine as se
import sympy

import lagrangian as lg
from lagrangian.model._frames import SEQUENTIAL_DEPTH, chain, frame_pose
from lagrangian.model._kinematics import to_se

PARAMS = {"m": 1.0, "m1": 0.2, "m_link": 0.5, "l": 6.0, "r": 1.5, "g": 9.8, "iXX": 0.9, "iYY": 0.8, "iZZ": 0.7}


def rods(n: int, bodies: bool = True) -> lg.Model:
    """n rods, rod k on a spherical joint (body-fixed x, y, z angles) at the end of rod k - 1, each with a ball,
    its own mass and a dot off its axis (tests/models/spatial-chain-3.toml for n = 3, other inertias); without
    `bodies`, only the frames and the last rod's dot."""
    m = lg.Model(f"spatial-chain-{n}")
    for i in range(1, n + 1):
        m.coordinate(f"qx{i}", f"qy{i}", f"qz{i}")
    for name, value in PARAMS.items():
        m.parameter(name, value)
    for i in range(1, n + 1):
        m.add_frame(f"rod{i}", parent="world" if i == 1 else f"rod{i - 1}",
                    origin=(0, 0, 0) if i == 1 else (0, "l", 0),
                    rotation=[("x", f"qx{i}"), ("y", f"qy{i}"), ("z", f"qz{i}")])
    if not bodies:
        m.add_particle("m1", (0, "l/2", "r"), frame=f"rod{n}", name=f"dot{n}")
        return m
    for i in range(1, n + 1):
        m.add_rigid_body("m", ("iXX", "iYY", "iZZ"), frame=f"rod{i}", center=(0, "l/2", 0), name=f"ball{i}")
        m.add_rigid_body("m_link", ("m_link*l**2/12", "0", "m_link*l**2/12"), frame=f"rod{i}",
                         center=(0, "l/2", 0), name=f"link{i}")
        m.add_particle("m1", (0, "l/2", "r"), frame=f"rod{i}", name=f"dot{i}")
    m.add_gravity("g", direction=(0, -1, 0))
    return m


def _tree_size(e, memo) -> int:
    """Nodes of `e`'s tree with every shared subexpression written out (as SymPy walks it)."""
    k = memo.get(id(e))
    if k is None:
        k = memo[id(e)] = 1 + sum(_tree_size(a, memo) for a in e.args)
    return k


def _sequential_pose(frames, name):
    origin, R = sympy.zeros(3, 1), sympy.eye(3)
    for frame in chain(frames, name):
        origin = origin + R * sympy.Matrix(frame.origin)
        R = R * frame.rotation
    return origin, R


def test_deep_pose_composed_in_halves_equals_the_sequential_one():
    m = rods(7, bodies=False)
    origin, R = frame_pose(m.frames, "rod7")
    o_seq, R_seq = _sequential_pose(m.frames, "rod7")
    rng = np.random.default_rng(7)
    symbols = [se.Symbol(s.name) for s in (*m.q, sympy.Symbol("l"))]
    for _ in range(3):
        point = {s: se.Float(v) for s, v in zip(symbols, rng.uniform(-2, 2, len(symbols)))}
        for a, b in zip([*origin, *R], [*o_seq, *R_seq]):
            assert abs(float(to_se(a).xreplace(point)) - float(to_se(b).xreplace(point))) < 1e-12
    # chains up to SEQUENTIAL_DEPTH frames keep their expressions (their printed forms)
    assert SEQUENTIAL_DEPTH == 3
    o3, R3 = frame_pose(m.frames, "rod3")
    o3s, R3s = _sequential_pose(m.frames, "rod3")
    assert list(o3) == list(o3s) and R3 == R3s


def test_twenty_rods_positions_stay_small():
    m = rods(20, bodies=False)
    memo: dict = {}
    (body,) = m.elements  # the last rod's particle, (0, l/2, r) in rod20
    assert body.name == "dot20"
    sizes = [_tree_size(x, memo) for x in body.position]
    assert max(sizes) < 200_000  # written out one frame after another: about 3^20 = 3.5e9
    origin, R = frame_pose(m.frames, "rod20")
    assert frame_pose(m.frames, "rod20")[1] == R  # cached, and a fresh matrix each call
    assert frame_pose(m.frames, "rod20")[1] is not R


def _pinocchio_chain(n: int, pin):
    """The same chain in Pinocchio: three revolute joints x, y, z per rod (intrinsic, as the frames)."""
    P = PARAMS
    model = pin.Model()
    model.gravity.linear = np.array([0.0, -P["g"], 0.0])
    parent = 0
    for i in range(1, n + 1):
        placement = pin.SE3(np.eye(3), np.array([0.0, 0.0 if i == 1 else P["l"], 0.0]))
        for k, joint in enumerate((pin.JointModelRX(), pin.JointModelRY(), pin.JointModelRZ())):
            parent = model.addJoint(parent, joint, placement if k == 0 else pin.SE3.Identity(), f"q{'xyz'[k]}{i}")
        c = np.array([0.0, P["l"] / 2, 0.0])
        ball = pin.Inertia(P["m"], c, np.diag([P["iXX"], P["iYY"], P["iZZ"]]))
        Il = P["m_link"] * P["l"] ** 2 / 12
        link = pin.Inertia(P["m_link"], c, np.diag([Il, 0.0, Il]))
        dot = pin.Inertia(P["m1"], np.array([0.0, P["l"] / 2, P["r"]]), np.zeros((3, 3)))
        model.appendBodyToJoint(parent, ball + link + dot, pin.SE3.Identity())
    return model


@pytest.mark.slow
def test_five_rods_match_pinocchio_and_momenta_from_M_equal_the_gradient():
    pin = pytest.importorskip("pinocchio", reason="the Pinocchio cross-check needs pip install pin")
    n = 5
    eqs = lg.derive(rods(n))
    nm = lg.compile(eqs, backend="scipy")
    pm = _pinocchio_chain(n, pin)
    data = pm.createData()
    assert [pm.names[i] for i in range(1, pm.njoints)] == [c.name for c in eqs.model.q]
    core = eqs.core
    values = {se.Symbol(k): se.Float(v) for k, v in PARAMS.items()}
    rng = np.random.default_rng(22)
    for _ in range(3):
        q, qd = rng.uniform(-2, 2, 3 * n), rng.uniform(-2, 2, 3 * n)
        x = np.concatenate([q, qd])
        M = nm.mass_matrix(0.0, x, [], nm.parameter_values)
        f = nm.forcing(0.0, x, [], nm.parameter_values)
        Mp = pin.crba(pm, data, q)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        nle = pin.rnea(pm, data, q, qd, np.zeros(3 * n))  # C q_dot + G: f = -nle
        assert np.abs(M - Mp).max() <= 1e-10 * np.abs(Mp).max()
        assert np.abs(f + nle).max() <= 1e-10 * np.abs(nle).max()
        # p = M q_dot (derive's, from the Kane form) against dL/dq_dot of L from the world positions
        point = dict(values)
        point.update({s: se.Float(v) for s, v in zip((*core.q, *core.qd), x)})
        p_new = np.array([float(e.xreplace(point)) for e in core.p])
        p_old = np.array([float(core.L.diff(v).xreplace(point)) for v in core.qd])
        assert np.abs(p_new - p_old).max() <= 1e-12 * np.abs(p_old).max()
        assert np.abs(p_new - M @ qd).max() <= 1e-12 * np.abs(p_old).max()


@pytest.mark.slow
def test_five_rods_conserve_energy():
    eqs = lg.derive(rods(5))
    initial = {"qx1": 0.2, "qy1": 0.2, "qz1": 0.2, **{f"qy{i}_dot": 1.5 for i in range(1, 6)}}
    traj = lg.simulate(eqs, t_end=0.5, initial=initial, rtol=1e-11, atol=1e-11, backend="scipy")
    assert traj.energy_name == "energy"
    E = np.asarray(traj.energy)
    assert np.abs(E - E[0]).max() <= 1e-8 * np.abs(E).max()
    assert np.ptp(traj["qy5"]) > 0.1  # it moved


@pytest.mark.parametrize("prescribed", [False, True])
def test_momenta_from_M_with_written_energy_and_prescribed_motion(prescribed):
    """p = M q_dot + dT_r/dq_dot - H_r q_dot with [energy] T terms of degree 1 and 2 in q_dot (T_r); with a
    frame turned by a prescribed angle (w t) p is T*'s gradient: both equal dL/dq_dot at random states."""
    from lagrangian.equations._derive import KANE_ABOVE
    from lagrangian.equations._readable import expanded_terms_bound

    m = rods(4)
    m.parameter("k", 0.7)
    m.parameter("w", 1.3)
    m.add_energy(T="k*qx1_dot + k*qy2_dot**2*cos(qz1)/2")
    if prescribed:
        m.add_frame("spin", parent="rod4", origin=(0, "l", 0), rotation=[("y", "w*t")])
        m.add_rigid_body("m", ("iXX", "iYY", "iZZ"), frame="spin", center=(0, "l/2", 0), name="spinner")
    eqs = lg.derive(m)
    core = eqs.core
    assert expanded_terms_bound(core.T, KANE_ABOVE) > KANE_ABOVE  # the Kane form's M and momenta
    rng = np.random.default_rng(5)
    values = {se.Symbol(k): se.Float(v) for k, v in {**PARAMS, "k": 0.7, "w": 1.3}.items()}
    for _ in range(2):
        point = dict(values)
        point.update({s: se.Float(v) for s, v in zip((*core.q, *core.qd, core.t), rng.uniform(-2, 2, 2 * eqs.n + 1))})
        p = np.array([float(e.xreplace(point)) for e in core.p])
        grad = np.array([float(core.L.diff(v).xreplace(point)) for v in core.qd])
        assert np.abs(p - grad).max() <= 1e-12 * np.abs(grad).max()


@pytest.mark.slow
def test_ten_rods_composite_mass_matrix_equals_kane_sum_and_pinocchio():
    """30 coordinates (COMPOSITE_FROM): derive's M by composite bodies equals Kane's sum over the bodies
    (the named form's) and Pinocchio's CRBA at random states, and is far smaller (fewer common subexpressions);
    T* from the momenta equals the bodies' and energy is conserved."""
    pin = pytest.importorskip("pinocchio", reason="the Pinocchio cross-check needs pip install pin")
    from lagrangian.equations._derive import COMPOSITE_FROM
    from lagrangian.equations._named import kane_form
    from lagrangian.model._kinematics import Kinematics

    n = 10
    assert 3 * n >= COMPOSITE_FROM
    eqs = lg.derive(rods(n))
    core = eqs.core
    kin = Kinematics(eqs.model.q)
    kane_M, _, _ = kane_form(eqs.model, kin)
    pm = _pinocchio_chain(n, pin)
    data = pm.createData()
    values = {se.Symbol(k): se.Float(v) for k, v in PARAMS.items()}
    rng = np.random.default_rng(3)
    N = eqs.n
    for _ in range(2):
        q, qd = rng.uniform(-2, 2, N), rng.uniform(-2, 2, N)
        point = dict(values)
        point.update({s: se.Float(v) for s, v in zip((*core.q, *core.qd), np.concatenate([q, qd]))})
        M = np.array([[float(core.M[i, j].xreplace(point)) for j in range(N)] for i in range(N)])
        K = np.array([[float(kane_M[i][j].xreplace(point)) for j in range(N)] for i in range(N)])
        Mp = pin.crba(pm, data, q)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        assert np.abs(M - K).max() <= 1e-12 * np.abs(K).max()
        assert np.abs(M - Mp).max() <= 1e-10 * np.abs(Mp).max()
        p = np.array([float(e.xreplace(point)) for e in core.p])
        assert np.abs(p - M @ qd).max() <= 1e-12 * np.abs(p).max()
        # T* = q_dot^T M q_dot / 2 (from the momenta) equals T* of the bodies' velocities
        T_bodies = sum((el.contribute(kin).T for el in eqs.model.elements), se.Integer(0))
        T_old = float(T_bodies.xreplace(point))
        assert abs(float(core.T.xreplace(point)) - T_old) <= 1e-12 * abs(T_old)
        assert abs(float(core.T.xreplace(point)) - qd @ M @ qd / 2) <= 1e-12 * abs(T_old)
    assert eqs.energy_name == "energy"
    traj = lg.simulate(eqs, t_end=0.05, backend="scipy", rtol=1e-10, atol=1e-10, initial={"qx1": 0.2, "qy1_dot": 1.0})
    E = np.asarray(traj.energy)
    assert np.abs(E - E[0]).max() <= 1e-9 * np.abs(E).max()
    lower = [core.M[i, j] for i in range(N) for j in range(i + 1)]
    kane_lower = [kane_M[i][j] for i in range(N) for j in range(i + 1)]
    assert 2 * len(se.cse(lower)[0]) < len(se.cse(kane_lower)[0])
