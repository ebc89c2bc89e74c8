"""[[frames]] (and points, bodies, joints) hanging from a joint's child frame in a model file, in any order of
the tables: the same model as the frame-by-frame version, and each problem (unknown parent, cycles through
frames and joints) reported under its key with what to do."""

import re

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.errors import ModelFileError
from lagrangian.io import loads_model

HEAD = '''name = "tool-arm"
[parameters]
m = 1.5
l = 0.7
d = 0.2
g = 9.81
'''

SHOULDER = '''[[joints]]
name = "shoulder"
type = "revolute"
axis = "y"
'''

TOOL = '''[[frames]]
name = "tool"
parent = "shoulder"
origin = ["l", "0", "0"]
rotation = [["z", "pi/2"]]
'''

WRIST = '''[[joints]]
name = "wrist"
type = "revolute"
parent = "tool"
axis = "x"
'''

BODIES = '''[[particles]]
name = "tip"
mass = "m"
frame = "tool"
position = ["d", "0", "0"]
[[bodies]]
name = "hand"
mass = "m"
frame = "wrist"
inertia = ["0.01", "0.02", "0.03"]
center = ["0", "d", "0"]
[[points]]
name = "marker"
frame = "wrist"
position = ["0", "0", "d"]
[gravity]
g = "g"
'''

FRAME_BY_FRAME = 'coordinates = ["shoulder", "wrist"]\n' + HEAD + '''[[frames]]
name = "upper"
rotation = [["y", "shoulder"]]
[[frames]]
name = "tool"
parent = "upper"
origin = ["l", "0", "0"]
rotation = [["z", "pi/2"]]
[[frames]]
name = "wrist"
parent = "tool"
rotation = [["x", "wrist"]]
''' + BODIES


@pytest.mark.parametrize("order", [(SHOULDER, TOOL, WRIST), (TOOL, SHOULDER, WRIST), (WRIST, TOOL, SHOULDER)])
def test_a_tool_frame_on_a_joint_gives_the_frame_by_frame_equations(order):
    in_file_order = loads_model(HEAD + "".join(order) + BODIES)  # coordinates: the joints' order in the file
    assert [q.name for q in in_file_order.q] == [t.split('"')[1] for t in order if t.startswith("[[joints]]")]
    joints = loads_model('coordinates = ["shoulder", "wrist"]\n' + HEAD + "".join(order) + BODIES)
    frames = loads_model(FRAME_BY_FRAME)
    assert [q.name for q in joints.q] == [q.name for q in frames.q]
    ea, eb = lg.derive(joints), lg.derive(frames)
    assert sp.simplify(ea.mass_matrix - eb.mass_matrix) == sp.zeros(2, 2)
    assert sp.simplify(ea.forcing - eb.forcing) == sp.zeros(2, 1)
    # the tip's world position: the closed form, and the same from both models
    q = {"shoulder": 0.4, "wrist": -1.1}
    for name in ("tip", "marker"):
        ka = lg.kinematics(joints, name).at([q["shoulder"], q["wrist"]])
        kb = lg.kinematics(frames, name).at([q["shoulder"], q["wrist"]])
        assert np.allclose(ka.position, kb.position, atol=1e-14)
    # tip = Ry(shoulder) (l e_x + Rz(pi/2) d e_x) = Ry(shoulder) (l, d, 0)
    s, c = np.sin(q["shoulder"]), np.cos(q["shoulder"])
    tip = lg.kinematics(joints, "tip").at([q["shoulder"], q["wrist"]]).position
    assert np.allclose(tip, [0.7 * c, 0.2, -0.7 * s], atol=1e-14)


@pytest.mark.slow
def test_a_body_on_a_frame_on_a_joint_simulates_as_the_frame_by_frame_version():
    a = lg.simulate(lg.derive(loads_model(HEAD + TOOL + WRIST + SHOULDER + BODIES)), t_end=0.5,
                    initial={"shoulder": 0.3, "wrist": 0.2}, rtol=1e-11, atol=1e-11)
    b = lg.simulate(lg.derive(loads_model(FRAME_BY_FRAME)), t_end=0.5, initial={"shoulder": 0.3, "wrist": 0.2},
                    rtol=1e-11, atol=1e-11)
    for name in ("shoulder", "wrist", "shoulder_dot", "wrist_dot"):
        assert np.max(np.abs(a[name] - b[name])) < 1e-9


def _problems(text):
    with pytest.raises(ModelFileError) as info:
        loads_model(text)
    return str(info.value)


@pytest.mark.parametrize("tables, match", [
    # a frame's unknown parent: the joints' child frames are among the suggestions
    (SHOULDER + TOOL.replace('parent = "shoulder"', 'parent = "shoulderr"'),
     r"\[frames\[0\]\.parent\].*no frame is named 'shoulderr' \(did you mean 'shoulder'\?\); use \"world\" "
     r"\(the inertial frame\) or the name of a \[\[frames\]\] table or of a joint's child frame"),
    # a cycle through a frame and a joint: reported once, under the frame
    ('[[frames]]\nname = "a"\nparent = "j"\n[[joints]]\nname = "j"\ntype = "revolute"\nparent = "a"\n',
     r"\[frames\[0\]\.parent\].*the frames a, j form a cycle of parents \(a -> j -> a\): every frame must hang, "
     r"through its parents, from \"world\""),
    # a cycle of joints only: under the first joint
    ('[[joints]]\nname = "j"\ntype = "revolute"\nparent = "k"\n[[joints]]\nname = "k"\ntype = "revolute"\n'
     'parent = "j"\n', r"\[joints\[0\]\.parent\].*the frames j, k form a cycle of parents \(j -> k -> j\)"),
    # a joint's unknown parent (its name is code): the message, nothing evaluated
    ('[[joints]]\nname = "j"\ntype = "revolute"\nparent = "__import__(\'os\')"\n',
     r"\[joints\[0\]\.parent\].*no frame is named '__import__\('os'\)'"),
])
def test_frame_and_joint_parent_problems(tables, match):
    message = _problems(HEAD + tables)
    assert re.search(match, message, flags=re.DOTALL), message
    assert message.count("cycle") <= 1


def test_a_frame_below_a_joint_with_problems_gets_no_second_error():
    text = HEAD + TOOL + SHOULDER.replace('axis = "y"', 'axis = "w"') + BODIES.split("[[bodies]]")[0]
    message = _problems(text)
    assert "joints[0].axis" in message and "'w' is not an axis" in message
    assert "frames[0]" not in message and "particles[0]" not in message


def test_a_frame_below_a_cycle_and_a_joint_below_it_are_still_checked():
    text = HEAD + ('[[frames]]\nname = "a"\nparent = "b"\n[[frames]]\nname = "b"\nparent = "a"\n'
                   '[[frames]]\nname = "c"\nparent = "a"\n[[joints]]\nname = "j"\ntype = "revolute"\nparent = "c"\n'
                   'axis = "w"\n')
    message = _problems(text)
    assert message.count("form a cycle") == 1
    assert "joints[0].axis" in message  # checked under a stand-in parent
