"""End-to-end tests of the command-line interface (`lagrangian derive|simulate|check|examples`).

Most tests call :func:`lagrangian.cli.main` in-process and read stdout/stderr with capsys; a
few run the real console script (``python -m lagrangian`` and the ``lagrangian`` executable)
in a subprocess to check exit codes, the separation of stdout and stderr and the absence of a
traceback. Everything checked here is the public contract that users script against: the JSON
keys, the SymPy syntax of its strings, the CSV layout, the exit statuses (0 ok, 2 bad input,
1 failed computation) and the content of the messages.
"""

from __future__ import annotations

import csv
import io
import json
import math
import random

import numpy as np
import re
import shutil
import subprocess
import sys
import tomllib
from decimal import Decimal
from pathlib import Path

import pytest
import sympy

from cli_support import run_cli

# --------------------------------------------------------------------------- helpers


def assert_bad_input(rc, out, err, *needles):
    """Exit 2, nothing on stdout, a one-off message on stderr naming every needle, no traceback."""
    assert rc == 2, (rc, out, err)
    assert out == ""
    assert err.strip(), "an error message is expected on stderr"
    assert "Traceback" not in err
    for needle in needles:
        assert needle in err, f"{needle!r} not in stderr: {err!r}"


_CALL = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*(\()?")


def parse(text: str) -> sympy.Expr:
    """A SymPy-syntax string from the JSON output, every plain name a Symbol (I, E, S, N, beta ...
    are parameters here, not SymPy objects), functions and pi as SymPy's."""
    names = {m.group(1) for m in _CALL.finditer(text) if not m.group(2)} - {"pi"}
    return sympy.sympify(text, locals={n: sympy.Symbol(n) for n in names})


def is_zero(expr) -> bool:
    expr = sympy.sympify(expr)
    return expr == 0 or sympy.simplify(sympy.expand_trig(sympy.expand(expr))) == 0


def derive_json(capsys, model) -> dict:
    rc, out, err = run_cli(capsys, "derive", model, "--json")
    assert rc == 0, err
    assert err == ""
    return json.loads(out)  # one JSON object and nothing else


def read_csv(text: str):
    rows = list(csv.reader(io.StringIO(text)))
    header, body = rows[0], [[float(x) for x in row] for row in rows[1:] if row]
    return header, body


def column(header, body, name):
    i = header.index(name)
    return [row[i] for row in body]


def expected_times(t_end: str, dt: str) -> list[float]:
    """t = 0, dt, 2 dt, ... <= t_end, as the decimal numbers they denote."""
    T, d = Decimal(t_end), Decimal(dt)
    out, i = [], 0
    while i * d <= T:
        out.append(float(i * d))
        i += 1
    return out


def fixed_examples() -> list[str]:
    from lagrangian.examples import example_descriptions

    return [n for n in example_descriptions() if "<n>" not in n]


OSCILLATOR = """\
# Harmonic oscillator m x'' + k x = F: omega = sqrt(k/m) = 2 with the defaults.
name = "oscillator"
description = "harmonic oscillator"
coordinates = ["x"]
inputs = ["F"]

[parameters]
m = 1.0
k = 4.0

[energy]
T = "1/2*m*x_dot**2"
V = "1/2*k*x**2"

[forces]
x = "F"
"""


@pytest.fixture
def oscillator(tmp_path) -> Path:
    path = tmp_path / "oscillator.toml"
    path.write_text(OSCILLATOR)
    return path


# --------------------------------------------------------------------------- derive

CP = {n: sympy.Symbol(n) for n in ("q1 q2 q1_dot q2_dot q1_ddot q2_ddot M1 M2 L g F t".split())}


def test_derive_json_cart_pendulum_matches_textbook(capsys):
    d = derive_json(capsys, "cart-pendulum")
    q1, q2, q2_dot = CP["q1"], CP["q2"], CP["q2_dot"]
    q1_ddot, q2_ddot, M1, M2, L, g, F = (CP[n] for n in "q1_ddot q2_ddot M1 M2 L g F".split())
    assert d["coordinates"] == ["q1", "q2"]
    assert isinstance(d["mass_matrix"], list) and all(isinstance(r, list) for r in d["mass_matrix"])
    assert all(isinstance(x, str) for r in d["mass_matrix"] for x in r)
    assert all(isinstance(x, str) for x in d["forcing"] + d["equations"])
    M = sympy.Matrix([[parse(x) for x in row] for row in d["mass_matrix"]])
    expected = sympy.Matrix([[M1 + M2, -M2 * L * sympy.sin(q2)], [-M2 * L * sympy.sin(q2), M2 * L**2]])
    assert M.shape == (2, 2)
    assert all(is_zero(x) for x in M - expected), M
    eq = [parse(e) for e in d["equations"]]
    assert len(eq) == 2
    textbook1 = (M1 + M2) * q1_ddot - M2 * L * sympy.sin(q2) * q2_ddot - M2 * L * sympy.cos(q2) * q2_dot**2 - F
    assert is_zero(eq[0] - textbook1), eq[0]
    textbook2 = M2 * L**2 * q2_ddot - M2 * L * sympy.sin(q2) * q1_ddot + M2 * g * L * sympy.cos(q2)
    assert is_zero(eq[1] - textbook2), eq[1]
    free = set().union(*(e.free_symbols for e in eq)) | M.free_symbols
    assert {x.name for x in free} <= set(CP), free
    assert q1 not in free and sympy.Symbol("q1_dot") not in free  # cyclic cart position, no velocity term


# the bicycle takes 25 to 30 s on 2 cores, the other examples 1.3 s together: it is marked slow
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "whipple-bicycle" else n
                                  for n in fixed_examples() + ["pendulum-chain-3", "spring-mass-damper-chain-2"]])
def test_every_example_derives_and_equations_equal_M_qddot_minus_forcing(capsys, name):
    d = derive_json(capsys, name)
    coords = d["coordinates"]
    n = len(coords)
    assert n >= 1 and len(d["mass_matrix"]) == n and all(len(r) == n for r in d["mass_matrix"])
    assert len(d["forcing"]) == n and len(d["equations"]) == n
    M = sympy.Matrix([[parse(x) for x in row] for row in d["mass_matrix"]])
    f = [parse(x) for x in d["forcing"]]
    eqs = [parse(x) for x in d["equations"]]
    qdd = [sympy.Symbol(f"{q}_ddot") for q in coords]
    assert M == M.T, "the mass matrix is symmetric"
    # residual_i == sum_j M_ij q_ddot_j - forcing_i, checked at random points (fast for every model)
    symbols = set().union(*(e.free_symbols for e in eqs + f), M.free_symbols)
    allowed = set(coords) | {f"{q}_dot" for q in coords} | {f"{q}_ddot" for q in coords} | {"t"}
    allowed |= set(d.get("parameters", {})) | set(d.get("inputs", [])) | set(d["multipliers"])
    if "parameters" in d:
        assert {x.name for x in symbols} <= allowed, symbols - {sympy.Symbol(a) for a in allowed}
    # with constraints, the residuals also hold the constraint forces G^T lambda
    G = sympy.Matrix([[parse(x) for x in c["jacobian"]] for c in d["constraints"]]) if d["constraints"] else None
    lam = [sympy.Symbol(m) for m in d["multipliers"]]
    assert [c["multiplier"] for c in d["constraints"]] == d["multipliers"]
    symbols |= set().union(*(e.free_symbols for e in G)) if G is not None else set()
    # evaluated by SymEngine (SymPy's subs on the bicycle's forcing took minutes)
    import symengine as se

    args = sorted(symbols | set(qdd) | set(lam), key=str)
    residual = [sum(M[i, j] * qdd[j] for j in range(n)) - f[i] - sum(G[k, i] * lam[k] for k in range(len(lam)))
                for i in range(n)]
    lhs_f = se.Lambdify([se.Symbol(a.name) for a in args], [se.sympify(e) for e in eqs], cse=True)
    rhs_f = se.Lambdify([se.Symbol(a.name) for a in args], [se.sympify(e) for e in residual], cse=True)
    rng = random.Random(1234)
    for _ in range(3):
        point = [rng.uniform(0.3, 1.7) for _ in args]
        lhs, rhs = (np.asarray(fn(point), float).ravel() for fn in (lhs_f, rhs_f))
        for i in range(n):
            assert abs(lhs[i] - rhs[i]) <= 1e-9 * (1 + abs(lhs[i])), (name, i, lhs[i], rhs[i])
    # each residual depends on the accelerations only through M q_ddot: d residual_i / d q_ddot_j == M_ij
    diff_f = se.Lambdify([se.Symbol(a.name) for a in args],
                         [se.sympify(eqs[i]).diff(se.Symbol(qdd[j].name)) - se.sympify(M[i, j])
                          for i in range(n) for j in range(n)], cse=True)
    point = [rng.uniform(0.3, 1.7) for _ in args]
    assert np.max(np.abs(np.asarray(diff_f(point), float))) < 1e-9, name
    for i in range(n):
        assert not (f[i].free_symbols & set(qdd)), "the forcing has no accelerations"


def test_derive_cart_pendulum_energy_form_agrees_with_element_form(capsys):
    a, b = derive_json(capsys, "cart-pendulum"), derive_json(capsys, "cart-pendulum-energy")
    for ea, eb in zip(a["equations"], b["equations"], strict=True):
        assert is_zero(parse(ea) - parse(eb))


def test_derive_pendulum_chain_3_mass_matrix(capsys):
    d = derive_json(capsys, "pendulum-chain-3")
    assert d["coordinates"] == ["theta1", "theta2", "theta3"]
    m, l = sympy.symbols("m l")
    th = sympy.symbols("theta1:4")
    M = sympy.Matrix([[parse(x) for x in row] for row in d["mass_matrix"]])
    for i in range(3):
        for j in range(3):
            expected = m * l**2 * (3 - max(i, j)) * sympy.cos(th[i] - th[j])
            assert is_zero(M[i, j] - expected), (i, j, M[i, j])


def test_derive_spring_mass_damper_chain_2(capsys):
    d = derive_json(capsys, "spring-mass-damper-chain-2")
    assert d["coordinates"] == ["x1", "x2"]
    m, k, c, F, x1, x2, v1, v2 = sympy.symbols("m k c F x1 x2 x1_dot x2_dot")
    M = sympy.Matrix([[parse(x) for x in row] for row in d["mass_matrix"]])
    assert all(is_zero(x) for x in M - sympy.diag(m, m))
    f = [parse(x) for x in d["forcing"]]
    assert is_zero(f[0] - (-2 * k * x1 + k * x2 - 2 * c * v1 + c * v2))
    assert is_zero(f[1] - (k * x1 - 2 * k * x2 + c * v1 - 2 * c * v2 + F))


def test_derive_text_prints_the_equations(capsys):
    rc, out, err = run_cli(capsys, "derive", "cart-pendulum")
    assert rc == 0 and err == ""
    assert "cart-pendulum" in out
    for name in ("q1_ddot", "q2_ddot", "M1", "M2", "F"):
        assert name in out
    assert "= 0" in out


def test_derive_latex(capsys):
    rc, out, err = run_cli(capsys, "derive", "cart-pendulum", "--latex")
    assert rc == 0 and err == ""
    assert r"\begin{align}" in out and r"\end{align}" in out
    assert r"\ddot" in out
    assert "q1_ddot" not in out  # LaTeX, not the plain-text names


def test_derive_model_file_by_path(capsys, oscillator):
    d = derive_json(capsys, oscillator)
    assert d["coordinates"] == ["x"]
    m, k, F, x, xdd = sympy.symbols("m k F x x_ddot")
    assert is_zero(parse(d["mass_matrix"][0][0]) - m)
    assert is_zero(parse(d["forcing"][0]) - (F - k * x))
    assert is_zero(parse(d["equations"][0]) - (m * xdd + k * x - F))


def test_derive_json_and_latex_are_exclusive(capsys):
    rc, out, err = run_cli(capsys, "derive", "cart-pendulum", "--json", "--latex")
    assert_bad_input(rc, out, err)


# --------------------------------------------------------------------------- simulate


@pytest.mark.parametrize("t_end, dt", [("1", "0.05"), ("1", "0.3"), ("0.3", "0.1"), ("2.9", "0.1"),
                                       ("1", "0.07"), ("0.5", "1")])
def test_simulate_rows_and_time_column(capsys, t_end, dt):
    rc, out, err = run_cli(capsys, "simulate", "mck", "--t-end", t_end, "--dt", dt)
    assert rc == 0 and err == ""
    header, body = read_csv(out)
    assert header[:5] == ["t", "x1", "x2", "x1_dot", "x2_dot"]
    assert all(len(row) == len(header) for row in body)
    assert column(header, body, "t") == expected_times(t_end, dt)


def test_simulate_cart_pendulum_csv_header_rows_and_initial(capsys):
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", "1",
                           "--initial", "q1=0,q2=0.5,q2_dot=0", "--dt", "0.05")
    assert rc == 0 and err == ""
    header, body = read_csv(out)
    assert header[:5] == ["t", "q1", "q2", "q1_dot", "q2_dot"]
    assert len(body) == 21
    assert column(header, body, "t") == [i / 20 for i in range(21)]
    assert body[0][1:5] == [0.0, 0.5, 0.0, 0.0]


def test_simulate_initial_values_not_given_keep_the_model_files(capsys):
    # the model file's [simulation] has q2 = 1.4; --initial changes the values it names and keeps the others
    # (one rule for the API, the CLI, the exports and the playground; before issue 20 the others were 0 here)
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", "0.1", "--dt", "0.1",
                           "--initial", "q1_dot=0.25")
    assert rc == 0, err
    header, body = read_csv(out)
    assert body[0][1:5] == [0.0, 1.4, 0.25, 0.0]


def test_simulate_without_initial_uses_the_model_defaults(capsys):
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", "0.1", "--dt", "0.1")
    assert rc == 0, err
    header, body = read_csv(out)
    assert body[0][1:5] == [0.0, 1.4, 0.0, 0.0]


def test_simulate_output_dash_is_stdout(capsys):
    args = ("simulate", "mck", "--t-end", "0.5", "--dt", "0.1")
    rc1, out1, err1 = run_cli(capsys, *args)
    rc2, out2, err2 = run_cli(capsys, *args, "--output", "-")
    assert rc1 == rc2 == 0 and err1 == err2 == ""
    assert out1 == out2 and out1.startswith("t,x1,x2,x1_dot,x2_dot")


def test_simulate_oscillator_matches_closed_form(capsys, oscillator):
    rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "2", "--dt", "0.1", "--initial", "x=1")
    assert rc == 0, err
    header, body = read_csv(out)
    assert header[:3] == ["t", "x", "x_dot"]
    for t, x, v in zip(column(header, body, "t"), column(header, body, "x"), column(header, body, "x_dot")):
        assert x == pytest.approx(math.cos(2 * t), abs=1e-6)
        assert v == pytest.approx(-2 * math.sin(2 * t), abs=1e-6)


def test_simulate_param_changes_the_result(capsys, oscillator):
    rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "2", "--dt", "0.1",
                           "--initial", "x=1", "--param", "k=9")
    assert rc == 0, err
    header, body = read_csv(out)
    for t, x in zip(column(header, body, "t"), column(header, body, "x")):
        assert x == pytest.approx(math.cos(3 * t), abs=1e-6)


def test_simulate_input_time_function_matches_closed_form(capsys, oscillator):
    # x'' + 4 x = sin t, x(0) = 1, x'(0) = 0: x = cos 2t - sin(2t)/6 + sin(t)/3
    rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "2", "--dt", "0.1",
                           "--initial", "x=1", "--input", "F=sin(t)")
    assert rc == 0, err
    header, body = read_csv(out)
    for t, x in zip(column(header, body, "t"), column(header, body, "x")):
        assert x == pytest.approx(math.cos(2 * t) - math.sin(2 * t) / 6 + math.sin(t) / 3, abs=1e-6)
    if "F" in header:
        assert column(header, body, "F") == pytest.approx([math.sin(t) for t in column(header, body, "t")])


def test_simulate_initial_accepts_pi_over_2(capsys, oscillator):
    rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "1", "--dt", "0.5",
                           "--initial", "x=pi/2")
    assert rc == 0, err
    header, body = read_csv(out)
    assert body[0][1] == pytest.approx(math.pi / 2, abs=1e-15)
    assert column(header, body, "x") == pytest.approx([math.pi / 2 * math.cos(2 * t) for t in (0, 0.5, 1)],
                                                      abs=1e-6)


def test_simulate_backends_agree(capsys, oscillator):
    from lagrangian.numeric._cbackend import c_compiler

    outputs = {}
    for backend in ("auto", "numba", "scipy") + (("c",) if c_compiler() else ()):
        rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "2", "--dt", "0.5", "--initial", "x=1",
                               "--input", "F=sin(t)", "--backend", backend, "--rtol", "1e-10", "--atol", "1e-10")
        assert rc == 0, (backend, err)
        outputs[backend] = read_csv(out)
    header, body = outputs["scipy"]
    for backend, (h, b) in outputs.items():
        assert h == header
        assert column(h, b, "x") == pytest.approx(column(header, body, "x"), abs=1e-11)


def test_simulate_variational_method(capsys, oscillator):
    rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "1", "--dt", "0.25", "--initial", "x=1",
                           "--method", "variational", "--step", "0.001")
    assert rc == 0, err
    header, body = read_csv(out)
    assert column(header, body, "x") == pytest.approx([math.cos(2 * t) for t in (0, .25, .5, .75, 1)], abs=1e-5)


def test_simulate_bad_backend_is_refused(capsys, oscillator):
    rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "1", "--backend", "fortran")
    assert rc == 2
    assert "invalid choice: 'fortran'" in err and "Traceback" not in err
    rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "1", "--method", "variational",
                           "--backend", "scipy")
    assert rc == 2
    assert "method 'variational' runs in compiled code only" in err


def test_simulate_tolerances_and_method_are_accepted(capsys, oscillator):
    for extra in (["--rtol", "1e-11", "--atol", "1e-12"], ["--method", "Radau"], ["--method", "RK45"]):
        rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "1", "--dt", "0.25",
                               "--initial", "x=1", *extra)
        assert rc == 0, (extra, err)
        header, body = read_csv(out)
        assert column(header, body, "x") == pytest.approx([math.cos(2 * t) for t in (0, .25, .5, .75, 1)],
                                                          abs=1e-4)


def test_simulate_cart_pendulum_momentum_balance(capsys):
    # d/dt [(M1+M2) q1_dot - M2 L sin(q2) q2_dot] = F: with F = 1.5 sin(3t) from rest the
    # horizontal momentum is 0.5 (1 - cos 3t); without the input it stays 0.
    base = ("simulate", "cart-pendulum", "--t-end", "2", "--dt", "0.1", "--initial", "q1=0,q2=0.5,q2_dot=0")
    M1, M2, L = 1.0, 0.5, 1.0

    def momentum(out):
        header, body = read_csv(out)
        ts = column(header, body, "t")
        p = [(M1 + M2) * v1 - M2 * L * math.sin(q2) * v2 for q2, v1, v2 in
             zip(column(header, body, "q2"), column(header, body, "q1_dot"), column(header, body, "q2_dot"))]
        return ts, p, column(header, body, "q1")

    rc, out_free, err = run_cli(capsys, *base)
    assert rc == 0, err
    ts, p, q1_free = momentum(out_free)
    assert p == pytest.approx([0.0] * len(ts), abs=1e-6)

    rc, out_forced, err = run_cli(capsys, *base, "--input", "F=1.5*sin(3*t)")
    assert rc == 0, err
    ts, p, q1_forced = momentum(out_forced)
    assert p == pytest.approx([0.5 * (1 - math.cos(3 * t)) for t in ts], abs=1e-6)
    assert q1_forced != pytest.approx(q1_free, abs=1e-3)  # the input changes the motion

    rc, out_param, err = run_cli(capsys, *base, "--param", "M1=2")
    assert rc == 0, err
    assert momentum(out_param)[2] != pytest.approx(q1_free, abs=1e-3)


def test_simulate_mck_input_column_and_param(capsys):
    rc, out, err = run_cli(capsys, "simulate", "mck", "--t-end", "1", "--dt", "0.1")
    assert rc == 0, err
    header, body = read_csv(out)
    assert body[0][1:5] == [0.01, 0.0, 0.0, 0.0]  # initial = { x1 = 0.01 } in the model file
    if "f" in header:  # default input f = sin(5 t) from the model file
        assert column(header, body, "f") == pytest.approx([math.sin(5 * t) for t in column(header, body, "t")])
    rc, out2, err = run_cli(capsys, "simulate", "mck", "--t-end", "1", "--dt", "0.1", "--param", "k1=400,k2=10")
    assert rc == 0, err
    h2, b2 = read_csv(out2)
    assert column(h2, b2, "x1") != pytest.approx(column(header, body, "x1"), abs=1e-4)
    # at rest with no force, nothing moves
    rc, out3, err = run_cli(capsys, "simulate", "mck", "--t-end", "1", "--dt", "0.5", "--initial", "x1=0",
                            "--input", "f=0")
    assert rc == 0, err
    h3, b3 = read_csv(out3)
    assert [row[1:5] for row in b3] == [[0.0] * 4] * 3


def test_simulate_generated_examples(capsys):
    for name, coords in (("pendulum-chain-3", ["theta1", "theta2", "theta3"]),
                         ("spring-mass-damper-chain-2", ["x1", "x2"])):
        rc, out, err = run_cli(capsys, "simulate", name, "--t-end", "0.5", "--dt", "0.1")
        assert rc == 0, (name, err)
        header, body = read_csv(out)
        assert header[:1 + 2 * len(coords)] == ["t", *coords, *(f"{q}_dot" for q in coords)]
        assert len(body) == 6


def test_readme_main_job_derive_then_simulate_to_file(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc, out, err = run_cli(capsys, "derive", "cart-pendulum")
    assert rc == 0 and "q1_ddot" in out and err == ""
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--output", "out.csv")
    assert rc == 0 and err == ""
    text = (tmp_path / "out.csv").read_text()
    header, body = read_csv(text)
    assert header[:5] == ["t", "q1", "q2", "q1_dot", "q2_dot"]
    assert len(body) == 1001  # [simulation] t_end = 10, dt = 0.01
    m = re.search(r"wrote (\d+) rows", out)
    assert m and int(m.group(1)) == len(body)
    assert "t,q1" not in out  # the CSV went to the file, only the summary to stdout
    assert len(out.strip().splitlines()) == 1


def test_simulate_output_file_with_options(capsys, tmp_path):
    path = tmp_path / "sub.csv"
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", "1", "--initial", "q1=0,q2=0.5,q2_dot=0",
                           "--param", "M1=2", "--input", "F=1.5*sin(3*t)", "--dt", "0.05", "-o", path)
    assert rc == 0, err
    assert "wrote 21 rows" in out
    header, body = read_csv(path.read_text())
    assert len(body) == 21 and body[-1][0] == 1.0


# --------------------------------------------------------------------------- check


def test_check_massless_cart_is_singular(capsys):
    rc, out, err = run_cli(capsys, "check", "cart-pendulum-massless", "--json")
    assert rc == 0 and err == ""
    d = json.loads(out)
    assert d["singular"] is True
    L, M, q2 = sympy.symbols("L M q2")
    assert is_zero(parse(d["det_mass_matrix"]) - L**2 * M**2 * sympy.cos(q2) ** 2)


def test_check_cart_pendulum_is_regular(capsys):
    rc, out, err = run_cli(capsys, "check", "cart-pendulum", "--json")
    assert rc == 0 and err == ""
    d = json.loads(out)
    assert d["singular"] is False
    L, M1, M2, q2 = sympy.symbols("L M1 M2 q2")
    assert is_zero(parse(d["det_mass_matrix"]) - L**2 * M2 * (M1 + M2 * sympy.cos(q2) ** 2))


def test_check_text_massless_gives_cause_and_fix(capsys):
    rc, out, err = run_cli(capsys, "check", "cart-pendulum-massless")
    assert rc == 0 and err == ""
    assert "Likely cause" in out and "Fix" in out
    assert "det M" in out


def test_check_text_regular(capsys):
    rc, out, err = run_cli(capsys, "check", "cart-pendulum")
    assert rc == 0 and err == ""
    assert "Likely cause" not in out


# --------------------------------------------------------------------------- examples

REQUIRED_NAMES = ["cart-pendulum", "rotating-pendulum", "double-pendulum", "pendulum-chain-<n>",
                  "spring-mass-damper-chain-<n>", "cart-pendulum-massless", "mck"]


def test_examples_lists_every_name_with_a_description(capsys):
    rc, out, err = run_cli(capsys, "examples")
    assert rc == 0 and err == ""
    lines = out.strip().splitlines()
    listed = {line.split()[0]: line.split(None, 1)[1] for line in lines}
    for name in REQUIRED_NAMES:
        assert name in listed, name
    assert all(desc.strip() for desc in listed.values())
    rc, out_json, _ = run_cli(capsys, "examples", "--json")
    assert rc == 0
    desc = json.loads(out_json)
    assert isinstance(desc, dict) and set(desc) == set(listed)
    assert all(isinstance(v, str) and v and "\n" not in v for v in desc.values())


def test_examples_show_prints_a_model_file(capsys, tmp_path):
    rc, out, err = run_cli(capsys, "examples", "--show", "cart-pendulum")
    assert rc == 0 and err == ""
    data = tomllib.loads(out)
    assert data["coordinates"] == ["q1", "q2"]
    # the shown text is a model file that derives the same as the example
    path = tmp_path / "mine.toml"
    path.write_text(out)
    a, b = derive_json(capsys, path), derive_json(capsys, "cart-pendulum")
    assert a["mass_matrix"] == b["mass_matrix"] and a["equations"] == b["equations"]


def test_examples_show_generated(capsys):
    rc, out, err = run_cli(capsys, "examples", "--show", "pendulum-chain-3")
    assert rc == 0 and err == ""
    assert tomllib.loads(out)["coordinates"] == ["theta1", "theta2", "theta3"]


def test_examples_show_unknown(capsys):
    rc, out, err = run_cli(capsys, "examples", "--show", "cart-pendulm")
    assert_bad_input(rc, out, err, "cart-pendulm", "Did you mean", "cart-pendulum")


# --------------------------------------------------------------------------- help


@pytest.mark.parametrize("command", ["derive", "simulate", "check", "examples"])
def test_subcommand_help(capsys, command):
    rc, out, err = run_cli(capsys, command, "--help")
    assert rc == 0
    assert "Example" in out
    assert f"lagrangian {command}" in out


def _full_parser_commands():
    """{command: (its module, its sub-parser)} when every module registers its commands."""
    import argparse

    from lagrangian import cli

    out = {}
    for module in cli._command_modules():
        p = argparse.ArgumentParser(prog="lagrangian")
        sub = p.add_subparsers(dest="command", metavar="COMMAND")
        module.register(sub, argparse.RawDescriptionHelpFormatter)
        out.update({name: (module.__name__.rsplit(".", 1)[1], parser) for name, parser in sub.choices.items()})
    return out


def test_the_command_table_names_every_command_and_its_module():
    """cli.COMMANDS (a command line naming a command builds that command's module alone, issue 22)
    lists exactly the commands the modules register, each with its module."""
    from lagrangian import cli

    full = _full_parser_commands()
    assert {name: module for name, (module, _) in full.items()} == cli.COMMANDS, \
        "cli.COMMANDS must list every command with the module that registers it (a new command: add it there)"


def test_a_command_alone_parses_and_helps_as_with_every_command():
    """The parser built for one command (`lagrangian derive ...`) gives the same help and the same
    parse as the parser with every command."""
    import argparse

    from lagrangian import cli

    def sub_parser(parser, name):
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        return action.choices, action.choices[name]

    full = cli._parser(["--help"])
    for name in cli.COMMANDS:
        choices, alone = sub_parser(cli._parser([name]), name)
        assert list(choices) == [c for c, m in cli.COMMANDS.items() if m == cli.COMMANDS[name]]
        assert alone.format_help() == sub_parser(full, name)[1].format_help(), name
    argv = ["derive", "pendulum-chain-3", "--json"]
    assert vars(cli._parser(argv).parse_args(argv)) == vars(full.parse_args(argv))


def test_unknown_command_lists_every_command(capsys):
    rc, out, err = run_cli(capsys, "derivee", "cart-pendulum")
    assert rc == 2 and out == ""
    assert "invalid choice: 'derivee'" in err
    for command in ("derive", "simulate", "serve", "fit", "export"):
        assert f"'{command}'" in err


def test_top_level_help_and_version(capsys):
    rc, out, _ = run_cli(capsys, "--help")
    assert rc == 0
    for command in ("derive", "simulate", "check", "examples"):
        assert command in out
    assert "Example" in out
    rc, out, _ = run_cli(capsys, "--version")
    assert rc == 0 and out.startswith("lagrangian ")


# --------------------------------------------------------------------------- bad input: exit 2


def test_missing_file_names_it(capsys, tmp_path):
    missing = tmp_path / "no_such_model.toml"
    rc, out, err = run_cli(capsys, "derive", missing)
    assert_bad_input(rc, out, err, "no_such_model.toml")
    rc, out, err = run_cli(capsys, "simulate", "nope.toml", "--t-end", "1")
    assert_bad_input(rc, out, err, "nope.toml")


def test_unknown_example_did_you_mean(capsys):
    rc, out, err = run_cli(capsys, "derive", "cart-pendulm")
    assert_bad_input(rc, out, err, "cart-pendulm", "Did you mean", "'cart-pendulum'")
    rc, out, err = run_cli(capsys, "check", "zzzzzz")
    assert_bad_input(rc, out, err, "zzzzzz", "lagrangian examples")


def test_model_file_unknown_symbol_names_file_and_key(capsys, tmp_path):
    path = tmp_path / "bad_model.toml"
    path.write_text(OSCILLATOR.replace('V = "1/2*k*x**2"', 'V = "1/2*kk*x**2"'))
    for command in (["derive"], ["check"], ["simulate", "--t-end", "1"]):
        rc, out, err = run_cli(capsys, command[0], path, *command[1:])
        assert_bad_input(rc, out, err, "bad_model.toml", "energy.V", "kk")


def test_model_file_invalid_toml(capsys, tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text('coordinates = ["x"\n')
    rc, out, err = run_cli(capsys, "derive", path)
    assert_bad_input(rc, out, err, "broken.toml")


def test_model_path_is_a_directory(capsys, tmp_path):
    rc, out, err = run_cli(capsys, "derive", tmp_path)
    assert_bad_input(rc, out, err, str(tmp_path))


SIM = ("simulate", "cart-pendulum", "--t-end", "1")


@pytest.mark.parametrize("extra, needles", [
    (["--initial", "q9=1"], ["q9"]),
    (["--initial", "q2"], ["q2", "NAME=VALUE"]),
    (["--initial", "q2=abc"], ["q2", "abc", "not a number"]),
    (["--initial", "q2=nan"], ["q2"]),
    (["--param", "kk=2"], ["kk"]),
    (["--param", "M1=abc"], ["M1", "abc"]),
    (["--param", "M1"], ["M1"]),
    (["--input", "F=1.5*sin(3*t"], ["F", "1.5*sin(3*t"]),
    (["--input", "F=foo(t)"], ["foo"]),
    (["--input", "F=__import__('os')"], ["F"]),
    (["--input", "G=1"], ["G"]),
    (["--input", "F"], ["F"]),
    (["--method", "XYZ"], ["XYZ", "DOP853"]),
    (["--dt", "0"], ["dt"]),
    (["--dt", "-0.1"], ["dt"]),
    (["--rtol", "-1"], ["rtol"]),
    (["--bogus"], ["--bogus"]),
    (["--t-end", "abc"], ["abc"]),
])
def test_simulate_bad_input_exits_2(capsys, extra, needles):
    rc, out, err = run_cli(capsys, *SIM, *extra)
    assert_bad_input(rc, out, err, *needles)


def test_simulate_bad_t_end(capsys, oscillator):
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--t-end", "-1")
    assert_bad_input(rc, out, err, "--t-end must be a positive number, got -1; for example --t-end 10")
    rc, out, err = run_cli(capsys, "simulate", oscillator)  # no --t-end and no [simulation] t_end
    assert_bad_input(rc, out, err, "t_end")


def test_simulate_unknown_initial_name_lists_the_state(capsys):
    rc, out, err = run_cli(capsys, *SIM, "--initial", "q2_dto=1")
    assert_bad_input(rc, out, err, "q2_dto", "did you mean 'q2_dot'")


def test_simulate_unknown_initial_q9_did_you_mean(capsys):
    rc, out, err = run_cli(capsys, *SIM, "--initial", "q9=1")
    assert_bad_input(rc, out, err, "q9")
    assert "did you mean" in err.lower()


def test_simulate_initial_value_with_a_comma_inside_parentheses(capsys, oscillator):
    rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "0.5", "--dt", "0.5", "--initial", "x=atan2(1,2)")
    assert rc == 0, err
    header, body = read_csv(out)
    assert body[0][1] == pytest.approx(math.atan2(1, 2))


def test_model_file_atol_zero_is_accepted_consistently(capsys, tmp_path):
    path = tmp_path / "osc_atol0.toml"
    path.write_text(OSCILLATOR + "\n[simulation]\nt_end = 1.0\natol = 0\n")
    rc_derive, _, _ = run_cli(capsys, "derive", path)
    rc_sim, out, err = run_cli(capsys, "simulate", path, "--dt", "0.5")
    assert rc_derive == 2 or rc_sim == 0, err  # either the file is rejected up front, or it simulates


def test_simulate_unwritable_output(capsys, tmp_path):
    target = tmp_path / "no_dir" / "out.csv"
    rc, out, err = run_cli(capsys, "simulate", "mck", "--t-end", "0.1", "--output", target)
    assert_bad_input(rc, out, err, "out.csv")


def test_missing_model_argument_and_unknown_command(capsys):
    rc, out, err = run_cli(capsys, "derive")
    assert_bad_input(rc, out, err, "model")
    rc, out, err = run_cli(capsys, "frobnicate")
    assert_bad_input(rc, out, err, "frobnicate")


# --------------------------------------------------------------------------- failed computation: exit 1


def test_simulate_massless_cart_reaches_singular_configuration(capsys):
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum-massless", "--t-end", "5")
    assert rc == 1, err
    # the rows up to the failure are kept, marked as partial (tests/io/test_files_safety.py)
    assert out.startswith("# partial: the mass matrix became singular at t = ")
    assert "were written to stdout, marked as partial in the CSV's first line" in err
    assert "Traceback" not in err
    assert "singular" in err
    m = re.search(r"t = ([0-9.eE+-]+)", err)
    assert m and 0 < float(m.group(1)) < 5, err
    assert "Fix" in err and "det M" in err


def test_simulate_massless_cart_to_file_fails_with_exit_1(capsys, tmp_path):
    path = tmp_path / "massless.csv"
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum-massless", "--t-end", "5", "--output", path)
    assert rc == 1 and "singular" in err and "wrote" not in out


# --------------------------------------------------------------------------- the real console script


def _executable() -> str | None:
    found = shutil.which("lagrangian")
    if found:
        return found
    beside = Path(sys.executable).with_name("lagrangian")
    return str(beside) if beside.exists() else None


def _run(cmd, cwd=None):
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=cwd)


@pytest.fixture(scope="module")
def exe():
    path = _executable()
    if path is None:
        pytest.skip("the `lagrangian` console script is not installed")
    return path


@pytest.mark.subprocess
@pytest.mark.slow
def test_python_m_lagrangian_derive_json():
    p = _run([sys.executable, "-m", "lagrangian", "derive", "cart-pendulum", "--json"])
    assert p.returncode == 0, p.stderr
    assert p.stderr == ""
    assert json.loads(p.stdout)["coordinates"] == ["q1", "q2"]


@pytest.mark.subprocess
@pytest.mark.slow
def test_python_m_lagrangian_argparse_error():
    p = _run([sys.executable, "-m", "lagrangian", "simulate", "cart-pendulum", "--bogus"])
    assert p.returncode == 2
    assert p.stdout == ""
    assert "--bogus" in p.stderr and "Traceback" not in p.stderr


@pytest.mark.slow
@pytest.mark.subprocess
def test_console_script_readme_flow(exe, tmp_path):
    p = _run([exe, "simulate", "cart-pendulum", "--t-end", "1", "--dt", "0.1", "--output", "out.csv"], cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert p.stderr == ""
    assert re.search(r"wrote 11 rows", p.stdout)
    assert (tmp_path / "out.csv").read_text().startswith("t,q1,q2,q1_dot,q2_dot")


@pytest.mark.slow
@pytest.mark.subprocess
def test_console_script_csv_to_stdout_only(exe):
    p = _run([exe, "simulate", "mck", "--t-end", "0.2", "--dt", "0.1"])
    assert p.returncode == 0 and p.stderr == ""
    header, body = read_csv(p.stdout)
    assert header[0] == "t" and len(body) == 3


@pytest.mark.slow
@pytest.mark.subprocess
def test_console_script_bad_input(exe):
    p = _run([exe, "derive", "cart-pendulm"])
    assert p.returncode == 2 and p.stdout == ""
    assert "Did you mean 'cart-pendulum'" in p.stderr and "Traceback" not in p.stderr
    p = _run([exe, "simulate", "cart-pendulum", "--t-end", "1", "--initial", "q2=abc"])
    assert p.returncode == 2 and p.stdout == ""
    assert "abc" in p.stderr and "Traceback" not in p.stderr


@pytest.mark.slow
@pytest.mark.subprocess
def test_console_script_singular_simulation(exe):
    p = _run([exe, "simulate", "cart-pendulum-massless", "--t-end", "5"])
    assert p.returncode == 1
    assert p.stdout.startswith("# partial: the mass matrix became singular")  # the rows before it, marked
    assert "singular" in p.stderr and "Fix" in p.stderr and "Traceback" not in p.stderr


@pytest.mark.subprocess
@pytest.mark.slow
def test_console_script_help(exe):
    p = _run([exe, "check", "--help"])
    assert p.returncode == 0 and "Example" in p.stdout and p.stderr == ""


@pytest.mark.subprocess
@pytest.mark.slow
def test_console_script_closed_stdout_is_not_bad_input(exe):
    p = subprocess.Popen([exe, "check", "cart-pendulum-massless", "--json"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    p.stdout.close()  # the reader goes away before the CLI writes (it takes ~0.5 s to start)
    err = p.stderr.read()
    rc = p.wait(timeout=120)
    assert rc != 2 and "Broken pipe" not in err, (rc, err)


def test_family_size_out_of_range_says_the_range(capsys):
    rc, out, err = run_cli(capsys, "derive", "pendulum-chain-201")
    assert rc == 2
    assert "a pendulum-chain has 1 to 200 elements; choose n in that range, e.g. pendulum-chain-5" in err


def test_method_names_are_case_insensitive(capsys, oscillator):
    rc, out, err = run_cli(capsys, "simulate", oscillator, "--t-end", "0.5", "--dt", "0.5", "--method", "rk45")
    assert rc == 0, err


def test_output_folder_is_checked_before_simulating(capsys, tmp_path):
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--output", str(tmp_path / "nope" / "o.csv"))
    assert rc == 2
    assert "the folder" in err and "does not exist; create it or choose another path" in err


def test_failed_simulation_keeps_an_existing_output_file(capsys, tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("precious\n")
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum-massless", "--t-end", "5", "--output", str(target))
    assert rc == 1
    assert target.read_text() == "precious\n"
    # the rows before the failure go beside it, marked as partial (tests/io/test_files_safety.py)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv", "out.partial.csv"]
    assert (tmp_path / "out.partial.csv").read_text().startswith("# partial: the mass matrix became singular")


def test_check_json_det_is_a_sympy_string_for_large_models(capsys):
    rc, out, err = run_cli(capsys, "check", "pendulum-chain-5", "--json")
    assert rc == 0, err
    data = json.loads(out)
    assert data["singular"] is False
    det = sympy.sympify(data["det_mass_matrix"])
    assert isinstance(det, sympy.Determinant) and det.arg.shape == (5, 5)


def test_output_that_is_a_directory_is_refused_before_simulating(capsys, tmp_path):
    rc, out, err = run_cli(capsys, "simulate", "cart-pendulum", "--output", str(tmp_path))
    assert rc == 2
    assert "it is a directory; give a file name such as" in err


# ------------------------------------------------------------------------- events from the CLI


def test_simulate_records_events_and_stops_on_one(capsys, tmp_path):
    # undamped, x1 = cos(w t) with w = sqrt(2k/m): x1 crosses zero at (2j + 1) pi / (2 w)
    out_csv, ev_csv = tmp_path / "out.csv", tmp_path / "events.csv"
    rc, out, err = run_cli(capsys, "simulate", "spring-mass-damper-chain-1", "--param", "c=0", "--initial", "x1=1",
                           "--t-end", "1", "--event", "zero=x1", "-o", out_csv, "--events-output", ev_csv)
    assert rc == 0, err
    w = math.sqrt(200.0)
    rows = list(csv.reader(io.StringIO(ev_csv.read_text())))
    assert rows[0] == ["event", "t", "x1", "x1_dot"]
    times = [float(r[1]) for r in rows[1:]]
    assert [r[0] for r in rows[1:]] == ["zero"] * 5  # the fifth at 0.9997
    assert times == pytest.approx([(2 * j + 1) * math.pi / (2 * w) for j in range(5)], abs=1e-8)
    assert [abs(float(r[2])) for r in rows[1:]] == pytest.approx([0.0] * 5, abs=1e-8)
    assert "event zero: 5 crossings, the first at t = 0.111072" in out
    # stop at the first time x1_dot reaches -13: w sin(w t) = 13
    rc, out, err = run_cli(capsys, "simulate", "spring-mass-damper-chain-1", "--param", "c=0", "--initial", "x1=1",
                           "--t-end", "1", "--event", "zero=x1", "--event", "fast=x1_dot+13", "--stop-on", "fast")
    assert rc == 0, err
    t_stop = math.asin(13 / w) / w
    assert f"stopped by event fast at t = {t_stop:.6g}" in err and "event zero: 0 crossings" in err
    last = out.strip().splitlines()[-1].split(",")
    assert float(last[0]) <= t_stop < float(last[0]) + 0.01  # the CSV (on stdout) ends at the stop


@pytest.mark.parametrize("args, needles", [
    (["--events-output", "e.csv"], ["--events-output needs at least one --event NAME=EXPR"]),
    (["--event", "zero=x1", "--stop-on", "zz"], ["stop_on names 'zz', which is not one of the events; "
                                                 "the events are zero"]),
    (["--stop-on", "zz"], ["stop_on names 'zz', which is not one of the events; no events are given: define it "
                           "first, e.g. events={'zz': 'q1'} (on the command line: --event zz=EXPR)"]),
    (["--event", "zero=x1", "--method", "RK45"],
     ["events are watched by the compiled DOP853 only, not by method 'RK45'"]),
    (["--event", "zero=x1+"], ["event 'zero': missing operand after '+'"]),
    (["--event", "zero"], ["--event 'zero': expected NAME=VALUE"]),
])
def test_simulate_event_errors(capsys, tmp_path, args, needles):
    rc, out, err = run_cli(capsys, "simulate", "spring-mass-damper-chain-1", "--t-end", "1", *args)
    assert_bad_input(rc, out, err, *needles)
