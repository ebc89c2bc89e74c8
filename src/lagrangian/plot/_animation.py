"""Animation of a mechanism, drawn from the model's own geometry (see :mod:`._geometry`).

Particles are dots whose area grows with their mass (blocks when they slide along a straight
track; a point that slides so, a massless cart, is an empty block), rigid bodies are disks of
radius equal to their radius of gyration sqrt(I/m) with a spoke that shows their rotation, rods
join the nodes at constant distance (hidden pivots included, so a cart's mast too), springs are
zigzags, dampers dashpots, fixed points stand on a hatched ground block.
Planar models are drawn in 2D, spatial ones in a 3D projection (Matplotlib's 3D axes, z up), where
a body in space shows its frame's axes (x red, y green, z blue, a fifth of the scene long: of the
nodes' reach and the disks' diameters), the link that carries it and its disk, if it has one.
"""

from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from .._codetext import plot_text
from ..errors import LagrangianError, ModelError
from ._figures import matplotlib_module
from ._geometry import AXIS_LENGTH, Scene, check_drawable, clip_line, ground_grid, scene_of

__all__ = ["Animation", "animate", "FORMATS", "AXIS_LENGTH"]

#: Output formats of :meth:`Animation.save`, by file suffix.
FORMATS = {".gif": "GIF (Pillow)", ".mp4": "MP4 (needs ffmpeg)", ".html": "HTML/JavaScript"}

#: What to do where ffmpeg is missing: one line, for the CLI's error and the API's ValueError.
MISSING_FFMPEG = ("MP4 needs ffmpeg, which is not installed (not on PATH): install it (Debian/Ubuntu: "
                  "`sudo apt-get install ffmpeg`; Fedora: `sudo dnf install ffmpeg`; macOS: `brew install ffmpeg`; "
                  "Windows: `winget install ffmpeg`; conda: `conda install -c conda-forge ffmpeg`), "
                  "or write a .gif or an .html animation instead")

_ROD = dict(color="0.25", lw=2.5, solid_capstyle="round", zorder=2)
_SPRING = dict(color="C0", lw=1.4, zorder=3)
_DAMPER = dict(color="C2", lw=1.4, zorder=3)
_AXIS_COLORS = {"x": "tab:red", "y": "tab:green", "z": "tab:blue"}


def format_of(path: str) -> str:
    """The suffix of `path` if it is a supported animation format; a ValueError that lists them otherwise."""
    suffix = os.path.splitext(str(path))[1].lower()
    if suffix not in FORMATS:
        raise ValueError(f"cannot write an animation to '{path}': unknown format '{suffix or '(no suffix)'}'; "
                         f"use a file name ending in {', '.join(FORMATS)}")
    if suffix == ".mp4" and not ffmpeg_available():
        raise ValueError(f"cannot write '{path}': {MISSING_FFMPEG}")
    return suffix


def _ffmpeg() -> str | None:
    """The ffmpeg program Matplotlib is set to use (rcParams["animation.ffmpeg_path"]), if it is on PATH."""
    import shutil

    return shutil.which(matplotlib_module().rcParams["animation.ffmpeg_path"])


def ffmpeg_available() -> bool:
    return _ffmpeg() is not None


def _frame_indices(t: np.ndarray, fps: float, speed: float) -> np.ndarray:
    """Indices of the samples nearest to t0, t0 + speed/fps, ... (each used once)."""
    if len(t) == 0:
        raise ModelError("the trajectory is empty: there is nothing to animate")
    step = speed / fps
    if len(t) > 1 and step <= np.min(np.diff(t)) / 2:  # every sample is nearest to one of the wanted times:
        return np.arange(len(t))                       # a frame each, without an array of them (speed 1e-9)
    wanted = t[0] + step * np.arange(int(np.floor((t[-1] - t[0]) / step * (1 + 1e-12))) + 1)
    idx = np.clip(np.searchsorted(t, wanted), 0, len(t) - 1)
    left = np.clip(idx - 1, 0, len(t) - 1)
    idx = np.where(np.abs(t[left] - wanted) <= np.abs(t[idx] - wanted), left, idx)
    return np.unique(idx)


def _zigzag(a, b, width, coils=7):
    """Points of a zigzag spring from a to b (arrays of shape (dim,))."""
    d = b - a
    length = np.linalg.norm(d)
    if length < 1e-12:
        return np.array([a, b])
    u = d / length
    n = _normal(u)
    s = np.concatenate(([0.0, 0.15], np.linspace(0.15, 0.85, 2 * coils + 1)[1:-1], [0.85, 1.0]))
    off = np.zeros_like(s)
    off[2:-2] = width * np.where(np.arange(len(s) - 4) % 2 == 0, 1.0, -1.0)
    return a + np.outer(s * length, u) + np.outer(off, n)


def _dashpot(a, b, width):
    """Polyline (NaN-separated parts) of a damper from a to b: a piston in an open cylinder."""
    d = b - a
    length = np.linalg.norm(d)
    if length < 1e-12:
        return np.array([a, b])
    u = d / length
    n = _normal(u)
    nan = np.full_like(a, np.nan)

    def p(s, o):
        return a + s * length * u + o * width * n

    return np.array([p(0, 0), p(0.5, 0), nan, p(0.5, -0.75), p(0.5, 0.75), nan,
                     p(0.3, 1), p(0.7, 1), p(0.7, -1), p(0.3, -1), nan, p(0.7, 0), p(1, 0)])


def _normal(u):
    if len(u) == 2:
        return np.array([-u[1], u[0]])
    other = np.array([0.0, 0.0, 1.0]) if abs(u[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    n = np.cross(u, other)
    return n / np.linalg.norm(n)


class Animation:
    """An animation of a trajectory, drawn from its model's geometry.

    Built by :func:`animate`. Display it in a notebook (it renders as HTML/JavaScript), or
    :meth:`save` it as GIF, MP4 or HTML.

    Attributes
    ----------
    figure : matplotlib.figure.Figure
    scene : Scene
        What is drawn and the functions that place it.
    frame_indices : ndarray of int, shape (F,)
        The trajectory sample shown in each frame.
    times : ndarray, shape (F,)
        The time of each frame.
    fps : float
    artists : dict of str to matplotlib artist
        The marker of each point, particle, body and pivot by name (``"rod i-j"``, ``"spring NAME"``,
        ``"damper NAME"``, ``"trace NAME"`` and ``"time"`` for the others; a body in space also has
        ``"NAME axis x"`` (y, z), ``"NAME link"`` and, with a disk, ``"NAME disk"``).
    axis_length : float
        The length of the axes drawn for bodies in space.
    framing : Framing
        The box shown at each frame (``framing.follow``: whether it moves with the mechanism).
    """

    def __init__(self, traj, scene: Scene, *, fps: float = 25.0, speed: float = 1.0, trace: Sequence[str] = (),
                 dpi: float = 80.0, figsize=None, title: str | None = None, view: str = "auto"):
        Figure = matplotlib_module("matplotlib.figure").Figure
        FigureCanvasAgg = matplotlib_module("matplotlib.backends.backend_agg").FigureCanvasAgg

        if not fps > 0 or not speed > 0:
            raise ModelError(f"fps and speed must be positive numbers, got fps={fps!r}, speed={speed!r}")
        self.scene = scene
        self.fps = float(fps)
        self.trajectory = traj
        self._all = scene.positions(traj.t, traj.q)  # (N, nodes, dim)
        self._angles = scene.angles(traj.t, traj.q)
        self.frame_indices = _frame_indices(traj.t, fps, speed)
        self.times = traj.t[self.frame_indices]
        self.trace = tuple(trace)
        self.figure = Figure(figsize=figsize or ((5.6, 5.0) if scene.dim == 3 else (6.0, 4.6)), dpi=dpi,
                             layout="constrained")
        FigureCanvasAgg(self.figure)
        self.artists: dict[str, object] = {}
        self._build(title, view)
        self.draw(0)
        if self.framing.follow:  # one layout for every frame: the axes' tick labels change as they move
            self.figure.canvas.draw()
            self.figure.set_layout_engine("none")

    # ----------------------------------------------------------------- build
    def _build(self, title, view):
        scene, P = self.scene, self._all
        framing, self.axis_length, self._spatial = scene.framed(self.trajectory.t, self.trajectory.q,
                                                                self.frame_indices, view)
        size = self._size = framing.size
        self.framing = framing
        masses = [nd.mass for nd in scene.nodes if nd.mass > 0]
        mmax = max(masses) if masses else 1.0
        self._radius = {}
        for i in scene.bodies:
            nd = scene.nodes[i]
            self._radius[i] = min(np.sqrt(nd.inertia / nd.mass), 0.1 * size) if nd.mass > 0 else 0.05 * size
        pad = 0.12 * size + max(self._radius.values(), default=0.0)
        if scene.dim == 3:
            from mpl_toolkits.mplot3d import Axes3D  # noqa: F401  (registers the projection)

            ax = self.figure.add_subplot(projection="3d")
            self._half = max(size, 2 * float(np.max(framing.half))) / 2 + pad  # a cube
            ax.set_box_aspect((1, 1, 1))
            ax.set_xlabel("x")
            ax.set_ylabel("y")
            ax.set_zlabel("z")
            self.artists["time"] = ax.text2D(0.02, 0.95, "", transform=ax.transAxes)
        else:
            ax = self.figure.add_subplot()
            self._half = framing.half + pad
            ax.set_aspect("equal")
            ax.set_xlabel("x")
            ax.set_ylabel("y")
            ax.grid(True, alpha=0.2)
            self.artists["time"] = ax.text(0.02, 0.95, "", transform=ax.transAxes, va="top")
        self.axes = ax
        self._set_box(0)
        if title is not None:
            ax.set_title(plot_text(title))
        empty = [[] for _ in range(scene.dim)]
        # tracks and ground (static, unless a 3D view follows: then clipped to the box at each frame)
        for k, (point, direction) in enumerate(scene.tracks):
            if framing.follow and scene.dim == 3:
                self.artists[f"track {k}"] = ax.plot(*empty, color="0.6", lw=1.2, zorder=1)[0]
                continue
            s = (P.reshape(-1, scene.dim) - point) @ direction
            a = point + (s.min() - 0.15 * size) * direction
            b = point + (s.max() + 0.15 * size) * direction
            ax.plot(*np.array([a, b]).T, color="0.6", lw=1.2, zorder=1)
        if scene.ground:
            self.artists["ground"] = ax.plot(*empty, color="0.55", lw=0.8, zorder=0)[0]
        if scene.dim == 2:
            from matplotlib.patches import Rectangle

            g = 0.07 * size
            for i, nd in enumerate(scene.nodes):
                if nd.fixed:
                    x, y = P[0, i]
                    ax.add_patch(Rectangle((x - g / 2, y - g / 2), g, g, hatch="////", fill=False, lw=0.8,
                                           edgecolor="0.4", zorder=1))
        for i, j in scene.rods:
            self.artists[f"rod {scene.nodes[i].name}-{scene.nodes[j].name}"] = ax.plot(*empty, **_ROD)[0]
        for name, _, _ in scene.springs:
            self.artists[f"spring {name}"] = ax.plot(*empty, **_SPRING)[0]
        for name, _, _ in scene.dampers:
            self.artists[f"damper {name}"] = ax.plot(*empty, **_DAMPER)[0]
        for k, name in enumerate(self.trace):
            self.artists[f"trace {name}"] = ax.plot(*empty, lw=1, alpha=0.7, color=f"C{(k + 4) % 10}",
                                                    zorder=1)[0]
        self._outlines = scene.visual_outlines(self.trajectory.t[self.frame_indices],
                                               self.trajectory.q[self.frame_indices])
        for j, label in enumerate(scene.visuals):  # a URDF's visual shapes
            self.artists[f"visual {j} {label}"] = ax.plot(*empty, color="C7", lw=1.0, zorder=3)[0]
        for body in scene.spatial:
            if body.link > 1:
                self.artists[f"{body.name} link"] = ax.plot(*empty, **_ROD)[0]
            if body.radius is not None:
                self.artists[f"{body.name} disk"] = ax.plot(*empty, color="C1", lw=1.8, zorder=4)[0]
            for axis, color in _AXIS_COLORS.items():
                self.artists[f"{body.name} axis {axis}"] = ax.plot(*empty, color=color, lw=2, zorder=5)[0]
        for i, nd in enumerate(scene.nodes):
            if nd.kind == "end":
                continue
            if nd.kind == "body" and scene.dim == 2:
                from matplotlib.patches import Circle

                disk = Circle((0, 0), self._radius[i], facecolor="C1", alpha=0.45, edgecolor="C1", zorder=4)
                ax.add_patch(disk)
                self.artists[f"{nd.name} disk"] = disk
                self.artists[f"{nd.name} spoke"] = ax.plot([], [], color="C1", lw=1.5, zorder=5)[0]
            if nd.kind in ("particle", "body"):
                ms = 7 + 13 * np.sqrt(nd.mass / mmax) if mmax > 0 else 10
                style = dict(marker="s" if nd.slider else "o", markersize=ms * (1.6 if nd.slider else 1),
                             color="C1" if nd.kind == "body" else "C3", markeredgecolor="k", zorder=6)
            elif nd.slider:  # a massless cart or slider: an empty block
                style = dict(marker="s", markersize=16, color="w", markeredgecolor="k", zorder=6)
            else:  # points and hidden pivots: pins
                style = dict(marker="o", markersize=6, color="w", markeredgecolor="k", zorder=7)
            self.artists[nd.name] = ax.plot(*empty, linestyle="none", **style)[0]

    def _box(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The corners of what frame `k` shows: the framing's box, padded (a cube in 3D)."""
        centre = self.framing.centre[k]
        return centre - self._half, centre + self._half

    def _set_box(self, k: int) -> None:
        lo, hi = self._box(k)
        self.axes.set_xlim(lo[0], hi[0])
        self.axes.set_ylim(lo[1], hi[1])
        if self.scene.dim == 3:
            self.axes.set_zlim(lo[2], hi[2])

    # ------------------------------------------------------------------ draw
    def positions(self, k: int) -> dict[str, np.ndarray]:
        """Where each node is drawn in frame `k`: {name: position, shape (dim,)}."""
        p = self._all[self.frame_indices[k]]
        return {nd.name: p[i].copy() for i, nd in enumerate(self.scene.nodes)}

    def draw(self, k: int) -> list:
        """Place every artist for frame `k`; returns the artists that changed."""
        scene = self.scene
        idx = self.frame_indices[k]
        p = self._all[idx]
        changed = []
        follow3 = self.framing.follow and scene.dim == 3  # Matplotlib's 3D axes do not clip: we do
        if self.framing.follow:
            self._set_box(k)

        def put(artist, points):
            points = np.asarray(points, dtype=float)
            if scene.dim == 3:
                artist.set_data_3d(points[:, 0], points[:, 1], points[:, 2])
            else:
                artist.set_data(points[:, 0], points[:, 1])
            changed.append(artist)

        for i, j in scene.rods:
            put(self.artists[f"rod {scene.nodes[i].name}-{scene.nodes[j].name}"], [p[i], p[j]])
        width = 0.04 * self._size
        for name, i, j in scene.springs:
            put(self.artists[f"spring {name}"], _zigzag(p[i], p[j], width))
        for name, i, j in scene.dampers:
            put(self.artists[f"damper {name}"], _dashpot(p[i], p[j], width))
        if scene.ground and (k == 0 or self.framing.follow):
            put(self.artists["ground"], ground_grid(*self._box(k)))
        if follow3:
            for j, (point, direction) in enumerate(scene.tracks):
                ends = clip_line(point, direction, *self._box(k))
                put(self.artists[f"track {j}"], ends if ends is not None else np.empty((0, 3)))
        for name in self.trace:
            path = self._all[: idx + 1, scene.index(name)]
            if follow3:
                lo, hi = self._box(k)
                path = np.where(np.all((path >= lo) & (path <= hi), axis=1)[:, None], path, np.nan)
            put(self.artists[f"trace {name}"], path)
        for b, i in enumerate(scene.bodies):
            if scene.dim == 2:
                nd = scene.nodes[i]
                disk = self.artists[f"{nd.name} disk"]
                disk.set_center(tuple(p[i]))
                a = self._angles[idx, b]
                r = self._radius[i]
                put(self.artists[f"{nd.name} spoke"], [p[i], p[i] + r * np.array([np.cos(a), np.sin(a)])])
                changed.append(disk)
        for j, (label, outline) in enumerate(zip(scene.visuals, self._outlines)):
            put(self.artists[f"visual {j} {label}"], outline[k])
        for body, drawing in zip(scene.spatial, self._spatial):
            if body.link > 1:
                put(self.artists[f"{body.name} link"], drawing.link[k])
            if drawing.disk is not None:
                put(self.artists[f"{body.name} disk"], np.vstack([drawing.disk[k], drawing.disk[k][:1]]))
            for i, axis in enumerate(_AXIS_COLORS):
                put(self.artists[f"{body.name} axis {axis}"], drawing.axes[k, i])
        for i, nd in enumerate(scene.nodes):
            if nd.kind != "end":
                put(self.artists[nd.name], p[i][None, :])
        self.artists["time"].set_text(f"t = {self.times[k]:.2f} s")
        changed.append(self.artists["time"])
        return changed

    # ---------------------------------------------------------------- output
    def frames(self):
        """Yield each frame as an RGBA image, ndarray of shape (height, width, 4), uint8.

        The static parts (axes, ground, tracks) are drawn once; each frame redraws only the moving
        artists over that background (blitting). When the view follows the mechanism, the axes
        move, and each frame is drawn whole (in the layout of the first).
        """
        canvas = self.figure.canvas
        if self.framing.follow:
            try:
                for k in range(len(self.times)):
                    self.draw(k)
                    canvas.draw()
                    yield np.asarray(canvas.buffer_rgba()).copy()
            finally:
                self.draw(0)
            return
        moving = sorted(self._moving(), key=lambda a: a.get_zorder())
        for a in moving:
            a.set_animated(True)
        try:
            self.draw(0)
            canvas.draw()
            self.figure.set_layout_engine("none")  # keep the layout computed once
            background = canvas.copy_from_bbox(self.figure.bbox)
            for k in range(len(self.times)):
                canvas.restore_region(background)
                self.draw(k)
                for a in moving:
                    self.axes.draw_artist(a)
                yield np.asarray(canvas.buffer_rgba()).copy()
        finally:
            for a in moving:
                a.set_animated(False)
            self.draw(0)

    def _moving(self) -> list:
        return [a for name, a in self.artists.items()]

    def _png_frames(self) -> list[bytes]:
        from PIL import Image
        import io

        out = []
        for rgba in self.frames():
            buf = io.BytesIO()
            Image.fromarray(rgba).convert("RGB").save(buf, format="PNG")
            out.append(buf.getvalue())
        return out

    def to_html(self) -> str:
        """The animation as an HTML/JavaScript player (frames embedded as PNG), for notebooks and the web."""
        import base64
        import json
        import uuid

        frames = ["data:image/png;base64," + base64.b64encode(png).decode("ascii") for png in self._png_frames()]
        uid = "lg" + uuid.uuid4().hex[:12]
        times = [f"{t:.3f}" for t in self.times]
        return _PLAYER.format(uid=uid, frames=json.dumps(frames), times=json.dumps(times), count=len(frames),
                              last=len(frames) - 1, interval=1000.0 / self.fps, first=frames[0])

    def _repr_html_(self) -> str:
        return self.to_html()

    def save(self, path: str | os.PathLike, *, dpi: float | None = None) -> None:
        """Write the animation: ``.gif`` (Pillow), ``.mp4`` (needs ffmpeg) or ``.html`` (a standalone page),
        atomically (a temporary file beside `path`, created with the user's umask, then renamed to it);
        a symbolic link to a file at `path` is refused, and a FIFO or a device (/dev/null) is written to
        directly.

        Raises
        ------
        ValueError
            Another suffix, or .mp4 without ffmpeg.
        OutputFileError
            `path` is a folder, a link, or in a folder that does not exist.
        """
        from ..io._files import check_output, is_stream, replacing

        path = os.fspath(path)
        suffix = format_of(path)
        check_output(path, "Animation.save", "out.gif")
        if dpi is not None:
            self.figure.set_dpi(dpi)
        if is_stream(path):
            self._write(path, suffix, path)
            return
        with replacing(path) as tmp:
            self._write(tmp, suffix, path)

    def _write(self, path: str, suffix: str, shown: str) -> None:
        """Write the file `path` (a temporary one) for the user's `shown` (named in errors)."""
        if suffix == ".html":
            import html

            title = html.escape(str(getattr(self.trajectory.model, "name", "animation")))
            page = (f"<!DOCTYPE html>\n<html>\n<head><meta charset=\"utf-8\"><title>{title}</title></head>\n"
                    f"<body>\n{self.to_html()}\n</body>\n</html>\n")
            with open(path, "w", encoding="utf-8") as fh:
                fh.write(page)
        elif suffix == ".gif":
            from PIL import Image

            # a 64-colour palette per frame: the drawing has few colours, and the file stays small. An
            # octree keeps the thin coloured lines (a body's axes) that median cut merges into the greys
            # of a 3D scene's grid; its files are smaller too
            images = [Image.fromarray(rgba).convert("RGB").quantize(64, method=Image.Quantize.FASTOCTREE)
                      for rgba in self.frames()]
            images[0].save(path, format="GIF", save_all=True, append_images=images[1:], loop=0,
                           duration=int(round(1000.0 / self.fps)), optimize=False)
        else:
            self._save_mp4(path, shown)

    def _save_mp4(self, path: str, shown: str | None = None) -> None:
        """Pipe the blitted frames (raw RGBA) to ffmpeg, which encodes them as H.264 in an MP4 file."""
        import subprocess

        frames = self.frames()
        first = next(frames)
        height, width = first.shape[:2]
        cmd = [_ffmpeg() or "ffmpeg", "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgba",
               "-s", f"{width}x{height}", "-r", f"{self.fps:g}", "-i", "-",
               "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",  # H.264 in yuv420p needs even sides
               "-c:v", matplotlib_module().rcParams["animation.codec"], "-pix_fmt", "yuv420p", path]
        with subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE) as proc:
            try:
                proc.stdin.write(first.tobytes())
                for rgba in frames:
                    proc.stdin.write(rgba.tobytes())
            except BrokenPipeError:  # ffmpeg stopped early: its message says why
                pass
            finally:
                frames.close()
                try:
                    proc.stdin.close()
                except BrokenPipeError:
                    pass
            message = proc.stderr.read().decode(errors="replace").strip()
        if proc.returncode != 0:
            last = message.splitlines()[-1] if message else f"exit status {proc.returncode}"
            if shown is not None:
                last = last.replace(path, shown)
            raise LagrangianError(f"ffmpeg could not write '{shown or path}': {last}")

    def save_frame(self, path: str | os.PathLike, k: int = 0, *, dpi: float | None = None) -> None:
        """Write frame `k` as a still image (PNG, SVG, PDF... by suffix), atomically and with the
        user's umask (see :meth:`save`)."""
        from ..io._files import check_output, replacing

        path = os.fspath(path)
        check_output(path, "Animation.save_frame", "frame.png")
        self.draw(k)
        suffix = os.path.splitext(path)[1][1:].lower() or None
        with replacing(path) as tmp:
            self.figure.savefig(tmp, dpi=dpi or self.figure.dpi, format=suffix)

    def __len__(self) -> int:
        return len(self.times)

    def __repr__(self) -> str:
        name = getattr(self.trajectory.model, "name", "?")
        return (f"<Animation of {name!r}: {len(self.times)} frames at {self.fps:g} fps, "
                f"t = {self.times[0]:g} .. {self.times[-1]:g} s>")


def animate(traj, *, model=None, fps: float = 25.0, speed: float = 1.0, trace: Sequence[str] | str = (),
            dpi: float = 80.0, figsize=None, title: str | None = None, view: str = "auto") -> Animation:
    """Animate a trajectory with its model's geometry.

    Parameters
    ----------
    traj : Trajectory
    model : Model, optional
        The model to draw (default: the one the trajectory was simulated from, ``traj.model``).
    fps : float
        Frames per second of the output.
    speed : float
        Simulated seconds per second of animation (2 plays twice as fast).
    trace : str or sequence of str
        Names of points, particles or bodies whose path is drawn.
    dpi : float
    figsize : (float, float), optional
    title : str, optional
        Default: the model's name.
    view : {"auto", "fixed", "follow"}
        "fixed": one box holds the whole motion; "follow": the box moves with the mechanism's centre
        of mass, sized to the mechanism; "auto" (default) follows when the motion reaches more than
        FOLLOW_RATIO (3) times the mechanism's own size, such as a bicycle riding away.

    Returns
    -------
    Animation
        ``.save("out.gif")`` (or .mp4, .html), ``.to_html()``; shown inline in notebooks.

    Raises
    ------
    ModelError
        The model has no geometry (only energies), a traced name is unknown, fps/speed is not positive,
        or `view` is not one of auto, fixed, follow.
    """
    model = model if model is not None else getattr(traj, "model", None)
    if model is None:
        raise ModelError("this trajectory does not carry its model, so it cannot be drawn: pass model=... "
                         "(the Model it was simulated from)")
    trace = (trace,) if isinstance(trace, str) else tuple(trace)
    check_drawable(model, trace)
    scene = scene_of(model, traj.parameters)
    return Animation(traj, scene, fps=fps, speed=speed, trace=trace, dpi=dpi, figsize=figsize,
                     title=model.name if title is None else title, view=view)


_PLAYER = """<div id="{uid}" class="lagrangian-animation" style="display:inline-block">
<img id="{uid}-img" src="{first}" style="max-width:100%"><br>
<button id="{uid}-play" type="button">pause</button>
<input id="{uid}-slider" type="range" min="0" max="{last}" value="0" style="width:60%;vertical-align:middle">
<span id="{uid}-label">t = 0 s</span>
<script>
(function() {{
  var frames = {frames};
  var times = {times};
  var img = document.getElementById("{uid}-img");
  var slider = document.getElementById("{uid}-slider");
  var label = document.getElementById("{uid}-label");
  var button = document.getElementById("{uid}-play");
  var k = 0, timer = null;
  function show(i) {{ k = i; img.src = frames[i]; slider.value = i; label.textContent = "t = " + times[i] + " s"; }}
  function play() {{
    timer = setInterval(function() {{ show((k + 1) % {count}); }}, {interval});
    button.textContent = "pause";
  }}
  function pause() {{ clearInterval(timer); timer = null; button.textContent = "play"; }}
  button.onclick = function() {{ if (timer) pause(); else play(); }};
  slider.oninput = function() {{ pause(); show(parseInt(slider.value)); }};
  play();
}})();
</script>
</div>"""
