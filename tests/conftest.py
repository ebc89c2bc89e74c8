import sys
from pathlib import Path

import sympy
import pytest

# The tests live in folders that mirror the package (tests/numeric/ for lagrangian/numeric, ...). Some
# import helpers of others across folders (test_crosscheck_sympy.check, serve_support.Server): every folder is
# on the import path, as pytest puts each test file's own. The folders have no __init__.py, so the file
# names are unique across them (pytest says so when they are not).
HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(d) for d in sorted(HERE.iterdir())
                if d.is_dir() and d.name not in ("models", "__pycache__") and not d.name.startswith(".")]

pytest_plugins = ["pytester"]  # tests/test_quick_selection.py runs pytest on small projects

# The markers that --quick leaves out (registered, with what each means, in pyproject.toml).
QUICK_LEAVES_OUT = ("slow", "browser", "network", "subprocess")


def pytest_addoption(parser):
    parser.addoption("--quick", action="store_true", default=False,
                     help="the quick selection: leave out the tests marked " + ", ".join(QUICK_LEAVES_OUT)
                          + " (python -m pytest alone runs every test)")


def pytest_collection_modifyitems(config, items):
    if not config.getoption("quick"):
        return
    kept, left_out = [], []
    for item in items:
        (left_out if any(item.get_closest_marker(m) for m in QUICK_LEAVES_OUT) else kept).append(item)
    if left_out:
        config.hook.pytest_deselected(items=left_out)
        items[:] = kept


def assert_same(actual, expected, msg=""):
    """Symbolic equality: the simplified difference is zero (scalars or matrices)."""
    a, e = sympy.sympify(actual), sympy.sympify(expected)
    if isinstance(a, sympy.MatrixBase) or isinstance(e, sympy.MatrixBase):
        a, e = sympy.Matrix(a), sympy.Matrix(e)
        assert a.shape == e.shape, f"{msg}: shapes {a.shape} != {e.shape}"
        diff = (a - e).applyfunc(lambda x: sympy.simplify(sympy.expand_trig(x)))
        assert diff == sympy.zeros(*a.shape), f"{msg}: difference {diff}"
    else:
        diff = sympy.simplify(sympy.expand_trig(a - e))
        assert diff == 0, f"{msg}: {a} != {e} (difference {diff})"


@pytest.fixture
def same():
    return assert_same
