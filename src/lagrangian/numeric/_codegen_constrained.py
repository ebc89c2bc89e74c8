"""The compiled functions of a constrained model (numba): the saddle-point right-hand side and the
projection onto the constraints, for the DOP853 kernel of _kernels.py.

``rhs(t, x, u, p, dx, work)`` evaluates M (lower triangle), f, the constraint Jacobian G and c of
G q_ddot = c, and solves M q_ddot = f + G^T lambda, G q_ddot = c by the Schur complement: the LDL^T
factors of M give a = M^-1 f and Y = M^-1 G^T, then S = G Y (m x m, symmetric positive definite while
G has full rank) is factorized by Cholesky and S lambda = c - G a gives lambda, q_ddot = a + Y lambda.
It returns min(the inertia measure of M, sqrt of the smallest pivot of S relative to its diagonal):
near 0 where M is singular or the constraints become dependent (a dead point), which the kernel
stops at as it does for a singular M.

``project(t, x, u, p, work, drift)`` moves x onto the constraints as ConstrainedModel.project does:
the coordinates onto the holonomic g = 0 by Gauss-Newton steps with the smallest change
(q -= G^T (G G^T)^-1 g), the velocities onto G q_dot + b = 0 with the smallest change of kinetic
energy (q_dot -= M^-1 G^T (G M^-1 G^T)^-1 w); drift[0], drift[1] receive the largest |g| and |w|
met before projecting. The kernel calls it after every accepted step.

The work array holds, in order: M (n*n, lower triangle row-major), f (n), G (m*n), c (m), the
factor's diagonal (n), a (n), Y (n*m), S (m*m), the right-hand side of S (m), and scratch (n + m).
"""

from __future__ import annotations

from ..equations import Equations
from ..model._constraints import HOLONOMIC
from ._codegen import SINGULAR, UNROLL_MAX, _cfunc_head, _ldl, _Printer

__all__ = ["constrained_main", "work_size"]


def work_size(n: int, m: int) -> int:
    return n * n + n + m * n + m + n + n + n * m + m * m + m + n + m + 2 * n


_LINEAR = """

@njit(cache=True)
def _ldl(work, n):
    \"\"\"LDL^T of M (lower triangle of work[:n*n]) in place, D in work[D0:D0+n]; returns the inertia
    measure min_j D_j / M_jj (0.0 when M is not positive definite).\"\"\"
    D0 = @D0@
    r = 1.0
    for j in range(n):
        mjj = work[j * n + j]
        d = mjj
        for k in range(j):
            d -= work[j * n + k] * work[j * n + k] * work[D0 + k]
        if not (d > 0.0 and d < math.inf):
            return 0.0
        r = min(r, d / mjj)
        work[D0 + j] = d
        inv = 1.0 / d
        for i in range(j + 1, n):
            s = work[i * n + j]
            for k in range(j):
                s -= work[i * n + k] * work[j * n + k] * work[D0 + k]
            work[i * n + j] = s * inv
    return r


@njit(cache=True)
def _ldl_solve(work, n, b, out, stride):
    \"\"\"out[k*stride] = (M^-1 b)[k], with M's factors in work (b and out may be the same array).\"\"\"
    D0 = @D0@
    for i in range(n):
        s = b[i * stride]
        for k in range(i):
            s -= work[i * n + k] * out[k * stride]
        out[i * stride] = s
    for i in range(n - 1, -1, -1):
        s = out[i * stride] / work[D0 + i]
        for k in range(i + 1, n):
            s -= work[k * n + i] * out[k * stride]
        out[i * stride] = s


@njit(cache=True)
def _schur(work, n, m, G0, S0):
    \"\"\"Y = M^-1 G^T (columns in work[Y0:], n x m row-major) and S = G Y (work[S0:], m x m) factorized
    by Cholesky in place; returns the smallest pivot of S relative to its diagonal (0.0 if not
    positive definite).\"\"\"
    Y0 = @Y0@
    for k in range(m):
        for i in range(n):
            work[Y0 + i * m + k] = work[G0 + k * n + i]
        _ldl_solve(work, n, work[Y0 + k:], work[Y0 + k:], m)
    for a in range(m):
        for b in range(m):
            s = 0.0
            for i in range(n):
                s += work[G0 + a * n + i] * work[Y0 + i * m + b]
            work[S0 + a * m + b] = s
    r = 1.0
    for j in range(m):
        sjj = work[S0 + j * m + j]
        d = sjj
        for k in range(j):
            d -= work[S0 + j * m + k] ** 2
        if not (d > 0.0 and d < math.inf) or not (sjj > 0.0):
            return 0.0
        r = min(r, d / sjj)
        d = math.sqrt(d)
        work[S0 + j * m + j] = d
        for i in range(j + 1, m):
            s = work[S0 + i * m + j]
            for k in range(j):
                s -= work[S0 + i * m + k] * work[S0 + j * m + k]
            work[S0 + i * m + j] = s / d
    return r


@njit(cache=True)
def _chol_solve(work, m, S0, b):
    \"\"\"b <- S^-1 b with S's Cholesky factor in work[S0:].\"\"\"
    for i in range(m):
        s = b[i]
        for k in range(i):
            s -= work[S0 + i * m + k] * b[k]
        b[i] = s / work[S0 + i * m + i]
    for i in range(m - 1, -1, -1):
        s = b[i]
        for k in range(i + 1, m):
            s -= work[S0 + k * m + i] * b[k]
        b[i] = s / work[S0 + i * m + i]


@njit(cache=True)
def _saddle(work, x, dx):
    \"\"\"q_ddot of M q_ddot = f + G^T lambda, G q_ddot = c (M, f, G, c in work) into dx[n:];
    lambda into work[L0:L0+m]; returns the measure (see the module).\"\"\"
    n = @N@
    m = @M@
    F0, G0, C0, A0, Y0, S0, L0 = @F0@, @G0@, @C0@, @A0@, @Y0@, @S0@, @L0@
    r = _ldl(work, n)
    if r <= @SINGULAR@:
        return r
    for i in range(n):
        if not math.isfinite(work[F0 + i]):
            return -1.0
    _ldl_solve(work, n, work[F0:], work[A0:], 1)
    rs = _schur(work, n, m, G0, S0)
    if rs <= 0.0:
        return 0.0
    for k in range(m):
        s = work[C0 + k]
        for i in range(n):
            s -= work[G0 + k * n + i] * work[A0 + i]
        work[L0 + k] = s
    _chol_solve(work, m, S0, work[L0:])
    for i in range(n):
        s = work[A0 + i]
        for k in range(m):
            s += work[Y0 + i * m + k] * work[L0 + k]
        dx[n + i] = s
        dx[i] = x[n + i]
    return min(r, math.sqrt(rs))


@njit(cache=True)
def _spd_solve(A, k, b):
    \"\"\"b <- A^-1 b by Cholesky of the k x k A (in place); False if A is not positive definite.\"\"\"
    for j in range(k):
        d = A[j * k + j]
        for q in range(j):
            d -= A[j * k + q] ** 2
        if not d > 0.0:
            return False
        d = math.sqrt(d)
        A[j * k + j] = d
        for i in range(j + 1, k):
            s = A[i * k + j]
            for q in range(j):
                s -= A[i * k + q] * A[j * k + q]
            A[i * k + j] = s / d
    for i in range(k):
        s = b[i]
        for q in range(i):
            s -= A[i * k + q] * b[q]
        b[i] = s / A[i * k + i]
    for i in range(k - 1, -1, -1):
        s = b[i]
        for q in range(i + 1, k):
            s -= A[q * k + i] * b[q]
        b[i] = s / A[i * k + i]
    return True


@njit(cache=True)
def _u(u_):
    return carray(u_, (@NU1@,))


@njit(cache=True)
def _p(p_):
    return carray(p_, (@NP1@,))
"""


def constrained_main(equations: Equations) -> list[str]:
    """The lines of the numba module's constrained part: helpers, ``rhs``, ``project``."""
    from ._codegen import _mass_and_forcing

    core = equations.core
    n, m = equations.n, len(core.g)
    nu, npar = len(equations.inputs), len(equations.parameters)
    hol = [k for k, c in enumerate(equations.model.constraints) if c.kind == HOLONOMIC]
    mh = len(hol)
    F0 = n * n
    G0 = F0 + n
    C0 = G0 + m * n
    D0 = C0 + m
    A0 = D0 + n
    Y0 = A0 + n
    S0 = Y0 + n * m
    L0 = S0 + m * m
    R0 = L0 + m  # scratch
    consts = {"@N@": n, "@M@": m, "@F0@": F0, "@G0@": G0, "@C0@": C0, "@D0@": D0, "@A0@": A0, "@Y0@": Y0,
              "@S0@": S0, "@L0@": L0, "@SINGULAR@": repr(SINGULAR),
              "@NU1@": max(nu, 1), "@NP1@": max(npar, 1)}
    text = _LINEAR
    for k, v in consts.items():
        text = text.replace(k, str(v))
    out = [text]
    Ms, fs = _mass_and_forcing(equations)
    Mlow = [Ms[i][j] for i in range(n) for j in range(i + 1)]
    lower = [(i, j) for i in range(n) for j in range(i + 1)]
    G = [core.G[k, j] for k in range(m) for j in range(n)]
    pr = _Printer(equations, "py")

    def stores(exprs, names):
        return [f"    {name} = {e}" for name, e in zip(names, exprs)]

    # the right-hand side
    out += _cfunc_head("rhs", "_SIG_RHS", (("dx", 2 * n), ("work", work_size(n, m))), n, nu, npar,
                       "dx = [q_dot, q_ddot] of the saddle-point system; returns the measure (see the module).")
    out += pr.unpack()
    lines, exprs, _ = pr.trig_block(Mlow + list(fs) + G + list(core.c))
    out += lines
    targets = ([f"work[{i * n + j}]" for i, j in lower] + [f"work[{F0 + i}]" for i in range(n)]
               + [f"work[{G0 + k}]" for k in range(m * n)] + [f"work[{C0 + k}]" for k in range(m)])
    if n <= UNROLL_MAX and m <= UNROLL_MAX:  # written out: names instead of the work array
        out += [f"    {name} = {e}" for name, e in zip(
            [f"m{i}_{j}" for i, j in lower] + [f"f{i}" for i in range(n)]
            + [f"g{k}_{j}" for k in range(m) for j in range(n)] + [f"c{k}_" for k in range(m)], exprs)]
        out += _unrolled_saddle(n, m)
    else:
        out += stores(exprs, targets)
        out.append("    return _saddle(work, x, dx)")

    # the constraint parts the projection needs, as njit functions of (t, x, u, p, out)
    def parts(name, exprs, doc, places=None):
        body = [f"", f"", "@njit(cache=True)", f"def {name}(t, x, u, p, out):", f'    """{doc}"""']
        body += pr.unpack()
        lines, values = pr.block(exprs)
        places = places or list(range(len(values)))
        body += lines + [f"    out[{k}] = {v}" for k, v in zip(places, values)] + ["    return 0.0"]
        return body

    if mh:
        out += parts("_position", [core.g[k] for k in hol] + [core.G[k, j] for k in hol for j in range(n)],
                     "g of the holonomic constraints, then their rows of G.")
    out += parts("_velocity", list(core.w) + G + Mlow, "w = G q_dot + b (into the scratch), G and M's lower "
                 "triangle (into their places in rhs's layout).",
                 [R0 + k for k in range(m)] + [G0 + k for k in range(m * n)] + [i * n + j for i, j in lower])
    out += _cfunc_head("project", "_SIG_VOID", (("work", work_size(n, m)), ("drift", 2)), n, nu, npar,
                       "x moved onto the constraints (see the module); drift[0], drift[1]: the largest |g|, |w| met.")
    out += [
        "    nq = 1.0",
        f"    for i in range({n}):",
        "        nq = max(nq, abs(x[i]))",
    ]
    if mh:
        out += [
            f"    for it in range(4):",
            "        _position(t, x, _u(u_), _p(p_), work)",
            "        gmax = 0.0",
            f"        for k in range({mh}):",
            "            gmax = max(gmax, abs(work[k]))",
            "        if it == 0:",
            "            drift[0] = max(drift[0], gmax)",
            "        if gmax <= 1e-14 * nq:",
            "            break",
            f"        # (G G^T) y = g, q -= G^T y  (G in work[{mh}:], G G^T and y in the scratch)",
            f"        o = {mh + mh * n}",
            f"        for a in range({mh}):",
            f"            for b in range({mh}):",
            "                s = 0.0",
            f"                for i in range({n}):",
            f"                    s += work[{mh} + a * {n} + i] * work[{mh} + b * {n} + i]",
            f"                work[o + a * {mh} + b] = s",
            f"        y = work[o + {mh * mh}:o + {mh * mh + mh}]",
            f"        for a in range({mh}):",
            "            y[a] = work[a]",
            f"        if not _spd_solve(work[o:o + {mh * mh}], {mh}, y):",
            "            break",
            f"        for i in range({n}):",
            "            s = 0.0",
            f"            for a in range({mh}):",
            f"                s += work[{mh} + a * {n} + i] * y[a]",
            "            x[i] -= s",
            "        if gmax <= 1e-8 * nq:  # Newton from there: the next residual is about gmax**2",
            "            break",
        ]
    out += [
        "    _velocity(t, x, _u(u_), _p(p_), work)",
        "    wmax = 0.0",
        f"    for k in range({m}):",
        f"        wmax = max(wmax, abs(work[{R0} + k]))",
        "    drift[1] = max(drift[1], wmax)",
        "    if wmax == 0.0:",
        "        return",
        f"    if _ldl(work, {n}) <= 0.0 or _schur(work, {n}, {m}, {G0}, {S0}) <= 0.0:",
        "        return",
        f"    w = work[{R0}:{R0 + m}]",
        f"    _chol_solve(work, {m}, {S0}, w)",
        f"    for i in range({n}):",
        "        s = 0.0",
        f"        for k in range({m}):",
        f"            s += work[{Y0} + i * {m} + k] * w[k]",
        f"        x[{n} + i] -= s",
    ]
    return out


def _unrolled_saddle(n: int, m: int) -> list[str]:
    """Statements of rhs's saddle-point solve written out (n, m <= UNROLL_MAX), from the names
    m{i}_{j} (M's lower triangle), f{i}, g{k}_{j} (G) and c{k}_: the LDL^T factors of M (as for an
    unconstrained model), a = M^-1 f and the columns y{k} = M^-1 G_k^T by substitution, S = G Y by
    Cholesky, lambda, and q_ddot = a + Y lambda; the same measure as _saddle."""
    ind = "    "
    out = _ldl(n, "py", lambda i, j: f"m{i}_{j}", lambda i: f"f{i}", part="factor")
    out.append(f"{ind}if not math.isfinite({' + '.join(f'f{i}' for i in range(n))}):")
    out.append(f"{ind}    return -1.0")

    def substitute(rhs, name):  # M^-1 rhs into {name}{i}
        lines = []
        for i in range(n):  # L z = rhs
            terms = "".join(f" - l{i}_{k} * z{name}{k}" for k in range(i))
            lines.append(f"{ind}z{name}{i} = {rhs(i)}{terms}")
        for i in range(n - 1, -1, -1):  # L^T v = D^-1 z
            terms = "".join(f" - l{k}_{i} * {name}{k}" for k in range(i + 1, n))
            lines.append(f"{ind}{name}{i} = z{name}{i} * i{i}{terms}")
        return lines

    out += substitute(lambda i: f"f{i}", "a")
    for k in range(m):
        out += substitute(lambda i, k=k: f"g{k}_{i}", f"y{k}_")
    for a in range(m):  # S = G Y, lower triangle
        for b in range(a + 1):
            out.append(f"{ind}s{a}_{b} = " + " + ".join(f"g{a}_{i} * y{b}_{i}" for i in range(n)))
    out.append(f"{ind}rs = 1.0")
    for j in range(m):  # Cholesky of S
        terms = "".join(f" - h{j}_{k} * h{j}_{k}" for k in range(j))
        out.append(f"{ind}e{j} = s{j}_{j}{terms}")
        out.append(f"{ind}if not (e{j} > 0.0 and s{j}_{j} > 0.0):")
        out.append(f"{ind}    return 0.0")
        out.append(f"{ind}rs = min(rs, e{j} / s{j}_{j})")
        out.append(f"{ind}h{j}_{j} = math.sqrt(e{j})")
        for i in range(j + 1, m):
            terms = "".join(f" - h{i}_{k} * h{j}_{k}" for k in range(j))
            out.append(f"{ind}h{i}_{j} = (s{i}_{j}{terms}) / h{j}_{j}")
    for k in range(m):  # S lambda = c - G a
        ga = " + ".join(f"g{k}_{i} * a{i}" for i in range(n))
        terms = "".join(f" - h{k}_{q} * w{q}" for q in range(k))
        out.append(f"{ind}w{k} = (c{k}_ - ({ga}){terms}) / h{k}_{k}")
    for k in range(m - 1, -1, -1):
        terms = "".join(f" - h{q}_{k} * lam{q}" for q in range(k + 1, m))
        out.append(f"{ind}lam{k} = (w{k}{terms}) / h{k}_{k}")
    for i in range(n):
        out.append(f"{ind}dx[{n + i}] = a{i} + " + " + ".join(f"y{k}_{i} * lam{k}" for k in range(m)))
        out.append(f"{ind}dx[{i}] = x[{n + i}]")
    out.append(f"{ind}return min(r, math.sqrt(rs))")
    return out
