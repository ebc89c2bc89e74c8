"""`python -m pytest --quick` (tests/conftest.py) leaves out exactly the tests marked slow, browser, network or
subprocess; `python -m pytest` alone runs them all; a marker that is not registered is an error."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
QUIET = ("-p", "no:benchmark")  # pytest-benchmark, where installed, runs git and hg at each start: not wanted here

FILE = '''
import pytest
{module_marker}


def test_kept_a():
    pass


@pytest.mark.slow
def test_slow():
    pass


@pytest.mark.browser
def test_browser():
    pass


@pytest.mark.network
def test_network():
    pass


@pytest.mark.subprocess
def test_subprocess():
    pass


@pytest.mark.parametrize("n", [1, 2])
def test_kept_b(n):
    pass
'''


def project(pytester, module_marker=""):
    """A copy of this suite's conftest.py and pytest settings around a test file with each marker."""
    pytester.makeconftest((ROOT / "tests" / "conftest.py").read_text())
    toml = (ROOT / "pyproject.toml").read_text()
    pytester.makefile(".toml", pyproject=toml[toml.index("[tool.pytest.ini_options]"):].replace(
        'testpaths = ["tests"]', 'testpaths = ["."]'))
    pytester.makepyfile(test_marked=FILE.format(module_marker=module_marker))


def test_quick_leaves_out_the_four_markers_and_the_full_run_keeps_them(pytester):
    project(pytester)
    quick = pytester.runpytest_inprocess("--quick", "-v", *QUIET)
    quick.assert_outcomes(passed=3, deselected=4)
    assert {line.split("::")[1].split(" ")[0] for line in quick.outlines if "PASSED" in line} == {
        "test_kept_a", "test_kept_b[1]", "test_kept_b[2]"}
    pytester.runpytest_inprocess(*QUIET).assert_outcomes(passed=7)


def test_a_marker_on_the_whole_file_leaves_out_the_whole_file(pytester):
    project(pytester, module_marker="pytestmark = pytest.mark.browser")
    pytester.runpytest_inprocess("--quick", *QUIET).assert_outcomes(deselected=7)
    pytester.runpytest_inprocess(*QUIET).assert_outcomes(passed=7)


def test_a_misspelt_marker_is_an_error(pytester):
    project(pytester)
    pytester.makepyfile(test_typo="import pytest\n\n@pytest.mark.slwo\ndef test_x():\n    pass\n")
    result = pytester.runpytest_inprocess("test_typo.py", *QUIET)
    assert result.ret != 0
    result.stdout.fnmatch_lines(["*'slwo' not found in `markers` configuration option*"])
