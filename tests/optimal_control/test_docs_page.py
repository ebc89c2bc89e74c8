"""docs/optimal-control.md does what it says: its Python block runs, its model file and commands give
the printed transcript."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytest.importorskip("casadi", reason="optimal motions need CasADi (the 'optimal' extra)")

from lagrangian.cli import main  # noqa: E402

PAGE = Path(__file__).resolve().parents[2] / "docs" / "optimal-control.md"


def blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", PAGE.read_text(), re.S)


def test_python_block_runs():
    (block,) = blocks("python")
    exec(compile(block, str(PAGE), "exec"), {})  # our own docs page, not user input


@pytest.mark.slow
def test_cart_pole_commands_print_the_transcript(tmp_path, monkeypatch, capsys):
    (toml,) = blocks("toml")
    monkeypatch.chdir(tmp_path)
    Path("cart-pole.toml").write_text(toml)
    assert main(["optimize", "cart-pole.toml", "-o", "motion.csv", "--input-law", "law.csv"]) == 0
    out = capsys.readouterr().out
    shown = next(b for b in blocks("text") if b.startswith("optimal motion of cart-pole"))
    for line in ("cost 58.8076", "mesh: 112 intervals", "replay by simulate: largest deviation"):
        assert line in out and line in shown, line
    assert main(["simulate", "cart-pole.toml", "--input", "F=@law.csv:F", "--t-end", "2", "-o", "replay.csv"]) == 0
    last = Path("replay.csv").read_text().splitlines()[-1].split(",")
    assert float(last[1]) == pytest.approx(1.0, abs=1e-3) and float(last[2]) == pytest.approx(3.14159, abs=3e-3)
