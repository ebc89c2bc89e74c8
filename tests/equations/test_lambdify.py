"""equations._lambdify: SymEngine's LLVM Lambdify, its code kept on disk and loaded by the next call
(the same function, the same numbers bit for bit); what would not define the function exactly, and
entries that are not what it writes, are never used."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import symengine as se

from lagrangian.equations import _lambdify
from lagrangian.equations._lambdify import lambdify

if type(se.Lambdify([se.Symbol("x")], [se.Symbol("x")], real=True, cse=True)).__name__ != "LLVMDouble":
    pytest.skip("SymEngine without LLVM: nothing is kept", allow_module_level=True)

x, y, z = se.symbols("x y z")
EXPRS = [se.sin(x) * y + se.cos(x * y) ** 2, (x + y) ** 3 / (1 + z ** 2), se.sqrt(1 + x ** 2) * se.Rational(3, 7)]


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(_lambdify, "_WORTH_KEEPING", 0)  # these small functions are kept too
    return tmp_path / "lambdify"


def _no_compile(monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("compiled again")

    monkeypatch.setattr(_lambdify.se, "Lambdify", refuse)


def _points():
    return np.random.default_rng(0).uniform(-3, 3, (50, 3))


def test_kept_and_loaded_with_the_same_numbers(cache, monkeypatch):
    fresh = lambdify([x, y, z], EXPRS)
    direct = se.Lambdify([x, y, z], EXPRS, cse=True, real=True)
    assert len(list(cache.iterdir())) == 1
    _no_compile(monkeypatch)
    loaded = lambdify([x, y, z], EXPRS)
    for row in _points():
        a, b, c = (np.asarray(f(row)) for f in (fresh, loaded, direct))
        assert np.array_equal(a, b) and np.array_equal(a, c)
    assert np.array_equal(np.asarray(loaded(_points())), np.asarray(direct(_points())))


def test_another_function_is_another_entry(cache):
    lambdify([x, y, z], EXPRS)
    other = lambdify([x, y, z], [EXPRS[0] + 1, *EXPRS[1:]])  # one term more
    renamed = lambdify([y, x, z], EXPRS)  # the arguments in another order
    assert len(list(cache.iterdir())) == 3
    p = np.array([0.3, -1.2, 2.0])
    assert np.asarray(other(p))[0] == pytest.approx(np.asarray(se.Lambdify([x, y, z], EXPRS, real=True)(p))[0] + 1)
    assert np.asarray(renamed(p))[0] == pytest.approx(float(EXPRS[0].subs({x: -1.2, y: 0.3})))


def test_floats_are_keys_by_their_exact_value(cache, monkeypatch):
    """SymEngine prints 15 digits: 1/3 and the next float print alike, and are two entries."""
    third = 1 / 3
    near = np.nextafter(third, 1.0)
    assert str(se.RealDouble(third)) == str(se.RealDouble(near))
    f = lambdify([x], [x * se.RealDouble(third) + se.RealDouble(9.81)])
    g = lambdify([x], [x * se.RealDouble(near) + se.RealDouble(9.81)])
    assert len(list(cache.iterdir())) == 2
    _no_compile(monkeypatch)
    f2 = lambdify([x], [x * se.RealDouble(third) + se.RealDouble(9.81)])
    g2 = lambdify([x], [x * se.RealDouble(near) + se.RealDouble(9.81)])
    p = np.array([3.0e15])
    assert np.asarray(f2(p))[0] == np.asarray(f(p))[0] == 3.0e15 * third + 9.81
    assert np.asarray(g2(p))[0] == np.asarray(g(p))[0] == 3.0e15 * near + 9.81
    assert np.asarray(f2(p))[0] != np.asarray(g2(p))[0]


@pytest.mark.parametrize("names", [["x0", "y"], ["x12", "y"], ["_float_0x1p-2", "y"]])
def test_names_like_the_eliminations_are_not_kept(cache, names):
    a, b = (se.Symbol(n) for n in names)
    f = lambdify([a, b], [se.sin(a * b) + se.sin(a * b) ** 2, a])
    assert not cache.exists() or not list(cache.iterdir())
    assert np.asarray(f(np.array([0.5, 2.0])))[1] == 0.5


def test_a_name_that_is_code_is_not_kept(cache):
    weird = se.Symbol("__import__('os')")
    f = lambdify([weird, x], [weird * x + 1])
    assert not cache.exists() or not list(cache.iterdir())
    assert np.asarray(f(np.array([2.0, 3.0])))[0] == 7.0


def _entry(cache):
    (path,) = list(cache.iterdir())
    return path


@pytest.mark.parametrize("tamper", ["code", "sha", "shape", "not json", "empty", "huge header"])
def test_an_entry_not_as_written_is_compiled_again(cache, monkeypatch, tamper):
    lambdify([x, y, z], EXPRS)
    path = _entry(cache)
    head, _, code = path.read_bytes().partition(b"\n")
    header = json.loads(head)
    if tamper == "code":
        data = head + b"\n" + code[:-1] + bytes([code[-1] ^ 1])
    elif tamper == "sha":
        header["sha256"] = "0" * 64
        data = json.dumps(header).encode() + b"\n" + code
    elif tamper == "shape":
        header["shape"][1] = 7
        data = json.dumps(header).encode() + b"\n" + code
    elif tamper == "not json":
        data = b"{'shape': \n" + code
    elif tamper == "empty":
        data = b""
    else:
        data = b"[" * 100000 + b"\n" + code
    path.write_bytes(data)
    calls = []
    real = _lambdify.se.Lambdify
    monkeypatch.setattr(_lambdify.se, "Lambdify", lambda *a, **k: calls.append(1) or real(*a, **k))
    f = lambdify([x, y, z], EXPRS)
    assert calls == [1]
    p = np.array([0.1, 0.2, 0.3])
    assert np.array_equal(np.asarray(f(p)), np.asarray(real([x, y, z], EXPRS, cse=True, real=True)(p)))


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX permissions")
def test_an_entry_others_may_write_is_not_read(cache, monkeypatch):
    lambdify([x, y, z], EXPRS)
    path = _entry(cache)
    os.chmod(path, 0o666)
    calls = []
    real = _lambdify.se.Lambdify
    monkeypatch.setattr(_lambdify.se, "Lambdify", lambda *a, **k: calls.append(1) or real(*a, **k))
    lambdify([x, y, z], EXPRS)
    assert calls == [1]


def test_a_link_is_not_followed(cache, monkeypatch, tmp_path):
    lambdify([x, y, z], EXPRS)
    path = _entry(cache)
    target = tmp_path / "elsewhere.bin"
    path.rename(target)
    path.symlink_to(target)
    calls = []
    real = _lambdify.se.Lambdify
    monkeypatch.setattr(_lambdify.se, "Lambdify", lambda *a, **k: calls.append(1) or real(*a, **k))
    lambdify([x, y, z], EXPRS)
    assert calls == [1]


def test_a_small_function_is_not_kept(tmp_path, monkeypatch):
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path))
    f = lambdify([x, y], [x * y + 1])
    assert not (tmp_path / "lambdify").exists()
    assert np.asarray(f(np.array([2.0, 3.0])))[0] == 7.0


def test_an_unwritable_folder_only_costs_time(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(blocker / "cache"))  # under a file: cannot be made
    f = lambdify([x, y, z], EXPRS)
    g = lambdify([x, y, z], EXPRS)
    p = np.array([0.1, 0.2, 0.3])
    assert np.array_equal(np.asarray(f(p)), np.asarray(g(p)))


def test_the_constrained_model_loads_its_code(cache, monkeypatch):
    """The bicycle's saddle-point parts (M, f, G, c): compiled once, then loaded by a new Equations."""
    import lagrangian as lg
    from lagrangian.numeric._compiled import compile_equations
    from lagrangian.numeric._constrained import constrained_model

    model = lg.load("rolling-disk")
    eqs = lg.derive(model)
    cm = constrained_model(eqs, compile_equations(eqs))
    rng = np.random.default_rng(3)
    args = rng.uniform(-1, 1, (4, 1 + 2 * eqs.n + len(eqs.inputs) + len(eqs.parameters)))
    before = np.asarray(cm._parts(args))
    _no_compile(monkeypatch)
    again = lg.derive(model)
    cm2 = constrained_model(again, compile_equations(again))
    assert cm2 is not cm
    assert np.array_equal(np.asarray(cm2._parts(args)), before)


@pytest.mark.parametrize("name, constant", [("pi", se.pi), ("E", se.E)])
def test_an_argument_named_like_a_constant_is_not_the_constant(cache, name, constant):
    """An argument `pi` prints as the constant pi does ("pi"): the key names the arguments by their place,
    so the function that returns the argument and the one that returns the constant are two entries, each
    with its own number."""
    a = se.Symbol(name)
    assert str(a) == str(constant)
    f = lambdify([a, x], [constant, 2 * x])
    g = lambdify([a, x], [a, 2 * x])
    assert len(list(cache.iterdir())) == 2
    f2, g2 = lambdify([a, x], [constant, 2 * x]), lambdify([a, x], [a, 2 * x])  # loaded
    p = np.array([10.0, 0.5])
    assert np.asarray(f2(p))[0] == np.asarray(f(p))[0] == float(constant)
    assert np.asarray(g2(p))[0] == np.asarray(g(p))[0] == 10.0
