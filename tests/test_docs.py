"""The README's and the docs' examples do what they say."""

import re
from pathlib import Path

import pytest
import sympy

import lagrangian as lg
from lagrangian.io import loads_model

ROOT = Path(__file__).resolve().parents[1]
S = sympy.Symbol
q1, q2, q1d, q2d, q1dd, q2dd = (S(n) for n in ("q1", "q2", "q1_dot", "q2_dot", "q1_ddot", "q2_ddot"))
M1, M2, L, g, F = (S(n) for n in ("M1", "M2", "L", "g", "F"))
SLIDE_11_WITH_CART = (
    (M1 + M2) * q1dd - M2 * L * sympy.sin(q2) * q2dd - M2 * L * sympy.cos(q2) * q2d**2 - F,
    M2 * L**2 * q2dd - M2 * L * sympy.sin(q2) * q1dd + M2 * g * L * sympy.cos(q2),
)


def blocks(path, lang):
    return re.findall(rf"```{lang}\n(.*?)```", (ROOT / path).read_text(), re.S)


def check_cart(text):
    eqs = lg.derive(loads_model(text))
    for got, expected in zip(eqs.equations, SLIDE_11_WITH_CART):
        assert sympy.simplify(got - expected) == 0


def test_readme_model_file_gives_the_slides_equations():
    (toml,) = blocks("README.md", "toml")
    check_cart(toml)


def test_getting_started_cart_from_elements_and_from_energies():
    elements, energies = blocks("docs/getting-started.md", "toml")[:2]
    check_cart(elements)
    head = elements[: elements.index("[[particles]]")]
    check_cart(head + energies)


def test_readme_python_example_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    first, analysis = blocks("README.md", "python")
    namespace = {}
    exec(compile(first, "README.md", "exec"), namespace)  # our own README, not user input
    eqs = namespace["eqs"]
    assert eqs.mass_matrix == sympy.Matrix([[M1 + M2, -L * M2 * sympy.sin(q2)], [-L * M2 * sympy.sin(q2), L**2 * M2]])
    assert (tmp_path / "out.csv").read_text().startswith("t,q1,q2,q1_dot,q2_dot,F")
    report = lg.singularities(eqs)
    assert str(report.det_mass_matrix) == "L**2*M2*(M1 + M2*cos(q2)**2)"


def test_model_file_doc_error_example_is_current(tmp_path):
    doc = (ROOT / "docs/model-files.md").read_text()
    bad = doc[doc.index("```toml\ncoordinates") + 8: doc.index("```\n\ngives")]
    expected = doc[doc.index("gives\n\n```\n") + 11:]
    expected = expected[: expected.index("```")]
    path = tmp_path / "bad.toml"
    path.write_text(bad)
    try:
        lg.load(str(path))
    except lg.ModelFileError as exc:
        message = f"lagrangian derive: error: {exc}".replace(str(path), "bad.toml")
    assert message.strip() == expected.strip()


@pytest.mark.slow
def test_readme_analysis_example_runs(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the README's first block writes out.csv: here, not in the checkout
    first, analysis = blocks("README.md", "python")
    namespace = {}
    exec(compile(first + analysis, "README.md", "exec"), namespace)  # our own README, not user input
    out = capsys.readouterr().out
    assert "theta = acos(g/(Omega**2*l)) = 0.994407 [exists when g <= Omega**2*l]: stable" in out
    assert namespace["sweep"].critical_exact == (sympy.sqrt(g / S("l")),)
    assert namespace["lin"].stability == "unstable"
