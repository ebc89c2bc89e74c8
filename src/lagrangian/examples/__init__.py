"""The model zoo: built-in examples, shared by the CLI, the tests, the docs and the benchmarks.

Fixed examples are TOML model files shipped beside this module. Three families are generated for
any size n: ``pendulum-chain-<n>`` (n point masses on massless links),
``spring-mass-damper-chain-<n>`` (n masses between two walls) and ``robot-arm-<n>`` (a serial arm
of n revolute joints in space, each link a rigid body in its own frame). Every generated text is
an ordinary model file, read by the same loader.
"""

from __future__ import annotations

import re
import tomllib
from importlib import resources

__all__ = ["example_names", "example_descriptions", "example_source", "pendulum_chain_toml",
           "spring_mass_damper_chain_toml", "robot_arm_toml", "ARM_AXES", "GENERATED"]

#: The generated families: pattern, name shown in listings, description.
GENERATED = {
    "pendulum-chain": "Chain of n point masses on massless links (pendulum-chain-<n>, any n >= 1, "
                      "e.g. pendulum-chain-5)",
    "spring-mass-damper-chain": "n masses in a row between two walls, joined by springs and dampers, force F on "
                                "the last (spring-mass-damper-chain-<n>, e.g. spring-mass-damper-chain-3)",
    "robot-arm": "Serial arm of n revolute joints in space (z, y, y, x, y, x, ...), each link a rigid body in its "
                 "own frame, a motor torque at each joint (robot-arm-<n>, e.g. robot-arm-3)",
}
_GENERATED = re.compile(r"(pendulum-chain|spring-mass-damper-chain|robot-arm)-([0-9]+)\Z")
_MAX_N = 200


def _files() -> dict[str, object]:
    root = resources.files(__name__)
    return {p.name[:-5]: p for p in root.iterdir() if p.name.endswith(".toml")}


def example_names() -> list[str]:
    """Names of the fixed examples, then the generated families as ``<family>-<n>``."""
    return sorted(_files()) + [f"{family}-<n>" for family in GENERATED]


def example_descriptions() -> dict[str, str]:
    """{name: one-line description} of every example (generated families as ``<family>-<n>``)."""
    out = {}
    for name, path in sorted(_files().items()):
        data = tomllib.loads(path.read_text())
        out[name] = data.get("description", "")
    for family, text in GENERATED.items():
        out[f"{family}-<n>"] = text
    return out


def example_source(name: str) -> str | None:
    """The model-file text of the example `name`, or None if there is no such example."""
    files = _files()
    if name in files:
        return files[name].read_text()
    m = _GENERATED.match(name)
    if m:
        n = int(m.group(2))
        if not 1 <= n <= _MAX_N:
            return None
        return {"pendulum-chain": pendulum_chain_toml, "spring-mass-damper-chain": spring_mass_damper_chain_toml,
                "robot-arm": robot_arm_toml}[m.group(1)](n)
    return None


def pendulum_chain_toml(n: int) -> str:
    """Model file of an n-link pendulum chain: point masses m at the ends of links of length l,
    angles theta1..thetan from the downward vertical."""
    lines = [f'name = "pendulum-chain-{n}"',
             f'description = "Chain of {n} point masses m on massless links of length l"',
             "coordinates = [" + ", ".join(f'"theta{i}"' for i in range(1, n + 1)) + "]",
             "", "[parameters]", "m = 1.0", "l = 1.0", "g = 9.81", "",
             "[[points]]", 'name = "pivot"', 'position = ["0", "0"]', ""]
    x, y = [], []
    for i in range(1, n + 1):
        x.append(f"l*sin(theta{i})")
        y.append(f"l*cos(theta{i})")
        lines += ["[[particles]]", f'name = "bob{i}"', 'mass = "m"',
                  f'position = ["{" + ".join(x)}", "-({" + ".join(y)})"]', ""]
    lines += ["[gravity]", 'g = "g"', "", "[simulation]", "t_end = 10.0", "dt = 0.01",
              "initial = { " + ", ".join(f"theta{i} = 0.5" for i in range(1, n + 1)) + " }"]
    return "\n".join(lines) + "\n"


def spring_mass_damper_chain_toml(n: int) -> str:
    """Model file of n masses m between two walls, joined by n + 1 springs k and dampers c,
    with a force input F on the last mass."""
    lines = [f'name = "spring-mass-damper-chain-{n}"',
             f'description = "{n} masses m between two walls, springs k and dampers c, force F on the last"',
             "coordinates = [" + ", ".join(f'"x{i}"' for i in range(1, n + 1)) + "]",
             'inputs = ["F"]', "", "[parameters]", "m = 1.0", "k = 100.0", "c = 0.5", ""]
    for i in range(1, n + 1):
        lines += ["[[particles]]", f'name = "mass{i}"', 'mass = "m"', f'position = ["x{i}", "0"]', ""]
    stretches = ["x1"] + [f"x{i + 1} - x{i}" for i in range(1, n)] + [f"-x{n}"]
    for i, s in enumerate(stretches, start=1):
        lines += ["[[springs]]", f'name = "spring{i}"', 'stiffness = "k"', f'length = "{s}"', ""]
        lines += ["[[dampers]]", f'name = "damper{i}"', 'coefficient = "c"', f'length = "{s}"', ""]
    lines += ["[[loads]]", 'name = "drive"', 'force = ["F", "0"]', f'at = "mass{n}"', "",
              "[simulation]", "t_end = 10.0", "dt = 0.01", 'initial = { x1 = 0.1 }']
    return "\n".join(lines) + "\n"


#: The axes of the joints of robot-arm-<n>, in turn (then y and x alternate): a base that turns
#: about the vertical, a shoulder and an elbow that pitch, a wrist that rolls, pitches and rolls.
ARM_AXES = ("z", "y", "y", "x", "y", "x")


def robot_arm_toml(n: int) -> str:
    """Model file of a serial arm of n revolute joints in space. Joint k turns the frame of link k
    about the axis ARM_AXES[k-1] of the frame of link k-1; the base column (link 1) stands
    vertically, height h; every other link lies along its frame's x axis, length l, its joint at
    the far end of the link before. Each link is a uniform rod of mass m and radius r (inertia
    m r^2/2 about its axis, m (3 r^2 + L^2)/12 across), under gravity along -z, with a motor
    torque tau<k> about its joint's axis (the reaction on the link before included)."""
    axes = [ARM_AXES[k] if k < len(ARM_AXES) else ("y", "x")[k % 2] for k in range(n)]
    lines = [f'name = "robot-arm-{n}"',
             f'description = "Serial arm of {n} revolute joints in space, joint axes {", ".join(axes)}"',
             "coordinates = [" + ", ".join(f'"q{k}"' for k in range(1, n + 1)) + "]",
             "inputs = [" + ", ".join(f'"tau{k}"' for k in range(1, n + 1)) + "]",
             "", "[parameters]", "m = 1.0", "h = 0.5", "l = 0.4", "r = 0.03", "g = 9.81", ""]
    for k in range(1, n + 1):
        parent = "world" if k == 1 else f"link{k - 1}"
        origin = '["0", "0", "0"]' if k == 1 else ('["0", "0", "h"]' if k == 2 else '["l", "0", "0"]')
        lines += ["[[frames]]", f'name = "link{k}"', f'parent = "{parent}"', f"origin = {origin}",
                  f'rotation = [["{axes[k - 1]}", "q{k}"]]', ""]
    for k in range(1, n + 1):
        if k == 1:  # the column, along z
            inertia, center = '["m*(3*r**2 + h**2)/12", "m*(3*r**2 + h**2)/12", "m*r**2/2"]', '["0", "0", "h/2"]'
        else:  # a link along x
            inertia, center = '["m*r**2/2", "m*(3*r**2 + l**2)/12", "m*(3*r**2 + l**2)/12"]', '["l/2", "0", "0"]'
        lines += ["[[bodies]]", f'name = "link{k}"', 'mass = "m"', f'frame = "link{k}"', f"inertia = {inertia}",
                  f"center = {center}", ""]
    tip = '["0", "0", "h"]' if n == 1 else '["l", "0", "0"]'
    lines += ["[[points]]", 'name = "base"', 'position = ["0", "0", "0"]', "",
              "[[points]]", 'name = "tip"', f'frame = "link{n}"', f"position = {tip}", "",
              "[gravity]", 'g = "g"', ""]
    for k in range(1, n + 1):
        axis = {"x": '["tau{k}", "0", "0"]', "y": '["0", "tau{k}", "0"]', "z": '["0", "0", "tau{k}"]'}[axes[k - 1]]
        lines += ["[[loads]]", f'name = "motor{k}"', f"torque = {axis.format(k=k)}", f'body = "link{k}"', ""]
        if k > 1:  # the reaction on the link before, about the same axis (written in link k's axes)
            reaction = axis.format(k=k).replace(f'"tau{k}"', f'"-tau{k}"')
            lines += ["[[loads]]", f'name = "reaction{k}"', f"torque = {reaction}", f'body = "link{k - 1}"',
                      f'frame = "link{k}"', ""]
    lines += ["[simulation]", "t_end = 5.0", "dt = 0.01",
              "initial = { " + ", ".join(f"q{k} = 0.3" for k in range(1, n + 1)) + " }"]
    return "\n".join(lines) + "\n"
