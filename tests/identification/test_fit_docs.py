"""docs/fit.md runs as shown: its model file, its Python blocks (in order, as one script) and the
table they print, and its command line."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "fit.md"


def blocks(lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", PAGE.read_text(), re.S | re.M)


@pytest.fixture
def folder(tmp_path, monkeypatch):
    (toml,) = blocks("toml")
    (tmp_path / "pendulum.toml").write_text(toml)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_python_blocks_print_the_table_shown(folder, capsys):
    script = "\n\n".join(blocks("python"))
    exec(compile(script, str(PAGE), "exec"), {"__name__": "__main__"})  # our own page, not user input
    printed = capsys.readouterr().out
    shown = blocks("text")[0]
    for line in shown.splitlines():
        assert line in printed, f"docs/fit.md shows {line!r}; the example prints:\n{printed}"


def test_command_line_shown(folder, capsys):
    from lagrangian.cli import main

    (command,) = blocks("bash")
    first, second = (part.split()[1:] for part in command.strip().split(" && "))
    assert main(first) == 0 and main(second) == 0
    out = capsys.readouterr().out
    assert "fit of pendulum: 1 experiment(s), 251 samples" in out and "(converged)" in out
