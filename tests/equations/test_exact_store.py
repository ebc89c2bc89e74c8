"""The diagnoses' exact parameter values (equations._singular.exact_number: sympy.nsimplify, 20 to 35 ms
for values such as 0.0603) kept on disk for the next process: the same numbers as nsimplify's, read back
only as checked JSON, and a file that is not what lagrangian writes is ignored."""

from __future__ import annotations

import json

import pytest
import sympy

from lagrangian.equations import _singular


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    """A process that has read no stored numbers yet, with its cache folder in tmp_path."""
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_singular, "_STORED", None)
    _singular._exact_number.cache_clear()
    yield tmp_path
    _singular._exact_number.cache_clear()


def _new_process(monkeypatch):
    monkeypatch.setattr(_singular, "_STORED", None)
    _singular._exact_number.cache_clear()


VALUES = [0.0603, 0.3141592653589793, -0.00756, 9.81, 2.0, 0.0, 1e-300, 1.5e20]


def test_stored_exact_numbers_are_nsimplify_s(fresh, monkeypatch):
    want = [sympy.nsimplify(v) for v in VALUES]
    got = [_singular.exact_number(v) for v in VALUES]
    assert got == want and [type(x) for x in got] == [type(x) for x in want]
    path = _singular._exact_numbers_path()
    assert path.parent == fresh and path.is_file()
    stored = json.loads(path.read_text())
    assert stored[(0.0603).hex()] == [603, 10000]
    assert stored[(0.3141592653589793).hex()] == [314159265358979, 1000000000000000]  # nsimplify's, not pi/10
    assert want[6] == 0 and (1e-300).hex() not in stored  # nsimplify's 0 is not the value: not kept
    _new_process(monkeypatch)
    calls = []
    monkeypatch.setattr(_singular.sympy, "nsimplify", lambda v, *a, **k: calls.append(v) or sympy.Integer(7))
    again = [_singular.exact_number(v) for v in VALUES if v.hex() in stored]
    assert again == [w for v, w in zip(VALUES, want) if v.hex() in stored] and not calls  # read, not computed
    assert _singular.exact_number(float("nan")) == 7 and calls  # not a finite float: never stored


@pytest.mark.parametrize("text", [
    "not json", "[1, 2]", '{"0x1.eccccccccccccp-5": "__import__(\'os\')"}',
    '{"0x1.eccccccccccccp-5": [1]}', '{"0x1.eccccccccccccp-5": [1, 0]}', '{"0x1.eccccccccccccp-5": [1.5, 2]}',
    '{"0x1.eccccccccccccp-5": [true, 2]}', '{"0x1.eccccccccccccp-5": [1' + "0" * 40 + ', 2]}',
    '{"1e5; rm -rf": [1, 2]}', "[" * 100000 + "]" * 100000,
])
def test_a_stored_file_that_is_not_ours_is_ignored(fresh, text):
    _singular._exact_numbers_path().write_text(text)
    assert _singular.exact_number(0.0603) == sympy.Rational(603, 10000)
    assert _singular._stored_exact_numbers()[(0.0603).hex()] == (603, 10000)  # the file rewritten


def test_a_stored_number_changed_on_disk_is_computed_again(fresh, monkeypatch):
    """An entry that is not the value to 1e-14 (nsimplify's are, to 1e-15) is not used."""
    _singular._exact_numbers_path().write_text(json.dumps({(0.0603).hex(): [1, 3], (0.3).hex(): [3, 10]}))
    assert _singular.exact_number(0.0603) == sympy.Rational(603, 10000)
    assert json.loads(_singular._exact_numbers_path().read_text())[(0.0603).hex()] == [603, 10000]
    calls = []
    monkeypatch.setattr(_singular.sympy, "nsimplify", lambda v, *a, **k: calls.append(v) or sympy.Integer(7))
    assert _singular.exact_number(0.3) == sympy.Rational(3, 10) and not calls  # a good entry is read


def test_a_huge_stored_file_is_not_read(fresh, monkeypatch):
    monkeypatch.setattr(_singular, "_STORED_BYTES", 10)
    _singular._exact_numbers_path().write_text(json.dumps({(0.0603).hex(): [1, 3]}))
    assert _singular.exact_number(0.0603) == sympy.Rational(603, 10000)


def test_an_unwritable_cache_folder_only_costs_time(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(blocker / "cache"))  # under a file: cannot be made
    monkeypatch.setattr(_singular, "_STORED", None)
    _singular._exact_number.cache_clear()
    try:
        assert _singular.exact_number(0.0603) == sympy.Rational(603, 10000)
    finally:
        _singular._exact_number.cache_clear()
