"""Code generation: the model's M, f, energy and Lagrangian parts as common-subexpression-
eliminated Python (for numba) or C source, written to a cache directory under a name made from a
hash of the equations' content, so that a second process finds the module (and numba its compiled
machine code) and compiles nothing.

The cache directory is ``$LAGRANGIAN_CACHE_DIR`` or ``~/.cache/lagrangian``.
"""

from __future__ import annotations

import hashlib
import importlib.util
import keyword
import os
import re
import sys
import tempfile
from pathlib import Path

import symengine as se

from ..equations import Equations
from ._kernels import SINGULAR_RATIO as SINGULAR

__all__ = ["cache_dir", "model_key", "numba_source", "c_source", "load_module", "Unsupported",
           "GENERATOR_VERSION"]

#: Changes whenever the generated code changes, so that old cache entries are not reused.
GENERATOR_VERSION = "13"

_PY_FUNCS = {
    "sin": "math.sin", "cos": "math.cos", "tan": "math.tan", "asin": "math.asin", "acos": "math.acos",
    "atan": "math.atan", "atan2": "math.atan2", "sinh": "math.sinh", "cosh": "math.cosh",
    "tanh": "math.tanh", "asinh": "math.asinh", "acosh": "math.acosh", "atanh": "math.atanh",
    "exp": "math.exp", "log": "math.log", "sqrt": "math.sqrt", "abs": "abs", "sign": "_sign",
    "Heaviside": "_heaviside", "floor": "math.floor", "ceiling": "math.ceil", "max": "max",
    "min": "min", "pi": "math.pi", "E": "math.e",
}
_C_FUNCS = {
    "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh", "acosh",
    "atanh", "exp", "log", "sqrt", "fabs", "pow", "floor", "ceil", "fmax", "fmin",
}
_TOKEN = re.compile(r"(\d+\.?\d*(?:[eE][-+]?\d+)?)|([^\W\d]\w*)")


class Unsupported(Exception):
    """An expression the code generator cannot translate (the caller falls back to SciPy)."""


def cache_dir() -> Path:
    """$LAGRANGIAN_CACHE_DIR or ~/.cache/lagrangian (created when missing)."""
    path = Path(os.environ.get("LAGRANGIAN_CACHE_DIR") or Path.home() / ".cache" / "lagrangian")
    path.mkdir(parents=True, exist_ok=True)
    return path


def _names(equations: Equations):
    core = equations.core
    return ([core.t.name], [s.name for s in (*core.q, *core.qd)], [u.name for u in equations.inputs],
            [p.name for p in equations.parameters])


def model_key(equations: Equations, backend: str = "numba") -> str:
    """A hash of everything the generated code depends on (not of the generated code itself, so
    that finding a cached module costs no code generation)."""
    core = equations.core
    h = hashlib.sha256()
    h.update(f"{GENERATOR_VERSION}|{backend}|{_names(equations)}".encode())
    for e in (*core.M, *core.f, core.L, core.D, *core.Q, *core.p):
        h.update(str(e).encode())
        h.update(b"|")
    return h.hexdigest()[:24]


def _symbols(equations: Equations):
    """(symbol, accessor) pairs: t, x[i], u[i], p[i]."""
    core = equations.core
    out = [(se.Symbol(core.t.name), "t")]
    out += [(s, f"x[{i}]") for i, s in enumerate((*core.q, *core.qd))]
    out += [(se.Symbol(u.name), f"u[{i}]") for i, u in enumerate(equations.inputs)]
    out += [(se.Symbol(p.name), f"p[{i}]") for i, p in enumerate(equations.parameters)]
    return out


def _local_name(name: str, taken: set) -> str:
    base = name if (name.isidentifier() and not keyword.iskeyword(name) and name.isascii()) else "s"
    cand = f"v_{base}"
    k = 0
    while cand in taken:
        k += 1
        cand = f"v_{base}_{k}"
    taken.add(cand)
    return cand


class _Printer:
    """Prints CSE'd SymEngine expressions with the model's symbols renamed to safe local names."""

    def __init__(self, equations: Equations, lang: str):
        self.lang = lang
        taken: set = set()
        self.locals = []  # (local name, accessor)
        self.rename: dict[str, str] = {}
        for sym, acc in _symbols(equations):
            local = _local_name(sym.name, taken)
            self.locals.append((local, acc, sym.name))
            self.rename[sym.name] = local
        self.clash = any(re.fullmatch(r"x\d+", n) for n in self.rename)  # SymEngine's CSE names
        self.syms = {sym.name: sym for sym, _ in _symbols(equations)}

    def _translate(self, text: str, temps: dict[str, str]) -> str:
        def sub(m):
            if m.group(1):
                return m.group(1)
            name = m.group(2)
            if name in temps:
                return temps[name]
            if name in self.rename:
                return self.rename[name]
            if self.lang == "py":
                if name in _PY_FUNCS:
                    return _PY_FUNCS[name]
            elif name in _C_FUNCS:
                return name
            raise Unsupported(f"'{name}' in a generated expression")
        return _TOKEN.sub(sub, text)

    def block(self, exprs: list, indent: str = "    ", first: int | None = None):
        """(statements defining the common subexpressions, the output expressions); with `first`,
        (the statements the first `first` outputs need, the other statements, the outputs)."""
        safe = {}
        if self.clash:  # rename model symbols that look like SymEngine's CSE symbols
            safe = {self.syms[n]: se.Symbol(f"__lg_{n}") for n in self.syms if re.fullmatch(r"x\d+", n)}
            exprs = [e.subs(safe) for e in exprs]
            back = {f"__lg_{n}": self.rename[n] for n in self.syms if re.fullmatch(r"x\d+", n)}
        reps, reduced = se.cse(exprs)
        temps: dict[str, str] = {}
        if safe:
            temps.update(back)
        lines = []
        for k, (sym, expr) in enumerate(reps):
            name = f"c{k}"
            text = self._translate(self._str(expr), temps)
            temps[sym.name] = name
            lines.append(f"{indent}{'double ' if self.lang == 'c' else ''}{name} = {text}{';' if self.lang == 'c' else ''}")
        outputs = [self._translate(self._str(e), temps) for e in reduced]
        if first is None:
            return lines, outputs
        # the common subexpressions the first `first` outputs need, and the others
        needed: set = set()
        for e in reduced[:first]:
            needed |= set(e.free_symbols)
        for sym, expr in reversed(reps):
            if sym in needed:
                needed |= set(expr.free_symbols)
        early = [line for (sym, _), line in zip(reps, lines) if sym in needed]
        late = [line for (sym, _), line in zip(reps, lines) if sym not in needed]
        return early, late, outputs

    def _str(self, e) -> str:
        if self.lang == "c":
            text = se.ccode(e)
            if "NAN" in text or "INFINITY" in text:
                raise Unsupported("a non-finite constant")
            return text
        return str(e)  # a name that is not the model's (I, oo, nan) is refused by _translate

    def unpack(self, indent: str = "    ") -> list[str]:
        end = ";" if self.lang == "c" else ""
        decl = "double " if self.lang == "c" else ""
        return [f"{indent}{decl}{local} = {acc}{end}" for local, acc, _ in self.locals]


def _header(equations: Equations) -> str:
    t, x, u, p = _names(equations)
    return (f"Generated by lagrangian for the model '{equations.model.name}'. Do not edit.\n\n"
            f"Arguments, in this order, of every function below:\n"
            f"    t : float, time\n"
            f"    x : float64[{len(x)}], the state [{', '.join(x)}]\n"
            f"    u : float64[{len(u)}], the inputs [{', '.join(u)}]\n"
            f"    p : float64[{len(p)}], the parameters [{', '.join(p)}]\n")


#: Models whose M and f print shorter than this (characters) are generated from the simplified
#: forms of Equations.mass_matrix and .forcing (trigonometric identities applied): a double
#: pendulum's forcing shrinks six-fold; larger models are generated as derived.
SIMPLIFY_MAX_CHARS = 20000


def _mass_and_forcing(equations: Equations):
    core = equations.core
    n = equations.n
    M = [[core.M[i, j] for j in range(n)] for i in range(n)]
    f = list(core.f)
    if sum(len(str(e)) for e in (*core.M, *f)) <= SIMPLIFY_MAX_CHARS:
        import sympy

        from ..model._kinematics import to_sympy

        Ms, fs = equations.mass_matrix, equations.forcing
        calls = lambda exprs: len(set().union(*(e.atoms(sympy.Function) for e in exprs)))  # noqa: E731
        # simplifying turns sin(q1) cos(q2) - ... into sin(q1 - q2): fewer operations, but one
        # trigonometric call per pair of coordinates; keep it when it needs no more calls
        if calls([*Ms, *fs]) <= calls([to_sympy(e) for e in (*core.M, *core.f)]):
            M = [[se.sympify(Ms[i, j]) for j in range(n)] for i in range(n)]
            f = [se.sympify(e) for e in fs]
    return M, f


def _model_parts(equations: Equations, part: str = "main"):
    core = equations.core
    n = equations.n
    Ms, fs = _mass_and_forcing(equations)
    Mlow = [Ms[i][j] for i in range(n) for j in range(i + 1)]
    if part != "main":
        F = [core.L.diff(qi) - core.D.diff(vi) + Qi for qi, vi, Qi in zip(core.q, core.qd, core.Q)]
        return Mlow, fs, None, list(core.p), F
    h = sum((v * pi for v, pi in zip(core.qd, core.p)), se.Integer(0)) - core.L
    return Mlow, fs, h, None, None


_PRELUDE = """
import math

from numba import carray, cfunc, njit, types

_P = types.CPointer(types.float64)
_SIG_VOID = types.void(types.float64, _P, _P, _P, _P, _P)
_SIG_DOUBLE = types.float64(types.float64, _P, _P, _P)
_SIG_RHS = types.float64(types.float64, _P, _P, _P, _P, _P)


@njit(cache=True)
def _sign(a):
    return 1.0 if a > 0.0 else (-1.0 if a < 0.0 else 0.0)


@njit(cache=True)
def _heaviside(a):
    return 1.0 if a > 0.0 else (0.5 if a == 0.0 else 0.0)
"""


_SOLVE_LOOP = """

@njit(cache=True)
def _solve_loop(work, x, dx):
    \"\"\"The LDL^T solve of rhs with loops (n = @N@): M (lower triangle, row-major) in work[:n*n],
    f in work[n*n:n*n+n], D in work[n*n+n:].\"\"\"
    n = @N@
    o = n * n
    r = 1.0
    for j in range(n):
        d = work[j * n + j]
        for k in range(j):
            d -= work[j * n + k] * work[j * n + k] * work[o + n + k]
        if not (d > 0.0 and d < math.inf):
            return 0.0
        r = min(r, d / work[j * n + j])
        work[o + n + j] = d
        inv = 1.0 / d
        for i in range(j + 1, n):
            s = work[i * n + j]
            for k in range(j):
                s -= work[i * n + k] * work[j * n + k] * work[o + n + k]
            work[i * n + j] = s * inv
    if r <= @SINGULAR@:
        return r
    for i in range(n):
        if not math.isfinite(work[o + i]):
            return -1.0
    for i in range(n):
        s = work[o + i]
        for k in range(i):
            s -= work[i * n + k] * dx[n + k]
        dx[n + i] = s
    for i in range(n - 1, -1, -1):
        s = dx[n + i] / work[o + n + i]
        for k in range(i + 1, n):
            s -= work[k * n + i] * dx[n + k]
        dx[n + i] = s
    for i in range(n):
        dx[i] = x[n + i]
    return r
"""


def _cfunc_head(name: str, sig: str, outs: tuple, n: int, nu: int, npar: int, doc: str) -> list[str]:
    args = ", ".join(["t", "x_", "u_", "p_", *[f"{o}_" for o, _ in outs]])
    lines = ["", "", f"@cfunc({sig}, cache=True)", f"def {name}({args}):", f'    """{doc}"""',
             f"    x = carray(x_, ({2 * n},))"]
    if nu:
        lines.append(f"    u = carray(u_, ({nu},))")
    if npar:
        lines.append(f"    p = carray(p_, ({npar},))")
    lines += [f"    {o} = carray({o}_, ({size},))" for o, size in outs]
    return lines


#: Largest n whose LDL^T solve is written out statement by statement; larger models use loops.
UNROLL_MAX = 12


def _ldl(n: int, lang: str, M, f, indent: str = "    ", part: str = "both") -> list[str]:
    """Statements solving M q_ddot = f by LDL^T, written out (n <= UNROLL_MAX): `M(i, j)` and
    `f(i)` name the entries (lower triangle); q_ddot goes to dx[n:], q_dot = x[n:] to dx[:n].
    The function returns the inertia measure min_j D_j / M_jj, 0.0 when M is not positive
    definite, -1.0 when f is not finite."""
    c = lang == "c"
    dbl, end = ("double ", ";") if c else ("", "")
    fin = "isfinite" if c else "math.isfinite"
    out = []
    def st(text):
        out.append(f"{indent}{text}{end}")
    for j in range(n):
        terms = "".join(f" - l{j}_{k} * l{j}_{k} * d{k}" for k in range(j))
        st(f"{dbl}d{j} = {M(j, j)}{terms}")
        if c:
            out.append(f"{indent}if (!(d{j} > 0.0 && d{j} < INFINITY)) return 0.0;")
        else:
            out.append(f"{indent}if not (d{j} > 0.0 and d{j} < math.inf):")
            out.append(f"{indent}    return 0.0")
        st(f"{dbl}i{j} = 1.0 / d{j}")
        for i in range(j + 1, n):
            terms = "".join(f" - l{i}_{k} * l{j}_{k} * d{k}" for k in range(j))
            st(f"{dbl}l{i}_{j} = ({M(i, j)}{terms}) * i{j}")
    st(f"{dbl}r = 1.0")  # d0 / M00 = 1
    for j in range(1, n):
        if c:
            st(f"r = fmin(r, d{j} / ({M(j, j)}))")
        else:
            st(f"r = min(r, d{j} / ({M(j, j)}))")
    if c:
        out.append(f"{indent}if (r <= {SINGULAR!r}) return r;")
    else:
        out.append(f"{indent}if r <= {SINGULAR!r}:")
        out.append(f"{indent}    return r")
    factor, out = out, []
    if c:
        out.append(f"{indent}if (!{fin}({' + '.join(f(i) for i in range(n))})) return -1.0;")
    else:
        out.append(f"{indent}if not {fin}({' + '.join(f(i) for i in range(n))}):")
        out.append(f"{indent}    return -1.0")
    for i in range(n):  # L z = f
        terms = "".join(f" - l{i}_{k} * z{k}" for k in range(i))
        st(f"{dbl}z{i} = {f(i)}{terms}")
    for i in range(n - 1, -1, -1):  # L^T a = D^-1 z
        terms = "".join(f" - l{k}_{i} * a{k}" for k in range(i + 1, n))
        st(f"{dbl}a{i} = z{i} * i{i}{terms}")
    for i in range(n):
        st(f"dx[{n + i}] = a{i}")
        st(f"dx[{i}] = x[{n + i}]")
    st("return r")
    return {"both": factor + out, "factor": factor, "solve": out}[part]


def numba_source(equations: Equations, part: str = "main") -> str:
    """The numba module of `equations`: ``rhs`` and ``energy`` (part "main"), or
    ``mass_forcing`` and ``lagrange_parts`` (part "variational", generated on first use), as
    cfuncs for the kernels of _kernels.py."""
    n = equations.n
    nu, npar = len(equations.inputs), len(equations.parameters)
    Mlow, f, h, pm, F = _model_parts(equations, part)
    pr = _Printer(equations, "py")
    out = ['"""' + _header(equations) + '"""', _PRELUDE, f"N = {n}", f"NU = {nu}", f"NPAR = {npar}"]
    if n > UNROLL_MAX and part == "main":
        out.append(_SOLVE_LOOP.replace("@N@", str(n)).replace("@SINGULAR@", repr(SINGULAR)))
    if part == "main":
        out += _cfunc_head("rhs", "_SIG_RHS", (("dx", 2 * n), ("work", n * n + 2 * n)), n, nu, npar,
                           "dx = [q_dot, q_ddot]; returns the inertia measure of M (min_j D_j / M_jj of "
                           "its LDL^T factorization: 0 when singular) or -1.0 when f is not finite.")
        out += pr.unpack()
        # (factorizing M before computing f, to overlap the divisions with the forcing's work,
        # measured 8% slower for a double pendulum: the order is common subexpressions, M, f)
        lines, exprs = pr.block(Mlow + f)
        out += lines
        out += _rhs_values(n, exprs)
        if n <= UNROLL_MAX:
            out += _ldl(n, "py", lambda i, j: f"m{i}_{j}", lambda i: f"f{i}")
        else:
            out.append("    return _solve_loop(work, x, dx)")
        out += _cfunc_head("energy", "_SIG_DOUBLE", (), n, nu, npar,
                           "The Jacobi integral h = q_dot . dL/dq_dot - L (the energy T* + V when T* = T2).")
        out += pr.unpack()
        lines, exprs = pr.block([h])
        out += lines + [f"    return {exprs[0]}"]
    else:
        out += _cfunc_head("mass_forcing", "_SIG_VOID", (("M", n * n), ("f", n)), n, nu, npar,
                           "M (row-major n x n) and f with M q_ddot = f.")
        out += pr.unpack()
        lines, exprs = pr.block(Mlow + f)
        out += lines
        out += _stores(n, exprs, ("M", "f"))
        out += _cfunc_head("lagrange_parts", "_SIG_VOID", (("pm", n), ("F", n)), n, nu, npar,
                           "pm = dL/dq_dot and F = dL/dq - dD/dq_dot + Q.")
        out += pr.unpack()
        lines, exprs = pr.block(pm + F)
        out += lines
        out += _stores(n, exprs, ("pm", "F"))
    return "\n".join(out) + "\n"


#: The C functions' declarations (cffi cdef): the same signatures as the numba cfuncs.
C_DECLARATIONS = """
double lg_rhs(double t, double *x, double *u, double *p, double *dx, double *work);
double lg_energy(double t, double *x, double *u, double *p);
void lg_mass_forcing(double t, double *x, double *u, double *p, double *M, double *f);
void lg_lagrange_parts(double t, double *x, double *u, double *p, double *pm, double *F);
"""

_C_SOLVE_LOOP = """
static double lg_solve_loop(int n, double *work, const double *x, double *dx) {
    /* LDL^T with loops: M (lower triangle, row-major) in work[0:n*n], f in work[n*n:n*n+n],
       D in work[n*n+n:n*n+2n]. */
    int o = n * n, i, j, k;
    double r = 1.0, d, s, inv;
    for (j = 0; j < n; j++) {
        d = work[j * n + j];
        for (k = 0; k < j; k++) d -= work[j * n + k] * work[j * n + k] * work[o + n + k];
        if (!(d > 0.0 && d < INFINITY)) return 0.0;
        r = fmin(r, d / work[j * n + j]);
        work[o + n + j] = d;
        inv = 1.0 / d;
        for (i = j + 1; i < n; i++) {
            s = work[i * n + j];
            for (k = 0; k < j; k++) s -= work[i * n + k] * work[j * n + k] * work[o + n + k];
            work[i * n + j] = s * inv;
        }
    }
    if (r <= @SINGULAR@) return r;
    for (i = 0; i < n; i++) if (!isfinite(work[o + i])) return -1.0;
    for (i = 0; i < n; i++) {
        s = work[o + i];
        for (k = 0; k < i; k++) s -= work[i * n + k] * dx[n + k];
        dx[n + i] = s;
    }
    for (i = n - 1; i >= 0; i--) {
        s = dx[n + i] / work[o + n + i];
        for (k = i + 1; k < n; k++) s -= work[k * n + i] * dx[n + k];
        dx[n + i] = s;
    }
    for (i = 0; i < n; i++) dx[i] = x[n + i];
    return r;
}
"""


def c_source(equations: Equations) -> str:
    """C source of `equations`' functions, with the signatures of C_DECLARATIONS (the same as the
    numba cfuncs): lg_rhs, lg_energy, lg_mass_forcing (M row-major, n x n), lg_lagrange_parts."""
    n = equations.n
    Mlow, f, h, _, _ = _model_parts(equations)
    _, _, _, pm, F = _model_parts(equations, "variational")
    pr = _Printer(equations, "c")
    head = ("/* " + _header(equations).replace("*/", "* /") + "*/\n#include <math.h>\n"
            + (_C_SOLVE_LOOP.replace("@SINGULAR@", repr(SINGULAR)) if n > UNROLL_MAX else "") + "\n")
    body = ["double lg_rhs(double t, double *x, double *u, double *p, double *dx, double *work) {"]
    body += pr.unpack()
    lines, exprs = pr.block(Mlow + f)
    body += lines
    body += _rhs_values(n, exprs, "double ", ";")
    if n <= UNROLL_MAX:
        body += _ldl(n, "c", lambda i, j: f"m{i}_{j}", lambda i: f"f{i}")
    else:
        body.append(f"    return lg_solve_loop({n}, work, x, dx);")
    body += ["}", "", "void lg_mass_forcing(double t, double *x, double *u, double *p, double *M, double *f) {"]
    body += pr.unpack()
    body += lines
    body += _stores(n, exprs, ("M", "f"), ";")
    body += ["}", "", "double lg_energy(double t, double *x, double *u, double *p) {"]
    body += pr.unpack()
    lines, exprs = pr.block([h])
    body += lines + [f"    return {exprs[0]};", "}", ""]
    body += ["void lg_lagrange_parts(double t, double *x, double *u, double *p, double *pm, double *F) {"]
    body += pr.unpack()
    lines, exprs = pr.block(pm + F)
    body += lines
    body += _stores(n, exprs, ("pm", "F"), ";")
    body += ["}", ""]
    return head + "\n".join(body)


def _rhs_values(n: int, exprs, decl: str = "", end: str = "") -> list[str]:
    """Lines naming M's lower triangle and f for the unrolled solve (m{i}_{j}, f{i}), or storing
    them in work[] for the loop solve (n > UNROLL_MAX); `decl` and `end` make them C."""
    out, k = [], 0
    for i in range(n):
        for j in range(i + 1):
            out.append(f"    {decl}m{i}_{j} = {exprs[k]}{end}" if n <= UNROLL_MAX
                       else f"    work[{i * n + j}] = {exprs[k]}{end}")
            k += 1
    for i in range(n):
        out.append(f"    {decl}f{i} = {exprs[k + i]}{end}" if n <= UNROLL_MAX
                   else f"    work[{n * n + i}] = {exprs[k + i]}{end}")
    return out


def _stores(n: int, exprs, names: tuple[str, str], end: str = "") -> list[str]:
    """Lines storing into two output arrays: ("M", "f"), exprs = M's lower triangle then f (M
    filled symmetric, row-major); or ("pm", "F"), exprs = n values each."""
    first, second = names
    out, k = [], 0
    if first == "M":
        for i in range(n):
            for j in range(i + 1):
                out.append(f"    M[{i * n + j}] = {exprs[k]}{end}")
                if i != j:
                    out.append(f"    M[{j * n + i}] = M[{i * n + j}]{end}")
                k += 1
    else:
        out += [f"    {first}[{i}] = {e}{end}" for i, e in enumerate(exprs[:n])]
        k = n
    out += [f"    {second}[{i}] = {e}{end}" for i, e in enumerate(exprs[k:])]
    return out


def write_once(path: Path, text: str) -> None:
    """Write atomically (another process may be reading the same cache)."""
    if path.exists():
        return
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=path.suffix, dir=path.parent)
    with os.fdopen(fd, "w") as fh:
        fh.write(text)
    os.replace(tmp, path)


def load_module(path: Path, name: str):
    """Import the generated module at `path` (once per process)."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module
