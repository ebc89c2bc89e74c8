"""[[joints]] tables in model files (io._jointtable): the same model as Model.add_joint, and every
problem reported under its key."""

import re

import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.errors import ModelFileError
from lagrangian.io import loads_model

ARM = '''
name = "arm"
[parameters]
m = 1.0
l = 0.5
g = 9.81
c = 0.1
[[joints]]
name = "shoulder"
type = "revolute"
child = "upper"
axis = "y"
damping = "c"
limits = ["-pi/2", "pi/2"]
[[joints]]
name = "elbow"
type = "revolute"
parent = "upper"
child = "fore"
origin = ["l", "0", "0"]
rpy = [0, 0, "pi/2"]
axis = "y"
[[bodies]]
name = "upper"
mass = "m"
frame = "upper"
inertia = ["0.01", "m*l**2/12", "m*l**2/12"]
center = ["l/2", "0", "0"]
[[bodies]]
name = "fore"
mass = "m"
frame = "fore"
inertia = ["0.01", "m*l**2/12", "m*l**2/12"]
center = ["l/2", "0", "0"]
[gravity]
g = "g"
'''


def test_joint_tables_build_the_model_add_joint_builds():
    a = loads_model(ARM)
    b = lg.Model("arm")
    for k, v in dict(m=1.0, l=0.5, g=9.81, c=0.1).items():
        b.parameter(k, v)
    b.add_joint("shoulder", "revolute", child="upper", axis="y", damping="c", limits=("-pi/2", "pi/2"))
    b.add_joint("elbow", "revolute", parent="upper", child="fore", origin=("l", 0, 0), rotation=[("z", "pi/2")],
                axis="y")
    for name, frame in (("upper", "upper"), ("fore", "fore")):
        b.add_rigid_body("m", ["0.01", "m*l**2/12", "m*l**2/12"], frame=frame, center=("l/2", 0, 0), name=name)
    b.add_gravity("g")
    ea, eb = lg.derive(a), lg.derive(b)
    assert a.q == b.q == (sp.Symbol("shoulder"), sp.Symbol("elbow"))
    assert sp.simplify(ea.mass_matrix - eb.mass_matrix) == sp.zeros(2, 2)
    assert sp.simplify(ea.forcing - eb.forcing) == sp.zeros(2, 1)
    assert a.joints["shoulder"].limits == ((-sp.pi / 2, sp.pi / 2),)


def test_listed_coordinates_fix_the_order_and_expressions_may_use_joint_coordinates():
    text = ARM.replace('name = "arm"', 'name = "arm"\ncoordinates = ["elbow", "shoulder"]')
    text += '[outputs]\nbend = "elbow - shoulder"\n'
    m = loads_model(text)
    assert m.q == (sp.Symbol("elbow"), sp.Symbol("shoulder"))
    assert "bend" in m.outputs


def test_the_example_robot_arm_3_joints_simulates():
    eqs = lg.derive(lg.load("robot-arm-3-joints"))
    traj = lg.simulate(eqs, t_end=0.5)
    assert traj.x.shape[1] == 6 and abs(traj["q2"][-1] - 0.3) > 1e-3  # it falls


def _problems(text):
    with pytest.raises(ModelFileError) as info:
        loads_model(text)
    return str(info.value)


@pytest.mark.parametrize("table, match", [
    ('name = "j"\ntype = "revolute"\naxes = "z"', r"\[joints\[0\]\.axes\].*unknown key 'axes' in \[\[joints\]\] "
                                                  r"\(did you mean 'axis'\?\)"),
    ('name = "j"', r"\[joints\[0\]\.type\].*missing required key 'type'"),
    ('type = "revolute"', r"\[joints\[0\]\.name\].*missing required key 'name'"),
    ('name = "j"\ntype = "hinge"', r"\[joints\[0\]\.type\].*unknown joint type 'hinge'"),
    ('name = "j"\ntype = "revolute"\nparent = "nowhere"', r"\[joints\[0\]\.parent\].*no frame is named 'nowhere'"),
    ('name = "j"\ntype = "revolute"\norigin = ["0", "nan", "0"]', r"joints\[0\]\.origin\[1\]"),
    ('name = "j"\ntype = "revolute"\norigin = [0, 0]', r"a joint's origin has 3 components"),
    ('name = "j"\ntype = "revolute"\nrpy = [0, 0]', r"\[joints\[0\]\.rpy\].*expected \[roll, pitch, yaw\]"),
    ('name = "j"\ntype = "revolute"\nrpy = [0, 0, 1]\nrotation = [["z", "1"]]', r"give the joint frame's rotation one"),
    ('name = "j"\ntype = "revolute"\ndamping = "__import__(\'os\')"', r"\[joints\[0\]\.damping\]"),
    ('name = "__import__(\'os\')"\ntype = "revolute"', r"a joint's name must be an identifier"),
    ('name = "j"\ntype = "revolute"\ncoordinates = ["a\\nb"]', r"is not a valid coordinate name"),
    ('name = "j"\ntype = "revolute"\nlimits = ["1", "0"]', r"\[joints\[0\]\.limits\].*not below the upper limit"),
    ('name = "j"\ntype = "revolute"\nlimits = "wide"', r"\[joints\[0\]\.limits\].*expected \[lower, upper\]"),
    ('name = "j"\ntype = "revolute"\ndamping = 1e400', r"joints\[0\]\.damping"),
    ('name = "j"\ntype = "spherical"\nfriction = 1', r"\[joints\[0\]\.friction\].*no Coulomb friction"),
    ('name = "j"\ntype = "revolute"\nmatrix = [[1, 0, 0], [0, 1, 0], [0, 0, 2]]',
     r"\[joints\[0\]\.matrix\].*the matrix is not a rotation"),
    ('name = "j"\ntype = "revolute"\ncoordinates = 5', r"a revolute joint has 1 coordinate, got 5; give 1 name, e\.g\. "
                                                    r"\['j'\]"),
    ('name = "j"\ntype = "revolute"\nparent = 5', r"\[joints\[0\]\.parent\].*no frame is named '5'"),
    ('name = "j"\ntype = "revolute"\nchild = "a b"', r"\[joints\[0\]\.child\].*must be an identifier"),
    ('name = "j"\ntype = "revolute"\nfriction = {a = 1}', r"\[joints\[0\]\.friction\].*got a table"),
    (f'name = "j"\ntype = "revolute"\nchild = "{"x" * 5000}"\ncoordinates = ["q"]\nparent = "{"y" * 5000}"',
     r"no frame is named"),
])
def test_joint_table_problems(table, match):
    text = f'name = "bad"\n[parameters]\nk = 1.0\n[[joints]]\n{table}\n'
    assert re.search(match, _problems(text), flags=re.DOTALL)


def test_a_body_in_a_joint_frame_that_failed_gets_no_second_error():
    text = ('[[joints]]\nname = "j"\ntype = "revolute"\naxis = "w"\n[[bodies]]\nmass = 1\nframe = "j"\n'
            'inertia = [1, 1, 1]\n')
    message = _problems(text)
    assert "joints[0].axis" in message and "'w' is not an axis" in message
    assert "bodies[0]" not in message


def test_joints_must_be_tables():
    assert "expected [[joints]] tables" in _problems('coordinates = ["x"]\njoints = 3\n')
