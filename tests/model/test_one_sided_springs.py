"""One-sided springs (issue 22, item 2): acts = "compression" (a contact: pushes only when the two
points are closer than the rest length) and acts = "tension" (a cable: pulls only when farther).
Two balls colliding conserve energy and momentum and leave with the elastic-collision velocities;
a 3D three-link pendulum's contacts written with the element give the forces of the potential
written by hand (NumPy positions, finite differences: an independent path); the compiled backends
(numba, C) and SciPy agree; the model file's key and its errors."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.io import loads_model


def _balls(acts="compression", dim=2):
    m = lg.Model("balls")
    x1, x2 = m.coordinate("x1", "x2")
    m.parameter("k", 1000.0)
    m.parameter("r", 0.1)
    zero = (0,) * (dim - 1)
    m.add_particle(1, (x1, *zero), name="b1")
    m.add_particle(2, (x2, *zero), name="b2")
    m.add_spring("k", between=["b1", "b2"], rest_length="2*r", acts=acts, name="contact")
    return m


@pytest.mark.parametrize("backend", ["numba", "scipy"])
def test_two_balls_collide_elastically_conserving_energy_and_momentum(backend):
    eqs = lg.derive(_balls())
    traj = lg.simulate(eqs, 2.0, initial={"x1": 0.0, "x2": 1.0, "x2_dot": -1.0}, rtol=1e-11, atol=1e-11,
                       backend=backend)
    assert traj.stats["backend"] == backend
    p = traj["x1_dot"] + 2 * traj["x2_dot"]
    assert np.ptp(p) < 1e-12
    assert np.ptp(traj.energy) < 1e-8 * traj.energy[0]
    # elastic collision, m1 = 1 at rest, m2 = 2 at -1: v1 = 2 m2 v / (m1 + m2), v2 = (m2 - m1) v / (m1 + m2)
    assert traj["x1_dot"][-1] == pytest.approx(-4 / 3, abs=1e-8)
    assert traj["x2_dot"][-1] == pytest.approx(-1 / 3, abs=1e-8)
    # they touched (distance below 2r) and parted
    d = traj["x2"] - traj["x1"]
    assert d.min() < 0.2 and d[-1] > 0.2


def test_the_potential_is_zero_apart_and_the_force_pushes_only_when_overlapping():
    eqs = lg.derive(_balls())
    V = sp.lambdify(("x1", "x2"), eqs.V.subs({sp.Symbol("k"): 1000.0, sp.Symbol("r"): 0.1}))
    assert V(0.0, 0.5) == 0.0 and V(0.0, 0.2) == 0.0
    assert V(0.0, 0.15) == pytest.approx(1000 * 0.05**2 / 2)
    f = sp.lambdify(("x1", "x2"), eqs.forcing.subs({sp.Symbol("k"): 1000.0, sp.Symbol("r"): 0.1}))
    assert np.allclose(np.ravel(f(0.0, 0.15)), [-50.0, 50.0])  # pushed apart
    assert np.allclose(np.ravel(f(0.0, 0.5)), [0.0, 0.0])


def test_a_cable_pulls_only_when_taut():
    eqs = lg.derive(_balls("tension"))
    f = sp.lambdify(("x1", "x2"), eqs.forcing.subs({sp.Symbol("k"): 1000.0, sp.Symbol("r"): 0.1}))
    assert np.allclose(np.ravel(f(0.0, 0.15)), [0.0, 0.0])  # slack
    assert np.allclose(np.ravel(f(0.0, 0.25)), [50.0, -50.0])  # taut: pulled together
    traj = lg.simulate(eqs, 3.0, initial={"x2": 0.1, "x2_dot": 1.0}, rtol=1e-11, atol=1e-11)
    assert traj.stats["backend"] in ("numba", "c")
    assert np.ptp(traj["x1_dot"] + 2 * traj["x2_dot"]) < 1e-12
    assert np.ptp(traj.energy) < 1e-8 * traj.energy[0]
    assert (traj["x2"] - traj["x1"]).max() < 0.2 + 2 * np.sqrt(2 / 3 / 1000) * 1.01  # the cable held them


def _chain3d():
    """A three-link pendulum in space (each link turned by z then x about its joint), a ball of radius r
    at each link's end, the balls in contact pairwise: the PyDy n-body pendulum with collisions."""
    m = lg.Model("chain3d")
    angles = m.coordinate("a1", "b1", "a2", "b2", "a3", "b3")
    m.parameter("l", 1.0)
    m.parameter("r", 0.4)
    m.parameter("k", 500.0)
    parent = "world"
    for i in range(3):
        origin = (0, 0, 0) if i == 0 else (0, 0, "-l")
        m.add_frame(f"link{i + 1}", parent=parent, origin=origin,
                    rotation=[("z", angles[2 * i]), ("x", angles[2 * i + 1])])
        m.add_particle(1, (0, 0, "-l"), frame=f"link{i + 1}", name=f"ball{i + 1}")
        parent = f"link{i + 1}"
    for i, j in ((1, 2), (1, 3), (2, 3)):
        m.add_spring("k", between=[f"ball{i}", f"ball{j}"], rest_length="2*r", acts="compression")
    return m


def _positions(q, l=1.0):
    def rz(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    def rx(a):
        c, s = np.cos(a), np.sin(a)
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])

    R, o, out = np.eye(3), np.zeros(3), []
    for i in range(3):
        R = R @ rz(q[2 * i]) @ rx(q[2 * i + 1])
        o = o + R @ np.array([0, 0, -l])
        out.append(o)
    return out


def _hand_V(q, r=0.4, k=500.0):
    p = _positions(q)
    return sum(k / 2 * max(0.0, 2 * r - np.linalg.norm(p[i] - p[j])) ** 2 for i, j in ((0, 1), (0, 2), (1, 2)))


def test_3d_pendulum_contacts_equal_the_hand_written_potential():
    eqs = lg.derive(_chain3d())
    nm = lg.compile(eqs, backend="scipy")
    p = np.array([float(v) for v in eqs.parameters.values()])
    u = np.zeros(0)
    rng = np.random.default_rng(5)
    touching = 0
    for _ in range(40):
        q = rng.uniform(-2.5, 2.5, 6)
        x = np.concatenate([q, np.zeros(6)])
        M = np.asarray(nm.mass_matrix(0.0, x, u, p), dtype=float)
        f = np.asarray(nm.forcing(0.0, x, u, p), dtype=float)
        h = 1e-6
        grad = np.array([(_hand_V(q + h * e) - _hand_V(q - h * e)) / (2 * h) for e in np.eye(6)])
        # at rest and without gravity the forcing is -dV/dq (the velocity terms vanish)
        assert np.allclose(f, -grad, atol=1e-6 * (1 + np.abs(grad).max())), q
        assert np.all(np.isfinite(M))
        touching += np.abs(grad).max() > 0
    assert touching >= 3  # some of the random configurations overlap


TOML = """
coordinates = ["x1", "x2"]
[parameters]
k = 1000.0
r = 0.1
[[particles]]
name = "b1"
mass = 1
position = ["x1", "0"]
[[particles]]
name = "b2"
mass = 2
position = ["x2", "0"]
[[springs]]
name = "contact"
stiffness = "k"
between = ["b1", "b2"]
rest_length = "2*r"
acts = "compression"
"""


def test_model_file_acts():
    eqs = lg.derive(loads_model(TOML))
    assert sp.simplify(eqs.V - lg.derive(_balls()).V) == 0


@pytest.mark.parametrize("value, message", [
    ('"compresion"', "unknown value 'compresion' (did you mean 'compression'?): a spring acts \"both\" ways"),
    ("1", "expected \"both\", \"compression\" or \"tension\" in quotes, got"),
    ('"__import__(\'os\')"', "unknown value \"__import__('os')\""),
])
def test_model_file_acts_errors(value, message):
    with pytest.raises(ModelError, match=re.escape(message)):
        loads_model(TOML.replace('acts = "compression"', f"acts = {value}"))


def test_api_acts_error():
    with pytest.raises(ModelError, match=re.escape("unknown value 'tensoin' (did you mean 'tension'?)")) as info:
        _balls("tensoin")
    assert "\"tension\" only (it pulls when longer: a cable)" in str(info.value)


@pytest.mark.slow
@pytest.mark.subprocess
def test_the_c_backend_and_the_exports_run_the_one_sided_spring(tmp_path):
    import subprocess

    from lagrangian.export import export_c, export_modelica
    from lagrangian.numeric._cbackend import c_compiler

    if c_compiler() is None:
        pytest.skip("no C compiler ($CC, cc or gcc) to build the export")
    eqs = lg.derive(_balls())
    x0 = {"x2": 1.0, "x2_dot": -1.0}
    c = lg.simulate(eqs, 2.0, initial=x0, rtol=1e-11, atol=1e-11, backend="c")
    numba = lg.simulate(eqs, 2.0, initial=x0, rtol=1e-11, atol=1e-11, backend="numba")
    assert c.stats["backend"] == "c" and np.allclose(c.x, numba.x, atol=1e-12, rtol=0)
    export_c(eqs, tmp_path)
    build = subprocess.run([*c_compiler().split(), "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2",
                            "-o", str(tmp_path / "demo"), str(tmp_path / "main.c"), str(tmp_path / "balls.c"), "-lm"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    export_modelica(eqs, tmp_path / "balls.mo")
    assert "(if 2*r - sqrt((-x1 + x2)^2) > 0 then " in (tmp_path / "balls.mo").read_text()


PYDY_CHAIN = Path(__file__).resolve().parents[1] / "models" / "spatial-chain-3.toml"


@pytest.mark.slow
def test_pydy_n_body_pendulum_ball_contacts_equal_the_hand_written_potential():
    """PyDy's 3D n-body pendulum (tests/models/spatial-chain-3.toml: nine body-fixed angles) with its balls'
    contacts as compression springs between the balls' centres (rest length 2r): the forces at rest,
    gravity off, are -dV/dq of the contact potential written by hand from sympy.physics.mechanics'
    positions of the balls (PyDy's construction: orient_body_fixed "123", the ball l/2 along the rod)."""
    import sympy.physics.mechanics as me

    text = PYDY_CHAIN.read_text().replace("[parameters]", "[parameters]\nk = 200.0", 1)
    for i, j in ((1, 2), (1, 3), (2, 3)):
        text += (f'\n[[springs]]\nname = "contact{i}{j}"\nstiffness = "k"\nbetween = ["ball{i}", "ball{j}"]\n'
                 'rest_length = "2*r"\nacts = "compression"\n')
    eqs = lg.derive(loads_model(text))
    values = {p.name: v for p, v in eqs.parameters.items()}
    values["g"] = 0.0
    nm = lg.compile(eqs, backend="scipy")
    p = np.array([values[s.name] for s in eqs.parameters])

    q = me.dynamicsymbols("qx1 qy1 qz1 qx2 qy2 qz2 qx3 qy3 qz3")
    N, root = me.ReferenceFrame("N"), me.Point("P0")
    joint, frames, centres = root, [], []
    for i in range(3):
        A = me.ReferenceFrame(f"A{i}")
        A.orient_body_fixed(N if i == 0 else frames[-1], q[3 * i:3 * i + 3], "123")
        if i > 0:
            joint = joint.locatenew(f"P{i}", values["l"] * frames[-1].y)
        frames.append(A)
        centres.append(joint.locatenew(f"D{i}", values["l"] / 2 * A.y))
    positions = sp.lambdify(q, [c.pos_from(root).to_matrix(N) for c in centres])
    k, r = values["k"], values["r"]

    def V(x):
        c = [np.ravel(np.asarray(v, dtype=float)) for v in positions(*x)]
        return sum(k / 2 * max(0.0, 2 * r - np.linalg.norm(c[i] - c[j])) ** 2 for i, j in ((0, 1), (0, 2), (1, 2)))

    rng = np.random.default_rng(9)
    touching = 0
    for _ in range(30):
        x = rng.uniform(-2.5, 2.5, 9)
        f = np.asarray(nm.forcing(0.0, np.concatenate([x, np.zeros(9)]), np.zeros(0), p), dtype=float)
        h = 1e-6
        grad = np.array([(V(x + h * e) - V(x - h * e)) / (2 * h) for e in np.eye(9)])
        assert np.allclose(f, -grad, atol=1e-5 * (1 + np.abs(grad).max())), x
        touching += np.abs(grad).max() > 0
    assert touching >= 3
