"""The package's layers point down: no module imports one of a higher layer.

Every ``import`` and ``from ... import`` of every module under src/lagrangian is read with ast
(module level, inside functions and under ``if TYPE_CHECKING`` alike, since a lazy import is a
dependency too) and placed in this order, bottom to top:

0. ``errors``, ``_version``: the exceptions and the version, importing nothing of the package.
1. The floor: ``_limits`` (the bounds on numbers and sizes), ``_progress``, ``_codetext`` (names
   and text in generated code), ``examples`` (the model zoo's TOML text) and ``io._files`` (atomic,
   umask-respecting writes for every output).
2. ``_util``: did-you-mean, read-only arrays and the check of named values (by _limits' bounds).
3. ``model``: Model, symbols, elements, frames, and the expression language (``model._expr``: it
   is the model's language, so it is not in io/).
4. ``io`` (model files: TOML read into a Model; above model because it builds Models) and ``plot``
   (figures and animations of arrays and models; it imports nothing above model, so the results
   that draw themselves, ``Trajectory.plot`` and ``Continuation.plot``, call down into it).
5. ``equations``: derive, Equations, singularities, and the exact numbers of the symbolic forms
   (``equations._exact``).
6. ``numeric`` (compiled models, simulation, trajectories) and ``control`` (lqr, place: matrices in,
   a feedback law out; ``LinearModel.lqr`` calls down into it).
7. ``analysis``: equilibria, linearization, modes, steady motions, continuation.
7b. ``identification`` (fit: parameter identification and identifiability) and ``optimal_control``
   (optimal motions by direct collocation): optimization problems over the equations, the simulation
   (to replay an answer) and the analysis (the linearization along a motion); peers.
8. ``reporting`` and ``export``: documents and generated code from the layers below.
9. ``lagrangian`` itself: the public names, re-exported from the layers below.
10. ``serve``: the playground (it calls the library as the CLI does, never the CLI).
11. ``cli``: the command line, which also starts the playground.
12. ``lagrangian.__main__``: ``python -m lagrangian``, which runs the command line.

A module may import any module of its own package or of a lower layer; two packages of one layer
are peers and import neither each other. There are no deliberate exceptions (EXCEPTIONS is empty):
an arrow that must point up is listed there with its reason.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SOURCE = Path(__file__).resolve().parents[1] / "src" / "lagrangian"

LAYERS: tuple[tuple[str, ...], ...] = (
    ("lagrangian.errors", "lagrangian._version"),
    ("lagrangian._limits", "lagrangian._progress", "lagrangian._codetext", "lagrangian.examples",
     "lagrangian.io._files"),
    ("lagrangian._util",),
    ("lagrangian.model",),
    ("lagrangian.io", "lagrangian.plot"),
    ("lagrangian.equations",),
    ("lagrangian.numeric", "lagrangian.control"),
    ("lagrangian.analysis",),
    ("lagrangian.identification", "lagrangian.optimal_control"),
    ("lagrangian.reporting", "lagrangian.export"),
    ("lagrangian",),
    ("lagrangian.serve",),
    ("lagrangian.cli",),
    ("lagrangian.__main__",),
)

#: (importing module, imported module): the reason the arrow points up. None today.
EXCEPTIONS: dict[tuple[str, str], str] = {}


def module_name(path: Path, root: Path = SOURCE) -> str:
    """lagrangian.numeric._simulate for src/lagrangian/numeric/_simulate.py."""
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_module(name: str, root: Path) -> bool:
    where = root.parent.joinpath(*name.split("."))
    return where.with_suffix(".py").is_file() or (where / "__init__.py").is_file()


def imports(path: Path, root: Path = SOURCE) -> list[tuple[str, int]]:
    """The package's modules that the file at `path` imports, with the line of each import: relative
    imports resolved, and ``from package import submodule`` read as the submodule."""
    name = module_name(path, root)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            found += [(a.name, node.lineno) for a in node.names if a.name.split(".")[0] == "lagrangian"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "lagrangian":
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                found.append((sub if _is_module(sub, root) else target, node.lineno))
    return found


def layer(module: str) -> int:
    """The index in LAYERS of the longest entry that `module` is or lies under."""
    best, index = "", None
    for i, names in enumerate(LAYERS):
        for entry in names:
            if (module == entry or module.startswith(entry + ".")) and len(entry) > len(best):
                best, index = entry, i
    if index is None:
        raise KeyError(module)
    return index


def _package(module: str) -> str:
    """The LAYERS entry `module` belongs to (its package, for the peers' rule)."""
    entries = [e for names in LAYERS for e in names if module == e or module.startswith(e + ".")]
    return max(entries, key=len)


def upward_arrows(root: Path = SOURCE) -> list[str]:
    """Every import under `root` that points to a higher layer or to a peer package of the same
    layer, as 'importer:line -> imported', less the EXCEPTIONS."""
    arrows = []
    for path in sorted(root.rglob("*.py")):
        source = module_name(path, root)
        for target, line in imports(path, root):
            if _package(source) == _package(target) or (source, target) in EXCEPTIONS:
                continue
            if layer(target) >= layer(source):
                arrows.append(f"{source}:{line} -> {target}")
    return arrows


def test_every_module_has_a_layer():
    unplaced = []
    for path in sorted(SOURCE.rglob("*.py")):
        for module in [module_name(path)] + [t for t, _ in imports(path)]:
            try:
                layer(module)
            except KeyError:
                unplaced.append(module)
    assert not unplaced, f"modules in no layer (add them to LAYERS in tests/test_layers.py): {sorted(set(unplaced))}"


def test_no_import_points_up():
    arrows = upward_arrows()
    assert not arrows, "imports that point up the layers (see the order in tests/test_layers.py):\n" + "\n".join(arrows)


def test_the_exceptions_are_still_needed():
    present = set()
    for path in sorted(SOURCE.rglob("*.py")):
        present |= {(module_name(path), t) for t, _ in imports(path)}
    assert not set(EXCEPTIONS) - present, "EXCEPTIONS lists imports that no longer exist: remove them"


@pytest.mark.parametrize("text, expected", [
    ("from ..io._files import replacing", ["lagrangian.io._files"]),
    ("from .. import derive, plot", ["lagrangian", "lagrangian.plot"]),
    ("from . import _tasks", ["lagrangian.serve._tasks"]),
    ("import lagrangian.numeric._simulate as s", ["lagrangian.numeric._simulate"]),
    ("def f():\n    from ..cli._common import number\n", ["lagrangian.cli._common"]),
])
def test_imports_are_resolved(tmp_path, text, expected):
    """The reader itself: relative imports, submodules named in a from-import, and imports inside
    functions are all seen (a test of the test, so that an empty answer cannot pass silently)."""
    root = tmp_path / "lagrangian"
    for name in ("serve", "io", "numeric", "cli", "plot"):
        (root / name).mkdir(parents=True)
        (root / name / "__init__.py").write_text("")
    (root / "__init__.py").write_text("")
    for module in ("io/_files", "numeric/_simulate", "cli/_common", "serve/_tasks"):
        (root / f"{module}.py").write_text("")
    path = root / "serve" / "_app.py"
    path.write_text(text)
    assert [t for t, _ in imports(path, root)] == expected


def test_an_upward_import_is_found(tmp_path):
    root = tmp_path / "lagrangian"
    for name in ("model", "io"):
        (root / name).mkdir(parents=True)
        (root / name / "__init__.py").write_text("")
    (root / "__init__.py").write_text("")
    (root / "io" / "_expr.py").write_text("")
    (root / "model" / "_model.py").write_text("def f():\n    from ..io._expr import parse_expression\n")
    assert upward_arrows(root) == ["lagrangian.model._model:2 -> lagrangian.io._expr"]
