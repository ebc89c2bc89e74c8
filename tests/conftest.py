import sympy
import pytest


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
