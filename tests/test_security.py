"""Model files are data: names and free text reach generated code only through
lagrangian._codetext, so that no name runs as code in any target and every symbol means the
user's symbol in every backend.

The payloads are the issue's (the numba docstring, C comments closed by ``*/`` or spliced by
``*\\``+newline, CMake's execute_process, the FMU's C, Modelica's declarations, the compiler
quoting ``/etc/hostname``) and a corpus of breakout strings per target. Each goes through every
generator as the model's name and description; the tests compile, import, load and run the
results and assert that no marker file appears, that the code equals the code of a plainly named
model once comments are taken out, and that the numbers are those of the closed form."""

from __future__ import annotations

import ast
import math
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import lagrangian as lg
from lagrangian import _codetext as ct
from lagrangian.export import export_c, export_fmu, export_modelica
from lagrangian.numeric._cbackend import c_compiler
from lagrangian.numeric._codegen import c_source, numba_source

needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler (cc, gcc or $CC)")

MARKER = "LG_PWNED"


def payloads(folder: Path) -> dict[str, str]:
    """Breakout strings per target; each creates a file named MARKER* in `folder` if it ever runs."""
    d = str(folder / MARKER)
    return {
        "python-docstring": f'x"""\nimport os; os.system("touch {d}-py1")\n"""',
        "python-single": f"x'''\nopen('{d}-py2', 'w')\n'''\\",
        "nul": "nul\x00name\x00",
        "c-comment": f'*/ __attribute__((constructor)) static void pwn(void) {{ system("touch {d}-c1"); }} /*',
        "c-splice": f'*\\\n/ __attribute__((constructor)) static void pwn2(void) {{ system("touch {d}-c2"); }} /*',
        "c-trigraph": f'??/\n__attribute__((constructor)) static void pwn3(void) {{ system("touch {d}-c3"); }}',
        "c-include": '\n#include "/etc/hostname"\n',
        "cmake": f"\nexecute_process(COMMAND touch {d}-cmake1)\n#",
        "cmake-bracket": f"]=] execute_process(COMMAND touch {d}-cmake2) #[=[ ${{HOME}}",
        "modelica": '";\n parameter Real injected = 1; //',
        "xml": '"/><ScalarVariable name="evil"/><x a="',
        "unicode": "pendule \u00e0 ressort \u2028 \u2029 \r\n \ufeff \U0001f600",
    }


def oscillator(name: str, description: str = "") -> lg.Model:
    """x'' = -(k/m) x with names that collide with the targets: a parameter E (Euler's number in
    SymEngine's printing), a coordinate pow (C's pow), NAN, NANO, INFINITY (C's macros), main,
    Real, M_PI, and x0, c0 (the generators' own temporaries); x(t) = cos(sqrt(6 e) t)."""
    model = lg.Model(name, coordinates=["pow"],
                     parameters={"E": 1.0, "NAN": 2.0, "NANO": 3.0, "INFINITY": 1.0, "main": 1.0, "Real": 1.0,
                                 "M_PI": 1.0, "x0": 0.0, "c0": 0.0},
                     inputs=["printf"],
                     T="Real*pow_dot**2/2", V="exp(1)*NAN*NANO*INFINITY*main*pow**2/2 + x0*c0*M_PI*pow",
                     Q={"pow": "printf"}, description=description)
    model.simulation = {"initial": {"pow": 1.0}}
    return model


OMEGA = math.sqrt(6 * math.e)


def no_marker(folder: Path) -> None:
    found = [p.name for p in folder.rglob(f"{MARKER}*")]
    assert found == [], f"a payload ran: {found}"


# ---------------------------------------------------------------------------------- the layer


@settings(max_examples=300, deadline=None)
@given(st.text())
def test_comment_text_keeps_only_inert_characters(text):
    out = ct.comment_text(text)
    assert set(out) <= ct._SAFE
    assert len(out) <= ct.COMMENT_MAX
    for closer in ("*/", "\\", "\n", '"""', "'''", "??", "#", "$", "//", "[["):
        assert closer not in out


@settings(max_examples=300, deadline=None)
@given(st.text())
def test_c_string_decodes_to_the_text_s_utf8_bytes(text):
    literal = ct.c_string(text)
    assert literal[0] == literal[-1] == '"' and "\n" not in literal and "??" not in literal
    body, out, i = literal[1:-1], bytearray(), 0
    while i < len(body):
        if body[i] == "\\":
            assert re.fullmatch(r"[0-7]{3}", body[i + 1:i + 4])
            out.append(int(body[i + 1:i + 4], 8))
            i += 4
        else:
            assert body[i] not in '"?'
            out.append(ord(body[i]))
            i += 1
    assert bytes(out) == text.encode("utf-8", "replace")


@settings(max_examples=300, deadline=None)
@given(st.text())
def test_xml_attribute_parses_back_to_the_text(text):
    element = ElementTree.fromstring(f"<a v={ct.xml_attribute(text)}/>")
    assert list(element.attrib) == ["v"]
    expected = "".join(" " if ct._XML_INVALID.match(c) else c for c in text)
    assert element.attrib["v"] == expected


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet=st.sampled_from("&<>\"'\n\r\tab \u00e9")) | st.text())
def test_xml_attribute_quotes_as_the_standard_library_does(text):
    """Written out (xml.sax.saxutils imports urllib.request and ssl: 65 ms at each start), the same text."""
    from xml.sax.saxutils import quoteattr

    clean = ct._XML_INVALID.sub(" ", text)
    assert ct.xml_attribute(text) == quoteattr(clean, {"\n": "&#10;", "\r": "&#13;", "\t": "&#9;"})


def test_the_code_text_layer_imports_no_network_module():
    code = "import sys, lagrangian._codetext; print(sorted({'ssl', 'urllib.request'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


@settings(max_examples=200, deadline=None)
@given(st.text())
def test_modelica_string_cannot_end_early(text):
    literal = ct.modelica_string(text)
    body = literal[1:-1]
    assert "\n" not in literal and "\x00" not in literal
    assert re.fullmatch(r'(?:[^"\\]|\\["\\])*', body)  # every quote and backslash escaped


@pytest.mark.parametrize("target, name, expected", [
    ("c", "cart-pendulum", "cart_pendulum"), ("c", "main", "main_model"), ("c", "fmu", "fmu_model"),
    ("c", "Math", "Math_model"), ("c", "fmi2Functions", "fmi2Functions_model"), ("c", "int", "int_model"),
    ("c", "2link", "m_2link"), ("c", "**", "model"), ("c", 'x"""\nimport os', "x____import_os"), ("c", "a\x00b", "a_b"),
    ("modelica", "cart-pendulum", "CartPendulum"), ("modelica", "Real", "RealModel"),
    ("modelica", "end", "End"), ("modelica", "Modelica", "ModelicaModel"), ("modelica", "String", "StringModel"),
    ("modelica", "2link", "M2link"),
])
def test_module_identifiers_are_never_reserved(target, name, expected):
    assert ct.module_identifier(name, target) == expected


def test_an_identifier_that_breaks_the_rule_is_refused():
    with pytest.raises(ValueError, match=r"the symbol 'a\\nb' cannot enter generated code: a name there is ASCII "
                                         "letters, digits and '_'"):
        ct.local_name("a\nb")


# ------------------------------------------------------------- the code holds no user text


def _without_docstring(source: str) -> str:
    tree = ast.parse(source)
    first = tree.body[0]
    assert isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
    return ast.dump(ast.Module(body=tree.body[1:], type_ignores=[]))


def test_numba_modules_of_hostile_names_are_the_plain_module(tmp_path):
    """For every payload, the generated numba modules (main and variational) parse to the same
    code as those of a plainly named model: the name is in the docstring only, made inert."""
    plain = lg.derive(oscillator("plain"))
    for key, text in payloads(tmp_path).items():
        eq = lg.derive(oscillator(text, description=text))
        for part in ("main", "variational"):
            source = numba_source(eq, part)
            assert _without_docstring(source) == _without_docstring(numba_source(plain, part)), key
            assert ct.comment_text(text) in ast.get_docstring(ast.parse(source)), key


def _c_code(path: Path) -> str:
    """The C file without its comments (the compiler's own preprocessor, no macro expanded)."""
    run = subprocess.run([c_compiler(), "-fpreprocessed", "-dD", "-E", "-P", "-x", "c", str(path)],
                         capture_output=True, text=True, check=True)
    return run.stdout


@needs_cc
@pytest.mark.slow
@pytest.mark.subprocess
def test_c_sources_of_hostile_names_are_the_plain_sources(tmp_path):
    """The C backend's source and the C export's four files: with comments taken out, the same as
    those of a model named by the identifier the hostile name maps to; CMakeLists.txt without its
    comment lines likewise."""
    for key, text in payloads(tmp_path).items():
        ident = ct.module_identifier(text)
        hostile, plain = lg.derive(oscillator(text, text)), lg.derive(oscillator(ident))
        for name, eq in (("hostile", hostile), ("plain", plain)):
            (tmp_path / f"{name}.c").write_text(c_source(eq))
            export_c(eq, tmp_path / name)
        assert _c_code(tmp_path / "hostile.c") == _c_code(tmp_path / "plain.c"), key
        for file in (f"{ident}.c", f"{ident}.h", "main.c"):
            assert _c_code(tmp_path / "hostile" / file) == _c_code(tmp_path / "plain" / file), (key, file)
        cmake = [(tmp_path / name / "CMakeLists.txt").read_text().splitlines() for name in ("hostile", "plain")]
        assert [[line for line in c if not line.startswith("#")] for c in cmake][0] == \
            [line for line in cmake[1] if not line.startswith("#")], key
        assert all("\n" not in line for line in cmake[0])
        shutil.rmtree(tmp_path / "hostile")
        shutil.rmtree(tmp_path / "plain")
    no_marker(tmp_path)


@needs_cc
@pytest.mark.slow
@pytest.mark.subprocess
def test_fmu_sources_of_hostile_names_are_the_plain_sources(tmp_path):
    """The FMU's C (fmu.c, where the name stood in a comment) and the model's C in it: without
    comments, those of the model named by the identifier; its modelDescription.xml differs only in
    the name, the description and the time of generation."""
    varying = {"modelName", "description", "generationDateAndTime", "guid"}  # the guid hashes the name too
    for key, text in payloads(tmp_path).items():
        ident = ct.module_identifier(text)
        out = {}
        for name, eq in (("hostile", lg.derive(oscillator(text, text))), ("plain", lg.derive(oscillator(ident)))):
            export_fmu(eq, tmp_path / f"{name}.fmu", binary=False)
            with zipfile.ZipFile(tmp_path / f"{name}.fmu") as z:
                for file in ("fmu.c", f"{ident}.c", f"{ident}.h"):
                    (tmp_path / f"{name}-{file}").write_bytes(z.read(f"sources/{file}"))
                root = ElementTree.fromstring(z.read("modelDescription.xml"))
            out[name] = [(e.tag, {k: v for k, v in e.attrib.items() if not (e is root and k in varying)})
                         for e in root.iter()]
        assert out["hostile"] == out["plain"], key
        guid = re.compile(r'#define GUID "[^"]*"')
        for file in ("fmu.c", f"{ident}.c", f"{ident}.h"):
            codes = [guid.sub("", _c_code(tmp_path / f"{name}-{file}")) for name in ("hostile", "plain")]
            assert codes[0] == codes[1], (key, file)
    no_marker(tmp_path)


def test_modelica_of_hostile_names_declares_what_the_plain_model_declares(tmp_path):
    for key, text in payloads(tmp_path).items():
        ident = ct.module_identifier(text, "modelica")
        hostile = export_modelica(lg.derive(oscillator(text, text)), tmp_path / "h.mo")
        plain = export_modelica(lg.derive(oscillator(ident, "plain")), tmp_path / "p.mo")
        h, p = (Path(r.files[0]).read_text() for r in (hostile, plain))
        h = h.replace(ct.modelica_string(text), ct.modelica_string("plain"), 1)
        strip = lambda s: re.sub(r"//[^\n]*", "", s)  # noqa: E731
        assert strip(h) == strip(p), key


# ------------------------------------------------------------------ every backend, run


@needs_cc
@pytest.mark.parametrize("key, about", [("python-docstring", "c-comment"), ("c-splice", "xml"),
                                        ("cmake", "modelica")])
@pytest.mark.slow
@pytest.mark.subprocess
def test_hostile_names_run_no_code_in_any_backend_and_give_the_closed_form(key, about, tmp_path, monkeypatch):
    """The model named (and described) by the payload: simulated by the numba, C and SciPy
    backends, exported as C (built with -Wall -Werror and with CMake, and run), as an FMU (loaded
    and run by fmpy) and as Modelica (checked by rumoca): no marker appears, and x(1) is
    cos(sqrt(6 e)) in every one of them (E is the parameter, exp(1) is e). The description is
    another payload."""
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path / "cache"))
    text = payloads(tmp_path)[key]
    eq = lg.derive(oscillator(text, payloads(tmp_path)[about]))
    exact = math.cos(OMEGA)
    for backend in ("numba", "c", "scipy"):
        traj = lg.simulate(eq, 1.0, backend=backend, rtol=1e-11, atol=1e-11, dt=0.5)
        assert traj["pow"][-1] == pytest.approx(exact, abs=1e-8), backend
    ident = ct.module_identifier(text)
    folder = tmp_path / "c"
    export_c(eq, folder)
    cc = c_compiler()
    subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", "-o", str(folder / "example"),
                    str(folder / "main.c"), str(folder / f"{ident}.c"), "-lm"], check=True, capture_output=True)
    out = subprocess.run([str(folder / "example"), "1", "0.0001", "10000"], check=True, capture_output=True,
                         text=True).stdout.splitlines()
    assert out[0].split(",")[:2] == ["t", "pow"]
    assert float(out[-1].split(",")[1]) == pytest.approx(exact, abs=1e-8)
    if shutil.which("cmake"):
        build = tmp_path / "build"
        for cmd in (["cmake", "-S", str(folder), "-B", str(build)], ["cmake", "--build", str(build)]):
            subprocess.run(cmd, check=True, capture_output=True, text=True)
    fmu = tmp_path / "m.fmu"
    result = export_fmu(eq, fmu)
    assert result.binary is not None, result.warnings
    with zipfile.ZipFile(fmu) as z:
        root = ElementTree.fromstring(z.read("modelDescription.xml"))
    assert root.attrib["modelName"] == "".join(" " if ct._XML_INVALID.match(c) else c for c in text)
    assert [v.attrib["name"] for v in root.iter("ScalarVariable")][:2] == ["pow", "pow_dot"]
    fmpy = pytest.importorskip("fmpy")
    res = fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", stop_time=1.0, output_interval=0.5,
                            start_values={"solver.rtol": 1e-11, "solver.atol": 1e-11}, output=["pow"])
    assert res["pow"][-1] == pytest.approx(exact, abs=1e-7)
    mo = tmp_path / "m.mo"
    export_modelica(eq, mo)
    rm = pytest.importorskip("rumoca")
    cls = ct.module_identifier(text, "modelica")
    assert rm.validate(str(mo), model=cls) == []
    no_marker(tmp_path)


@needs_cc
@pytest.mark.parametrize("name", ["main", "fmu", "math", "Real"])
@pytest.mark.subprocess
@pytest.mark.slow
def test_model_names_that_are_the_targets_own_build(name, tmp_path):
    """A model named main keeps its C source (main_model.c beside the example's main.c), fmu its
    model in the FMU, math does not shadow <math.h>, Real is a Modelica class: each builds and
    runs."""
    eq = lg.derive(oscillator(name))
    ident = ct.module_identifier(name)
    files = export_c(eq, tmp_path / "c").files
    assert sorted(Path(f).name for f in files) == sorted([f"{ident}.c", f"{ident}.h", "main.c", "CMakeLists.txt"])
    subprocess.run([c_compiler(), "-std=c99", "-O2", "-I", str(tmp_path / "c"), "-o", str(tmp_path / "ex"),
                    str(tmp_path / "c" / "main.c"), str(tmp_path / "c" / f"{ident}.c"), "-lm"], check=True)
    result = export_fmu(eq, tmp_path / "m.fmu")
    assert result.binary is not None, result.warnings
    fmpy = pytest.importorskip("fmpy")
    res = fmpy.simulate_fmu(str(tmp_path / "m.fmu"), fmi_type="CoSimulation", stop_time=1.0, output_interval=0.5,
                            start_values={"solver.rtol": 1e-11, "solver.atol": 1e-11}, output=["pow"])
    assert res["pow"][-1] == pytest.approx(math.cos(OMEGA), abs=1e-7)
    export_modelica(eq, tmp_path / "m.mo")
    rm = pytest.importorskip("rumoca")
    assert rm.validate(str(tmp_path / "m.mo"), model=ct.module_identifier(name, "modelica")) == []


def test_a_parameter_named_e_is_that_parameter_in_every_backend():
    """The issue's case: with E = 1, V = exp(1) k x^2 / 2 gave x(1) = -0.4161 in numba (E read
    as the parameter) against -0.9879 in SciPy and C; now cos(2 sqrt(e)) everywhere."""
    model = lg.Model("euler", coordinates=["x"], parameters={"k": 4.0, "E": 1.0}, T="x_dot**2/2",
                     V="exp(1)*k*x**2/2")
    eq = lg.derive(model)
    backends = ("numba", "scipy", "c") if c_compiler() else ("numba", "scipy")
    for backend in backends:
        traj = lg.simulate(eq, 1.0, {"x": 1.0}, backend=backend, rtol=1e-11, atol=1e-11, dt=0.5)
        assert traj["x"][-1] == pytest.approx(math.cos(2 * math.sqrt(math.e)), abs=1e-8), backend
        assert traj["x"][-1] == pytest.approx(-0.98788, abs=1e-5)


# -------------------------------------------------------------------------------- the cache


EVIL = '''name = "x\\"\\"\\"\\nimport os; os.system('touch {marker}')\\n\\"\\"\\""
coordinates = ["x"]
[parameters]
k = 4.0
[energy]
T = "x_dot**2/2"
V = "k*x**2/2"
[simulation]
initial = {{ x = 1.0 }}
'''


def _seeded_cache(folder: Path) -> Path:
    """A new cache folder holding the compiled integrators of this machine's cache (copied with their
    times, so that numba reuses them: compiling them again would take 20 s a process)."""
    from lagrangian.numeric._codegen import cache_dir
    from lagrangian.numeric._fast import kernels

    kernels()
    (folder / "__pycache__").mkdir(parents=True)
    for path in [*cache_dir().glob("lagrangian_kernels_*"),
                 *(cache_dir() / "__pycache__").glob("lagrangian_kernels_*")]:
        shutil.copy2(path, folder / path.relative_to(cache_dir()))
    return folder


def _cli(args, cwd, cache):
    env = {**os.environ, "LAGRANGIAN_CACHE_DIR": str(cache)}
    return subprocess.run([sys.executable, "-m", "lagrangian", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=600)


@pytest.mark.slow
@pytest.mark.subprocess
def test_the_issue_s_model_file_runs_no_code_and_cannot_poison_the_cache(tmp_path):
    """`lagrangian simulate evil.toml` creates no PWNED; the innocent model with the same equations
    has its own cache entry (the key is the hash of the exact source); an entry changed on disk
    (here: made to create a marker) is rewritten before it is imported, never run."""
    cache = _seeded_cache(tmp_path / "cache")
    marker = tmp_path / f"{MARKER}-evil"
    (tmp_path / "evil.toml").write_text(EVIL.format(marker=marker))
    run = _cli(["simulate", "evil.toml", "--t-end", "0.1", "-o", "out.csv"], tmp_path, cache)
    assert run.returncode == 0, run.stderr
    assert not marker.exists() and not (tmp_path / "PWNED").exists()
    evil_modules = sorted(cache.glob("lagrangian_[0-9a-f]*.py"))
    assert len(evil_modules) == 1
    (tmp_path / "innocent.toml").write_text(EVIL.format(marker=marker).replace(
        EVIL.format(marker=marker).splitlines()[0], 'name = "innocent"'))
    run = _cli(["simulate", "innocent.toml", "--t-end", "0.1", "-o", "out2.csv"], tmp_path, cache)
    assert run.returncode == 0, run.stderr
    modules = sorted(cache.glob("lagrangian_[0-9a-f]*.py"))
    assert len(modules) == 2 and "'innocent'" in (set(modules) - set(evil_modules)).pop().read_text()
    # tamper with the innocent model's entry: the next process rewrites it from the source
    entry = (set(modules) - set(evil_modules)).pop()
    good = entry.read_text()
    entry.write_text(f"open({str(marker)!r}, 'w').close()\n" + good)
    run = _cli(["simulate", "innocent.toml", "--t-end", "1", "-o", "out3.csv"], tmp_path, cache)
    assert run.returncode == 0, run.stderr
    assert not marker.exists() and entry.read_text() == good
    x = np.loadtxt(tmp_path / "out3.csv", delimiter=",", skiprows=1, comments="#")
    assert x[-1, 0] == 1.0 and x[-1, 1] == pytest.approx(math.cos(2.0), abs=1e-5)


def test_a_nul_in_the_name_leaves_no_broken_entry(tmp_path, monkeypatch):
    """A NUL in the name left a module that failed to import in the cache, and every later model
    with those equations failed; now the name is inert and both models run."""
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path))
    for name in ("a\x00b", "innocent"):
        model = lg.Model(name, coordinates=["x"], parameters={"k": 4.0}, T="x_dot**2/2", V="k*x**2/2")
        traj = lg.simulate(lg.derive(model), 1.0, {"x": 1.0}, rtol=1e-11, atol=1e-11, dt=0.5)
        assert traj["x"][-1] == pytest.approx(math.cos(2.0), abs=1e-8)
    assert all("\x00" not in p.read_text() for p in tmp_path.glob("*.py"))


def test_a_truncated_entry_is_rebuilt(tmp_path, monkeypatch):
    from lagrangian.numeric._codegen import cached_module

    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path))
    source = "X = 1\n"
    path, key, module = cached_module(source, prefix="lagrangian_test")
    assert module.X == 1 and path.read_text() == source
    path.write_text("X = ")  # a broken entry (a crash while writing, a full disk)
    path2, key2, _ = cached_module(source, prefix="lagrangian_test")
    assert (path2, key2) == (path, key) and path.read_text() == source
    with pytest.raises(SyntaxError):  # what does not compile is never stored
        cached_module("X = (", prefix="lagrangian_test")
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


# ------------------------------------------------------------------------------- the report

TEX = "\\input{/etc/hostname} \\immediate\\write18{touch LG_PWNED} $x$ # & % ~ ^ \x00 \x0c"
HTML = "<script>alert(1)</script> <img src=x onerror=alert(1)> [link](javascript:alert(1)) **bold**\n# heading"


@pytest.mark.subprocess
def test_reports_show_hostile_names_as_text(tmp_path):
    """The report's title and description are text in every format: HTML escaped, Markdown without a
    tag, a link or a second heading, LaTeX that pdflatex compiles (when installed) without reading a
    file or running a command."""
    from lagrangian.reporting import report
    from lagrangian.reporting._writers import to_html, to_latex, to_markdown

    rep = report(oscillator(TEX + HTML, description=HTML + TEX))
    html_text = to_html(rep)
    assert "<script>" not in html_text and "<img" not in html_text and "&lt;script&gt;" in html_text
    md = to_markdown(rep)
    head = md.split("\n\n")[:2]
    assert head[0].startswith("# ") and "\n" not in head[0] and "\x00" not in md
    for raw in ("<script>", "<img", " [link](javascript", "**bold**", "\n# heading"):
        assert raw not in md
    assert "&lt;script&gt;" in md and "\\[link\\]" in md
    tex = to_latex(rep)
    assert "\\input{" not in tex and "\\write18{" not in tex and "\x00" not in tex
    latex = shutil.which("pdflatex")
    if latex is None:
        pytest.skip("pdflatex is not installed (apt-get install texlive-latex-base): the .tex was checked as text")
    (tmp_path / "r.tex").write_text(tex)
    run = subprocess.run([latex, "-no-shell-escape", "-interaction=nonstopmode", "-halt-on-error", "r.tex"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-2000:]
    assert (tmp_path / "r.pdf").exists() and "(/etc/hostname" not in run.stdout  # TeX logs a file it reads
    no_marker(tmp_path)


def test_pictures_show_hostile_names_as_text(tmp_path):
    """A model's name is a figure's title as it is (Matplotlib parsed '$\\frac{ $' as mathtext and
    raised while drawing), and the HTML animation's <title> is escaped."""
    from lagrangian import plot

    name = "cost $\\frac{ and \x00 $ </title><script>alert(1)</script>"
    model = lg.Model(name, coordinates=["x"], parameters={"k": 4.0}, T="x_dot**2/2", V="k*x**2/2")
    model.add_particle(1, ("x", 0), name="mass")
    traj = lg.simulate(lg.derive(model), 0.2, {"x": 1.0}, dt=0.1)
    for figure in (plot.time_history(traj), plot.energy_drift(traj)):
        figure.savefig(tmp_path / "f.png")
        titles = [t.get_text() for t in figure.findobj(lambda a: hasattr(a, "get_text"))]
        assert any("cost \\$\\frac{ and   \\$" in t for t in titles)
    anim = plot.animate(traj)
    anim.save(str(tmp_path / "a.html"))
    page = (tmp_path / "a.html").read_text()
    assert "<script>alert(1)" not in page and "&lt;/title&gt;&lt;script&gt;" in page


@pytest.mark.parametrize("backend", ["numba", "c"])
@pytest.mark.slow
def test_names_of_the_generators_own_variables_are_the_user_s_symbols(backend):
    """Parameters named like the placeholders (__lg_s0), the sin/cos pairs (__lg_sn0), the locals
    (v_x), SymEngine's CSE names (x1), the generated temporaries (c0, m0_0, f0, d0, r, sn0) and the
    module's own names (dx, work, carray, math, np) give the SciPy backend's pendulum to 1e-10."""
    if backend == "c" and c_compiler() is None:
        pytest.skip("no C compiler")
    names = ["__lg_s0", "__lg_s1", "__lg_sn0", "__lg_cs0", "v_x", "x1", "c0", "m0_0", "f0", "d0", "r", "sn0", "cs0",
             "b0", "dx", "work", "carray", "math", "np", "p", "u", "x_"]
    params = {name: 1.0 + k / 10 for k, name in enumerate(names)}
    weight = "*".join(names)
    model = lg.Model("generator-names", coordinates=["x", "y"], parameters=params,
                     T="(x_dot**2 + y_dot**2 + x_dot*y_dot*cos(x - y))/2",
                     V=f"-{weight}*cos(x)/1000 - cos(y)*__lg_s0")
    eq = lg.derive(model)
    ref = lg.simulate(eq, 2.0, {"x": 0.5, "y": -0.3}, backend="scipy", rtol=1e-12, atol=1e-12, dt=0.5)
    got = lg.simulate(eq, 2.0, {"x": 0.5, "y": -0.3}, backend=backend, rtol=1e-12, atol=1e-12, dt=0.5)
    assert np.max(np.abs(got.x - ref.x)) < 1e-9
    assert abs(ref["x"][-1] - 0.5) > 0.01  # it moved


def test_integers_past_the_targets_ranges_are_written_as_doubles(tmp_path):
    """99999999999999999999 in T and V: numba could not type it and C truncated it (the energy came
    out -1.5e19 instead of 5e19); now x(1) = cos(1) and h = 1e20/2 in every backend, and the
    Modelica model (whose Integer has 32 bits) writes it as a Real."""
    big = "99999999999999999999"
    model = lg.Model("big", coordinates=["x"], T=f"{big}*x_dot**2/2", V=f"{big}*x**2/2 + 3000000000*x/3000000000")
    eq = lg.derive(model)
    backends = ("numba", "scipy", "c") if c_compiler() else ("numba", "scipy")
    for backend in backends:
        traj = lg.simulate(eq, 1.0, {"x": 1.0}, backend=backend, rtol=1e-11, atol=1e-11, dt=0.5)
        # x'' = -x - 1e-20: x = cos t to 1e-15
        assert traj["x"][-1] == pytest.approx(math.cos(1.0), abs=1e-8), backend
        assert traj.energy[-1] == pytest.approx(0.5e20 + 1.0, rel=1e-9), backend
    text = Path(export_modelica(eq, tmp_path / "big.mo").files[0]).read_text()
    assert big not in text and "1e+20" in text
