"""The example notebooks run from top to bottom in a fresh kernel (their own asserts check results)."""

import pathlib

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel", reason="ipykernel is needed to run the notebooks (pip install 'lagrangian[test]')")

NOTEBOOKS = sorted((pathlib.Path(__file__).parent.parent / "notebooks").glob("*.ipynb"))

# a notebook that needs an optional package: (module, why), skipped with that reason where it is missing
REQUIRES = {"cart-pole-swing-up": ("casadi", "the cart-pole swing-up needs CasADi's IPOPT "
                                             "(pip install 'lagrangian[optimal]')")}


def test_the_notebooks_are_there():
    assert [p.name for p in NOTEBOOKS] == ["cart-inverted-pendulum.ipynb", "cart-pendulum-control.ipynb",
                                          "cart-pole-swing-up.ipynb", "fit-pendulum.ipynb",
                                          "rotating-pendulum.ipynb"]
    assert set(REQUIRES) <= {p.stem for p in NOTEBOOKS}


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
@pytest.mark.slow
@pytest.mark.subprocess
def test_notebook_runs(path, tmp_path):
    if path.stem in REQUIRES:
        module, why = REQUIRES[path.stem]
        pytest.importorskip(module, reason=why)
    book = nbformat.read(path, as_version=4)
    assert all(not c.get("outputs") for c in book.cells if c.cell_type == "code"), "store notebooks without outputs"
    client = nbclient.NotebookClient(book, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    outputs = [o for c in book.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    html = [o["data"]["text/html"] for o in outputs if "data" in o and "text/html" in o["data"]]
    latex = [o["data"]["text/latex"] for o in outputs if "data" in o and "text/latex" in o["data"]]
    images = [o for o in outputs if "data" in o and "image/png" in o["data"]]
    assert any("lagrangian-animation" in h for h in html), "the animation shows inline"
    assert any(h.startswith("<div><b>Model ") for h in html), "the model shows as a table"
    assert any("Trajectory" in h for h in html) or path.stem == "rotating-pendulum"
    assert latex, "equations show as LaTeX"
    assert images, "figures show inline"
