"""A large model's run that reaches a singular M (a spatial chain's body-fixed angles at their gimbal lock) is
diagnosed from M's numbers in that state (equations._singular.diagnosis_at), not by the symbolic diagnosis, whose
readable M and det M search take minutes to hours for such a model (the 20-rod chain: past 3 minutes)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import lagrangian as lg
import lagrangian.numeric._codegen as codegen
import lagrangian.numeric._simulate as simulate_module
from lagrangian.equations._singular import diagnosis_at



def rods(n: int) -> lg.Model:
    """n rods in space, rod k on a spherical joint (body-fixed x, y, z angles) at the end of rod k - 1, each with a
    ball, its own mass and a dot off its axis (tests/models/spatial-chain-3.toml's chain)."""
    m = lg.Model(f"spatial-chain-{n}")
    for i in range(1, n + 1):
        m.coordinate(f"qx{i}", f"qy{i}", f"qz{i}")
    for name, value in {"m": 1.0, "m1": 0.2, "m_link": 0.5, "l": 6.0, "r": 1.5, "g": 9.8, "iXX": 0.9}.items():
        m.parameter(name, value)
    for i in range(1, n + 1):
        m.add_frame(f"rod{i}", parent="world" if i == 1 else f"rod{i - 1}", origin=(0, 0 if i == 1 else "l", 0),
                    rotation=[("x", f"qx{i}"), ("y", f"qy{i}"), ("z", f"qz{i}")])
        m.add_rigid_body("m", ("iXX", "iXX", "iXX"), frame=f"rod{i}", center=(0, "l/2", 0), name=f"ball{i}")
        m.add_rigid_body("m_link", ("m_link*l**2/12", "0", "m_link*l**2/12"), frame=f"rod{i}",
                         center=(0, "l/2", 0), name=f"link{i}")
        m.add_particle("m1", (0, "l/2", "r"), frame=f"rod{i}", name=f"dot{i}")
    m.add_gravity("g", direction=(0, -1, 0))
    return m


def _chain_near_the_lock():
    """Two rods, the second's middle angle 1e-3 short of pi/2 and turning towards it: the gimbal lock where its x
    and z rotations line up (qx2_dot = -qz2_dot moves nothing)."""
    m = rods(2)
    m.simulation["initial"] = {"qx1": 0.2, "qy1": 0.2, "qz1": 0.2, "qy2": math.pi / 2 - 1e-3,
                               "qy1_dot": 7.5, "qy2_dot": 7.5}
    return lg.derive(m)


@pytest.mark.slow  # a new model compiled: about 15 s
def test_a_large_model_s_singular_run_is_diagnosed_at_its_state(monkeypatch):
    eq = _chain_near_the_lock()
    lg.simulate(eq, t_end=1e-5)  # (compiled before the model is taken for a large one)

    def symbolic(*args, **kwargs):
        raise AssertionError("the symbolic diagnosis was called for a large model")

    monkeypatch.setattr(codegen, "large_model", lambda equations: True)
    monkeypatch.setattr(simulate_module, "singularities", symbolic)
    with pytest.raises(lg.SingularMassMatrixError) as info:
        lg.simulate(eq, t_end=0.2)
    err = info.value
    assert err.time < 1e-3 and abs(err.state["qy2"] - math.pi / 2) < 1e-3
    d = err.diagnosis
    assert d.startswith("det M: not expanded or searched for a model this large (6 coordinates); M is diagnosed "
                        "from its numbers in this state.\n")
    assert "Here the velocity combination qx2_dot = 1, qz2_dot = -1 has almost no inertia" in d
    assert "the gimbal lock of successive rotations" in d and "qx2, qz2" in d
    assert d in str(err)


def test_the_diagnosed_combination_is_m_s_null_direction():
    eq = _chain_near_the_lock()
    nm = lg.compile(eq, backend="scipy")
    x = np.zeros(12)
    x[:6] = [0.2, 0.2, 0.2, 0.3, math.pi / 2, -0.4]
    M = nm.mass_matrix(0.0, x, np.zeros(0), nm.parameter_values)
    text = diagnosis_at(eq, M, dict(zip(eq.state_names, x)))
    line = text.splitlines()[1]
    shown = dict(part.split(" = ") for part in line.split("combination ")[1].split(" has")[0].split(", "))
    v = np.array([float(shown.get(f"{q.name}_dot", 0.0)) for q in eq.coordinates])
    assert set(shown) == {"qx2_dot", "qz2_dot"}
    assert np.linalg.norm(M @ v) < 1e-12 * np.linalg.norm(M)  # qx2 and qz2 turn about one axis at qy2 = pi/2


def test_a_diagonal_without_inertia_and_a_matrix_not_finite():
    eq = _chain_near_the_lock()
    M = np.eye(6)
    M[4, 4] = 0.0
    text = diagnosis_at(eq, M, {})
    assert ("Likely cause: the diagonal entry of M of qy2_dot is zero, negative or not finite in this state: that "
            "velocity carries no inertia of its own.") in text
    assert text.endswith("Fix: give the body that this coordinate moves a mass or inertia, or eliminate the "
                         "coordinate from the model.")
    assert "Likely cause: M is not finite in this state." in diagnosis_at(eq, np.full((6, 6), np.nan), {})


def test_a_large_model_s_linearization_at_the_lock_is_diagnosed_at_the_point(monkeypatch):
    eq = _chain_near_the_lock()

    def symbolic(*args, **kwargs):
        raise AssertionError("the symbolic diagnosis was called for a large model")

    import lagrangian.analysis._linearize as linearize_module

    monkeypatch.setattr(codegen, "large_model", lambda equations: True)
    monkeypatch.setattr(linearize_module, "singularities", symbolic)
    with pytest.raises(lg.SingularMassMatrixError) as info:
        lg.linearize(eq, at={"qy2": math.pi / 2})
    d = info.value.diagnosis
    assert str(info.value).startswith("the mass matrix is singular at the operating point (")
    assert d.startswith("det M: not expanded or searched for a model this large (6 coordinates)")
    assert "the velocity combination qx2_dot = 1, qz2_dot = -1 has almost no inertia" in d
    assert "the gimbal lock of successive rotations" in d
