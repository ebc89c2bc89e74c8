"""The saddle-point solve and the projection onto the constraints, written once and emitted for
numba and for C (the numba module's ``rhs`` and ``project``, the C backend's and export_c's);
:class:`lagrangian.numeric._constrained.ConstrainedModel` transcribes the same steps in NumPy.

The algorithm (the range-space method, Nocedal and Wright 16.2; Golub and Van Loan 12.1).
M q_ddot = f + G^T lambda, G q_ddot = c, that is

    [ M   G^T ] [ q_ddot  ]   [ f ]
    [ G    0  ] [ -lambda ] = [ c ],

with M symmetric positive definite on a mechanism (the kinetic energy):

1. M = L D L^T (unit lower L, no pivoting: M is positive definite). Its *inertia measure*
   r_M = min_j D_j / M_jj is 1 for a diagonal M and 0 for a singular one: the unconstrained solve's.
2. Z = L^-1 G^T, and the QR factorization Z = Q R by modified Gram-Schmidt in the metric D^-1
   (Q^T D^-1 Q = I), so that R^T R = Z^T D^-1 Z = G M^-1 G^T = S, the Schur complement, without
   forming S: its *rank measure* rho_G = min_k R_kk / max_k |z_k| (|z_k| the length of column k
   before orthogonalization) is the sine of the angle between a constraint's direction and those
   of the constraints before it, in the kinetic-energy metric: 1 for independent orthogonal
   constraints, 0 for dependent ones (a dead point) or a constraint whose gradient vanishes while
   another's does not. S's own Cholesky pivots are its square (their cosine is lost to round-off
   at rho_G ~ 1e-8), rho_G is resolved down to round-off (1e-16): the thresholds below sit four
   orders of magnitude above it, so that every backend decides the same way.
3. a = M^-1 f (L, D), w = R^-T (c - G a), lambda = R^-1 w, q_ddot = a + L^-T D^-1 Q w.

Written as generated, the QR keeps its columns unnormalized: Z = V R' with V^T D^-1 V = diag(d) and
R' unit upper triangular (Q = V d^-1/2, R = d^1/2 R': the same measure, min_k d_k / |z_k|^2 under
one square root), so that step 3 is w' = d^-1 R'^-T (c - G a), lambda = R'^-1 w', q_ddot = a +
L^-T D^-1 V w': no square root and no division on the chain of dependent operations but one 1/d_k
per column. Where n and m are small enough to be written out, the products with a structural zero
(an entry of M or G that is 0 in the equations, and those of L, Z, V and R' that follow from them:
_structure) are left out. Both change the rounding, not the decisions; the NumPy transcription
(LAPACK's Cholesky and QR) agrees to rounding.

The *measure* is min(r_M, rho_G) (r_M alone at m = 0: then steps 2 and 3 vanish and this is the
unconstrained solve). The compiled DOP853 stops at once where it is at most SINGULAR_RATIO and
locates the crossing of EVENT_RATIO (numeric._kernels); the SciPy path does the same. Which of the
two measures fell tells a singular M from dependent constraints.

The projection after a step: the coordinates onto the holonomic g(q, t) = 0 by at most
PROJECTION_STEPS Gauss-Newton steps of the smallest change, q -= G_h^T (G_h G_h^T)^-1 g = Q R^-T g
with G_h^T = Q R (the same QR in the identity metric), until max|g| <= PROJECTION_TOL (1 + max|q|),
or after the step that started from max|g| <= NEWTON_EXIT (1 + max|q|) (its residual is then of
the order of the square); the velocities onto G q_dot + b = 0 with the smallest change of kinetic
energy, q_dot -= M^-1 G^T S^-1 w = L^-T D^-1 Q R^-T w (steps 1 and 2 again). Where the QR's
measure is at most SINGULAR_RATIO the step is not taken (the result code says SINGULAR).

The work array holds, in order: M (n*n, its lower triangle row-major, L below the diagonal after
the factorization), f (n), G (m*n), c (m), D (n), 1/D (n), a (n), Z then V (m columns of n), R'
(m*m, upper; 1/d_k on its diagonal), lambda (m), w (m), v (n), and the holonomic g (m) and G_h (m*n)
of the projection.

A change of the template changes the generated code: bump numeric._codegen.GENERATOR_VERSION with
it (the compiled modules are found in the cache by a fingerprint of the equations and that
version, and Python reads lambda from the work array by this layout).
"""

from __future__ import annotations

import re
from contextlib import contextmanager

import numpy as np

from ..equations import Equations
from ..model._constraints import HOLONOMIC
from ._codegen import _cfunc_head, _Printer
from ._kernels import EVENT_RATIO, PROJECTION_MET, PROJECTION_NOT_FINITE, PROJECTION_SINGULAR, SINGULAR_RATIO

__all__ = ["C_DECLARATIONS", "EVENT_RATIO", "MET", "NEWTON_EXIT", "NOT_FINITE", "PROJECTION_STEPS", "PROJECTION_TOL",
           "SINGULAR", "SINGULAR_RATIO", "compiled_multipliers", "compiled_project", "compiled_projection",
           "compiled_solve", "constrained_c", "constrained_main", "layout", "work_size"]

#: Gauss-Newton steps of one projection of the coordinates (each converges quadratically from a
#: step's error).
PROJECTION_STEPS = 4
#: The coordinates are on the constraints when max|g| <= PROJECTION_TOL * (1 + max|q|).
PROJECTION_TOL = 1e-14
#: A Gauss-Newton step from max|g| <= NEWTON_EXIT * (1 + max|q|) is the last: the residual after
#: it is of the order of the square.
NEWTON_EXIT = 1e-8
#: The projection's result codes (export_c's <ID>_MET, <ID>_SINGULAR, <ID>_NOT_FINITE), returned by
#: the numba module's and the C backend's project (as a double) to the compiled DOP853, which stops
#: with Status.PROJECTION_SINGULAR or PROJECTION_NOT_FINITE where one is not MET.
MET, SINGULAR, NOT_FINITE = PROJECTION_MET, PROJECTION_SINGULAR, PROJECTION_NOT_FINITE
#: numba's rhs factors M and G before it evaluates f and c (see constrained_main) where f and c
#: need at least this many common subexpressions of their own (the bicycle 393, the four-bar 4).
SPLIT_MIN = 64


def layout(n: int, m: int) -> dict[str, int]:
    """The offsets of the work array's parts (see the module) and its size, "size"."""
    out, at = {}, 0
    for name, size in (("F0", 0), ("G0", n), ("C0", m * n), ("D0", m), ("E0", n), ("A0", n), ("Q0", n), ("R0", n * m),
                       ("L0", m * m), ("W0", m), ("V0", m), ("P0", n), ("H0", m), ("size", m * n)):
        at += size if name != "F0" else n * n
        out[name] = at
    return out


def work_size(n: int, m: int) -> int:
    """The length of the work array of rhs and project."""
    return layout(n, m)["size"]


#: The declarations (cffi cdef) of constrained_c's two functions, with the default prefix.
C_DECLARATIONS = """
double lg_constrained_rhs(double t, double *x, double *u, double *p, double *dx, double *work);
double lg_project(double t, double *x, double *u, double *p, double *work, double *drift);
"""


# ------------------------------------------------------------------------------- one text, two languages
_TO_PY = [(r"&&", "and"), (r"\|\|", "or"), (r"!(?!=)", "not "), (r"\bfmin\(", "min("), (r"\bfmax\(", "max("),
          (r"\bfabs\(", "abs("), (r"\bsqrt\(", "math.sqrt("), (r"\bisfinite\(", "math.isfinite("),
          (r"\bINFINITY\b", "math.inf")]


def _c_arg(name: str, ctype: str) -> str:
    return f"{ctype}{name}" if ctype.endswith("*") else f"{ctype} {name}"


class _Emit:
    """Statements of the algorithm in numba's Python or in C99, from one description: expressions
    are written in the C subset both read (+ - * /, comparisons, && || !(...), fmin fmax fabs sqrt
    isfinite, INFINITY, a[i]) and translated word by word for Python.

    With `unroll` (n and m at most UNROLL_MAX) the loops whose bounds are constants are written out
    statement by statement with constant indices (the same operations in the same order: the same
    numbers bit for bit), and a helper with a size argument m is written once per size it is called
    with (lg_qr for m = M, lg_qr_<m> for the holonomic MH < M); an offset b stays an argument."""

    def __init__(self, lang: str, consts: dict[str, int | float], unroll: bool = False,
                 zeros: dict[int, frozenset[int]] | None = None):
        self.lang, self.consts, self.unroll, self.lines, self.depth = lang, consts, unroll, [], 0
        self.defined: set[str] = set()
        self.defs: list[str] = []
        # structural zeros (see _structure): {m: the work entries that are 0 wherever a helper of size m,
        # or the code of the rhs (m = M), reads them}; written out, a term reading one is left out
        self.zeros = zeros if unroll and zeros else {}
        self.zero: frozenset[int] = self.zeros.get(consts.get("M"), frozenset())

    def is_zero(self, index: str) -> bool:
        """Whether work[index] (a constant index, written out) is a structural zero here."""
        if not self.zero:
            return False
        text = self.x(str(index))
        return bool(re.fullmatch(r"\d+", text)) and int(text) in self.zero

    def _reads_zero(self, term: str) -> bool:
        return bool(self.zero) and any(int(k) in self.zero for k in re.findall(r"work\[(\d+)\]", self.x(term)))

    def x(self, expr: str) -> str:
        for name, value in self.consts.items():
            expr = re.sub(rf"\b{name}\b", repr(value), expr)
        expr = re.sub(r"\[([\d\s+*()-]+)\]", lambda k: f"[{_int(k.group(1))}]", expr)  # constant indices
        if self.lang == "py":
            for pattern, repl in _TO_PY:
                expr = re.sub(pattern, repl, expr)
        return expr

    def line(self, text: str) -> None:
        self.lines.append("    " * self.depth + text)

    def do(self, stmt: str) -> None:
        """An assignment or a call."""
        self.line(self.x(stmt) + (";" if self.lang == "c" else ""))

    def ret(self, expr: str = "") -> None:
        self.line(("return " + self.x(expr)).rstrip() + (";" if self.lang == "c" else ""))

    def stop(self) -> None:
        self.line("break;" if self.lang == "c" else "break")

    @contextmanager
    def block(self, head_py: str, head_c: str):
        self.line(head_py if self.lang == "py" else head_c + " {")
        self.depth += 1
        yield
        self.depth -= 1
        if self.lang == "c":
            self.line("}")

    def loop(self, var: str, lo, hi, unroll: bool = True):
        """Iterate the body once with `var` (a loop) or, unrolled, once per value (an int)."""
        lo, hi = self.x(str(lo)), self.x(str(hi))
        if self.unroll and unroll:
            yield from range(_int(lo), _int(hi))
            return
        with self.block(f"for {var} in range({lo}, {hi}):", f"for ({var} = {lo}; {var} < {hi}; {var}++)"):
            yield var

    def down(self, var: str, hi, lo=0):
        """var from hi - 1 down to lo."""
        hi, lo = self.x(str(hi)), self.x(str(lo))
        if self.unroll:
            yield from range(_int(hi) - 1, _int(lo) - 1, -1)
            return
        with self.block(f"for {var} in range({hi} - 1, {lo} - 1, -1):",
                        f"for ({var} = {hi} - 1; {var} >= {lo}; {var}--)"):
            yield var

    def total(self, var: str, init: str, op: str, k: str, lo, hi, term) -> None:
        """var = init op (the sum of term(k) over k from lo to hi - 1), op "+" or "-": a loop; unrolled,
        one expression with the sum taken pairwise (a tree of additions of depth log2 of the count,
        not a chain: the dot products of the factorizations are the critical path)."""
        if not self.unroll:
            self.do(f"{var} = {init}")
            for v in self.loop(k, lo, hi):
                self.do(f"{var} {op}= {term(v)}")
            return
        terms = [term(v) for v in range(_int(self.x(str(lo))), _int(self.x(str(hi))))]
        terms = [t for t in terms if not self._reads_zero(t)]  # a structural zero's product: 0 (see _structure)
        while len(terms) > 1:
            terms = [f"({a} + {b})" for a, b in zip(terms[::2], terms[1::2])] + terms[len(terms) - len(terms) % 2:]
        if not terms:
            self.do(f"{var} = {init}")
        elif init == "0.0" and op == "+":
            self.do(f"{var} = {terms[0]}")
        else:
            self.do(f"{var} = {init} {op} {terms[0]}")

    def when(self, cond: str):
        c = self.x(cond)
        return self.block(f"if {c}:", f"if ({c})")

    def call(self, name: str, *args: str, m: int | None = None) -> str:
        """The text of a call of helper `name` (written on first use) with `args` after work, and
        its size m where it takes one (a constant when unrolled: then one helper per size)."""
        ret, params, doubles, ints, doc, body = _HELPERS[name]
        sized = any(a == "m" for a, _ in params)
        fname = f"{name}_{m}" if self.unroll and sized and m != self.consts["M"] else name
        if sized and not self.unroll:
            args = (str(m), *args)
        if fname not in self.defined:
            self.defined.add(fname)
            saved = self.lines, self.depth, self.zero
            self.lines, self.depth = [], 1
            if sized and self.zeros:  # the projection's QR of the holonomic rows (m = MH < M) has its own zeros
                self.zero = self.zeros.get(m, frozenset())
            body(self, m if self.unroll else "m") if sized else body(self)
            self._define(fname, ret, [a for a in params if not (self.unroll and a[0] == "m")], doubles, ints, doc)
            self.lines, self.depth, self.zero = saved
        return f"{fname}({', '.join(args if params[0][0] != 'work' else ('work', *args))})"

    def _define(self, name, ret, params, doubles, ints, doc):
        body = self.lines
        text = "\n".join(body)
        if self.lang == "py":
            # error_model="numpy": no ZeroDivisionError test at each division (each divisor is tested
            # positive first, as in C); inline="always": the sizes become constants in rhs and project
            head = ["", "", '@njit(cache=True, error_model="numpy", inline="always")',
                    f"def {name}({', '.join(a for a, _ in params)}):"] + ([f'    """{doc}"""'] if doc else [])
            self.defs += head + body
        else:
            local = [", ".join(v for v in names.split(", ") if re.search(rf"\b{v}\b", text))
                     for names in (doubles, ints)]
            args = ", ".join(_c_arg(a, t) for a, t in params)
            head = ["", f"/* {doc} */" if doc else "", f"static {ret} {name}({args}) {{"]
            head += [f"    {kind} {names};" for kind, names in zip(("double", "int"), local) if names]
            self.defs += head + body + ["}"]


def _int(expr: str) -> int:
    """The value of an integer expression of constants (+ - * and parentheses)."""
    if not re.fullmatch(r"[\d\s+*()-]+", expr):
        raise ValueError(f"not a constant: {expr}")
    return int(eval(expr, {"__builtins__": {}}))  # noqa: S307 (digits and + - * only, checked above)


# ------------------------------------------------------------------------------- the algorithm's steps
def _ldl(e: _Emit) -> None:
    e.do("r = 1.0")
    for j in e.loop("j", 0, "N"):
        e.total("d", f"work[{j} * N + {j}]", "-", "k", 0, j,
                lambda k: f"work[{j} * N + {k}] * work[{j} * N + {k}] * work[D0 + {k}]")
        with e.when("!(d > 0.0 && d < INFINITY)"):
            e.ret("0.0")
        e.do(f"r = fmin(r, d / work[{j} * N + {j}])")
        e.do(f"work[D0 + {j}] = d")
        e.do("inv = 1.0 / d")
        e.do(f"work[E0 + {j}] = inv")
        for i in e.loop("i", f"{j} + 1", "N"):
            e.total("s", f"work[{i} * N + {j}]", "-", "k", 0, j,
                    lambda k: f"work[{i} * N + {k}] * work[{j} * N + {k}] * work[D0 + {k}]")
            e.do(f"work[{i} * N + {j}] = s * inv")
    e.ret("r")


def _lower(e: _Emit) -> None:
    for i in e.loop("i", 0, "N"):
        e.total("s", f"work[b + {i}]", "-", "k", 0, i, lambda k: f"work[{i} * N + {k}] * work[b + {k}]")
        e.do(f"work[b + {i}] = s")


def _upper(e: _Emit) -> None:
    for i in e.down("i", "N"):
        e.total("s", f"work[b + {i}] * work[E0 + {i}]", "-", "k", f"{i} + 1", "N",
                lambda k: f"work[{k} * N + {i}] * work[b + {k}]")
        e.do(f"work[b + {i}] = s")


def _qr(e: _Emit, m) -> None:
    e.do("big = 0.0")
    for k in e.loop("k", 0, m):
        e.total("s", "0.0", "+", "i", 0, "N",
                lambda i: f"work[Q0 + {k} * N + {i}] * work[Q0 + {k} * N + {i}] * work[E0 + {i}]")
        e.do("big = fmax(big, s)")
    with e.when("!(big > 0.0 && big < INFINITY)"):
        e.ret("0.0")
    e.do("rho = big")  # min(big, d_k ...) / big at the end: min_k d_k / big, one division (it is monotonic)
    for k in e.loop("k", 0, m):  # column k is orthogonal to v_0 .. v_k-1: v_k, then the later columns made
        # orthogonal to it (right-looking: the same operations on each column in the same order as
        # column by column, but the later columns' updates are independent of each other); v_k is not
        # normalized (no square root, no scaling of the column on the chain of dependent operations)
        e.total("s", "0.0", "+", "i", 0, "N",
                lambda i: f"work[Q0 + {k} * N + {i}] * work[Q0 + {k} * N + {i}] * work[E0 + {i}]")
        with e.when("!(s > 0.0 && s < INFINITY)"):
            e.ret("0.0")
        e.do("rho = fmin(rho, s)")
        e.do("s = 1.0 / s")
        e.do(f"work[R0 + {k} * M + {k}] = s")
        for j in e.loop("j", f"{k} + 1", m):
            e.total("t", "0.0", "+", "i", 0, "N",
                    lambda i: f"work[Q0 + {k} * N + {i}] * work[Q0 + {j} * N + {i}] * work[E0 + {i}]")
            e.do("t = t * s")
            e.do(f"work[R0 + {k} * M + {j}] = t")
            for i in e.loop("i", 0, "N"):
                if not e.is_zero(f"Q0 + {k} * N + {i}"):
                    e.do(f"work[Q0 + {j} * N + {i}] -= t * work[Q0 + {k} * N + {i}]")
    e.ret("sqrt(rho / big)")


def _rt(e: _Emit, m) -> None:
    for k in e.loop("k", 0, m):  # y = R'^-T b (R' unit upper), then w' = y / d
        e.total("s", f"work[b + {k}]", "-", "j", 0, k, lambda j: f"work[R0 + {j} * M + {k}] * work[b + {j}]")
        e.do(f"work[b + {k}] = s")
    for k in e.loop("k", 0, m):
        e.do(f"work[b + {k}] *= work[R0 + {k} * M + {k}]")


def _qv(e: _Emit, m) -> None:
    for i in e.loop("i", 0, "N"):
        e.total("s", "0.0", "+", "k", 0, m, lambda k: f"work[Q0 + {k} * N + {i}] * work[b + {k}]")
        e.do(f"work[V0 + {i}] = s")


def _to_q(e: _Emit) -> None:
    """Z = L^-1 G^T into Q0 (step 2's start)."""
    for k in e.loop("k", 0, "M"):
        for i in e.loop("i", 0, "N"):
            e.do(f"work[Q0 + {k} * N + {i}] = work[G0 + {k} * N + {i}]")
        e.do(e.call("lg_lower", f"Q0 + {k} * N"))


def _factor(e: _Emit) -> None:
    e.do(f"r = {e.call('lg_ldl')}")
    with e.when("r <= SINGULAR_RATIO"):
        e.ret("r")
    _to_q(e)
    e.do(f"rho = {e.call('lg_qr', m=e.consts['M'])}")
    e.ret("fmin(r, rho)")


def _finite(e: _Emit) -> None:
    """Return -1.0 where f, G or c is not finite."""
    for i in e.loop("i", 0, "N + M * N + M", unroll=False):
        with e.when(f"!isfinite(work[F0 + {i}])"):
            e.ret("-1.0")


def _step3(e: _Emit) -> None:
    """Step 3 (M factored, Z = Q R): q_ddot into A0, lambda into L0."""
    M = e.consts["M"]
    for i in e.loop("i", 0, "N"):
        e.do(f"work[A0 + {i}] = work[F0 + {i}]")
    e.do(e.call("lg_lower", "A0"))
    e.do(e.call("lg_upper", "A0"))
    for k in e.loop("k", 0, "M"):
        e.total("s", f"work[C0 + {k}]", "-", "i", 0, "N", lambda i: f"work[G0 + {k} * N + {i}] * work[A0 + {i}]")
        e.do(f"work[W0 + {k}] = s")
    e.do(e.call("lg_rt", "W0", m=M))
    for k in e.down("k", "M"):
        e.total("s", f"work[W0 + {k}]", "-", "i", f"{k} + 1", "M",
                lambda i: f"work[R0 + {k} * M + {i}] * work[L0 + {i}]")
        e.do(f"work[L0 + {k}] = s")
    e.do(e.call("lg_qv", "W0", m=M))
    e.do(e.call("lg_upper", "V0"))
    for i in e.loop("i", 0, "N"):
        e.do(f"work[A0 + {i}] += work[V0 + {i}]")


def _saddle(e: _Emit) -> None:
    e.do(f"r = {e.call('lg_ldl')}")
    with e.when("r <= SINGULAR_RATIO"):
        e.ret("r")
    _finite(e)
    _to_q(e)
    e.do(f"r = fmin(r, {e.call('lg_qr', m=e.consts['M'])})")
    with e.when("r <= SINGULAR_RATIO"):
        e.ret("r")
    _step3(e)
    e.ret("r")


def _range(e: _Emit) -> None:
    _to_q(e)
    e.ret(e.call("lg_qr", m=e.consts["M"]))


def _solve(e: _Emit) -> None:
    _finite(e)
    with e.when("r <= SINGULAR_RATIO"):
        e.ret("r")
    _step3(e)
    e.ret("r")


def _projection(e: _Emit) -> None:
    M, MH = e.consts["M"], e.consts["MH"]
    e.do("nq = 0.0")
    for i in e.loop("i", 0, "N"):
        e.do(f"nq = fmax(nq, fabs(x[{i}]))")
    e.do("nq += 1.0")
    if MH:
        for _ in e.loop("it", 0, "PROJECTION_STEPS", unroll=False):
            e.do("lg_position(t, x, u, p, work)")
            e.do("gmax = 0.0")
            for k in e.loop("k", 0, "MH", unroll=False):  # g_h at P0, G_h at H0 = P0 + M (not P0 + MH)
                with e.when(f"!isfinite(work[P0 + {k}])"):
                    e.ret("NOT_FINITE")
            for k in e.loop("k", 0, "MH * N", unroll=False):
                with e.when(f"!isfinite(work[H0 + {k}])"):
                    e.ret("NOT_FINITE")
            for k in e.loop("k", 0, "MH"):
                e.do(f"gmax = fmax(gmax, fabs(work[P0 + {k}]))")
            with e.when("it == 0"):
                e.do("drift[0] = fmax(drift[0], gmax)")
            with e.when("gmax <= PROJECTION_TOL * nq"):
                e.stop()
            for k in e.loop("k", 0, "MH"):  # G_h^T = Q R in the identity metric
                e.do(f"work[W0 + {k}] = work[P0 + {k}]")
                for i in e.loop("i", 0, "N"):
                    e.do(f"work[Q0 + {k} * N + {i}] = work[H0 + {k} * N + {i}]")
            for i in e.loop("i", 0, "N"):
                e.do(f"work[E0 + {i}] = 1.0")
            with e.when(f"{e.call('lg_qr', m=MH)} <= SINGULAR_RATIO"):
                e.ret("SINGULAR")
            e.do(e.call("lg_rt", "W0", m=MH))
            e.do(e.call("lg_qv", "W0", m=MH))
            for i in e.loop("i", 0, "N"):
                e.do(f"x[{i}] -= work[V0 + {i}]")
            with e.when("gmax <= NEWTON_EXIT * nq"):
                e.stop()
    e.do("lg_velocity(t, x, u, p, work)")
    e.do("wmax = 0.0")
    for k in e.loop("k", 0, "M"):
        with e.when(f"!isfinite(work[W0 + {k}])"):
            e.ret("NOT_FINITE")
        e.do(f"wmax = fmax(wmax, fabs(work[W0 + {k}]))")
    for i in e.loop("i", 0, "N", unroll=False):  # M's lower triangle and G
        for k in e.loop("k", 0, f"{i} + 1", unroll=False):
            with e.when(f"!isfinite(work[{i} * N + {k}])"):
                e.ret("NOT_FINITE")
    for k in e.loop("k", 0, "M * N", unroll=False):
        with e.when(f"!isfinite(work[G0 + {k}])"):
            e.ret("NOT_FINITE")
    e.do("drift[1] = fmax(drift[1], wmax)")
    with e.when("wmax > 0.0"):
        with e.when(f"{e.call('lg_factor')} <= SINGULAR_RATIO"):
            e.ret("SINGULAR")
        e.do(e.call("lg_rt", "W0", m=M))
        e.do(e.call("lg_qv", "W0", m=M))
        e.do(e.call("lg_upper", "V0"))
        for i in e.loop("i", 0, "N"):
            e.do(f"x[N + {i}] -= work[V0 + {i}]")
    for i in e.loop("i", 0, "2 * N", unroll=False):
        with e.when(f"!isfinite(x[{i}])"):
            e.ret("NOT_FINITE")
    e.ret("MET")


_W = "double *"
#: name: (C return type, arguments (name, C type), the C locals double and int, doc, the steps)
_HELPERS = {
    "lg_ldl": ("double", [("work", _W)], "r, d, s, inv", "i, j, k",
               "M = L D L^T in place (M's lower triangle in work[0:N*N], D at D0, 1/D at E0); the inertia measure "
               "min_j D_j / M_jj (0 where M is not positive definite)", _ldl),
    "lg_lower": ("void", [("work", _W), ("b", "int")], "s", "i, k", "work[b:b+N] <- L^-1 work[b:b+N] (L unit lower)",
                 _lower),
    "lg_upper": ("void", [("work", _W), ("b", "int")], "s", "i, k", "work[b:b+N] <- L^-T D^-1 work[b:b+N]", _upper),
    "lg_qr": ("double", [("work", _W), ("m", "int")], "big, s, t, rho", "i, j, k",
              "Z = V R' (the m columns of Z at Q0, column k at Q0 + k N, become V's) by modified Gram-Schmidt "
              "in the metric D^-1, V's columns orthogonal, not normalized (V^T D^-1 V = diag(d)), R' unit upper "
              "(R'_jk at R0 + j M + k, 1/d_k on the diagonal); Z = Q R with Q = V d^-1/2, R = d^1/2 R'. The "
              "rank measure min_k R_kk / max_k |z_k| (0 where a column is 0 or not finite)", _qr),
    "lg_rt": ("void", [("work", _W), ("m", "int"), ("b", "int")], "s", "j, k",
              "work[b:b+m] <- d^-1 R'^-T work[b:b+m] (= d^-1/2 R^-T)", _rt),
    "lg_qv": ("void", [("work", _W), ("m", "int"), ("b", "int")], "s", "i, k",
              "work[V0:V0+N] <- V work[b:b+m] (after lg_rt: Q R^-T)", _qv),
    "lg_factor": ("double", [("work", _W)], "r, rho", "i, k",
                  "Steps 1 and 2 (M, G in work): the measure min(r_M, rho_G)", _factor),
    "lg_saddle": ("double", [("work", _W)], "r, s", "i, k",
                  "q_ddot into work[A0:A0+N] and lambda into work[L0:L0+M] from M, f, G, c in work; the "
                  "measure (-1.0 where f, G or c is not finite)", _saddle),
    "lg_range": ("double", [("work", _W)], "", "i, k",
                 "Step 2 (M factored, G in work): Z = L^-1 G^T = Q R; the rank measure", _range),
    "lg_solve": ("double", [("work", _W), ("r", "double")], "s", "i, k",
                 "After lg_ldl and lg_range (r: the smaller measure): lg_saddle's test of f, G, c and step 3; "
                 "returns r (-1.0 where f, G or c is not finite)", _solve),
    "lg_projection": ("int", [("t", "double"), ("x", _W), ("u", _W), ("p", _W), ("work", _W), ("drift", _W)],
                      "nq, wmax, gmax", "i, k, it",
                      "x onto the constraints (see the module); drift[0], drift[1]: the largest |g|, |w| met "
                      "before projecting. Returns MET, SINGULAR or NOT_FINITE", _projection),
}


def _algorithm(e: _Emit, mh: int, split: bool = False) -> None:
    """The helpers of the saddle-point solve and of the projection (see the module), into e.defs;
    N, M, MH and the offsets are e's constants. `split`: also lg_saddle's two halves, lg_range and
    lg_solve (numba's rhs calls lg_ldl and lg_range after M and G, before f and c, then lg_solve)."""
    e.call("lg_saddle")
    if split:
        e.call("lg_range")
        e.call("lg_solve", "r")
    e.call("lg_projection", "t", "x", "u", "p", "work", "drift")
    e.lines = e.defs


def _constants(eq: Equations) -> tuple[dict, int]:
    n, m = eq.n, len(eq.model.constraints)
    mh = len(holonomic_rows(eq))
    consts = {"N": n, "M": m, "MH": mh, **{k: v for k, v in layout(n, m).items() if k != "size"},
              "SINGULAR_RATIO": SINGULAR_RATIO, "PROJECTION_STEPS": PROJECTION_STEPS,
              "PROJECTION_TOL": PROJECTION_TOL, "NEWTON_EXIT": NEWTON_EXIT, "MET": MET, "SINGULAR": SINGULAR,
              "NOT_FINITE": NOT_FINITE}
    return consts, mh


def _structure(eq: Equations, consts: dict) -> dict[int, frozenset[int]]:
    """The structural zeros of the written-out solve: {m: the indices of the work array that hold 0
    wherever the code of size m reads them} (m = M: the rhs, the velocity projection and their
    helpers; m = MH < M: the QR of the holonomic rows in the coordinate projection).

    Known from the generated expressions (an entry of M or G that is 0): L's pattern from M's by the
    fill-in of M = L D L^T without pivoting, Z = L^-1 G^T's column by column, then Q's and R's of the
    Gram-Schmidt QR (a column takes the pattern of each earlier column it is not orthogonal to by
    structure); the projection's QR from the holonomic rows of G. A product with such an entry is 0
    and is left out of the written-out sums (the Whipple bicycle: M 46 of 64 entries, G 25 of 40,
    L 23 of 28 below the diagonal, Z 33 of 40); the other operations are those of the loop form, the
    sums over fewer terms (rounding changes, not the decisions)."""
    from ._codegen import _mass_and_forcing

    n, m = consts["N"], consts["M"]
    Ms, _ = _mass_and_forcing(eq)
    G = eq.core.G
    return structural_zeros([[Ms[i][j] != 0 for j in range(n)] for i in range(n)],
                            [[G[k, j] != 0 for j in range(n)] for k in range(m)], holonomic_rows(eq), consts)


def structural_zeros(Mnz, Gnz, holonomic, consts: dict) -> dict[int, frozenset[int]]:
    """_structure from the patterns: Mnz[i][j] (M's entry not 0; the lower triangle is read), Gnz[k][j],
    the indices of the holonomic rows, the constants of the layout (N, M, MH, G0, Q0, R0)."""
    n, m, mh = consts["N"], consts["M"], consts["MH"]
    L = [[i > j and bool(Mnz[i][j]) for j in range(n)] for i in range(n)]
    for j in range(n):
        for i in range(j + 1, n):
            L[i][j] = L[i][j] or any(L[i][k] and L[j][k] for k in range(j))
    common = {i * n + j for i in range(n) for j in range(i) if not L[i][j]}
    common |= {consts["G0"] + k * n + j for k in range(m) for j in range(n) if not Gnz[k][j]}

    def qr(columns: list[list[bool]]) -> set[int]:
        Q = [list(c) for c in columns]
        R = [[False] * len(Q) for _ in Q]
        for k in range(len(Q)):
            for j in range(k + 1, len(Q)):
                if any(a and b for a, b in zip(Q[k], Q[j])):
                    R[k][j] = True
                    Q[j] = [a or b for a, b in zip(Q[j], Q[k])]
        zero = {consts["Q0"] + k * n + i for k in range(len(Q)) for i in range(n) if not Q[k][i]}
        # R_kj left 0 only where the final columns share no entry (a superset of those met while the
        # columns were still filling in: the sums are taken over the final patterns)
        return zero | {consts["R0"] + k * m + j for k in range(len(Q)) for j in range(k + 1, len(Q))
                       if not any(a and b for a, b in zip(Q[k], Q[j]))}

    def forward(g: list[bool]) -> list[bool]:  # the pattern of L^-1 g
        z = list(g)
        for i in range(n):
            z[i] = z[i] or any(L[i][k] and z[k] for k in range(i))
        return z

    out = {m: frozenset(common | qr([forward(Gnz[k]) for k in range(m)]))}
    if 0 < mh < m:
        out[mh] = frozenset(common | qr([list(map(bool, Gnz[k])) for k in holonomic]))
    return out


def _unrolled(eq: Equations) -> bool:
    """Whether the template's loops are written out (n and m at most UNROLL_MAX, as the
    unconstrained solve's)."""
    from ._codegen import UNROLL_MAX

    return eq.n <= UNROLL_MAX and len(eq.model.constraints) <= UNROLL_MAX


def holonomic_rows(eq: Equations) -> list[int]:
    """The indices of the holonomic constraints, in the model's order."""
    return [k for k, c in enumerate(eq.model.constraints) if c.kind == HOLONOMIC]


def _parts(eq: Equations):
    """The expressions of the three evaluations and where they go in the work array: (rhs: M's
    lower triangle, f, G, c), (position: g_h, G_h), (velocity: w, G, M's lower triangle)."""
    from ._codegen import _mass_and_forcing

    core = eq.core
    n, m = eq.n, len(core.g)
    at = layout(n, m)
    hol = holonomic_rows(eq)
    Ms, fs = _mass_and_forcing(eq)
    lower = [(i, j) for i in range(n) for j in range(i + 1)]
    Mlow = [Ms[i][j] for i, j in lower]
    G = [core.G[k, j] for k in range(m) for j in range(n)]
    places_M = [i * n + j for i, j in lower]
    places_G = [at["G0"] + k for k in range(m * n)]
    rhs = (Mlow + list(fs) + G + list(core.c),
           places_M + [at["F0"] + i for i in range(n)] + places_G + [at["C0"] + k for k in range(m)])
    position = ([core.g[k] for k in hol] + [core.G[k, j] for k in hol for j in range(n)],
                [at["P0"] + k for k in range(len(hol))] + [at["H0"] + k for k in range(len(hol) * n)])
    velocity = (list(core.w) + G + Mlow, [at["W0"] + k for k in range(m)] + places_G + places_M)
    return rhs, position, velocity


def constrained_main(equations: Equations) -> list[str]:
    """The lines of the numba module's constrained part: the algorithm, ``rhs`` and ``project``."""
    eq = equations
    n = eq.n
    nu, npar = len(eq.inputs), len(eq.parameters)
    consts, mh = _constants(eq)
    size = work_size(n, consts["M"])
    rhs, position, velocity = _parts(eq)
    pr = _Printer(eq, "py")
    out = []

    def parts(name, exprs, places, doc):
        body = ["", "", "@njit(cache=True)", f"def {name}(t, x, u, p, work):", f'    """{doc}"""']
        body += pr.unpack()
        lines, values = pr.block(exprs)
        return body + lines + [f"    work[{k}] = {v}" for k, v in zip(places, values)]

    if mh:
        out += parts("lg_position", *position, "g of the holonomic constraints, then their rows of G.")
    out += parts("lg_velocity", *velocity, "w = G q_dot + b, G and M's lower triangle.")
    body, split = _rhs_body(pr, rhs, consts)
    unroll = _unrolled(eq)
    e = _Emit("py", consts, unroll=unroll, zeros=_structure(eq, consts) if unroll else None)
    _algorithm(e, mh, split=split)
    out += e.lines
    out += ["", "", "@njit(cache=True)", "def _u(u_):", f"    return carray(u_, ({max(nu, 1)},))",
            "", "", "@njit(cache=True)", "def _p(p_):", f"    return carray(p_, ({max(npar, 1)},))"]
    out += _cfunc_head("rhs", "_SIG_RHS", (("dx", 2 * n), ("work", size)), n, nu, npar,
                       "dx = [q_dot, q_ddot] of the saddle-point system; returns the measure (see "
                       "lagrangian.numeric._codegen_constrained).")
    out += pr.unpack() + body
    out += [f"    if r <= {SINGULAR_RATIO!r}:", "        return r",
            f"    for i in range({n}):", "        dx[i] = x[i + N]", f"        dx[i + N] = work[{consts['A0']} + i]",
            "    return r"]
    out += _cfunc_head("project", "_SIG_RHS", (("work", size), ("drift", 2)), n, nu, npar,
                       "x moved onto the constraints (see lagrangian.numeric._codegen_constrained); returns "
                       "MET, SINGULAR or NOT_FINITE (as a double).")
    out.append("    return float(lg_projection(t, x, _u(u_), _p(p_), work, drift))")
    return out


def _rhs_body(pr: _Printer, rhs, consts: dict) -> tuple[list[str], bool]:
    """(numba's rhs from the evaluation of M, f, G, c to r = the measure, whether it calls the split
    helpers lg_range and lg_solve).

    M and G (and what they need) first, factored (lg_ldl, lg_range: the solve's long chain of
    dependent operations) before f and c are evaluated, whose independent work the processor then
    overlaps with that chain's tail; then lg_solve: lg_saddle's operations in its order, the same
    numbers and measures. Where f and c need few statements of their own (fewer than SPLIT_MIN)
    there is nothing to overlap and the split costs (measured in one process with
    benchmarks/constrained.py: the bicycle's rhs 4% faster, the four-bar's and the slider-crank's
    4-7% slower): then M, f, G, c and lg_saddle, as before."""
    exprs, places = rhs
    first = [k for k, at in enumerate(places) if at < consts["F0"] or consts["G0"] <= at < consts["C0"]]
    early, late, values, _ = pr.trig_block(exprs, first=first)
    if len(late) < SPLIT_MIN:
        lines, values, _ = pr.trig_block(exprs)
        return lines + [f"    work[{k}] = {v}" for k, v in zip(places, values)] + ["    r = lg_saddle(work)"], False
    stores = [f"    work[{k}] = {v}" for k, v in zip(places, values)]
    out = early + [stores[k] for k in first]
    out += ["    r = lg_ldl(work)", f"    if r <= {SINGULAR_RATIO!r}:", "        return r", "    rho = lg_range(work)"]
    out += late + [line for k, line in enumerate(stores) if k not in set(first)]
    return out + ["    r = lg_solve(work, min(r, rho))"], True


def _used(lines: list[str], values: list[str]) -> list[str]:
    """`lines` (C definitions of common subexpressions, ``double cK = ...;``) without those that
    nothing reads (SymEngine's CSE can leave one whose uses cancelled): -Wall -Werror builds."""
    keep = list(lines)
    while True:
        text = "\n".join(keep + values)
        unused = [line for line in keep if (m := re.match(r"\s*double (c\d+) = ", line))
                  and len(re.findall(rf"\b{m.group(1)}\b", text)) == 1]
        if not unused:
            return keep
        keep = [line for line in keep if line not in unused]


def constrained_c(equations: Equations, prefix: str = "lg_", storage: str = "", project: bool = True) -> str:
    """The C of the saddle-point solve and the projection: ``<prefix>constrained_rhs(t, x, u, p,
    dx, work)`` (the numba rhs's signature and value) and ``<prefix>project(t, x, u, p, work,
    drift)`` (numba's project: its result code as a double; left out without `project`), after the static helpers, for
    the C backend and export_c. The work arrays hold work_size(n, m) values."""
    eq = equations
    n = eq.n
    consts, mh = _constants(eq)
    rhs, position, velocity = _parts(eq)
    pr = _Printer(eq, "c")
    quiet = ["    " + " ".join(["(void)t;", "(void)x;", "(void)u;", "(void)p;",
                                *(f"(void){local};" for local, _, _ in pr.locals)])]
    out = []

    def parts(name, exprs, places):
        body = [f"static void {name}(double t, double *x, double *u, double *p, double *work) {{"]
        body += pr.unpack() + quiet
        lines, values = pr.block(exprs)
        return body + _used(lines, values) + [f"    work[{k}] = {v};" for k, v in zip(places, values)] + ["}", ""]

    if mh:
        out += parts("lg_position", *position)
    out += parts("lg_velocity", *velocity)
    unroll = _unrolled(eq)
    e = _Emit("c", consts, unroll=unroll, zeros=_structure(eq, consts) if unroll else None)
    _algorithm(e, mh)
    out += e.lines
    out += ["", (f"{storage}double {prefix}constrained_rhs(double t, double *x, double *u, double *p, double *dx, "
                 "double *work) {"), "    double r;", "    int i;"]
    out += pr.unpack() + quiet
    lines, exprs = pr.block(rhs[0])
    out += _used(lines, exprs) + [f"    work[{k}] = {v};" for k, v in zip(rhs[1], exprs)]
    out += ["    r = lg_saddle(work);", f"    if (r <= {SINGULAR_RATIO!r}) return r;",
            f"    for (i = 0; i < {n}; i++) {{", f"        dx[i] = x[{n} + i];",
            f"        dx[{n} + i] = work[{consts['A0']} + i];", "    }", "    return r;", "}", ""]
    if project:  # (export_c calls lg_projection for its result code)
        out += [f"{storage}double {prefix}project(double t, double *x, double *u, double *p, double *work, "
                "double *drift) {", "    return (double)lg_projection(t, x, u, p, work, drift);", "}", ""]
    return "\n".join(out)


# ------------------------------------------------------------------------------- calls from Python
def _calls():
    import ctypes

    D = ctypes.POINTER(ctypes.c_double)
    return (ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_double, D, D, D, D, D),
            ctypes.CFUNCTYPE(ctypes.c_double, ctypes.c_double, D, D, D, D, D), D)


def _pointer(a, D):
    return a.ctypes.data_as(D)


def compiled_solve(fast, t, x, u, p):
    """(q_ddot, lambda, measure) of a compiled constrained model's rhs (numba or C) at the state:
    the same steps as ConstrainedModel.solve (q_ddot and lambda are NaN where the measure is at
    most SINGULAR_RATIO or -1.0)."""
    from ._fast import _address

    rhs_t, _, D = _calls()
    n, m = fast.n, len(fast.equations.model.constraints)
    x = np.ascontiguousarray(x, float)
    u, p = (np.ascontiguousarray(v, float) if len(v) else np.zeros(1) for v in (u, p))
    dx, work = np.full(2 * n, np.nan), np.full(work_size(n, m), np.nan)
    r = rhs_t(_address(fast.rhs_c))(float(t), *(_pointer(a, D) for a in (x, u, p, dx, work)))
    L0 = layout(n, m)["L0"]
    lam = work[L0:L0 + m] if r > SINGULAR_RATIO else np.full(m, np.nan)
    return dx[n:], lam.copy(), float(r)


def compiled_multipliers(fast, times, X, U, p) -> np.ndarray:
    """lambda at each row of (times, X, U) by the compiled rhs (one row each); the row where the
    measure is at most SINGULAR_RATIO (or -1.0) raises ConstraintSingular as ConstrainedModel.solve
    does there."""
    from ._constrained import ConstraintSingular
    from ._fast import _address

    rhs_t, _, D = _calls()
    rhs = rhs_t(_address(fast.rhs_c))
    n, m = fast.n, len(fast.equations.model.constraints)
    L0 = layout(n, m)["L0"]
    x, u = np.empty(2 * n), np.zeros(max(1, np.shape(U)[1] if np.ndim(U) == 2 else 0))
    p = np.ascontiguousarray(p, float) if len(p) else np.zeros(1)
    dx, work = np.empty(2 * n), np.empty(work_size(n, m))
    px, pu, pp, pdx, pw = (_pointer(a, D) for a in (x, u, p, dx, work))
    Lam = np.empty((len(times), m))
    for k, t in enumerate(times):
        x[:] = X[k]
        if np.ndim(U) == 2 and np.shape(U)[1]:
            u[:] = U[k]
        r = rhs(float(t), px, pu, pp, pdx, pw)
        if not r > SINGULAR_RATIO:
            raise ConstraintSingular(t, x, r)
        Lam[k] = work[L0:L0 + m]
    return Lam


def compiled_project(fast, t, x, p):
    """(x projected, drift [max |g|, max |w|] met) by a compiled constrained model's projection."""
    x, drift, _ = compiled_projection(fast, t, x, p)
    return x, drift


def compiled_projection(fast, t, x, p):
    """(x projected, drift [max |g|, max |w|] met, result code MET, SINGULAR or NOT_FINITE) by a
    compiled constrained model's projection (where the code is not MET, x as the projection left it)."""
    from ._fast import _address

    _, project_t, D = _calls()
    n, m = fast.n, len(fast.equations.model.constraints)
    x = np.array(x, float)
    u = np.zeros(max(1, len(fast.input_names)))
    p = np.ascontiguousarray(p, float) if len(p) else np.zeros(1)
    work, drift = np.zeros(work_size(n, m)), np.zeros(2)
    code = project_t(_address(fast.project_c))(float(t), *(_pointer(a, D) for a in (x, u, p, work, drift)))
    return x, drift, int(code)
