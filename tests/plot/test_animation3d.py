"""Bodies in space in the animations: their frame's axes, the link that carries them, their disk;
checked against rotation matrices computed here, independently of the library's frames."""

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from PIL import Image

import lagrangian as lg
from lagrangian import plot
from lagrangian.cli import main
from lagrangian.plot._animation import AXIS_LENGTH
from lagrangian.plot._geometry import DISK_POINTS


def Rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def Ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def Rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _drawn(artist):
    return np.array(artist.get_data_3d(), dtype=float).T


def top_rotation(theta, phi, psi):
    return Rz(phi) @ Rx(theta) @ Rz(psi)  # the heavy top's Euler angles, about the current axes


TOP_L, TOP_RADIUS = 0.1, np.sqrt(2 * 0.01 / 1.0)  # l, and sqrt(2*I3/m) of heavy-top.toml


@pytest.fixture(scope="module")
def top():
    traj = lg.simulate(lg.load("heavy-top"), t_end=0.4)
    return traj, plot.animate(traj, fps=10)


def test_heavy_top_scene_at_a_known_pose():
    scene = plot.scene_of(lg.load("heavy-top"))
    (body,) = scene.spatial
    assert (body.name, body.frame, body.axis, body.link) == ("top", "body", 2, 2)
    assert body.radius == pytest.approx(TOP_RADIUS, rel=1e-14)
    theta, phi, psi = 0.7, -0.4, 1.3
    (d,) = scene.body_drawings([0.0], [[theta, phi, psi]], axis_length=0.3)
    R = top_rotation(theta, phi, psi)
    np.testing.assert_allclose(d.rotation[0], R, atol=1e-14)
    np.testing.assert_allclose(d.origin[0], [0, 0, 0], atol=1e-15)
    for i in range(3):  # from the tip, along each body axis
        np.testing.assert_allclose(d.axes[0, i], [[0, 0, 0], 0.3 * R[:, i]], atol=1e-14)
    centre = TOP_L * R[:, 2]
    np.testing.assert_allclose(d.link[0], [[0, 0, 0], centre], atol=1e-14)
    outline = d.disk[0]
    assert outline.shape == (DISK_POINTS, 3)
    np.testing.assert_allclose(np.linalg.norm(outline - centre, axis=1), TOP_RADIUS, rtol=1e-13)
    np.testing.assert_allclose((outline - centre) @ R[:, 2], 0, atol=1e-14)  # across the symmetry axis
    # the points go once around the circle, evenly
    angles = np.unwrap(np.arctan2((outline - centre) @ R[:, 1], (outline - centre) @ R[:, 0]))
    np.testing.assert_allclose(np.diff(angles), 2 * np.pi / DISK_POINTS, rtol=1e-12)


def test_heavy_top_drawn_axes_link_and_disk(top):
    traj, anim = top
    assert len(anim) == 5
    # the axes' length: a fifth of the scene, the nodes' reach or the disk's diameter
    centres = np.array([TOP_L * top_rotation(*q)[:, 2] for q in traj.q])
    reach = np.ptp(np.vstack([centres, np.zeros((1, 3))]), axis=0).max()
    assert anim.axis_length == pytest.approx(AXIS_LENGTH * max(reach, 2 * TOP_RADIUS), rel=1e-12)
    L = anim.axis_length
    for k in range(len(anim)):
        anim.draw(k)
        i = anim.frame_indices[k]
        R = top_rotation(traj["theta"][i], traj["phi"][i], traj["psi"][i])
        for j, name in enumerate("xyz"):
            np.testing.assert_allclose(_drawn(anim.artists[f"top axis {name}"]), [[0, 0, 0], L * R[:, j]],
                                       atol=1e-12)
        centre = TOP_L * R[:, 2]
        np.testing.assert_allclose(_drawn(anim.artists["top link"]), [[0, 0, 0], centre], atol=1e-12)
        np.testing.assert_allclose(_drawn(anim.artists["top"]), [centre], atol=1e-12)
        outline = _drawn(anim.artists["top disk"])
        assert len(outline) == DISK_POINTS + 1 and np.allclose(outline[0], outline[-1])  # closed
        np.testing.assert_allclose(np.linalg.norm(outline - centre, axis=1), TOP_RADIUS, rtol=1e-12)
        np.testing.assert_allclose((outline - centre) @ R[:, 2], 0, atol=1e-12)
    assert [anim.artists[f"top axis {a}"].get_color() for a in "xyz"] == ["tab:red", "tab:green", "tab:blue"]
    # everything drawn is inside the 3D box
    anim.draw(0)
    box = np.array([anim.axes.get_xlim(), anim.axes.get_ylim(), anim.axes.get_zlim()])
    drawn = np.vstack([_drawn(anim.artists[n]) for n in ("top disk", "top axis x", "top axis y", "top axis z")])
    assert np.all(drawn >= box[:, 0]) and np.all(drawn <= box[:, 1])


def test_a_disk_across_another_axis_from_the_python_api():
    m = lg.Model("wheel")
    a, b = m.coordinate("a", "b")
    r, h = m.parameter("r", 0.3), m.parameter("h", 0.5)
    m.add_frame("fork", origin=(0, 0, h), rotation=[("z", a)])
    m.add_frame("wheel", parent="fork", origin=(0.2, 0, 0), rotation=[("x", b)])
    m.add_rigid_body(2.0, (0.09, 0.045, 0.045), frame="wheel", shape="disk", radius=r, axis="x", name="wheel")
    m.add_gravity(9.81)
    scene = plot.scene_of(m, {"r": 0.25})  # the drawing takes the given parameter values
    (body,) = scene.spatial
    assert (body.axis, body.radius, body.link) == (0, 0.25, 2)
    va, vb = 0.8, -2.1
    (d,) = scene.body_drawings([0.0], [[va, vb]], axis_length=0.1)
    R = Rz(va) @ Rx(vb)
    origin = np.array([0, 0, 0.5]) + Rz(va) @ [0.2, 0, 0]
    np.testing.assert_allclose(d.origin[0], origin, atol=1e-14)
    # the wheel is centred on its frame's origin: its link comes from the fork's origin
    np.testing.assert_allclose(d.link[0], [[0, 0, 0.5], origin], atol=1e-14)
    outline = d.disk[0]
    np.testing.assert_allclose(np.linalg.norm(outline - origin, axis=1), 0.25, rtol=1e-13)
    np.testing.assert_allclose((outline - origin) @ R[:, 0], 0, atol=1e-14)
    for i in range(3):
        np.testing.assert_allclose(d.axes[0, i, 1], origin + 0.1 * R[:, i], atol=1e-14)


def test_robot_arm_links_follow_the_joints():
    scene = plot.scene_of(lg.load("robot-arm-3"))
    assert [(b.name, b.link, b.radius) for b in scene.spatial] == [("link1", 2, None), ("link2", 3, None),
                                                                   ("link3", 3, None)]
    q = np.array([0.5, -0.6, 1.0])
    d1, d2, d3 = scene.body_drawings([0.0], [q], axis_length=0.2)
    h, l = 0.5, 0.4
    R1 = Rz(q[0])
    R2 = R1 @ Ry(q[1])
    R3 = R2 @ Ry(q[2])
    o1, o2 = np.zeros(3), np.array([0, 0, h])
    o3 = o2 + R2 @ [l, 0, 0]
    np.testing.assert_allclose(d1.link[0], [o1, [0, 0, h / 2]], atol=1e-14)  # the column, base to centre
    np.testing.assert_allclose(d2.link[0], [o1, o2, o2 + R2 @ [l / 2, 0, 0]], atol=1e-14)
    np.testing.assert_allclose(d3.link[0], [o2, o3, o3 + R3 @ [l / 2, 0, 0]], atol=1e-14)
    for d, o, R in ((d1, o1, R1), (d2, o2, R2), (d3, o3, R3)):
        np.testing.assert_allclose(d.rotation[0], R, atol=1e-14)
        for i in range(3):
            np.testing.assert_allclose(d.axes[0, i], [o, o + 0.2 * R[:, i]], atol=1e-14)
        assert d.disk is None


def test_robot_arm_gif_has_its_frames(tmp_path, capsys):
    out = tmp_path / "arm.gif"
    assert main(["animate", "robot-arm-3", "--t-end", "0.6", "--fps", "10", "-o", str(out)]) == 0
    assert "wrote 7 frames" in capsys.readouterr().out
    with Image.open(out) as im:
        assert im.n_frames == 7
        im.seek(3)
        rgb = np.asarray(im.convert("RGB")).reshape(-1, 3).astype(int)
    # the axes' colours survive the GIF's palette: some pixels are clearly red, green and blue
    for colour in ((214, 39, 40), (44, 160, 44), (31, 119, 180)):
        assert (np.abs(rgb - colour).max(axis=1) < 40).sum() > 20, colour


def test_cli_animates_the_heavy_top(tmp_path):
    out = tmp_path / "top.gif"
    assert main(["animate", "heavy-top", "--t-end", "0.2", "-o", str(out)]) == 0
    with Image.open(out) as im:
        assert im.n_frames == 6


@pytest.mark.parametrize("name", ["cart-pendulum", "double-pendulum", "mck-elements", "sliding-disk-pendulum"])
def test_planar_models_have_no_bodies_in_space(name):
    traj = lg.simulate(lg.load(name), t_end=0.2)
    anim = plot.animate(traj, fps=10)
    assert anim.scene.spatial == () and anim.scene.body_drawings(traj.t, traj.q, 1.0) == ()
    assert not [n for n in anim.artists if " axis " in n or n.endswith(" link")]
    assert anim.scene.dim == 2 and anim.axes.name == "rectilinear"


def test_a_spatial_model_without_bodies_in_space_is_drawn_as_before():
    anim = plot.animate(lg.simulate(lg.load("spherical-pendulum"), t_end=0.2), fps=10)
    assert anim.scene.dim == 3 and anim.scene.spatial == ()
    assert not [n for n in anim.artists if " axis " in n]


def test_the_examples_declare_their_disks():
    gyro = plot.scene_of(lg.load("gyroscope"))
    assert [(b.name, b.radius, b.axis) for b in gyro.spatial] == [("disk", 0.05, 2)]
    # the shape is drawn only: the equations are those of the model without it
    text = lg.examples.example_source("heavy-top")
    plain = "\n".join(line for line in text.splitlines() if not line.startswith(("shape", "radius")))
    assert lg.derive(lg.io.loads_model(plain)).mass_matrix == lg.derive(lg.load("heavy-top")).mass_matrix


# ----------------------------------------------------------------------------- errors
BODY = """\
coordinates = ["q"]
inputs = ["u"]
[parameters]
m = 1.0
R = -0.2
[[frames]]
name = "f"
rotation = [["z", "q"]]
"""


@pytest.mark.parametrize("keys, line, key, message", [
    ('shape = "cube"\nradius = "0.1"', 14, "shape",
     "unknown shape 'cube': a body in space is drawn as a \"disk\" (a circle of a given radius across one of its "
     "axes), or without a shape (its axes only)"),
    ('shape = "disk"', 9, "radius",
     "a disk needs its radius: an expression of the parameters such as \"R\" (with a value for R among the "
     "parameters), or a number"),
    ('radius = "0.1"', 14, "radius",
     "the radius of a shape, but the body has none: give the shape \"disk\" with it, or leave it out"),
    ('axis = "z"', 14, "axis", "the axis of a shape, but the body has none: give the shape \"disk\" with it, or "
                               "leave it out"),
    ('shape = "disk"\nradius = "0.1"\naxis = "w"', 16, "axis",
     "'w' is not an axis of the body: a disk lies across the \"x\", \"y\" or \"z\" axis of the body's frame"),
    ('shape = "disk"\nradius = "0.1*q + u"', 15, "radius",
     "a disk's radius is a constant, but this one depends on q, u: write it with parameters and numbers only"),
    ('shape = "disk"\nradius = -0.5', 15, "radius", "the radius is -0.5: a disk's radius must be positive"),
    ('shape = "disk"\nradius = "R"', 15, "radius",
     "the radius is -0.2: a disk's radius must be positive; check the sign or the parameter values"),
])
def test_shape_errors_name_the_key_and_line(keys, line, key, message):
    text = BODY + '[[bodies]]\nname = "b"\nmass = "m"\nframe = "f"\ninertia = ["1", "1", "1"]\n' + keys + "\n"
    with pytest.raises(lg.ModelFileError) as info:
        lg.io.loads_model(text, source="b.toml")
    assert str(info.value) == f"b.toml:{line} [bodies[0].{key}]: {message}"


def test_shape_errors_all_at_once():
    text = BODY + ('[[bodies]]\nmass = "m"\nframe = "f"\ninertia = ["1", "1", "1"]\nshape = "ball"\n'
                   'radius = "sqrt(q)"\naxis = "v"\n')
    with pytest.raises(lg.ModelFileError) as info:
        lg.io.loads_model(text, source="b.toml")
    lines = str(info.value).splitlines()
    assert lines[0] == "3 problems in b.toml:"
    assert [line.split(": ")[0] for line in lines[1:]] == [
        "  - b.toml:13 [bodies[0].shape]", "  - b.toml:14 [bodies[0].radius]", "  - b.toml:15 [bodies[0].axis]"]


def test_an_unreadable_radius_is_reported_once():
    text = BODY + '[[bodies]]\nmass = "m"\nframe = "f"\ninertia = ["1", "1", "1"]\nshape = "disk"\nradius = "rr"\n'
    with pytest.raises(lg.ModelFileError) as info:
        lg.io.loads_model(text, source="b.toml")
    text = str(info.value)
    assert text.startswith("b.toml:14 [bodies[0].radius]: unknown name 'rr' in the expression")
    assert "needs its radius" not in text


def test_shape_errors_in_python():
    m = lg.Model("bad")
    q = m.coordinate("q")
    m.add_frame("f", rotation=[("z", q)])
    with pytest.raises(lg.ModelError, match=r"^body 'b'.shape: unknown shape 'cube'"):
        m.add_rigid_body(1, (1, 1, 1), frame="f", shape="cube", radius=1, name="b")
    with pytest.raises(lg.ModelError, match=r"^body 'b'.radius: a disk needs its radius"):
        m.add_rigid_body(1, (1, 1, 1), frame="f", shape="disk", name="b")
    with pytest.raises(lg.ModelError, match=r"body 'b'.radius: a disk's radius is a constant, but this one depends "
                                            r"on q(.|\n)*body 'b'.axis: 'y2' is not an axis of the body"):
        m.add_rigid_body(1, (1, 1, 1), frame="f", shape="disk", radius=q, axis="y2", name="b")
    with pytest.raises(lg.ModelError, match=r"^body 'p': shape, radius and axis draw a body in space \(one with "
                                            r"frame=...\); a planar body is drawn as a disk of its radius of "
                                            r"gyration"):
        m.add_rigid_body(1, 1, (0, 0), q, shape="disk", radius=1, name="p")
    R = m.parameter("R", -1.0)
    m.add_rigid_body(1, (1, 1, 1), frame="f", shape="disk", radius=R, name="b")
    with pytest.raises(lg.ModelError, match=r"\[rigid body 'b'.radius\]: the radius is -1: a disk's radius must be "
                                            r"positive; check the sign or the parameter values"):
        lg.derive(m)
