"""The command line freezes the objects a command leaves when the process exits (gc.freeze, once per
process), so that the collections at shutdown do not walk them (issue 22: 0.5 s of the bicycle's
report); the exit handlers still run and the output is complete."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import lagrangian.cli as cli


def _env():
    return {**os.environ, "PYTHONHASHSEED": "0"}


def test_registered_once_per_process(monkeypatch):
    calls = []
    monkeypatch.setattr(cli, "_FREEZE_REGISTERED", False)
    monkeypatch.setattr("atexit.register", lambda f, *a, **k: calls.append(f))
    assert cli.main(["examples"]) == 0
    assert cli.main(["examples"]) == 0
    import gc

    assert calls == [gc.freeze]


def test_at_exit_the_objects_are_frozen_and_the_other_handlers_run(tmp_path):
    script = textwrap.dedent("""
        import atexit, gc, sys
        atexit.register(lambda: print("frozen at exit:", gc.get_freeze_count() > 0, flush=True))
        from lagrangian.cli import main
        status = main(["derive", "cart-pendulum", "--json"])
        print("status", status, flush=True)
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=_env(), timeout=300)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[-2:] == ["status 0", "frozen at exit: True"]
    json.loads("\n".join(lines[:-2]))  # the command's whole output, before the exit


def test_a_piped_output_is_complete():
    out = subprocess.run([sys.executable, "-m", "lagrangian", "derive", "double-pendulum", "--json"],
                         capture_output=True, text=True, env=_env(), timeout=300)
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data


def test_the_young_generation_is_collected_less_often_and_a_higher_setting_kept():
    script = textwrap.dedent("""
        import gc, sys
        from lagrangian.cli import main
        assert gc.get_threshold() == (700, 10, 10), gc.get_threshold()
        main(["examples"])
        print(gc.get_threshold(), flush=True)
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=_env(), timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == f"({cli._GEN0}, 10, 10)"
    higher = script.replace("from lagrangian.cli import main",
                            "gc.set_threshold(50000, 5, 5)\nfrom lagrangian.cli import main")
    higher = higher.replace("assert gc.get_threshold() == (700, 10, 10), gc.get_threshold()", "")
    out = subprocess.run([sys.executable, "-c", higher], capture_output=True, text=True, env=_env(), timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "(50000, 5, 5)"
