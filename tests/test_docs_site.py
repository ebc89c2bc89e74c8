"""The documentation site builds with `mkdocs build --strict` (every page in the nav, every link and
anchor valid, every docstring of the API reference rendered without a warning)."""

from __future__ import annotations

import html
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    for module in ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python"):
        if importlib.util.find_spec(module.split(".")[0]) is None:
            pytest.skip(f"{module} is not installed (pip install -e '.[docs]'): the site cannot be built")
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
                          str(ROOT / "mkdocs.yml"), "--site-dir", str(out)],
                         capture_output=True, text=True, timeout=300, env=env, cwd=ROOT)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-6000:]
    assert "WARNING" not in run.stderr
    return out


def nav_pages() -> list[str]:
    return re.findall(r"^\s+- [^:]+: (\S+\.md)\s*$", (ROOT / "mkdocs.yml").read_text(), re.M)


@pytest.mark.slow
@pytest.mark.subprocess
def test_every_nav_page_is_built(site):
    pages = nav_pages()
    assert {"index.md", "getting-started.md", "model-files.md", "report.md", "api.md"} <= set(pages)
    for page in pages:
        built = site / ("index.html" if page == "index.md" else f"{page[:-3]}/index.html")
        assert built.is_file(), page


@pytest.mark.subprocess
def test_api_reference_renders_the_public_api(site):
    import lagrangian as lg

    api = (site / "api" / "index.html").read_text()
    documented = set(re.findall(r'id="lagrangian\.([A-Za-z_]+)"', api))
    public = {name for name in lg.__all__ if not name[0].islower() or callable(getattr(lg, name))}
    maths = {"sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "exp", "log",
             "sqrt", "Abs", "sign", "pi", "t"}
    errors = {name for name in public if name.endswith("Error")}
    missing = public - maths - errors - documented
    assert not missing, f"public names missing from docs/api.md: {sorted(missing)}"
    assert "The derivation report of a model, step by step." in api


def text_of(page: Path) -> str:
    return html.unescape(re.sub(r"<[^>]+>", "", page.read_text()))


@pytest.mark.subprocess
def test_the_report_page_and_its_picture(site):
    assert "lagrangian report cart-pendulum -o cart.html" in text_of(site / "report" / "index.html")
    assert (site / "images" / "report-cart-pendulum.png").stat().st_size > 10_000


@pytest.mark.subprocess
def test_the_gallery_pictures_are_published(site):
    if not (ROOT / "docs" / "gallery.md").is_file():
        pytest.skip("docs/gallery.md is not written yet")
    page = (site / "gallery" / "index.html").read_text()
    pictures = re.findall(r'<img[^>]+src="([^"]+)"', page)
    assert pictures
    for src in pictures:
        assert (site / "gallery" / src).resolve().is_file(), src
