"""lagrangian load: what a model file, an example or a URDF builds (text and --json), --write of the equivalent
model file (the same equations when read back, written atomically, never over a file without --force), and
one clear error for each bad input."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.io import loads_model
from lagrangian.io._urdf import loads_urdf, model_file_text

# A 3-joint arm: a revolute waist on a heavy base (fixed to the world), a tool flange on a fixed joint (merged
# into the forearm), a prismatic wrist with rpy, limits, damping and friction.
ARM = """<?xml version="1.0"?>
<robot name="arm3">
  <link name="base"><inertial><mass value="4"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
  </inertial></link>
  <link name="upper">
    <inertial><origin xyz="0.1 0 0.2" rpy="0 0.3 0"/><mass value="2"/>
      <inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0.002" izz="0.015"/></inertial>
  </link>
  <link name="fore">
    <inertial><origin xyz="0 0 0.25"/><mass value="1.5"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.012" iyz="0" izz="0.004"/></inertial>
  </link>
  <link name="flange">
    <inertial><origin xyz="0 0.05 0"/><mass value="0.3"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
  </link>
  <link name="slider">
    <inertial><mass value="0.5"/><inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial>
  </link>
  <joint name="waist" type="continuous"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/></joint>
  <joint name="elbow-1" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="0.2 0 0.4" rpy="0.1 0 1.5707963267948966"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="5" velocity="3"/><dynamics damping="0.1" friction="0"/></joint>
  <joint name="tool" type="fixed"><parent link="fore"/><child link="flange"/><origin xyz="0 0 0.5"/></joint>
  <joint name="wrist" type="prismatic"><parent link="flange"/><child link="slider"/>
    <origin xyz="0 0 0.1" rpy="0 0 0.2"/><axis xyz="0.6 0 0.8"/>
    <limit lower="0" upper="0.3" effort="5" velocity="1"/><dynamics damping="0.5" friction="0.2"/></joint>
</robot>
"""


@pytest.fixture
def arm(tmp_path):
    path = tmp_path / "arm3.urdf"
    path.write_text(ARM)
    return path


def _run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def _numbers(model, states=3, seed=0):
    """M and f of `model` at random states (NumPy, SciPy backend)."""
    nm = lg.compile(lg.derive(model), backend="scipy")
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(states):
        x = rng.uniform(-1.5, 1.5, 2 * len(model.q))
        out.append((nm.mass_matrix(0.0, x, [], nm.parameter_values), nm.forcing(0.0, x, [], nm.parameter_values)))
    return out


def test_load_says_what_the_urdf_builds(arm, capsys):
    code, out, _ = _run(capsys, "load", str(arm))
    assert code == 0
    assert "coordinates (3, in order): waist, elbow_1, wrist (velocities waist_dot, elbow_1_dot, wrist_dot)" in out
    assert "elbow_1: revolute, upper -> fore, axis [0, 1, 0], coordinates elbow_1, limits [-2, 2], damping 0.1" in out
    assert "wrist: prismatic, flange -> slider, axis [0.6, 0, 0.8], coordinates wrist, limits [0, 0.3], damping 0.5, " \
           "friction 0.2" in out
    assert "tool: fixed, fore -> flange" in out
    assert "  upper: mass 2, in frame upper" in out and "  fore: mass 1.8, in frame fore" in out  # 1.5 + 0.3 merged
    assert "link 'flange' merged into link 'fore' (fixed joint 'tool')" in out
    assert "link 'base' is fixed to the world: its 4 kg (with the links merged into it) never move and are left out" \
        in out
    assert "parameters: g = 9.81" in out and "inputs: none" in out and "constraints: none" in out


def test_load_json(arm, capsys):
    code, out, _ = _run(capsys, "load", str(arm), "--json")
    assert code == 0
    info = json.loads(out)
    assert info["kind"] == "urdf" and info["model"] == "arm3" and info["written"] is None
    assert info["coordinates"] == ["waist", "elbow_1", "wrist"]
    assert [j["type"] for j in info["joints"]] == ["revolute", "revolute", "fixed", "prismatic"]
    assert info["joints"][1]["limits"] == [[-2, 2]] and info["joints"][3]["friction"] == [0.2]
    assert {b["name"]: b["mass"] for b in info["bodies"]} == {"upper": 2, "fore": 1.8, "slider": 0.5}
    assert info["parameters"] == {"g": 9.81}
    assert any("merged into link 'fore'" in n for n in info["notes"])


def test_write_gives_a_model_file_with_the_same_equations(arm, tmp_path, capsys):
    out_file = tmp_path / "arm3.toml"
    code, out, _ = _run(capsys, "load", str(arm), "--write", str(out_file))
    assert code == 0 and f"wrote the model file {out_file}" in out
    text = out_file.read_text()
    assert text.startswith("# Generated by lagrangian")
    written = lg.load(str(out_file))
    urdf = lg.load(str(arm))
    assert written.q == urdf.q and written.joints["elbow_1"].limits == ((-2, 2),)
    for (Ma, fa), (Mb, fb) in zip(_numbers(urdf), _numbers(written)):
        assert np.allclose(Ma, Mb, rtol=1e-12, atol=1e-13) and np.allclose(fa, fb, rtol=1e-12, atol=1e-13)
    assert main(["derive", str(out_file)]) == 0  # lagrangian derive reads it
    capsys.readouterr()
    # the JSON says where it wrote
    again = tmp_path / "again.toml"
    code, out, _ = _run(capsys, "load", str(arm), "--json", "--write", str(again))
    assert code == 0 and json.loads(out)["written"] == str(again) and again.read_text() == text


def test_write_of_an_example_and_of_a_model_file_is_their_own_text(tmp_path, capsys):
    from lagrangian.examples import example_source

    out_file = tmp_path / "arm.toml"
    assert main(["load", "robot-arm-3-joints", "--write", str(out_file)]) == 0
    assert out_file.read_text() == example_source("robot-arm-3-joints")
    copy = tmp_path / "copy.toml"
    code, out, _ = _run(capsys, "load", str(out_file), "--write", str(copy))
    assert code == 0 and copy.read_text() == out_file.read_text() and "from the model file" in out
    a, b = lg.derive(lg.load("robot-arm-3-joints")), lg.derive(lg.load(str(copy)))
    assert sp.simplify(a.mass_matrix - b.mass_matrix) == sp.zeros(3, 3)


def _written(model, folder) -> str:
    """The model file lg.write_model writes (the public writer), as text."""
    path = lg.write_model(model, folder / "written.toml")
    assert path == folder / "written.toml"
    return path.read_text(encoding="utf-8")


def test_a_quaternion_joint_and_frames_written_and_read_back(tmp_path):
    m = lg.Model("top")
    for k, v in dict(m=1.0, g=9.81, l=0.1, c=0.02).items():
        m.parameter(k, v)
    m.add_frame("tilted", rotation=[("x", "pi/6")], origin=(0, 0, "l"))
    m.add_joint("ball", "spherical", parent="tilted", parametrization="quaternion", damping="c")
    m.add_joint("hinge", "universal", parent="ball", origin=(0, 0, "l"), axis=("x", [0, 1, 1]))
    m.add_rigid_body("m", [[0.02, 0.001, 0], [0.001, 0.03, 0], [0, 0, 0.025]], frame="ball", center=(0, 0, "l"))
    m.add_rigid_body("m/2", [0.01, 0.01, 0.005], frame="hinge", center=(0, "l/2", 0))
    m.add_gravity("g")
    text = _written(m, tmp_path)
    assert 'parametrization = "quaternion"' in text and "initial" not in text  # q0 = 1 comes with the joint
    back = loads_model(text)
    assert back.q == m.q and [c.name for c in back.constraints] == ["ball_norm"]
    assert back.simulation["initial"] == {"ball_q0": 1.0}
    assert "center_frame" not in text and 'center = [0, "l/2", 0]' in text  # found in the frame's axes
    # the same equations (the file's numbers are read as exact rationals, Python's stay floats: to round-off)
    for (Ma, fa), (Mb, fb) in zip(_numbers(m), _numbers(back)):
        assert np.allclose(Ma, Mb, rtol=1e-13, atol=1e-15) and np.allclose(fa, fb, rtol=1e-13, atol=1e-14)


def test_what_the_writer_does_not_write_is_named(tmp_path):
    m = lg.Model("spring")
    x = m.coordinate("x")
    m.parameter("k", 1.0)
    m.add_particle(1, (x, 0), name="bob")
    m.add_spring("k", length=x, name="s")
    with pytest.raises(lg.ModelError) as info:
        lg.write_model(m, tmp_path / "spring.toml")
    message = str(info.value)
    assert "the particle 'bob' is not written by this writer" in message and "the spring 's'" in message
    assert not list(tmp_path.iterdir())  # nothing written


# ------------------------------------------------------------------------------------------- errors

@pytest.mark.parametrize("make, argv, match", [
    (None, ["load", "no/such/robot.urdf"], "no such URDF file 'no/such/robot.urdf': check the path"),
    (None, ["load", "no-such-example"], "'no-such-example' is neither a model file nor a built-in example"),
    ("bad.urdf", ["load", "{dir}/bad.urdf"], "the URDF is not well-formed XML"),
    ("mimic.urdf", ["load", "{dir}/mimic.urdf"], "a <mimic> joint (following 'waist') closes a loop of joints"),
    ("code.urdf", ["load", "{dir}/code.urdf"],
     "the link name \"__import__('os')\" has the characters"),
    ("arm.urdf", ["load", "{dir}/arm.urdf", "--write", "{dir}/out.txt"],
     "a model file's name ends in .toml (lagrangian load and derive read it by that); for example --write"),
    ("arm.urdf", ["load", "{dir}/arm.urdf", "--write", "{dir}"], "it is a directory; give a file name such as"),
    ("arm.urdf", ["load", "{dir}/arm.urdf", "--write", "{dir}/missing/out.toml"], "does not exist; create it"),
    ("arm.urdf", ["load", "robot-arm-3-joints", "--floating-base"],
     "--floating-base: 'robot-arm-3-joints' is not a URDF"),
])
def test_errors(tmp_path, capsys, make, argv, match):
    texts = {"bad.urdf": "<robot name='x'><link name='a'></robot>",
             "mimic.urdf": ARM.replace('<joint name="elbow-1" type="revolute">',
                                       '<joint name="elbow-1" type="revolute"><mimic joint="waist"/>'),
             "code.urdf": ARM.replace('name="slider"', 'name="__import__(\'os\')"'),
             "arm.urdf": ARM}
    if make:
        (tmp_path / make).write_text(texts[make])
    code, out, err = _run(capsys, *[a.format(dir=tmp_path) for a in argv])
    assert code == 2 and out == "" and "Traceback" not in err
    assert err.startswith("lagrangian load: error:") and match in err, err
    assert not list(tmp_path.glob("*.toml")) and not list(tmp_path.glob(".*lagrangian*"))


def test_write_never_replaces_a_file_without_force(arm, tmp_path, capsys):
    target = tmp_path / "mine.toml"
    target.write_text("my own notes\n")
    code, _, err = _run(capsys, "load", str(arm), "--write", str(target))
    assert code == 2 and "a file is there already and lagrangian load never replaces one without --force" in err
    assert target.read_text() == "my own notes\n"
    assert main(["load", str(arm), "--write", str(target), "--force"]) == 0
    assert target.read_text().startswith("# Generated by lagrangian")
    # a symbolic link: refused without --force; with it the link itself is replaced, its target left as it is
    other = tmp_path / "other.toml"
    other.write_text("target\n")
    link = tmp_path / "link.toml"
    os.symlink(other, link)
    code, _, err = _run(capsys, "load", str(arm), "--write", str(link))
    assert code == 2 and "a symbolic link is there already" in err
    assert main(["load", str(arm), "--write", str(link), "--force"]) == 0
    assert not link.is_symlink() and other.read_text() == "target\n"
    assert [p.name for p in tmp_path.iterdir() if "lagrangian" in p.name] == []  # no temporary file left


def test_names_with_newlines_and_quotes_stay_in_their_strings():
    urdf = ARM.replace('<robot name="arm3">', '<robot name="arm&quot;\n[parameters]\nevil = 1">')
    model = loads_urdf(urdf)
    text = model_file_text(model, source='a"b\nc.urdf')
    back = loads_model(text)
    assert back.name == model.name and "evil" not in {p.name for p in back.parameters}
    assert "\n[parameters]\nevil" not in text


@pytest.mark.slow
def test_a_public_arm_written_as_a_model_file_matches_pinocchio(tmp_path, capsys):
    pin = pytest.importorskip("pinocchio", reason="the Pinocchio cross-check needs pip install pin")
    import site

    robots = None
    for folder in [*site.getsitepackages(), site.getusersitepackages()]:
        path = Path(folder) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if path.is_dir():
            robots = path
    if robots is None:
        pytest.skip("example-robot-data is not installed (pip install example-robot-data)")
    urdf = robots / "ur_description" / "urdf" / "ur5_robot.urdf"
    out_file = tmp_path / "ur5.toml"
    assert main(["load", str(urdf), "--write", str(out_file)]) == 0
    capsys.readouterr()
    model = lg.load(str(out_file))
    pm = pin.buildModelFromUrdf(str(urdf))
    data = pm.createData()
    names = [c.name for c in model.q]
    order = [names.index(pm.names[i]) for i in range(1, pm.njoints)]
    nm = lg.compile(lg.derive(model), backend="scipy")
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, qd, qdd = (rng.uniform(-2, 2, len(names)) for _ in range(3))
        x = np.concatenate([q, qd])
        M = nm.mass_matrix(0.0, x, [], nm.parameter_values)
        tau = M @ qdd - nm.forcing(0.0, x, [], nm.parameter_values)
        Mp = pin.crba(pm, data, q[order])
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        assert np.allclose(M[np.ix_(order, order)], Mp, rtol=0, atol=1e-10 * np.abs(Mp).max())
        tp = pin.rnea(pm, data, q[order], qd[order], qdd[order])
        assert np.allclose(tau[order], tp, rtol=0, atol=1e-10 * np.abs(tp).max())


def test_a_floating_base_turned_by_a_quaternion(arm, tmp_path, capsys):
    code, out, _ = _run(capsys, "load", str(arm), "--floating-base", "quaternion", "--json")
    assert code == 0
    info = json.loads(out)
    assert info["coordinates"][:7] == ["floating_base_x", "floating_base_y", "floating_base_z", "floating_base_q0",
                                       "floating_base_q1", "floating_base_q2", "floating_base_q3"]
    assert info["coordinates"][7:] == ["waist", "elbow_1", "wrist"]
    assert info["joints"][0]["parametrization"] == "quaternion"
    assert [c["name"] for c in info["constraints"]] == ["floating_base_norm"]
    assert {b["name"]: b["mass"] for b in info["bodies"]}["base"] == 4  # it moves now
    # written and read back: the same equations
    out_file = tmp_path / "floating.toml"
    assert main(["load", str(arm), "--floating-base", "quaternion", "--write", str(out_file)]) == 0
    capsys.readouterr()
    a, b = lg.io.load_urdf(str(arm), floating_base="quaternion"), lg.load(str(out_file))
    assert a.q == b.q and b.simulation["initial"] == {"floating_base_q0": 1.0}
    for (Ma, fa), (Mb, fb) in zip(_numbers(a), _numbers(b)):
        assert np.allclose(Ma, Mb, rtol=1e-12, atol=1e-13) and np.allclose(fa, fb, rtol=1e-12, atol=1e-12)
    # three angles, as before
    code, out, _ = _run(capsys, "load", str(arm), "--floating-base", "--json")
    assert json.loads(out)["coordinates"][3:6] == ["floating_base_1", "floating_base_2", "floating_base_3"]


def test_floating_base_values_are_checked(arm, capsys):
    with pytest.raises(lg.ModelError, match=r"floating_base='quaternions' \(did you mean 'quaternion'\?\): expected "
                                            r"False \(the root link fixed to the world\), True or \"angles\""):
        lg.io.load_urdf(str(arm), floating_base="quaternions")
    with pytest.raises(SystemExit) as info:
        main(["load", str(arm), "--floating-base", "quaternions"])
    assert info.value.code == 2 and "invalid choice: 'quaternions'" in capsys.readouterr().err


def test_every_refusal_of_the_writer_is_named(tmp_path):
    m = lg.Model("mixed", coordinates=["x", "y"], T="x_dot**2/2", parameters={"k": None, "r": 1.0})
    m.add_constraint("x - y", name="tie")
    with pytest.raises(lg.ModelError) as info:
        lg.write_model(m, tmp_path / "mixed.toml")
    assert not list(tmp_path.iterdir())
    message = str(info.value)
    assert "the constraint 'tie' is not written by this writer: add it as a [[constraints]] table by hand" in message
    assert "explicit energies and forces ([energy], [forces]) are not written by this writer" in message
    assert "the parameter 'k' has no value: give it one before writing the model file" in message


def test_write_to_something_that_is_not_a_regular_file(arm, tmp_path, capsys):
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    code, _, err = _run(capsys, "load", str(arm), "--write", str(fifo), "--force")
    assert code == 2 and f"--write {fifo}: it is not a regular file; choose another path" in err
