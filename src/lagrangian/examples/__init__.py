"""The model zoo: built-in examples, shared by the CLI, the tests, the docs and the benchmarks.

Fixed examples are TOML model files shipped beside this module. Two families are generated for
any size n: ``pendulum-chain-<n>`` (n point masses on massless links) and
``spring-mass-damper-chain-<n>`` (n masses between two walls). Every generated text is an
ordinary model file, read by the same loader.
"""

from __future__ import annotations

import re
import tomllib
from importlib import resources

__all__ = ["example_names", "example_descriptions", "example_source", "pendulum_chain_toml",
           "spring_mass_damper_chain_toml", "GENERATED"]

#: The generated families: pattern, name shown in listings, description.
GENERATED = {
    "pendulum-chain": "Chain of n point masses on massless links (pendulum-chain-<n>, any n >= 1, e.g. pendulum-chain-5)",
    "spring-mass-damper-chain": "n masses in a row between two walls, joined by springs and dampers, force F on "
                                "the last (spring-mass-damper-chain-<n>, e.g. spring-mass-damper-chain-3)",
}
_GENERATED = re.compile(r"(pendulum-chain|spring-mass-damper-chain)-([0-9]+)\Z")
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
        return (pendulum_chain_toml if m.group(1) == "pendulum-chain" else spring_mass_damper_chain_toml)(n)
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
