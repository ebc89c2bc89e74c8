"""Animations: drawn from the model's own geometry, at the trajectory's positions; GIF, HTML, MP4; the CLI."""

import os
import stat
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from PIL import Image

import lagrangian as lg
from lagrangian import plot
from lagrangian.cli import main
from lagrangian.plot._animation import ffmpeg_available


def _drawn(artist):
    if hasattr(artist, "get_data_3d"):
        return np.array(artist.get_data_3d(), dtype=float).T
    return np.array(artist.get_data(), dtype=float).T


@pytest.fixture(scope="module")
def cart():
    return lg.simulate(lg.load("cart-pendulum"), t_end=1.0, initial={"q2": 1.4, "q1_dot": 0.5})


def test_cart_pendulum_drawn_at_its_positions(cart):
    anim = plot.animate(cart, fps=5)
    assert len(anim) == 6
    np.testing.assert_allclose(anim.times, [0, 0.2, 0.4, 0.6, 0.8, 1.0])
    L = 1.0
    for k in range(len(anim)):
        anim.draw(k)
        i = anim.frame_indices[k]
        q1, q2 = cart["q1"][i], cart["q2"][i]
        bob = [q1 + L * np.cos(q2), L + L * np.sin(q2)]
        np.testing.assert_allclose(_drawn(anim.artists["pendulum"]), [bob], atol=1e-12)
        np.testing.assert_allclose(_drawn(anim.artists["cart"]), [[q1, 0]], atol=1e-12)
        # the pendulum turns about its hidden pivot (q1, L), fixed on the cart by a rod
        np.testing.assert_allclose(_drawn(anim.artists["rod pendulum-pendulum pivot"]), [bob, [q1, L]], atol=1e-12)
        np.testing.assert_allclose(_drawn(anim.artists["rod cart-pendulum pivot"]), [[q1, 0], [q1, L]], atol=1e-12)
        assert anim.artists["time"].get_text() == f"t = {cart.t[i]:.2f} s"
    scene = anim.scene
    assert [n.name for n in scene.nodes] == ["cart", "pendulum", "pendulum pivot"]
    assert scene.nodes[0].slider and not scene.nodes[1].slider  # the cart rides on a track
    assert len(scene.tracks) == 1 and np.allclose(np.abs(scene.tracks[0][1]), [1, 0])


@pytest.mark.parametrize("name, cart_kind", [("cart-pendulum", "particle"), ("cart-pendulum-massless", "point"),
                                             ("cart-pendulum-extended", "point")])
def test_the_pendulum_pivot_stands_on_a_mast_on_the_cart(name, cart_kind):
    # the slides put the pivot at (q1, L), a height L above the cart at (q1, 0): a mast joins them
    traj = lg.simulate(lg.load(name), t_end=0.3, initial={"q2": 0.5, "q1_dot": 1.0})
    anim = plot.animate(traj, fps=10)
    scene = anim.scene
    cart, pivot = scene.index("cart"), scene.index("pendulum pivot")
    assert scene.nodes[cart].kind == cart_kind and scene.nodes[cart].slider
    assert (cart, pivot) in scene.rods
    # one guide line, the cart's, along y = 0: the pivot does not float on a line of its own
    assert len(scene.tracks) == 1
    np.testing.assert_allclose(scene.tracks[0][0][1], 0.0, atol=1e-12)
    np.testing.assert_allclose(scene.tracks[0][1], [1, 0], atol=1e-12)
    L = 1.0
    for k in range(len(anim)):
        anim.draw(k)
        q1 = traj["q1"][anim.frame_indices[k]]
        np.testing.assert_allclose(_drawn(anim.artists["rod cart-pendulum pivot"]), [[q1, 0], [q1, L]], atol=1e-12)
        np.testing.assert_allclose(_drawn(anim.artists["cart"]), [[q1, 0]], atol=1e-12)
    assert anim.artists["cart"].get_marker() == "s"  # a block; an empty one for the massless cart
    face = matplotlib.colors.to_rgba(anim.artists["cart"].get_markerfacecolor())
    assert (face == (1, 1, 1, 1)) == (cart_kind == "point")


def test_double_pendulum_rods_and_trace():
    traj = lg.simulate(lg.load("double-pendulum"), t_end=0.5)
    anim = traj.animate(fps=10, trace="bob2")
    names = [(anim.scene.nodes[i].name, anim.scene.nodes[j].name) for i, j in anim.scene.rods]
    assert names == [("pivot", "bob1"), ("bob1", "bob2")]
    k = len(anim) - 1
    anim.draw(k)
    i = anim.frame_indices[k]
    th1, th2 = traj["theta1"][:i + 1], traj["theta2"][:i + 1]
    path = np.column_stack([np.sin(th1) + np.sin(th2), -np.cos(th1) - np.cos(th2)])
    np.testing.assert_allclose(_drawn(anim.artists["trace bob2"]), path, atol=1e-12)
    np.testing.assert_allclose(anim.positions(k)["bob2"], path[-1], atol=1e-12)
    assert anim.scene.nodes[0].fixed  # the pivot stands on the ground


def test_rotating_pendulum_in_3d():
    traj = lg.simulate(lg.load("rotating-pendulum"), t_end=0.4)
    anim = plot.animate(traj, fps=10)
    assert anim.scene.dim == 3 and anim.axes.name == "3d"
    l, Omega = 0.5, 3.0
    for k in (0, 2, 4):
        anim.draw(k)
        i = anim.frame_indices[k]
        th, t = traj["theta"][i], traj.t[i]
        bob = [l * np.sin(th) * np.cos(Omega * t), l * np.sin(th) * np.sin(Omega * t), -l * np.cos(th)]
        np.testing.assert_allclose(_drawn(anim.artists["bob"]), [bob], atol=1e-12)
        np.testing.assert_allclose(_drawn(anim.artists["rod pivot-bob"]), [[0, 0, 0], bob], atol=1e-12)


def test_springs_dampers_and_bodies():
    traj = lg.simulate(lg.load("sliding-disk-heavy-rod"), t_end=0.3)
    anim = plot.animate(traj, fps=10)
    scene = anim.scene
    assert [(n, scene.nodes[i].name, scene.nodes[j].name) for n, i, j in scene.springs] == [("spring", "O", "disk")]
    assert [(scene.nodes[i].name, scene.nodes[j].name) for i, j in scene.rods] == [("O", "rod")]
    anim.draw(3)
    i = anim.frame_indices[3]
    q1, q2 = traj["q1"][i], traj["q2"][i]
    zigzag = _drawn(anim.artists["spring spring"])
    np.testing.assert_allclose(zigzag[[0, -1]], [[0, 0], [q1 * np.sin(q2), -q1 * np.cos(q2)]], atol=1e-12)
    np.testing.assert_allclose(anim.artists["disk disk"].center, [q1 * np.sin(q2), -q1 * np.cos(q2)], atol=1e-12)
    # radius of gyration sqrt(I/m) = 0.1, at most a tenth of the scene's extent
    assert anim.artists["disk disk"].radius == pytest.approx(min(0.1, 0.1 * anim._size))
    # springs and dampers given by their length only find their two ends
    mck = plot.scene_of(lg.load("mck-elements"))
    ends = [(n, mck.nodes[i].name, mck.nodes[j].name) for n, i, j in mck.springs + mck.dampers]
    assert ends == [("spring1", "wall", "mass1"), ("spring2", "mass1", "mass2"),
                    ("damper1", "wall", "mass1"), ("damper2", "mass1", "mass2")]


def test_a_torsional_spring_is_not_drawn():
    m = lg.Model("torsion")
    th = m.coordinate("theta")
    m.add_point("pivot", (0, 0))
    m.add_rigid_body(1.0, 0.1, (0, 0), th, name="wheel")
    m.add_spring(2.0, length=th, name="coil")
    scene = plot.scene_of(m)
    assert scene.springs == () and scene.undrawn[0].startswith("spring 'coil': its length theta is not the distance")


def test_energy_only_model_cannot_be_drawn():
    traj = lg.simulate(lg.load("cart-pendulum-energy"), t_end=0.1)
    with pytest.raises(lg.ModelError, match=r"model 'cart-pendulum-energy' cannot be drawn: it is described by its "
                                            r"energies \(T, V, D\) only.*Describe it with elements instead.*"
                                            r"'cart-pendulum' is the element form"):
        traj.animate()


def test_bad_arguments(cart):
    with pytest.raises(lg.ModelError, match=r"trace 'bob': model 'cart-pendulum' has no point, particle or rigid body "
                                            r"of that name; the names are cart, pendulum"):
        plot.animate(cart, trace="bob")
    with pytest.raises(lg.ModelError, match="fps and speed must be positive numbers, got fps=0"):
        plot.animate(cart, fps=0)
    bare = lg.Trajectory(cart.t, cart.x, cart.state_names)
    with pytest.raises(lg.ModelError,
                       match=r"this trajectory does not carry its model, so it cannot be drawn: pass model="):
        plot.animate(bare)
    assert len(plot.animate(bare, model=lg.load("cart-pendulum"), fps=2)) == 3
    anim = plot.animate(cart, fps=5)
    with pytest.raises(ValueError, match=r"unknown format '.avi'; use a file name ending in .gif, .mp4, .html"):
        anim.save("out.avi")


def test_gif_and_html(cart, tmp_path):
    anim = plot.animate(cart, fps=5, speed=0.5, dpi=40)  # 0.1 simulated s per frame
    assert len(anim) == 11
    anim.save(tmp_path / "cart.gif")
    with Image.open(tmp_path / "cart.gif") as im:
        assert im.n_frames == 11 and im.size == (240, 184)
    anim.save(tmp_path / "cart.html")
    page = (tmp_path / "cart.html").read_text()
    # the frames and the first shown
    assert page.startswith("<!DOCTYPE html>") and page.count("data:image/png;base64,") == 11 + 1
    assert '"1.000"' in page  # the time of the last frame
    assert anim._repr_html_().count("data:image/png;base64,") == 11 + 1


def test_mp4_without_ffmpeg(cart, monkeypatch):
    monkeypatch.setattr("lagrangian.plot._animation.ffmpeg_available", lambda: False)
    with pytest.raises(ValueError, match=r"cannot write 'out.mp4': MP4 needs ffmpeg, which is not installed \(not on "
                                         r"PATH\): install it \(Debian/Ubuntu: `sudo apt-get install ffmpeg`; .*"
                                         r"macOS: `brew install ffmpeg`; .*\), or write a .gif or an .html animation "
                                         r"instead$"):
        plot.animate(cart, fps=5).save("out.mp4")


def test_ffmpeg_is_looked_up_on_path(monkeypatch, tmp_path):
    monkeypatch.setenv("PATH", str(tmp_path))
    assert not ffmpeg_available()
    fake = tmp_path / "ffmpeg"
    fake.write_text("#!/bin/sh\n")
    fake.chmod(0o755)
    assert ffmpeg_available()


def test_without_matplotlib_plots_say_how_to_install_it(cart, monkeypatch):
    for name in ("matplotlib.pyplot", "matplotlib.figure"):
        monkeypatch.setitem(sys.modules, name, None)  # as if Matplotlib were not installed
    message = (r"plots and animations need Matplotlib, a dependency of lagrangian that is missing from this Python "
               r"environment: install it with `python -m pip install matplotlib`, or reinstall lagrangian "
               r"\(`python -m pip install -e .` in a clone\)")
    with pytest.raises(ImportError, match=message):
        cart.plot()
    with pytest.raises(ImportError, match=message):
        plot.animate(cart)


@pytest.mark.skipif(not ffmpeg_available(), reason="ffmpeg is not installed")
@pytest.mark.subprocess
def test_mp4(cart, tmp_path):  # pragma: no cover - only where ffmpeg is present
    anim = plot.animate(cart, fps=5, dpi=40)
    anim.save(tmp_path / "cart.mp4")
    import shutil
    import subprocess

    if shutil.which("ffprobe"):  # the video decodes, with one frame per animation frame
        out = subprocess.run(["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
                              "stream=nb_read_frames,codec_type", "-of", "csv=p=0", str(tmp_path / "cart.mp4")],
                             capture_output=True, text=True, check=True).stdout.strip()
        assert out == f"video,{len(anim)}"
    else:
        assert (tmp_path / "cart.mp4").stat().st_size > 0


@pytest.mark.skipif(not ffmpeg_available(), reason="ffmpeg is not installed")
@pytest.mark.subprocess
def test_mp4_ffmpeg_failure_is_reported(cart, tmp_path, monkeypatch):  # pragma: no cover - only with ffmpeg
    monkeypatch.setitem(matplotlib.rcParams, "animation.codec", "no-such-codec")
    with pytest.raises(lg.LagrangianError, match=r"ffmpeg could not write '.*cart.mp4': .*no-such-codec"):
        plot.animate(cart, fps=5, dpi=40).save(tmp_path / "cart.mp4")


# ---------------------------------------------------------------------------- CLI
def test_cli_animate_gif(tmp_path, capsys):
    out = tmp_path / "cart.gif"
    assert main(["animate", "cart-pendulum", "--t-end", "0.4", "--fps", "5", "--dpi", "40", "-o", str(out)]) == 0
    assert capsys.readouterr().out.strip() == f"wrote 3 frames (t = 0 .. 0.4 s, 5 fps) to {out}"
    with Image.open(out) as im:
        assert im.n_frames == 3
    mode = stat.S_IMODE(os.stat(out).st_mode)
    umask = os.umask(0)
    os.umask(umask)
    assert mode == 0o666 & ~umask
    assert [p.name for p in tmp_path.iterdir()] == ["cart.gif"]  # no temporary file left


def test_cli_animate_html_with_trace_and_speed(tmp_path):
    out = tmp_path / "double.html"
    assert main(["animate", "double-pendulum", "--t-end", "0.4", "--fps", "5", "--speed", "0.5", "--trace", "bob2",
                 "--initial", "theta1=0.5", "-o", str(out)]) == 0
    assert out.read_text().count("data:image/png;base64,") == 5 + 1


@pytest.mark.parametrize("args, message", [
    (["cart-pendulum", "-o", "{tmp}/cart.avi"], "unknown format '.avi'; use a file name ending in .gif, .mp4, .html"),
    (["cart-pendulum", "-o", "{tmp}/cart"], "unknown format '(no suffix)'"),
    (["cart-pendulum-energy", "-o", "{tmp}/c.gif"], "model 'cart-pendulum-energy' cannot be drawn"),
    (["cart-pendulum", "--trace", "pendulm", "-o", "{tmp}/c.gif"],
     "trace 'pendulm': model 'cart-pendulum' has no point, particle or rigid body of that name "
     "(did you mean 'pendulum'?)"),
    (["cart-pendulum", "--fps", "0", "-o", "{tmp}/c.gif"], "--fps must be a positive number, got 0"),
    (["cart-pendulum", "-o", "{tmp}/missing/c.gif"], "the folder"),
])
def test_cli_animate_errors(tmp_path, capsys, args, message):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    assert main(["animate", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("lagrangian animate: error: ") and message in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.subprocess
@pytest.mark.slow
def test_cli_animate_mp4_without_ffmpeg(tmp_path):
    # a real run with ffmpeg off PATH: exit 2, one line that says how to install it, before any simulation
    out = tmp_path / "c.mp4"
    run = subprocess.run([sys.executable, "-m", "lagrangian", "animate", "cart-pendulum", "-o", str(out)],
                         capture_output=True, text=True, env={**os.environ, "PATH": str(tmp_path)}, timeout=120)
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.count("\n") == 1, run.stderr
    assert run.stderr.startswith(f"lagrangian animate: error: cannot write '{out}': MP4 needs ffmpeg, which is not "
                                 "installed (not on PATH): install it (Debian/Ubuntu: `sudo apt-get install ffmpeg`;")
    assert run.stderr.rstrip().endswith("or write a .gif or an .html animation instead")
    assert list(tmp_path.iterdir()) == []


def test_cli_animate_without_matplotlib(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    assert main(["animate", "cart-pendulum", "-o", str(tmp_path / "c.gif")]) == 2
    err = capsys.readouterr().err
    assert err == ("lagrangian animate: error: plots and animations need Matplotlib, a dependency of lagrangian that "
                   "is missing from this Python environment: install it with `python -m pip install matplotlib`, or "
                   "reinstall lagrangian (`python -m pip install -e .` in a clone)\n")


def test_cli_animate_needs_output(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["animate", "cart-pendulum"])
    assert exc.value.code == 2
    assert "the following arguments are required: --output/-o" in capsys.readouterr().err
