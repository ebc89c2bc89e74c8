"""Property-based tests (Hypothesis) of the promise "a model file is data" (issue 19, item 7): any
expression, model file, name or command-line option either works or is refused with one clear
LagrangianError, within a time limit, and no code runs (a marker file that the payloads would create
never appears). The examples are few and small so that the suite stays fast."""

from __future__ import annotations

import contextlib
import os
import signal
import time
from pathlib import Path

import pytest
import sympy

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import lagrangian as lg  # noqa: E402
from lagrangian.cli import main  # noqa: E402
from lagrangian.errors import ExpressionError, LagrangianError, ModelError, ModelFileError  # noqa: E402
from lagrangian.io import loads_model  # noqa: E402
from lagrangian.model._expr import parse_expression  # noqa: E402

#: Where the payloads would leave their mark: absolute, so that a payload run from any folder is seen.
MARKER = Path(os.environ.get("TMPDIR", "/tmp")) / f"lagrangian-property-marker-{os.getpid()}"
#: The most seconds one example may take (parse, load and derive are milliseconds to a second).
TIME_LIMIT = 20

PAYLOADS = [
    f"__import__('os').system('touch {MARKER}')",
    f"open('{MARKER}', 'w')",
    f"exec(\"open('{MARKER}', 'w')\")",
    f"eval(\"__import__('os').system('touch {MARKER}')\")",
    "().__class__.__bases__[0].__subclasses__()",
    "lambda: 0",
    "[i for i in range(10**9)]",
    "x if y else z",
    "x.__class__",
    "globals()['os']",
    f'x"""\nimport os; os.system("touch {MARKER}")\n"""',
    f"*/ system(\"touch {MARKER}\"); /*",
    "\\\n",
    "x\x00y",
    "9" * 1200,
    "1e308*10",
    "10**10**10",
    "exp(exp(exp(100)))",
    "x**(10**100)",
    "(x+y+z)**5000",
]

SETTINGS = dict(deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow,
                                                                        HealthCheck.function_scoped_fixture])


@contextlib.contextmanager
def within(seconds: float):
    """Fail, instead of hanging, when the body takes more than `seconds` (SIGALRM: the main thread)."""
    def expire(signum, frame):
        raise TimeoutError(f"took more than {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture(autouse=True)
def no_marker():
    MARKER.unlink(missing_ok=True)
    yield
    assert not MARKER.exists(), "a payload ran: the marker file was created"


def assert_clear(exc: LagrangianError) -> None:
    """One clear error: a message that says something, never Python's internals."""
    text = str(exc)
    assert text.strip(), repr(exc)
    for internal in ("Traceback", "object at 0x", "site-packages", "Error(", "<class "):
        assert internal not in text, text
    if isinstance(exc, ModelError):
        assert exc.problems and all(p.message.strip() for p in exc.problems)


# ------------------------------------------------------------------ strategies
identifiers = st.from_regex(r"\A[A-Za-z_][A-Za-z0-9_]{0,7}\Z")
names = st.one_of(identifiers, st.sampled_from(["t", "pi", "sin", "E", "I", "lambda", "import", "x_dot", "x_ddot",
                                                "__import__", "os", "eval", "main", "pow", "NAN", ""]),
                  st.text(max_size=12))
numbers_text = st.one_of(
    st.integers(min_value=-10**30, max_value=10**30).map(str),
    st.integers(min_value=300, max_value=1200).map(lambda k: "9" * k),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.sampled_from(["1e308", "1e-400", "0.0", "1e1001", "0x10", "1_000", "1.5e-320"]),
)
FUNCTIONS = ["sin", "cos", "exp", "log", "sqrt", "acos", "asin", "atan2", "abs", "sign", "min", "clip", "where",
             "eval", "exec", "open", "getattr", "__import__"]


def valid_expressions(known=("x", "y", "z", "x_dot", "k")):
    """Expressions of the language: known names, small numbers, the allowed functions and operators."""
    leaves = st.one_of(st.sampled_from(list(known) + ["pi", "t"] if known else ["pi", "2"]),
                       st.integers(min_value=-50, max_value=50).map(str),
                       st.floats(min_value=-100, max_value=100).map(lambda v: f"{v:.3g}"))

    def grow(inner):
        return st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**"]), st.integers(0, 4).map(str))
              .map(lambda p: f"({p[0]}) {p[1]} {p[2]}"),
            st.tuples(inner, st.sampled_from(["+", "-", "*"]), inner).map(lambda p: f"({p[0]} {p[1]} {p[2]})"),
            st.tuples(st.sampled_from(["sin", "cos", "exp", "atan", "tanh", "abs"]), inner)
              .map(lambda p: f"{p[0]}({p[1]})"),
        )

    return st.recursive(leaves, grow, max_leaves=8)


def expressions(known=("x", "y", "z", "x_dot", "k")):
    """Any text: expressions of the language, wild ones (unknown names and functions, huge numbers,
    comparisons, Python), the payloads and random text."""
    leaves = st.one_of(numbers_text, st.sampled_from(list(known) + ["pi", "t"]), names)

    def grow(inner):
        return st.one_of(
            st.tuples(inner, st.sampled_from(["+", "-", "*", "/", "**", "^", "<", "==", " and "]), inner)
              .map(lambda p: f"({p[0]} {p[1]} {p[2]})"),
            st.tuples(st.sampled_from(FUNCTIONS), st.lists(inner, min_size=0, max_size=3))
              .map(lambda p: f"{p[0]}({', '.join(p[1])})"),
            inner.map(lambda e: f"-{e}"),
        )

    return st.one_of(valid_expressions(known), st.recursive(leaves, grow, max_leaves=12), st.sampled_from(PAYLOADS),
                     st.text(max_size=40))


def toml_value(value) -> str:
    """TOML text of a value built by `model_files` (a str that starts with RAW is written as it is)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "nan" if value != value else ("inf" if value == float("inf") else
                                             "-inf" if value == float("-inf") else repr(value))
    if isinstance(value, str):
        return value[len(RAW):] if value.startswith(RAW) else toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{toml_string(str(k))} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(value)  # pragma: no cover


RAW = "\x00raw:"


def toml_string(text: str) -> str:
    """A TOML basic string: quotes and backslashes escaped, control characters as \\uXXXX."""
    return '"' + "".join("\\" + ch if ch in '"\\' else f"\\u{ord(ch):04x}" if ord(ch) < 0x20 or ord(ch) == 0x7F
                         else ch for ch in text) + '"'


scalars = st.one_of(st.integers(min_value=-10**450, max_value=10**450), st.floats(), st.booleans(),
                    st.text(max_size=20), expressions())
nested = st.integers(min_value=1, max_value=2000).map(lambda d: RAW + "[" * d + "]" * d)
values = st.one_of(scalars, nested, st.lists(scalars, max_size=3),
                   st.dictionaries(names, scalars, max_size=3))


@st.composite
def model_files(draw) -> str:
    """A model file that is valid but for up to two fields, each then any value, name or expression; with
    frames and a [simulation] table or not, and at times a character inserted, deleted or replaced."""
    wild = draw(st.sets(st.sampled_from(["name", "coordinates", "extra", "k", "parameter", "T", "V", "frame name",
                                         "parent", "rotation", "t_end", "initial"]), max_size=2))

    def field(key, valid):
        return draw(values) if key in wild else draw(valid)

    coordinates = draw(st.lists(st.sampled_from(["x", "y", "z"]), min_size=1, max_size=3, unique=True))
    if "coordinates" in wild:
        coordinates = draw(st.one_of(st.lists(names, max_size=3), values))
    known = tuple(c for c in coordinates if isinstance(c, str)) if isinstance(coordinates, list) else ()
    positions = known + ("k",)
    known += tuple(f"{c}_dot" for c in known) + ("k",)
    lines = [f"name = {toml_value(draw(st.one_of(names, st.sampled_from(PAYLOADS))))}",
             f"coordinates = {toml_value(coordinates)}"]
    if "extra" in wild:
        lines.append(f"{draw(st.sampled_from(['description', 'inputs', 'version', 'bogus']))} = "
                     f"{toml_value(draw(values))}")
    lines.append("[parameters]")
    lines.append(f"k = {toml_value(field('k', st.floats(min_value=0.1, max_value=10)))}")
    if "parameter" in wild:
        lines.append(f"{draw(identifiers)} = {toml_value(draw(values))}")
    lines.append("[energy]")
    kinetic = " + ".join(f"{c}_dot**2/2" for c in positions[:-1]) or "0"
    lines.append(f"T = {toml_value(field('T', st.just(kinetic)))}")
    lines.append(f"V = {toml_value(field('V', valid_expressions(positions)))}")
    if draw(st.booleans()):
        lines.append("[[frames]]")
        lines.append(f"name = {toml_value(field('frame name', st.just('body')))}")
        lines.append(f"parent = {toml_value(field('parent', st.just('world')))}")
        lines.append(f"rotation = {toml_value(field('rotation', st.just([['z', known[0] if known else '1']])))}")
    if draw(st.booleans()):
        lines.append("[simulation]")
        lines.append(f"t_end = {toml_value(field('t_end', st.floats(min_value=0.1, max_value=10)))}")
        lines.append(f"initial = {toml_value(field('initial', st.just({known[0]: 0.5} if known else {})))}")
    text = "\n".join(lines) + "\n"
    if draw(st.integers(0, 3)) == 0:  # a random edit of the text: a character inserted, deleted or replaced
        i = draw(st.integers(min_value=0, max_value=len(text)))
        text = text[:i] + draw(st.text(max_size=3)) + text[i + draw(st.integers(min_value=0, max_value=3)):]
    return text


# ------------------------------------------------------------------ properties
@settings(max_examples=300, **SETTINGS)
@given(text=expressions(), feedback=st.booleans())
@pytest.mark.slow
def test_an_expression_parses_or_is_one_clear_error(text, feedback):
    known = {n: sympy.Symbol(n) for n in ("x", "y", "z", "x_dot", "k", "t")}
    with within(TIME_LIMIT):
        try:
            value = parse_expression(text, known, feedback=feedback)
        except ExpressionError as exc:
            event("refused")
            assert_clear(exc)
        else:
            event("parsed")
            assert isinstance(value, sympy.Basic)
            assert value.free_symbols <= set(known.values())


@settings(max_examples=120, **SETTINGS)
@given(text=model_files())
@pytest.mark.slow
def test_a_model_file_loads_and_derives_or_is_one_clear_error(text):
    with within(TIME_LIMIT):
        try:
            model = loads_model(text, source="m.toml")
        except ModelFileError as exc:
            event("refused by load")
            assert_clear(exc)
            assert all(p.line is None or 1 <= p.line <= text.count("\n") + 1 for p in exc.problems)
            return
        try:
            eqs = lg.derive(model)
        except ModelError as exc:
            event("refused by derive")
            assert_clear(exc)
        else:
            event("derived")
            assert eqs.n == len(model.q)


@settings(max_examples=150, **SETTINGS)
@given(name=st.one_of(names, st.sampled_from(PAYLOADS)),
       coordinates=st.one_of(st.just(["x", "y"]), st.lists(st.one_of(identifiers, names), max_size=3)),
       parameters=st.one_of(st.just({}), st.dictionaries(st.one_of(identifiers, names),
                                                         st.one_of(st.floats(), st.integers(), st.none()),
                                                         max_size=3)),
       V=st.one_of(valid_expressions(("x", "y")), expressions(("x", "y"))))
@pytest.mark.slow
def test_names_given_to_the_api_make_a_model_or_one_clear_error(name, coordinates, parameters, V):
    with within(TIME_LIMIT):
        try:
            model = lg.Model(name, coordinates=coordinates, parameters=parameters,
                             T=" + ".join(f"{c}_dot**2/2" for c in coordinates if c.isidentifier()) or 0, V=V)
            lg.derive(model)
            event("derived")
        except LagrangianError as exc:
            event("refused")
            assert_clear(exc)


bad_option_values = st.sampled_from(["-1", "0", "nan", "inf", "-inf", "1e300", "1e-320", "abc", "", "1e-12", "0x10",
                                     "1,5", "1e999"])


@st.composite
def simulation_options(draw) -> dict[str, str]:
    """The values of --t-end, --dt, --rtol, --atol, --initial, --param and --input: valid but for up to two."""
    wild = draw(st.sets(st.sampled_from(["t_end", "dt", "rtol", "atol", "initial", "param", "input"]), max_size=2))
    valid = {"t_end": st.floats(min_value=0.01, max_value=2.0).map(repr),
             "dt": st.floats(min_value=1e-3, max_value=0.5).map(repr),
             "rtol": st.sampled_from(["1e-3", "1e-6", "1e-9", "1e-12", "1"]),
             "atol": st.sampled_from(["1e-3", "1e-6", "1e-9", "1e-300"]),
             "initial": valid_expressions(("pi",)), "param": st.floats(min_value=1, max_value=1e3).map(repr),
             "input": valid_expressions(("t", "x1", "x2_dot", "k1"))}
    bad = {"initial": st.one_of(expressions(("q1", "q2")), bad_option_values),
           "param": st.one_of(numbers_text, expressions(()), bad_option_values),
           "input": expressions(("t", "x1", "x2_dot", "k1"))}
    return {key: draw(bad.get(key, bad_option_values) if key in wild else strategy) for key, strategy in valid.items()}


@settings(max_examples=40, **SETTINGS)
@given(options=simulation_options())
@pytest.mark.slow
def test_simulate_options_run_or_exit_2_with_one_clear_error(capsys, options):
    t_end, dt, rtol, atol, initial, param, signal_ = (options[k] for k in ("t_end", "dt", "rtol", "atol", "initial",
                                                                            "param", "input"))
    argv = ["simulate", "mck", "--backend", "scipy", f"--t-end={t_end}", f"--dt={dt}", f"--rtol={rtol}",
            f"--atol={atol}", "--initial", f"x1={initial}", "--param", f"k1={param}", "--input", f"f={signal_}"]
    old = os.environ.get("LAGRANGIAN_MAX_ROWS")
    os.environ["LAGRANGIAN_MAX_ROWS"] = "5000"  # every run that is allowed is small
    try:
        with within(TIME_LIMIT):
            started = time.monotonic()
            code = main(argv)
    finally:
        if old is None:
            del os.environ["LAGRANGIAN_MAX_ROWS"]
        else:
            os.environ["LAGRANGIAN_MAX_ROWS"] = old
    out, err = capsys.readouterr()
    event(f"exit {code}")
    assert code in (0, 1, 2), (code, err)
    assert "Traceback" not in err
    if code == 0:
        assert out.startswith("t,") and time.monotonic() - started < TIME_LIMIT
    else:
        assert err.startswith("lagrangian simulate: error: ") and (out == "" or code == 1)
