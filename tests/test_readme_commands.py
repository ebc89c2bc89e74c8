"""Every command the README and the docs show works on the default install.

A fresh virtual environment (no system site packages) gets only the README's first command,
`python -m pip install -e .`, run in the repository. Then every shell command of README.md and
docs/*.md runs in it, each in a new folder that holds the model files its page writes (a ```toml
block whose file name, such as `cart.toml`, the text just before it gives), and must end with
status 0 and no traceback (its compile cache starts as a copy of this machine's, so that the
commands do not compile again what the other tests compiled). The commands are read from the pages
when the tests are collected, so a command added to a page is run without touching this file:

* the lines of ```bash (and ```sh, ```shell) blocks;
* in other blocks (```console, ```text, plain ```), the lines after a `$ ` prompt, or, without a
  prompt, the lines that start with `lagrangian` or `python` (not `lagrangian X: ...`, an error
  message shown as output). A transcript whose output starts with `lagrangian X: error:` shows a
  failure: that command must fail so, without a traceback;
* each page's ```python blocks, in order, as one script (the README's as well as the docs').

`lagrangian serve` runs until Ctrl-C: each one shown runs with `--no-browser --port 0`, gets SIGINT
(Ctrl-C) after SERVE_SECONDS, and must have printed its address and stopped cleanly (the playground's
own tests, tests/serve/test_serve_*.py, drive the real server and page).

A command that writes an .mp4 needs ffmpeg: it must succeed where ffmpeg is installed, and each is
also run with ffmpeg off PATH, where it must exit 2 with one line that says how to install it.

The commands not run, and why, are listed below (EXCLUDED, EXCLUDED_PYTHON), with what is changed
before a command runs (REPLACED, STAND_INS); the default install, `python -m pip install -e .`
wherever a page shows it, is the one this module's fixture runs. Where pip cannot reach a package
index the default install cannot be made, and these tests are skipped, saying so.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_INSTALL = "python -m pip install -e ."

#: Shell commands shown in the pages and not run here, with the reason.
EXCLUDED = {
    'python -m pip install -e ".[test]" && python -m pytest':
        "installs the test extra and runs the whole test suite, this test included",
    "python benchmarks/bench.py":
        "the benchmark: minutes of timing runs against the peers, a measurement rather than an example",
    "python benchmarks/serve_load.py --requests 1000 --concurrency 400":
        "the playground's load test: a measurement (1000 requests against a server of its own), not an example",
    "lagrangian optimize cart-pole.toml -o motion.csv --input-law law.csv":
        "CasADi is the optional `optimal` extra (tests/optimal_control/test_docs_page.py runs the page's commands)",
    "lagrangian simulate cart-pole.toml --input F=@law.csv:F --t-end 2 -o replay.csv":
        "replays law.csv, which `lagrangian optimize` (the optional `optimal` extra) writes",
    "lagrangian animate cart-pole.toml --input F=@law.csv:F --t-end 2 -o swing-up.gif":
        "animates law.csv, which `lagrangian optimize` (the optional `optimal` extra) writes",
}

#: Lines of the pages' Python blocks not run here (they need an optional extra), with the reason.
#: The first line of a block excludes the whole block.
EXCLUDED_PYTHON = {
    "sys = lin.to_control()": "python-control is the optional `control` extra",
    "from dask.distributed import Client": "Dask is the optional `dask` extra (the whole block uses its client)",
    "from lagrangian import optimal_motion":
        "CasADi is the optional `optimal` extra (tests/optimal_control/test_docs_page.py runs the block)",
    "from fmpy import simulate_fmu":
        "fmpy is the optional `fmu` extra (tests/export/test_export.py runs the FMUs with it)",
}

#: Text of a shell command replaced before it runs, with the reason.
REPLACED = {
    "| less": ("| cat", "less pages output on a terminal; here the output is read through cat (less may be missing)"),
}

#: Files a command names that no block of its page writes: a stand-in from another page.
STAND_INS = {
    "my_model.toml": ("README.md", "cart.toml"),  # docs/report.md: the reader's own model file
}

FENCE = re.compile(r"^```([\w-]*)[^\n]*\n(.*?)^```", re.S | re.M)
SHELL = {"bash", "sh", "shell"}
TIMEOUT = 300  # seconds, each command
SERVE_SECONDS = 20  # how long each `lagrangian serve` runs before its Ctrl-C


def pages() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def rel(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


@dataclass(frozen=True)
class Case:
    """One thing to run: a shell command, or a page's Python blocks as one script."""

    page: str
    line: int
    shown: str            # the command as the page shows it (for Python: "python blocks")
    run: str              # what runs (a shell command line, or the script's text)
    python: bool = False
    error: str = ""       # the start of the error a transcript shows ("lagrangian simulate: error:")
    no_ffmpeg: bool = False
    serves: bool = False  # `lagrangian serve`, stopped by SIGINT after SERVE_SECONDS

    @property
    def id(self) -> str:
        return f"{self.page}:{self.line}" + (" without ffmpeg" if self.no_ffmpeg else "")

    @property
    def writes_mp4(self) -> bool:
        return not self.python and re.search(r"\S\.mp4\b", self.run) is not None


def strip_comment(line: str) -> str:
    """The command without a trailing shell comment (the pages put no # inside quotes)."""
    return re.sub(r"(^|\s+)#.*$", "", line).strip()


def logical_lines(body: str, first_line: int):
    """(line number, text) of a block's lines, with backslash continuations joined."""
    out, pending, start = [], "", 0
    for k, raw in enumerate(body.splitlines()):
        if not pending:
            start = first_line + k
        if raw.rstrip().endswith("\\"):
            pending += raw.rstrip()[:-1].rstrip() + " "
            continue
        out.append((start, (pending + raw.strip()).strip() if pending else raw))
        pending = ""
    if pending:
        out.append((start, pending.strip()))
    return out


def blocks(page: Path):
    """(language, body, line number of the body's first line, text before the block) of each fenced block."""
    text = page.read_text()
    previous = 0
    for m in FENCE.finditer(text):
        yield m.group(1), m.group(2), text.count("\n", 0, m.start(2)) + 1, text[previous:m.start()]
        previous = m.end()


def model_files(page: Path) -> dict[str, str]:
    """The files a page writes: each ```toml block whose name (`name.toml`) the text just before it gives."""
    files = {}
    for lang, body, _, before in blocks(page):
        names = re.findall(r"`([\w.-]+\.toml)`", before)
        if lang == "toml" and names:
            files[names[-1]] = body
    return files


def shell_commands(page: Path):
    """(line, command shown, start of the error it shows or "") of each shell command on a page."""
    for lang, body, first, _ in blocks(page):
        if lang not in SHELL | {"", "console", "text"}:
            continue
        lines = logical_lines(body, first)
        transcript = any(text.startswith("$ ") for _, text in lines)
        for k, (number, text) in enumerate(lines):
            if transcript:
                if not text.startswith("$ "):
                    continue
                command = text[2:].strip()
                output = [t for _, t in lines[k + 1:]]
                output = output[: next((i for i, t in enumerate(output) if t.startswith("$ ")), len(output))]
                shown_error = re.match(r"lagrangian [\w-]+: error:", output[0]) if output else None
                yield number, command, shown_error.group(0) if shown_error else ""
            elif lang in SHELL:
                if strip_comment(text):
                    yield number, text.strip(), ""
            elif re.match(r"(lagrangian|python)\s", text) and not re.match(r"lagrangian [\w-]+:", text):
                yield number, text.strip(), ""


def python_script(page: Path) -> tuple[int, str] | None:
    """A page's Python blocks, in order, as one script, without the EXCLUDED_PYTHON lines (and blocks)."""
    parts, first_line = [], None
    for lang, body, first, _ in blocks(page):
        if lang != "python":
            continue
        lines = body.splitlines()
        if lines and strip_comment(lines[0]) in EXCLUDED_PYTHON:
            continue
        kept = [line for line in lines if strip_comment(line) not in EXCLUDED_PYTHON]
        parts.append("\n".join(kept))
        first_line = first_line or first
    return (first_line, "\n\n".join(parts) + "\n") if parts else None


def cases() -> list[Case]:
    out = []
    for page in pages():
        for number, shown, error in shell_commands(page):
            command = strip_comment(shown)
            if command in EXCLUDED:
                continue
            parts = [p.strip() for p in command.split("&&") if p.strip() != DEFAULT_INSTALL]
            if not parts:
                continue  # the default install: the fixture runs it
            run = " && ".join(parts)
            for old, (new, _) in REPLACED.items():
                run = run.replace(old, new)
            serves = run.startswith("lagrangian serve")
            if serves:
                run = f"timeout --preserve-status -s INT {SERVE_SECONDS} {run} --no-browser --port 0"
            case = Case(rel(page), number, shown, run, error=error, serves=serves)
            out.append(case)
            if case.writes_mp4 and not error:
                out.append(Case(rel(page), number, shown, run, no_ffmpeg=True))
        script = python_script(page)
        if script:
            out.append(Case(rel(page), script[0], "python blocks", script[1], python=True))
    return out


CASES = cases()


# ------------------------------------------------------------------ what is read from the pages
def test_the_pages_commands_are_found():
    shown = {(c.page, strip_comment(c.shown)) for c in CASES}
    assert ("README.md", "python -m pip install -e . && lagrangian derive cart-pendulum && lagrangian simulate "
            "cart-pendulum --output cart-pendulum.csv") in shown
    assert ("README.md", "lagrangian animate cart-pendulum -o cart.gif") in shown
    assert ("docs/getting-started.md", "lagrangian derive cart.toml") in shown
    assert ("docs/numerics.md", 'lagrangian simulate double-pendulum --t-end 20 --initial theta1=2.5 --event '
            '"swing=theta1_dot" --event "flip=abs(theta2)-pi" --stop-on flip -o out.csv --events-output events.csv') \
        in shown  # a transcript, its continuation line joined
    assert ("docs/getting-started.md", "lagrangian simulate cart-pendulum-massless --t-end 5 --output out.csv",
            "lagrangian simulate: error:") in {(c.page, c.run, c.error) for c in CASES}  # a transcript of a failure
    assert not any(c.error for c in CASES if c.page == "README.md")
    assert any(c.serves for c in CASES if c.page == "README.md")  # `lagrangian serve`, with its Ctrl-C
    assert not any(c.run.startswith("lagrangian derive: error") for c in CASES)  # output, not a command
    assert {c.page for c in CASES if c.python} >= {"README.md", "docs/plots.md", "docs/getting-started.md"}
    assert model_files(ROOT / "README.md").keys() == {"cart.toml"}
    assert model_files(ROOT / "docs/getting-started.md").keys() == {"cart.toml"}


def test_the_exclusions_are_still_in_the_pages():
    text = "\n".join(page.read_text() for page in pages())
    for command in [*EXCLUDED, *EXCLUDED_PYTHON, *STAND_INS]:
        assert command in text, f"{command!r} is no longer in the README or the docs: drop it from the lists"
    first = next(shell_commands(ROOT / "README.md"))[1]
    assert first.startswith(DEFAULT_INSTALL + " && "), "the README's first command is the default install"


# ------------------------------------------------------------------ the fresh environment
@dataclass(frozen=True)
class Venv:
    bin: Path
    env: dict


def _unreachable_index(output: str) -> str:
    """pip's first line that says it could not connect to an index ("" when none does)."""
    signs = ("NewConnectionError", "Failed to establish a new connection", "Temporary failure in name resolution",
             "Network is unreachable", "ConnectTimeoutError", "ProxyError")
    return next((line.strip() for line in output.splitlines() if any(s in line for s in signs)), "")


@pytest.fixture(scope="module")
def venv(tmp_path_factory) -> Venv:
    if shutil.which("bash") is None:
        pytest.skip("bash is not installed: the pages' commands are shell commands")
    where = tmp_path_factory.mktemp("fresh-venv")
    made = subprocess.run([sys.executable, "-m", "venv", str(where / "venv")], capture_output=True, text=True)
    if made.returncode != 0:
        pytest.skip(f"cannot make a virtual environment here (python -m venv): {made.stderr.strip()[-300:]}")
    bin_dir = where / "venv" / ("Scripts" if os.name == "nt" else "bin")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP", "VIRTUAL_ENV", "MPLBACKEND")}
    env.update(PATH=f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}", VIRTUAL_ENV=str(where / "venv"),
               PYTHONNOUSERSITE="1", LAGRANGIAN_CACHE_DIR=str(where / "cache"))
    # the compile cache starts as a copy of this machine's, which the other tests have filled (else the
    # commands would spend a minute compiling the same integrators again); what is missing compiles anew
    mine = Path(os.environ.get("LAGRANGIAN_CACHE_DIR") or Path.home() / ".cache" / "lagrangian")
    if mine.is_dir():
        shutil.copytree(mine, where / "cache", ignore=shutil.ignore_patterns(".lagrangian-*", "*.tmp"))
    # the README's first command, in the repository
    install = subprocess.run([str(bin_dir / "python"), *DEFAULT_INSTALL.split()[1:]], cwd=ROOT, env=env,
                             capture_output=True, text=True, timeout=1200)
    output = install.stdout + install.stderr
    unreachable = _unreachable_index(output) if install.returncode != 0 else ""
    if unreachable:
        pytest.skip("pip cannot reach a package index, so the default install cannot be made here: "
                    + unreachable[:300])
    assert install.returncode == 0, output[-4000:]
    return Venv(bin_dir, env)


def _files_for(case: Case) -> dict[str, str]:
    """The model files a case reads: those of its page that it names (all of them, for a script)."""
    files = {name: text for name, text in model_files(ROOT / case.page).items() if case.python or name in case.run}
    for name, (page, source) in STAND_INS.items():
        if name in case.run:
            files[name] = model_files(ROOT / page)[source]
    return files


def _run(case: Case, venv: Venv, folder: Path):
    folder.mkdir(parents=True)
    for name, text in _files_for(case).items():
        (folder / name).write_text(text)
    env = dict(venv.env)
    if case.no_ffmpeg:  # only the environment's own programs: no ffmpeg
        env["PATH"] = str(venv.bin)
    if case.python:
        (folder / "page_examples.py").write_text(case.run)
        argv = [str(venv.bin / "python"), "page_examples.py"]
    else:
        argv = [shutil.which("bash"), "-c", "set -o pipefail\n" + case.run]
    start = time.perf_counter()
    try:
        done = subprocess.run(argv, cwd=folder, env=env, capture_output=True, text=True, timeout=TIMEOUT)
        result = (done.returncode, done.stdout, done.stderr)
    except subprocess.TimeoutExpired as exc:
        result = (None, exc.stdout or "", f"timed out after {TIMEOUT} s")
    return (*result, time.perf_counter() - start)


@pytest.fixture(scope="module")
def results(venv, tmp_path_factory):
    """Run every case: the first alone (the README's first command: it compiles what the cache lacks),
    the others in parallel, the longest kinds first (Python scripts, animations), each in its own folder."""
    base = tmp_path_factory.mktemp("commands")
    # a command shown on several pages, with the same files, runs once
    same = {case.id: (case.run, case.python, case.no_ffmpeg, tuple(sorted(_files_for(case).items())))
            for case in CASES}
    unique = list({same[case.id]: case for case in reversed(CASES)}.values())[::-1]
    folders = {case.id: base / f"{k:03d}" for k, case in enumerate(unique)}
    done = {}
    if unique:
        done[same[unique[0].id]] = _run(unique[0], venv, folders[unique[0].id])
    rest = sorted(unique[1:], key=lambda c: (not c.python, "animate" not in c.run))
    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        futures = {same[case.id]: pool.submit(_run, case, venv, folders[case.id]) for case in rest}
        done.update({key: future.result() for key, future in futures.items()})
    return {case.id: done[same[case.id]] for case in CASES}


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
@pytest.mark.slow
@pytest.mark.network
@pytest.mark.subprocess
def test_command_runs_on_the_default_install(case, results):
    code, stdout, stderr, seconds = results[case.id]
    what = (f"{case.page}:{case.line}: {case.shown}\n(exit status {code} after {seconds:.1f} s)\n"
            f"--- stdout\n{stdout[-2000:]}\n--- stderr\n{stderr[-4000:]}")
    assert "Traceback" not in stdout + stderr, what
    if case.no_ffmpeg or (case.writes_mp4 and shutil.which("ffmpeg") is None):
        assert code == 2 and stderr.count("\n") == 1, what  # one line that says how to install it
        assert re.match(r"lagrangian animate: error: cannot write '\S+\.mp4': MP4 needs ffmpeg, which is not "
                        r"installed \(not on PATH\): install it \(Debian/Ubuntu: `sudo apt-get install ffmpeg`;",
                        stderr), what
    elif case.serves:
        assert code == 0 and re.match(r"lagrangian serve: the playground is at http://127\.0\.0\.1:[0-9]+/ \(press "
                                      r"Ctrl-C to stop\)\nlagrangian serve: stopped\n\Z", stdout), what
    elif case.error:
        assert code in (1, 2) and stderr.startswith(case.error), what
    else:
        assert code == 0, what

