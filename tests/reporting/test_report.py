"""The derivation report: its content (SymPy expressions compared with the seed's slides), its
three formats, the `lagrangian report` command, and the HTML page rendered by a real browser."""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET

import pytest
import sympy

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.reporting import Paragraph, Report, Table, format_of

S = sympy.Symbol
q1, q2, q1d, q2d, q1dd, q2dd = (S(n) for n in ("q1", "q2", "q1_dot", "q2_dot", "q1_ddot", "q2_ddot"))
M1, M2, L, g, F = (S(n) for n in ("M1", "M2", "L", "g", "F"))
sin, cos = sympy.sin, sympy.cos

# Bona's slides 7, 11, 14 and 15, with the cart's mass M1 and the force F on the cart.
SLIDE_EQUATIONS = (
    (M1 + M2) * q1dd - M2 * L * sin(q2) * q2dd - M2 * L * cos(q2) * q2d**2 - F,
    M2 * L**2 * q2dd - M2 * L * sin(q2) * q1dd + M2 * g * L * cos(q2),
)
SLIDE_H = sympy.Matrix([[M1 + M2, -M2 * L * sin(q2)], [-M2 * L * sin(q2), M2 * L**2]])
SLIDE_C = sympy.Matrix([[0, -M2 * L * cos(q2) * q2d], [0, 0]])
SLIDE_G = sympy.Matrix([0, M2 * g * L * cos(q2)])

MATHML = "{http://www.w3.org/1998/Math/MathML}"


def same(a, b) -> bool:
    a, b = sympy.Matrix([a]) if not isinstance(a, sympy.MatrixBase) else a, \
        sympy.Matrix([b]) if not isinstance(b, sympy.MatrixBase) else b
    return a.shape == b.shape and all(sympy.simplify(x - y) == 0 for x, y in zip(a, b))


@pytest.fixture(scope="module")
def cart() -> Report:
    return lg.report("cart-pendulum")


@pytest.fixture(scope="module")
def cart_html(cart) -> str:
    return cart.to_html()


# ----------------------------------------------------------------- content
@pytest.mark.slow
def test_sections_follow_the_recipe(cart):
    assert [s.key for s in cart.sections] == [
        "bodies", "coordinates", "kinematics", "energies", "dissipation", "forces", "lagrangian",
        "equations", "matrix-form", "state-form", "singularities", "equilibria"]
    assert cart.model_name == "cart-pendulum"
    assert isinstance(cart, Report) and repr(cart) == "<Report of 'cart-pendulum': 12 sections>"


def test_positions_velocities_and_energies_are_the_slides(cart):
    assert same(cart.expression("position[pendulum]"), sympy.Matrix([q1 + L * cos(q2), L + L * sin(q2)]))
    assert same(cart.expression("velocity[pendulum]"), sympy.Matrix([q1d - L * sin(q2) * q2d, L * cos(q2) * q2d]))
    assert same(cart.expression("speed2[pendulum]"), q1d**2 + L**2 * q2d**2 - 2 * L * sin(q2) * q1d * q2d)
    assert same(cart.expression("T[pendulum]"), M2 * (q1d**2 + L**2 * q2d**2 - 2 * L * sin(q2) * q1d * q2d) / 2)
    assert same(cart.expression("position[cart]"), sympy.Matrix([q1, 0]))
    assert same(cart.expression("T"), M1 * q1d**2 / 2 + M2 * (q1d**2 + L**2 * q2d**2 - 2 * L * sin(q2) * q1d * q2d) / 2)
    assert same(cart.expression("V"), M2 * g * L * (1 + sin(q2)))
    assert same(cart.expression("L"), cart.expression("T") - cart.expression("V"))
    assert cart.expression("D") == 0
    # Q from virtual work of the push on the cart, and B = dQ/du
    assert same(cart.expression("Q[push]"), sympy.Matrix([F, 0]))
    assert same(cart.expression("Q"), sympy.Matrix([F, 0]))
    assert same(cart.expression("B"), sympy.Matrix([1, 0]))


def test_each_lagrange_equation_step_by_step(cart):
    for i, (q, qd, expected) in enumerate(zip((q1, q2), (q1d, q2d), SLIDE_EQUATIONS)):
        block = cart.math(f"equation[{q.name}]")
        assert block.rhs == 0 and same(block.lhs, expected)
        # the pieces add up: d/dt(dL/dq_dot) - dL/dq - Q = E
        pieces = (cart.expression(f"d/dt dL/d{qd.name}") - cart.expression(f"dL/d{q.name}")
                  - cart.expression(f"Q_{i + 1}"))
        assert same(pieces, expected)
    # slide 11: M d/dt(q1_dot - L sin q2 q2_dot) for equation 1 (with the cart's mass)
    assert same(cart.expression("dL/dq1_dot"), (M1 + M2) * q1d - M2 * L * sin(q2) * q2d)


@pytest.mark.slow
def test_matrix_form_is_slide_14_and_state_form_solves_it(cart):
    assert same(cart.expression("M"), SLIDE_H)
    assert same(cart.expression("C"), SLIDE_C)
    assert same(cart.expression("G"), SLIDE_G)
    qdd = cart.expression("q_ddot")
    assert same(SLIDE_H * qdd + SLIDE_C * sympy.Matrix([q1d, q2d]) + SLIDE_G, sympy.Matrix([F, 0]))
    assert same(cart.expression("x"), sympy.Matrix([q1, q2, q1d, q2d]))
    # slide 15: det H = M1 M2 L^2 + M2^2 L^2 - M2^2 L^2 sin^2 q2
    assert same(cart.expression("det M"), M1 * M2 * L**2 + M2**2 * L**2 - M2**2 * L**2 * sin(q2) ** 2)
    text = " ".join(p.text() for p in cart.section("singularities").blocks if isinstance(p, Paragraph))
    assert "regular" in text


def test_equilibria_and_their_stability(cart):
    blocks = cart.section("equilibria").blocks
    try:
        import lagrangian.analysis  # noqa: F401
    except ImportError:
        assert "not available" in blocks[0].text()
        return
    (table,) = [b for b in blocks if isinstance(b, Table)]
    stability = {}
    for row in table.rows:
        relations = row[1].args if isinstance(row[1], sympy.Tuple) else (row[1],)
        at = {r.lhs.name: r.rhs for r in relations}
        stability[float(at["q2"])] = row[2]
    assert set(stability) == {-float(sympy.pi / 2), float(sympy.pi / 2)}
    assert "unstable" not in stability[-float(sympy.pi / 2)] and "unstable" in stability[float(sympy.pi / 2)]


@pytest.mark.slow
def test_a_model_without_equilibrium_says_why_in_its_report():
    texts = [b.text() for b in lg.report("kepler").section("equilibria").blocks if isinstance(b, Paragraph)]
    assert texts[:3] == ["There is no equilibrium (with the inputs at zero and the parameter values):",
                         "SymPy finds no solution of -m*mu/r**2 = 0.",
                         "The numerical search from 49 starting points found none."]
    assert "a root at infinity is not an equilibrium" in texts[3]


def test_massless_cart_diagnosis_names_the_singular_configuration():
    rep = lg.report("cart-pendulum-massless", equilibria=False)
    assert same(rep.expression("det M"), (M2 if "M2" in str(rep.expression("det M")) else S("M")) ** 2
                * L**2 * cos(q2) ** 2)
    text = "\n".join(p.text() for p in rep.section("singularities").blocks if isinstance(p, Paragraph))
    assert "q2 = pi/2" in text and "no inertia" in text
    assert [s.key for s in rep.sections][-1] == "singularities"


def test_energy_only_model_says_so_and_gives_the_same_equations():
    rep = lg.report(lg.load("cart-pendulum-energy"), equilibria=False)
    text = " ".join(b.text() for b in rep.section("kinematics").blocks)
    assert "energies only" in text and "no element positions" in text
    assert not any(k.startswith("position[") for k in rep.keys())
    for q, expected in zip((q1, q2), SLIDE_EQUATIONS):
        assert same(rep.math(f"equation[{q.name}]").lhs, expected)


def test_rotating_pendulum_shows_preumonts_centrifugal_potential():
    rep = lg.report("rotating-pendulum", equilibria=False)
    m, l, Om, th = S("m"), S("l"), S("Omega"), S("theta")
    assert same(rep.expression("T0"), m * l**2 * Om**2 * sin(th) ** 2 / 2)
    assert same(rep.expression("position[bob]"), sympy.Matrix([l * sin(th) * cos(Om * lg.t),
                                                              l * sin(th) * sin(Om * lg.t), -l * cos(th)]))
    assert "centrifugal" in rep.keys()


def test_dampers_springs_bodies_and_the_linear_form():
    rep = lg.report("mck-elements", equilibria=False)
    x1d, x2d = S("x1_dot"), S("x2_dot")
    c1, c2, k1, k2 = S("c1"), S("c2"), S("k1"), S("k2")
    assert same(rep.expression("D"), c1 * x1d**2 / 2 + c2 * (x2d - x1d) ** 2 / 2)
    assert same(rep.expression("linear.K"), sympy.Matrix([[k1 + k2, -k2], [-k2, k2]]))
    assert same(rep.expression("linear.C"), sympy.Matrix([[c1 + c2, -c2], [-c2, c2]]))
    assert "dD/dx1_dot" in rep.keys() and "damping" in rep.keys()
    disk = lg.report("sliding-disk-heavy-rod", equilibria=False)
    assert same(disk.expression("rate[disk]"), S("q2_dot"))
    assert same(disk.expression("length[spring]"), sympy.sqrt(S("q1") ** 2))


@pytest.mark.slow
def test_a_too_large_expression_is_reported_not_printed():
    x = S("x")
    V = sympy.Add(*(i * x**i * sin(x) for i in range(1, 450)))
    model = lg.Model("big", coordinates=["x"], parameters={"m": 1.0}, T="m*x_dot**2/2", V=V)
    rep = lg.report(model, equilibria=False)
    for text in (rep.to_html(), rep.to_markdown(), rep.to_latex()):
        assert "expression too large to print: more than 2500 nodes" in text
        assert "lagrangian derive big --json" in text


def test_report_refuses_other_objects():
    with pytest.raises(TypeError, match="report\\(\\) expects Equations, a Model, or a model name or path, got int"):
        lg.report(3)
    with pytest.raises(TypeError):
        lg.report("cart-pendulum", colour="red")


# ----------------------------------------------------------------- formats
def math_elements(page: str) -> list[str]:
    return re.findall(r"<math\b.*?</math>", page, re.S)


def test_html_is_self_contained_with_well_formed_mathml(cart_html):
    assert cart_html.startswith("<!DOCTYPE html>")
    assert not re.search(r"<script|<link|src=|https?://", cart_html.replace(f'xmlns="{MATHML[1:-1]}"', ""))
    maths = math_elements(cart_html)
    assert len(maths) > 50
    for m in maths:
        root = ET.fromstring(m)  # well-formed XML, with numeric character references only
        assert root.tag == MATHML + "math"
    assert sum('display="block"' in m for m in maths) > 30
    # the slide's equation 2 is there as MathML: M2 L^2 q2_ddot with a dotted q
    eq2 = re.search(r'<div class="math" data-key="equation\[q2\]">.*?</div>', cart_html, re.S).group(0)
    root = ET.fromstring(math_elements(eq2)[0])
    texts = "".join(root.itertext())
    assert "\u00a8" in texts and "sin" in texts and "cos" in texts
    overs = root.findall(f".//{MATHML}mover")
    assert overs and all(o.get("accent") == "true" for o in overs)


def test_markdown_has_the_latex_of_each_equation(cart):
    md = cart.to_markdown()
    assert md.startswith("# Lagrange's equations of cart-pendulum")
    titles = re.findall(r"^## (.*)$", md, re.M)
    assert titles == [s.title for s in cart.sections]
    assert md.count("$$") % 2 == 0 and md.count("$$") > 60
    assert "\\ddot{q}_{2}" in md and "\\frac{\\partial L}{\\partial \\dot{q}_{1}}" in md


@pytest.mark.subprocess
def test_latex_is_a_complete_document_that_compiles(cart, tmp_path):
    tex = cart.to_latex()
    assert tex.startswith("\\documentclass") and tex.rstrip().endswith("\\end{document}")
    assert tex.count("\\[") == tex.count("\\]") > 30
    assert tex.isascii()
    latex = shutil.which("pdflatex")
    if latex is None:
        pytest.skip("pdflatex is not installed (apt-get install texlive-latex-base): the .tex was checked "
                    "but not compiled")
    (tmp_path / "cart.tex").write_text(tex)
    run = subprocess.run([latex, "-interaction=nonstopmode", "-halt-on-error", "cart.tex"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-3000:]
    assert (tmp_path / "cart.pdf").stat().st_size > 10_000


def test_save_by_suffix(cart, tmp_path):
    for name, start in (("r.html", "<!DOCTYPE html>"), ("r.md", "# Lagrange"), ("r.tex", "\\documentclass")):
        cart.save(tmp_path / name)
        assert (tmp_path / name).read_text().startswith(start)
    assert format_of("a/b.HTM") == "html" and format_of("x.markdown") == "markdown"
    with pytest.raises(ValueError, match="r.pdf: cannot tell the report format from the suffix '.pdf'; "
                                         "use .html, .md or .tex"):
        cart.save(tmp_path / "r.pdf")
    with pytest.raises(ValueError, match="unknown report format 'docx': use html, markdown \\(md\\) or latex"):
        cart.render("docx")


@pytest.mark.slow
def test_pendulum_chain_4_finishes_and_prints_everything():
    rep = lg.report("pendulum-chain-4")
    page = rep.to_html()
    assert "too large" not in page
    assert len(math_elements(page)) > 100
    assert rep.math("equation[theta4]").rhs == 0


# ---------------------------------------------------------------------- CLI
@pytest.mark.slow
def test_cli_report_writes_each_format(tmp_path, capsys):
    for suffix in ("html", "md", "tex"):
        out = tmp_path / f"cart.{suffix}"
        assert main(["report", "cart-pendulum", "-o", str(out), "--no-equilibria"]) == 0
        assert f"wrote the report of cart-pendulum (11 sections, {suffix}) to {out}" in capsys.readouterr().out
        assert out.stat().st_size > 5000
    assert main(["report", "cart-pendulum", "-o", "-", "--format", "md", "--title", "Cart", "--no-equilibria"]) == 0
    assert capsys.readouterr().out.startswith("# Cart\n")


@pytest.mark.parametrize("argv, message", [
    (["report", "cart-pendulum", "-o", "{tmp}/cart.pdf"],
     "lagrangian report: error: --output {tmp}/cart.pdf: cannot tell the report format from the file name; "
     "end it in .html, .md or .tex, or give --format html, md or tex"),
    (["report", "cart-pendulum", "-o", "-"],
     "lagrangian report: error: --output -: give --format html, md or tex to write the report to stdout"),
    (["report", "cart-pendulum", "-o", "{tmp}/missing/cart.html"],
     "lagrangian report: error: --output {tmp}/missing/cart.html: the folder {tmp}/missing does not exist; "
     "create it or choose another path"),
    (["report", "cart-pendulum", "-o", "{tmp}"],
     "lagrangian report: error: --output {tmp}: it is a directory; give a file name such as {tmp}/report.html"),
    (["report", "cart-pendulm", "-o", "{tmp}/cart.html"],
     "lagrangian report: error: 'cart-pendulm' is neither a model file nor a built-in example. "
     "Did you mean 'cart-pendulum'?"),
])
def test_cli_report_errors(tmp_path, capsys, argv, message):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    if argv[-1] == str(tmp_path):  # a directory: the format is given so that the folder check speaks
        argv += ["--format", "html"]
    assert main(argv) == 2
    assert message.replace("{tmp}", str(tmp_path)) in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_cli_report_needs_an_output(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["report", "cart-pendulum"])
    assert exc.value.code == 2
    assert "the following arguments are required: --output/-o" in capsys.readouterr().err


# ------------------------------------------------------------------ browser
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--hide-scrollbars", "--window-size=1200,2400"]

LAYOUT_PROBE = """<script>
(function () {
  const box = e => { const r = e.getBoundingClientRect(); return [r.left, r.top, r.width, r.height]; };
  const math = [...document.querySelectorAll('math')].map(m => box(m).concat([m.getAttribute('display') || 'inline']));
  const frac = [...document.querySelectorAll('mfrac')].map(f => [box(f.children[0]), box(f.children[1])]);
  const sup = [...document.querySelectorAll('msup')].map(s => [box(s.children[0]), box(s.children[1])]);
  const pre = document.createElement('pre');
  pre.id = 'layout';
  pre.textContent = JSON.stringify({math: math, frac: frac, sup: sup});
  document.body.appendChild(pre);
})();
</script>"""


@pytest.fixture(scope="module")
def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    pytest.skip("no chromium on this machine (Debian: apt-get install chromium): the browser rendering "
                "test of the HTML report needs it")


def run_chromium(chromium, tmp_path, *args):
    profile = tmp_path / "profile"
    run = subprocess.run([chromium, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *args],
                         capture_output=True, text=True, timeout=180)
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_browser_lays_out_the_mathml_and_the_screenshot_shows_equations(chromium, cart_html, tmp_path):
    from PIL import Image

    page = tmp_path / "cart.html"
    page.write_text(cart_html)
    probe = tmp_path / "probe.html"
    probe.write_text(cart_html.replace("</body>", LAYOUT_PROBE + "</body>"))
    dom = run_chromium(chromium, tmp_path, "--dump-dom", probe.as_uri())
    layout = json.loads(html.unescape(re.search(r'<pre id="layout">(.*?)</pre>', dom, re.S).group(1)))

    maths = layout["math"]
    assert len(maths) == len(math_elements(cart_html))
    assert all(w > 0 and h > 0 for _, _, w, h, _ in maths)
    # MathML really laid out: numerators above denominators, superscripts raised and smaller
    assert len(layout["frac"]) > 20
    for num, den in layout["frac"]:
        assert num[1] + num[3] <= den[1] + 1.0
    assert len(layout["sup"]) > 20
    for base, script in layout["sup"]:
        assert script[1] < base[1] + 0.5 * base[3] and script[1] + script[3] < base[1] + base[3]
    blocks = [m for m in maths if m[4] == "block"]
    assert max(h for _, _, _, h, _ in blocks) > 40  # matrices and fractions are taller than a line

    shot = tmp_path / "cart.png"
    run_chromium(chromium, tmp_path, f"--screenshot={shot}", page.as_uri())
    image = Image.open(shot).convert("L")
    assert image.size == (1200, 2400)
    visible = [m for m in blocks if m[1] + m[3] < 2400]
    assert len(visible) > 5
    for x, y, w, h, _ in visible:
        crop = image.crop((int(x), int(y), int(x + w) + 1, int(y + h) + 1))
        dark = sum(crop.histogram()[:110])
        assert dark > 40, f"no ink in the equation at {(x, y, w, h)}"
    lo, hi = image.getextrema()
    assert lo < 50 and hi > 240


# --------------------------------------------- issue 10: the velocities are shown with their dots
DOTTED_Q = '<mover accent="true"><mi>q</mi><mo>&#729;</mo></mover>'


def test_section_2_shows_the_velocities(cart, cart_html):
    block = cart.math("q_dot")
    assert block.lhs == S("q_dot") and list(block.rhs) == [q1d, q2d]
    html_block = re.search(r'<div class="math" data-key="q_dot">(.*?)</div>', cart_html, re.S).group(1)
    assert html_block.count(DOTTED_Q) == 3  # q_dot = [q1_dot, q2_dot]
    assert "\\dot{q} = \\left[\\begin{matrix}\\dot{q}_{1}\\\\\\dot{q}_{2}\\end{matrix}\\right]" in cart.to_markdown()


def test_chain_rule_multiplies_by_the_velocities(cart, cart_html):
    rule = next(p for p in cart.section("kinematics").blocks[0].parts if isinstance(p, sympy.Basic))
    assert {s.name for s in rule.free_symbols} >= {"q_j_dot", "q_j"}
    section = cart_html[cart_html.index('<section id="kinematics">'):]
    first = section[:section.index("</p>")]
    assert f"<msub>{DOTTED_Q}<mi>j</mi></msub>" in first
    assert "\\sum_{j=1}^{n} \\dot{q}_{j} \\frac{\\partial r}{\\partial q_{j}}" in cart.to_markdown()


ACCENT_PROBE = """<script>
(function () {
  const box = e => { const r = e.getBoundingClientRect(); return [r.width, r.height]; };
  const sel = '#coordinates mover[accent="true"], #kinematics p mover[accent="true"]';
  const acc = [...document.querySelectorAll(sel)].map(m => [box(m.children[0]), box(m.children[1])]);
  const pre = document.createElement('pre');
  pre.id = 'accents';
  pre.textContent = JSON.stringify(acc);
  document.body.appendChild(pre);
})();
</script>"""


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.subprocess
def test_browser_draws_the_dots_large_enough_to_see(chromium, cart_html, tmp_path):
    # Latin Modern Math's dot accent is two pixels high at text size: the velocities looked
    # like the coordinates. The report's style sheet draws it larger.
    probe = tmp_path / "accents.html"
    probe.write_text(cart_html.replace("</body>", ACCENT_PROBE + "</body>"))
    dom = run_chromium(chromium, tmp_path, "--dump-dom", probe.as_uri())
    accents = json.loads(html.unescape(re.search(r'<pre id="accents">(.*?)</pre>', dom, re.S).group(1)))
    assert len(accents) >= 4  # q_dot, q1_dot, q2_dot in section 2, q_j_dot in the chain rule
    for (base_w, base_h), (dot_w, dot_h) in accents:
        assert base_h > 0 and dot_h >= 0.25 * base_h and dot_w >= 0.4 * base_w
