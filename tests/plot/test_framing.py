"""The view of an animation: one box for the whole motion, or a box that follows a mechanism riding
away (the bicycle, the rolling disk) with the ground's grid under its wheels; and the rods of
closed loops, found at configurations that meet the constraints. Centres are checked against the
mass-weighted mean of the node positions computed here, sizes against extents computed here."""

import matplotlib

matplotlib.use("Agg")

import re

import numpy as np
import pytest
from PIL import Image

import lagrangian as lg
from lagrangian import plot
from lagrangian.cli import main
from lagrangian.errors import ModelError
from lagrangian.numeric._simulate import given_initial_names
from lagrangian.plot._geometry import AXIS_LENGTH, clip_line, framing_of, grid_step, ground_grid, scene_of

BICYCLE_MASSES = {"R": 2.0, "B": 85.0, "H": 4.0, "F": 3.0}  # mR, mB, mH, mF of whipple-bicycle.toml


def _drawn(artist):
    return np.array(artist.get_data_3d(), dtype=float).T


def _limits(anim):
    return np.array([anim.axes.get_xlim(), anim.axes.get_ylim(), anim.axes.get_zlim()])


@pytest.fixture(scope="module")
def bicycle():
    return lg.simulate(lg.load("whipple-bicycle"), t_end=3.0)


@pytest.fixture(scope="module")
def riding(bicycle):
    return plot.animate(bicycle, fps=5, trace="B")


@pytest.mark.slow
def test_the_view_follows_the_bicycles_centre_of_mass(bicycle, riding):
    anim = riding
    assert anim.framing.follow and len(anim) == 16
    names = [n.name for n in anim.scene.nodes]
    weights = np.array([BICYCLE_MASSES.get(n, 0.0) for n in names])
    P = anim.scene.positions(bicycle.t, bicycle.q)
    own = np.ptp(P, axis=1).max()  # the bicycle's own size: its largest extent at one instant
    assert anim.framing.size == pytest.approx(own, rel=1e-12) and 1.0 < own < 1.3
    assert anim.axis_length == pytest.approx(AXIS_LENGTH * max(own, 2 * 0.35), rel=1e-12)
    widths = set()
    for k in range(len(anim)):
        anim.draw(k)
        p = anim.scene.positions(anim.times[k:k + 1], bicycle.q[anim.frame_indices[k]][None, :])[0]
        centre = weights @ p / weights.sum()
        box = _limits(anim)
        np.testing.assert_allclose(box.mean(axis=1), centre, atol=1e-9)
        widths.add(round(float(np.ptp(box, axis=1).max()), 9))
        drawn = np.vstack([_drawn(a) for name, a in anim.artists.items()
                           if name != "time" and not name.startswith(("trace", "ground"))])
        assert np.all(drawn >= box[:, 0] - 1e-9) and np.all(drawn <= box[:, 1] + 1e-9), k
    assert len(widths) == 1 and widths.pop() < 3.5  # one cube, about the bicycle's size
    assert anim.framing.centre[-1][0] - anim.framing.centre[0][0] > 13  # it rode about 15 m at 5 m/s


@pytest.mark.slow
def test_the_path_and_the_ground_are_clipped_to_the_moving_box(riding):
    anim = riding
    anim.draw(len(anim) - 1)
    box = _limits(anim)
    path = _drawn(anim.artists["trace B"])
    inside = path[np.all(np.isfinite(path), axis=1)]
    assert 0 < len(inside) < len(path)  # the start of the ride is out of view
    assert np.all(inside >= box[:, 0]) and np.all(inside <= box[:, 1])
    grid = _drawn(anim.artists["ground"])
    lines = grid[np.all(np.isfinite(grid), axis=1)]
    assert np.all(lines[:, 2] == 0)
    assert np.all(lines[:, :2] >= box[:2, 0] - 1e-12) and np.all(lines[:, :2] <= box[:2, 1] + 1e-12)
    step = grid_step(float(np.ptp(box[:2], axis=1).max()))
    # each line runs at a multiple of the step in x (lines along y) or in y (lines along x)
    for a, b in zip(lines[0::2], lines[1::2]):
        axis = 0 if a[0] == b[0] else 1
        assert a[axis] == b[axis] and abs(a[axis] / step - round(a[axis] / step)) < 1e-9
    assert len(lines) // 2 >= 6


@pytest.mark.slow
def test_the_fixed_view_holds_the_whole_ride(bicycle):
    anim = plot.animate(bicycle, fps=5, view="fixed")
    assert not anim.framing.follow
    boxes = []
    for k in (0, len(anim) - 1):
        anim.draw(k)
        boxes.append(_limits(anim))
    np.testing.assert_array_equal(boxes[0], boxes[1])
    P = anim.scene.positions(bicycle.t, bicycle.q).reshape(-1, 3)
    assert np.all(P >= boxes[0][:, 0]) and np.all(P <= boxes[0][:, 1])


@pytest.mark.slow
def test_a_followed_bicycle_stays_as_large_in_the_pictures(bicycle, tmp_path):
    """In the GIF the wheels (orange) keep their size when the view follows; in the fixed view of
    the whole ride they shrink to a few pixels."""
    def orange(anim, k):
        anim.save_frame(tmp_path / "f.png", k)
        rgb = np.asarray(Image.open(tmp_path / "f.png").convert("RGB")).reshape(-1, 3).astype(int)
        return int((np.abs(rgb - (255, 127, 14)).max(axis=1) < 40).sum())

    follow, fixed = plot.animate(bicycle, fps=2, dpi=60), plot.animate(bicycle, fps=2, dpi=60, view="fixed")
    first, last = orange(follow, 0), orange(follow, len(follow) - 1)
    assert first > 150 and 0.5 < last / first < 2
    assert orange(fixed, len(fixed) - 1) < 0.5 * first


def test_the_rolling_disk_is_followed_and_the_pendulums_are_not():
    assert plot.animate(lg.simulate(lg.load("rolling-disk"), t_end=4.0), fps=2).framing.follow
    for name in ("double-pendulum", "spherical-pendulum", "heavy-top", "four-bar"):
        assert not plot.animate(lg.simulate(lg.load(name), t_end=1.0), fps=2).framing.follow, name


def test_framing_rules():
    t = np.linspace(0, 1, 11)
    # a dumbbell (masses 1 and 3, 0.5 apart) sliding 10 along x: followed, centred on its centre of mass
    a = np.stack([10 * t, 0 * t], axis=1)
    b = a + [0.0, 0.5]
    P = np.stack([a, b], axis=1)
    f = framing_of(P, [1.0, 3.0])
    assert f.follow and f.size == pytest.approx(0.5)
    np.testing.assert_allclose(f.centre, (a + 3 * b) / 4, atol=1e-15)
    np.testing.assert_allclose(f.half, [0.0, 0.375], atol=1e-15)
    assert not framing_of(P, [1.0, 3.0], "fixed").follow
    # short of FOLLOW_RATIO (3) times its size, one box; massless nodes are weighed equally
    short = np.stack([a / 10 * 1.4, b / 10 * 1.4 + [0, 0.5 - 0.07]], axis=1)
    assert not framing_of(short, [0.0, 0.0]).follow
    g = framing_of(short, [0.0, 0.0], "follow")
    np.testing.assert_allclose(g.centre, short.mean(axis=1), atol=1e-15)
    # a point mass alone has no size: never followed
    assert not framing_of(a[:, None, :], [1.0], "follow").follow
    # widened to hold what else is drawn
    wide = f.including(P + [0.0, 2.0])
    np.testing.assert_allclose(wide.half, [0.0, 2.5 - 0.375])
    with pytest.raises(ModelError, match=r"^view 'sideways': choose one of auto, fixed, follow \(auto follows"):
        framing_of(P, [1.0, 3.0], "sideways")


def test_grid_steps_and_line_clipping():
    assert [grid_step(s) for s in (2.3, 0.6, 1.0, 6.0, 12.0)] == pytest.approx([0.5, 0.1, 0.2, 1.0, 2.0])
    assert ground_grid([0, 0, 0.1], [1, 1, 2]).shape == (0, 3)  # the box is above the ground
    grid = ground_grid([-0.3, 0.05, -1], [0.3, 0.55, 1])  # side 0.6: step 0.1
    ends = grid[np.all(np.isfinite(grid), axis=1)]
    assert len(ends) == 2 * (7 + 5)  # x = -0.3 .. 0.3, y = 0.1 .. 0.5
    np.testing.assert_allclose(clip_line([0, 0, 0], [1, 0, 0], [-1, -1, -1], [2, 1, 1]), [[-1, 0, 0], [2, 0, 0]])
    np.testing.assert_allclose(clip_line([0, 0], [0.6, 0.8], [-3, -1], [3, 4]), [[-0.75, -1], [3, 4]])
    assert clip_line([0, 5, 0], [1, 0, 0], [-1, -1, -1], [1, 1, 1]) is None
    assert clip_line([5, 5], [1, -1], [-1, -1], [1, 1]) is None


def test_a_2d_view_that_follows_a_pushed_cart():
    traj = lg.simulate(lg.load("cart-pendulum"), t_end=3.0, inputs={"F": "20"})
    anim = plot.animate(traj, fps=4, view="follow")
    assert anim.framing.follow
    for k in range(len(anim)):
        anim.draw(k)
        p = anim.positions(k)
        centre = (1.0 * p["cart"] + 0.5 * p["pendulum"]) / 1.5  # M1 = 1, M2 = 0.5 (cart-pendulum.toml)
        np.testing.assert_allclose([np.mean(anim.axes.get_xlim()), np.mean(anim.axes.get_ylim())], centre,
                                   atol=1e-9)


def test_cli_view_option(tmp_path, capsys):
    out = tmp_path / "disk.gif"
    assert main(["animate", "rolling-disk", "--t-end", "1", "--fps", "4", "--view", "fixed", "-o", str(out)]) == 0
    assert "wrote 5 frames" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(["animate", "rolling-disk", "--view", "sideways", "-o", str(out)])
    assert exc.value.code == 2
    assert re.search(r"argument --view: invalid choice: 'sideways' \(choose from '?auto'?, '?fixed'?, '?follow'?\)",
                     capsys.readouterr().err)


# ----------------------------------------------------------------------------- closed loops
def test_rods_of_closed_loops_are_found_on_the_constraints():
    four = scene_of(lg.load("four-bar"))
    rods = {frozenset((four.nodes[i].name, four.nodes[j].name)) for i, j in four.rods}
    assert {frozenset(p) for p in [("O", "A"), ("A", "B"), ("D", "B"), ("B", "rocker"), ("B", "coupler")]} <= rods
    traj = lg.simulate(lg.load("four-bar"), t_end=1.0)
    P = four.positions(traj.t, traj.q)
    ab = np.linalg.norm(P[:, four.index("A")] - P[:, four.index("B")], axis=1)
    np.testing.assert_allclose(ab, 0.6, atol=1e-7)  # the coupler's length b, all along the motion
    cart = scene_of(lg.load("cartesian-pendulum"))
    assert [(cart.nodes[i].name, cart.nodes[j].name) for i, j in cart.rods] == [("O", "bob")]


def test_the_initial_values_a_simulation_takes_as_given():
    """What the playground's sliders send: the model file's initial values, or, with constraints and
    independent coordinates, those coordinates and the independent speeds (the file's other values
    are guesses); sent so, the simulation is the default one."""
    assert given_initial_names(lg.load("four-bar")) == ["th1", "th1_dot"]
    assert given_initial_names(lg.load("whipple-bicycle")) == ["x", "y", "psi", "phi", "thetaR", "delta", "thetaF",
                                                               "phi_dot", "thetaR_dot", "delta_dot"]
    assert given_initial_names(lg.load("rolling-disk")) == ["phi", "psi_dot", "phi_dot", "theta_dot"]
    assert given_initial_names(lg.load("cart-pendulum")) == ["q2"]
    model = lg.load("four-bar")
    default = lg.simulate(model, t_end=0.5)
    given = lg.simulate(model, t_end=0.5, initial={"th1": 1.2, "th1_dot": 4.0})
    np.testing.assert_array_equal(given.x, default.x)
    with pytest.raises(ModelError,
                       match="changing the coordinates that were not given \\(none; given: th1, th2, th3\\)"):
        lg.simulate(model, t_end=0.5, initial={"th1": 1.2, "th2": 0.2, "th3": 1.4, "th1_dot": 4.0})
