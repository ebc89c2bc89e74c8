"""Make the gallery: a still (PNG) and a short animation (GIF) of every built-in example that has a
geometry, and docs/gallery.md listing them all.

Run from the repository root:  python docs/gallery/make_gallery.py
The outputs are kept small (low dpi, low frame rate, a few seconds) because they are committed.
"""

from __future__ import annotations

import pathlib
import tomllib

import matplotlib

matplotlib.use("Agg")

import lagrangian as lg
from lagrangian.examples import example_names, example_source
from lagrangian.plot._geometry import drawable_names

HERE = pathlib.Path(__file__).resolve().parent
PAGE = HERE.parent / "gallery.md"
SECONDS, FPS, DPI = 4.0, 8, 50


def main() -> None:
    names = [n for n in example_names() if "<n>" not in n] + ["pendulum-chain-3", "spring-mass-damper-chain-3",
                                                               "robot-arm-3"]
    lines = ["# Gallery", "",
             "Every built-in example, simulated from its model file's `[simulation]` settings for "
             f"{SECONDS:g} s and drawn from its own geometry by the command under it. "
             "Examples written with their energies only have no geometry to draw; their element form is "
             "shown instead. Regenerate with `python docs/gallery/make_gallery.py`.", ""]
    for name in names:
        model = lg.load(name)
        data = tomllib.loads(example_source(name))
        lines += [f"## {name}", "", data.get("description", ""), ""]
        if not drawable_names(model):
            twin = name.removesuffix("-energy")
            lines += [f"Given by its energies T*, V, D only: no geometry to draw"
                      + (f"; see [{twin}](#{twin}) for the same system built from elements." if twin != name else "."),
                      ""]
            continue
        note = ""
        t_end = min(SECONDS, model.simulation.get("t_end", SECONDS))
        try:
            traj = lg.simulate(model, t_end=t_end)
        except lg.SingularMassMatrixError as exc:  # the massless cart: shown up to the singularity
            t_end = float(f"{0.98 * exc.time:.3g}")
            traj = lg.simulate(model, t_end=t_end)
            note = (f"The simulation stops at t = {exc.time:.3g} s, where the mass matrix becomes singular "
                    "(`lagrangian check " + name + "` explains why); the animation ends just before.")
        trace = [n for n in drawable_names(model) if n in ("pendulum", "bob", "bob2", "bob3", "disk", "mass")][:1]
        anim = traj.animate(fps=FPS, dpi=DPI, trace=trace)
        anim.save(HERE / f"{name}.gif")
        anim.save_frame(HERE / f"{name}.png", len(anim) // 3)
        cmd = (f"lagrangian animate {name} --t-end {t_end:g} --fps {FPS} --dpi {DPI}"
               + "".join(f" --trace {t}" for t in trace) + f" -o {name}.gif")
        lines += [f"![{name}](gallery/{name}.png) ![{name} animation](gallery/{name}.gif)", "",
                  f"```bash\n{cmd}\n```", ""] + ([note, ""] if note else [])
        print(f"{name}: {len(anim)} frames")
    PAGE.write_text("\n".join(lines).rstrip() + "\n")
    print(f"wrote {PAGE}")


if __name__ == "__main__":
    main()
