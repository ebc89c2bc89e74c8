"""The visual commands: animate."""

from __future__ import annotations

import argparse

from ..errors import ModelError
from ._common import MODEL_HELP, add_simulation_options, check_writable, option_number, run_simulation
from ._control import add_feedback_options, feedback_inputs


def register(sub, fmt) -> None:
    a = sub.add_parser("animate", help="simulate a model and write an animation of the mechanism (GIF, MP4, HTML)",
                       formatter_class=fmt, description="Simulate a model (the same options as `simulate`) and "
                       "draw the mechanism from its own geometry: particles, rigid bodies, rods, springs, dampers "
                       "and the ground. The format comes from the suffix of --output: .gif, .mp4 (needs ffmpeg) "
                       "or .html (a page with an HTML/JavaScript player). Models given by their energies only "
                       "have no geometry and cannot be drawn.",
                       epilog="Examples:\n  lagrangian animate cart-pendulum -o cart.gif\n"
                              "  lagrangian animate double-pendulum --t-end 10 --trace bob2 --fps 20 -o double.html\n"
                              "  lagrangian animate cart-pendulum --input \"F=1.5*sin(3*t)\" --speed 0.5 -o cart.mp4\n"
                              "  lagrangian animate whipple-bicycle -o bicycle.gif   (the view follows it)\n"
                              "  lagrangian animate cart-pendulum --lqr \"Q=q1=1,q2=10;R=F=1\" --at q2=pi/2 "
                              "--initial q2=1.4 -o held.gif")
    a.add_argument("model", help=MODEL_HELP)
    add_simulation_options(a)
    add_feedback_options(a)
    a.add_argument("--output", "-o", required=True, metavar="FILE",
                   help="the animation to write: FILE.gif, FILE.mp4 or FILE.html")
    a.add_argument("--fps", type=option_number("--fps", positive=True, maximum=1000, example="--fps 25"), default=25.0,
                   help="frames per second (default 25)")
    a.add_argument("--speed", type=option_number("--speed", positive=True, example="--speed 0.5"), default=1.0,
                   help="simulated seconds per second of animation (default 1; 0.5 plays at half speed)")
    a.add_argument("--trace", action="append", default=[], metavar="NAME",
                   help="draw the path of this point, particle or body (repeatable)")
    a.add_argument("--dpi", type=option_number("--dpi", minimum=10, maximum=1000, example="--dpi 80"), default=80.0,
                   help="resolution in dots per inch (default 80)")
    a.add_argument("--view", choices=("auto", "fixed", "follow"), default="auto",
                   help="fixed: one box holds the whole motion; follow: the view moves with the mechanism's "
                        "centre of mass; auto (default): follow when the motion reaches more than 3 times the "
                        "mechanism's own size (a bicycle riding away)")
    a.set_defaults(handler=_cmd_animate)


def _cmd_animate(args: argparse.Namespace) -> int:
    from ..io import load
    from ..plot._animation import animate, format_of
    from ..plot._figures import matplotlib_module
    from ..plot._geometry import check_drawable

    try:  # before the simulation: Matplotlib, a known format, and ffmpeg for .mp4
        matplotlib_module()
        format_of(args.output)
    except (ImportError, ValueError) as exc:
        raise ModelError(str(exc)) from None
    check_writable(args.output, "out.gif")
    check_drawable(load(args.model), args.trace)  # before the simulation, not after it
    feedback_inputs(args)  # --lqr, --controller: the law as --input, as simulate does
    _, _, traj = run_simulation(args)
    anim = animate(traj, fps=args.fps, speed=args.speed, trace=args.trace, dpi=args.dpi, view=args.view)
    anim.save(args.output)  # atomically, with the user's umask
    print(f"wrote {len(anim)} frames (t = {anim.times[0]:g} .. {anim.times[-1]:g} s, {args.fps:g} fps) "
          f"to {args.output}")
    return 0
