"""The C of a constrained model (M q_ddot = f + G^T lambda, G q_ddot = c), for export_c and the
FMU: the generated constraint functions (G and c; the residuals g and w) and, written once, the
dense LU with partial pivoting that solves the saddle-point system, the projection onto the
constraints after a step (the method of numeric._constrained.ConstrainedModel.project) and the
consistent initial state (that of numeric._constrained.consistent_state)."""

from __future__ import annotations

from .._codetext import c_strings, comment_text
from ..equations import Equations
from ..model._constraints import HOLONOMIC

__all__ = ["holonomic_rows", "generated_functions", "runtime", "header_part", "tables", "example_main", "RETURN_CODES"]

#: The return values of <id>_project and <id>_consistent_state (the header's macros).
RETURN_CODES = (("MET", 0, "the constraints are met"),
                ("POSITION_NOT_MET", 1, "the coordinates that may change cannot meet the holonomic constraints"),
                ("VELOCITY_NOT_MET", 2, "the velocities that may change cannot meet the constraints"),
                ("SINGULAR", 3, ("a linear system is singular (G has lost rank: the constraints are dependent "
                                 "there; or M is singular)")),
                ("NOT_FINITE", 4, "a residual or a Jacobian entry is not finite"))


def holonomic_rows(eq: Equations) -> list[int]:
    """The indices of the holonomic constraints, in the model's order."""
    return [k for k, c in enumerate(eq.model.constraints) if c.kind == HOLONOMIC]


def generated_functions(eq: Equations, prefix: str, quiet: bool = True) -> str:
    """Static C functions ``<prefix>constraint_jacobian(t, x, u, p, G, c)`` (G: m x n row-major,
    c: m values, G q_ddot = c) and ``<prefix>constraint_residuals(t, x, u, p, g, w)`` (g: the
    holonomic constraints' residuals, w = G q_dot + b of all), printed as lagrangian.numeric's C
    (common subexpressions eliminated)."""
    from ..numeric._codegen import _Printer

    core = eq.core
    n, m = eq.n, len(core.g)
    hol = holonomic_rows(eq)
    pr = _Printer(eq, "c")

    def unpack() -> list[str]:
        lines = pr.unpack()
        if quiet:
            lines.append("    " + " ".join(["(void)u;", "(void)p;", *(f"(void){local};" for local, _, _ in pr.locals)]))
        return lines

    body = [f"static void {prefix}constraint_jacobian(double t, double *x, double *u, double *p, double *G, "
            "double *c) {"]
    body += unpack()
    lines, exprs = pr.block([core.G[k, j] for k in range(m) for j in range(n)] + list(core.c))
    body += lines
    body += [f"    G[{i}] = {e};" for i, e in enumerate(exprs[:m * n])]
    body += [f"    c[{k}] = {e};" for k, e in enumerate(exprs[m * n:])]
    body += ["}", "", f"static void {prefix}constraint_residuals(double t, double *x, double *u, double *p, "
             "double *g, double *w) {"]
    body += unpack()
    if not hol:
        body.append("    (void)g;")
    lines, exprs = pr.block([core.g[k] for k in hol] + list(core.w))
    body += lines
    body += [f"    g[{i}] = {e};" for i, e in enumerate(exprs[:len(hol)])]
    body += [f"    w[{k}] = {e};" for k, e in enumerate(exprs[len(hol):])]
    body += ["}", ""]
    return "\n".join(body)


def header_part(eq: Equations, ident: str) -> str:
    """The declarations a constrained model adds to <id>.h."""
    up = ident.upper()
    m, nh = len(eq.model.constraints), len(holonomic_rows(eq))
    codes = "\n".join(f"#define {up}_{name} {value}  /* {text} */" for name, value, text in RETURN_CODES)
    return f"""
/* ------------------------------------------------------------------------------ constraints

   The model has {m} constraint(s), {nh} of them holonomic (g(q, t) = 0), the others velocity
   constraints (a(q, t) . q_dot + b(q, t) = 0); constraint k has the multiplier lambda_<name>.
   With G the constraints' Jacobian ({up}_NC x {up}_N: rows dg/dq, or a) and c the constraints
   differentiated to acceleration level, the equations of motion are

       M q_ddot = f + G^T lambda,      G q_ddot = c,

   solved at each call of {ident}_rhs as one saddle-point system [M G^T; G 0] [q_ddot; -lambda] =
   [f; c] (rows and columns scaled to unit diagonal of M and unit largest entry of each row of G,
   then LU with partial pivoting). Integrating x' = f(t, x, u, p) alone lets g and
   w = G q_dot + b drift with the integration error: call {ident}_project after every step
   (main.c does), as lagrangian.simulate does. */

#define {up}_NC {m}    /* constraints, and multipliers */
#define {up}_NH {nh}    /* of them holonomic */
{codes}

extern const char *const {ident}_constraint_names[];  /* {up}_NC names */
extern const char *const {ident}_multiplier_names[];  /* lambda_<name>, {up}_NC names */
extern const int {ident}_constraint_holonomic[];      /* {up}_NC flags: 1 holonomic, 0 velocity constraint */
extern const int {ident}_independent[];               /* {up}_NX flags: the independent coordinates and speeds
                                                           ([simulation] independent, independent_speeds) */

/* x' = [q_dot, q_ddot] into dx and the multipliers into lambda ({up}_NC values). Returns the
   ratio of the smallest to the largest pivot of the scaled saddle-point matrix, in (0, 1] when it
   is regular; <= 1e-12 when it is singular there (M singular, or the constraints dependent: G has
   lost rank, a dead point of a mechanism), and -1 when M, f, G or c is not finite; dx and lambda
   are set only when the value is > 1e-12. */
double {ident}_rhs_multipliers(double t, const double *x, const double *u, const double *p, double *dx,
                               double *lambda);

/* The multipliers alone (the same return value). */
double {ident}_multipliers(double t, const double *x, const double *u, const double *p, double *lambda);

/* G ({up}_NC x {up}_N, row-major) and c ({up}_NC) of G q_ddot = c at the state. */
void {ident}_constraint_jacobian(double t, const double *x, const double *p, double *G, double *c);

/* The residuals: g ({up}_NH values: the holonomic constraints' g(q, t), in their order) and
   w = G q_dot + b ({up}_NC values: every constraint at velocity level). */
void {ident}_constraint_residuals(double t, const double *x, const double *p, double *g, double *w);

/* Project the state x in place onto the constraints, the method of lagrangian's simulation: the
   coordinates onto g = 0 by up to 4 Gauss-Newton steps with the smallest change
   (q -= G_h^T (G_h G_h^T)^-1 g, until max|g| <= 1e-14 (1 + max|q|)), then the velocities onto
   G q_dot + b = 0 with the smallest change of kinetic energy
   (q_dot -= M^-1 G^T (G M^-1 G^T)^-1 w). Returns {up}_MET, {up}_SINGULAR or {up}_NOT_FINITE. */
int {ident}_project(double t, double *x, const double *p);

/* Make x consistent, holding the values whose flag in held ({up}_NX flags; {ident}_independent for
   the model's independent coordinates and speeds) and changing the others: the coordinates by
   Gauss-Newton (least-norm steps, at most 1 in size) from their values, the velocities by the
   least-norm change, as lagrangian does for an initial state. Returns {up}_MET, or which
   constraints the free values cannot meet ({up}_POSITION_NOT_MET, {up}_VELOCITY_NOT_MET), or
   {up}_NOT_FINITE. */
int {ident}_consistent_state(double t, double *x, const double *p, const int *held);
"""


_RUNTIME = r"""
/* ------------------------------------------------------------------------------ constraints */

#define LG_N @N@
#define LG_NC @NC@
#define LG_NH @NH@
#define LG_NK (LG_N + LG_NC)
#define LG_MAXK @MAXK@
#define LG_NU1 @NU1@
#define LG_SINGULAR 1e-12
#define LG_RANK 1e-18

@HOLONOMIC_ROWS@

/* LU with partial pivoting of the k x k matrix A (row-major, in place; rows swapped as LAPACK's
   getrf, the pivot rows in piv). Returns the smallest pivot's magnitude over the largest's:
   0 when a pivot is 0 or not finite. */
static double lg_lu(int k, double *A, int *piv) {
    int i, j, r, best;
    double big, s, lo = INFINITY, hi = 0.0;
    for (j = 0; j < k; j++) {
        best = j;
        big = fabs(A[j * k + j]);
        for (i = j + 1; i < k; i++) {
            if (fabs(A[i * k + j]) > big) {
                big = fabs(A[i * k + j]);
                best = i;
            }
        }
        piv[j] = best;
        if (!(big > 0.0 && big < INFINITY)) return 0.0;
        if (best != j) {
            for (r = 0; r < k; r++) {
                s = A[j * k + r];
                A[j * k + r] = A[best * k + r];
                A[best * k + r] = s;
            }
        }
        lo = fmin(lo, big);
        hi = fmax(hi, big);
        for (i = j + 1; i < k; i++) {
            s = A[i * k + j] / A[j * k + j];
            A[i * k + j] = s;
            for (r = j + 1; r < k; r++) A[i * k + r] -= s * A[j * k + r];
        }
    }
    return k > 0 ? lo / hi : 1.0;
}

/* b <- A^-1 b with the factors of lg_lu */
static void lg_lu_solve(int k, const double *A, const int *piv, double *b) {
    int i, j;
    double s;
    for (j = 0; j < k; j++) {
        if (piv[j] != j) {
            s = b[j];
            b[j] = b[piv[j]];
            b[piv[j]] = s;
        }
    }
    for (i = 0; i < k; i++)
        for (j = 0; j < i; j++) b[i] -= A[i * k + j] * b[j];
    for (i = k - 1; i >= 0; i--) {
        for (j = i + 1; j < k; j++) b[i] -= A[i * k + j] * b[j];
        b[i] /= A[i * k + i];
    }
}

/* W (k x k, the normal equations' matrix) factored in place; when it is singular (A has lost
   rank: dependent rows) a ridge of 1e-14 times its largest diagonal entry is added, so that the
   solution tends to the least-norm least-squares one of numpy.linalg.lstsq. 0 when W is 0 or not
   finite. */
static int lg_normal_factor(int k, double *W, int *piv) {
    double copy[LG_MAXK * LG_MAXK], top = 0.0;
    int i;
    for (i = 0; i < k * k; i++) copy[i] = W[i];
    if (lg_lu(k, W, piv) > LG_RANK) return 1;
    for (i = 0; i < k; i++) top = fmax(top, copy[i * k + i]);
    if (!(top > 0.0 && top < INFINITY)) return 0;
    for (i = 0; i < k * k; i++) W[i] = copy[i];
    for (i = 0; i < k; i++) W[i * k + i] += 1e-14 * top;
    return lg_lu(k, W, piv) > 0.0;
}

/* z: the least-norm solution of A z = b (rows <= cols) or the least-squares one (rows > cols),
   A rows x cols row-major, by the normal equations; 0 when A is 0 or not finite */
static int lg_lstsq(int rows, int cols, const double *A, const double *b, double *z) {
    double W[LG_MAXK * LG_MAXK], y[LG_MAXK];
    int piv[LG_MAXK], i, j, k;
    if (rows <= cols) {
        for (i = 0; i < rows; i++) {
            for (j = 0; j < rows; j++) {
                double s = 0.0;
                for (k = 0; k < cols; k++) s += A[i * cols + k] * A[j * cols + k];
                W[i * rows + j] = s;
            }
            y[i] = b[i];
        }
        if (!lg_normal_factor(rows, W, piv)) return 0;
        lg_lu_solve(rows, W, piv, y);
        for (k = 0; k < cols; k++) {
            double s = 0.0;
            for (i = 0; i < rows; i++) s += A[i * cols + k] * y[i];
            z[k] = s;
        }
    } else {
        for (i = 0; i < cols; i++) {
            for (j = 0; j < cols; j++) {
                double s = 0.0;
                for (k = 0; k < rows; k++) s += A[k * cols + i] * A[k * cols + j];
                W[i * cols + j] = s;
            }
            y[i] = 0.0;
            for (k = 0; k < rows; k++) y[i] += A[k * cols + i] * b[k];
        }
        if (!lg_normal_factor(cols, W, piv)) return 0;
        lg_lu_solve(cols, W, piv, y);
        for (i = 0; i < cols; i++) z[i] = y[i];
    }
    return 1;
}

static int lg_finite(int k, const double *v) {
    int i;
    for (i = 0; i < k; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

static double lg_max_abs(int k, const double *v) {
    int i;
    double m = 0.0;
    for (i = 0; i < k; i++) m = fmax(m, fabs(v[i]));
    return m;
}

/* the saddle-point solve: dx = [q_dot, q_ddot], lambda (see the header) */
static double lg_saddle(double t, const double *x, const double *u, const double *p, double *dx, double *lambda) {
    double K[LG_NK * LG_NK], b[LG_NK], M[LG_N * LG_N], f[LG_N], G[LG_NC * LG_N], c[LG_NC], d[LG_N], s[LG_NC];
    double r, big;
    int piv[LG_NK], i, j, k;
    @P@gen_mass_forcing(t, (double *)x, (double *)u, (double *)p, M, f);
    @P@gen_constraint_jacobian(t, (double *)x, (double *)u, (double *)p, G, c);
    if (!lg_finite(LG_N * LG_N, M) || !lg_finite(LG_N, f) || !lg_finite(LG_NC * LG_N, G) || !lg_finite(LG_NC, c))
        return -1.0;
    for (i = 0; i < LG_N; i++) d[i] = M[i * LG_N + i] > 0.0 ? 1.0 / sqrt(M[i * LG_N + i]) : 1.0;
    for (k = 0; k < LG_NC; k++) {
        big = 0.0;
        for (j = 0; j < LG_N; j++) big = fmax(big, fabs(G[k * LG_N + j] * d[j]));
        s[k] = big > 0.0 ? 1.0 / big : 1.0;
    }
    for (i = 0; i < LG_N; i++) {
        for (j = 0; j < LG_N; j++) K[i * LG_NK + j] = d[i] * M[i * LG_N + j] * d[j];
        for (k = 0; k < LG_NC; k++) {
            K[i * LG_NK + LG_N + k] = d[i] * G[k * LG_N + i] * s[k];
            K[(LG_N + k) * LG_NK + i] = s[k] * G[k * LG_N + i] * d[i];
        }
        b[i] = d[i] * f[i];
    }
    for (k = 0; k < LG_NC; k++) {
        for (j = 0; j < LG_NC; j++) K[(LG_N + k) * LG_NK + LG_N + j] = 0.0;
        b[LG_N + k] = s[k] * c[k];
    }
    r = lg_lu(LG_NK, K, piv);
    if (r <= LG_SINGULAR) return r;
    lg_lu_solve(LG_NK, K, piv, b);
    for (i = 0; i < LG_N; i++) {
        dx[i] = x[LG_N + i];
        dx[LG_N + i] = d[i] * b[i];
    }
    for (k = 0; k < LG_NC; k++) lambda[k] = -s[k] * b[LG_N + k];
    return r;
}

double @ID@_rhs_multipliers(double t, const double *x, const double *u, const double *p, double *dx,
                               double *lambda) {
    return lg_saddle(t, x, u, p, dx, lambda);
}

double @ID@_multipliers(double t, const double *x, const double *u, const double *p, double *lambda) {
    double dx[2 * LG_N];
    return lg_saddle(t, x, u, p, dx, lambda);
}

void @ID@_constraint_jacobian(double t, const double *x, const double *p, double *G, double *c) {
    double u[LG_NU1] = {0.0};
    @P@gen_constraint_jacobian(t, (double *)x, u, (double *)p, G, c);
}

void @ID@_constraint_residuals(double t, const double *x, const double *p, double *g, double *w) {
    double u[LG_NU1] = {0.0};
    @P@gen_constraint_residuals(t, (double *)x, u, (double *)p, g, w);
}

/* the velocities onto G q_dot + b = 0, the smallest change of kinetic energy */
static int lg_project_velocities(double t, double *x, const double *p) {
    double u[LG_NU1] = {0.0}, M[LG_N * LG_N], f[LG_N], G[LG_NC * LG_N], c[LG_NC], g[LG_NH + 1], w[LG_NC];
    double Y[LG_N * LG_NC], A[LG_NC * LG_NC], col[LG_N];
    int piv[LG_MAXK], i, j, k;
    @P@gen_constraint_residuals(t, x, u, (double *)p, g, w);
    @P@gen_constraint_jacobian(t, x, u, (double *)p, G, c);
    @P@gen_mass_forcing(t, x, u, (double *)p, M, f);
    if (!lg_finite(LG_NC, w) || !lg_finite(LG_NC * LG_N, G) || !lg_finite(LG_N * LG_N, M)) return @UP@_NOT_FINITE;
    if (lg_lu(LG_N, M, piv) == 0.0) return @UP@_SINGULAR;
    for (k = 0; k < LG_NC; k++) {  /* Y = M^-1 G^T */
        for (i = 0; i < LG_N; i++) col[i] = G[k * LG_N + i];
        lg_lu_solve(LG_N, M, piv, col);
        for (i = 0; i < LG_N; i++) Y[i * LG_NC + k] = col[i];
    }
    for (k = 0; k < LG_NC; k++) {  /* A = G M^-1 G^T */
        for (j = 0; j < LG_NC; j++) {
            double s = 0.0;
            for (i = 0; i < LG_N; i++) s += G[k * LG_N + i] * Y[i * LG_NC + j];
            A[k * LG_NC + j] = s;
        }
    }
    if (lg_lu(LG_NC, A, piv) == 0.0) return @UP@_SINGULAR;
    lg_lu_solve(LG_NC, A, piv, w);
    for (i = 0; i < LG_N; i++) {
        double s = 0.0;
        for (k = 0; k < LG_NC; k++) s += Y[i * LG_NC + k] * w[k];
        x[LG_N + i] -= s;
    }
    return lg_finite(2 * LG_N, x) ? @UP@_MET : @UP@_NOT_FINITE;
}

int @ID@_project(double t, double *x, const double *p) {
@PROJECT_POSITIONS@
    return lg_project_velocities(t, x, p);
}

int @ID@_consistent_state(double t, double *x, const double *p, const int *held) {
    double u[LG_NU1] = {0.0}, G[LG_NC * LG_N], c[LG_NC], g[LG_NH + 1], w[LG_NC], dq[LG_N];
    double A[LG_NC * LG_N], scale, vscale, step;
    int freeq[LG_N], freev[LG_N], nq = 0, nv = 0, i, j, k;
    for (i = 0; i < LG_N; i++) {
        if (!held || !held[i]) freeq[nq++] = i;
        if (!held || !held[LG_N + i]) freev[nv++] = i;
    }
    scale = 1.0 + lg_max_abs(LG_N, x);
@CONSISTENT_POSITIONS@
    @P@gen_constraint_residuals(t, x, u, (double *)p, g, w);
    @P@gen_constraint_jacobian(t, x, u, (double *)p, G, c);
    if (!lg_finite(LG_NC, w) || !lg_finite(LG_NC * LG_N, G)) return @UP@_NOT_FINITE;
    if (nv > 0 && lg_max_abs(LG_NC, w) > 0.0) {
        for (k = 0; k < LG_NC; k++)
            for (j = 0; j < nv; j++) A[k * nv + j] = G[k * LG_N + freev[j]];
        /* a zero A (the free velocities do not enter the constraints): no change, as lstsq's 0 */
        if (lg_lstsq(LG_NC, nv, A, w, dq))
            for (j = 0; j < nv; j++) x[LG_N + freev[j]] -= dq[j];
    }
    @P@gen_constraint_residuals(t, x, u, (double *)p, g, w);
    if (!lg_finite(LG_NC, w)) return @UP@_NOT_FINITE;
    vscale = 1.0 + lg_max_abs(LG_N, x + LG_N);
    for (k = 0; k < LG_NC; k++)
        if (!(fabs(w[k]) <= 1e-9 * vscale)) return @UP@_VELOCITY_NOT_MET;
    (void)step;
    (void)c;
    return @UP@_MET;
}
"""

# the coordinates' part of <id>_project (holonomic constraints only)
_PROJECT_POSITIONS = r"""    double u[LG_NU1] = {0.0}, G[LG_NC * LG_N], c[LG_NC], g[LG_NH], w[LG_NC];
    double Gh[LG_NH * LG_N], dq[LG_N];
    int it, i, k;
    for (it = 0; it < 4; it++) {
        @P@gen_constraint_residuals(t, x, u, (double *)p, g, w);
        if (!lg_finite(LG_NH, g)) return @UP@_NOT_FINITE;
        if (lg_max_abs(LG_NH, g) <= 1e-14 * (1.0 + lg_max_abs(LG_N, x))) break;
        @P@gen_constraint_jacobian(t, x, u, (double *)p, G, c);
        if (!lg_finite(LG_NC * LG_N, G)) return @UP@_NOT_FINITE;
        for (k = 0; k < LG_NH; k++)
            for (i = 0; i < LG_N; i++) Gh[k * LG_N + i] = G[lg_holonomic_rows[k] * LG_N + i];
        if (!lg_lstsq(LG_NH, LG_N, Gh, g, dq)) return @UP@_SINGULAR;
        for (i = 0; i < LG_N; i++) x[i] -= dq[i];
    }"""

# the coordinates' part of <id>_consistent_state: Gauss-Newton over the free coordinates, as
# numeric._constrained.consistent_state (a fixed small nudge where it draws a random one)
_CONSISTENT_POSITIONS = r"""    if (nq > 0) {
        int it;
        for (it = 0; it < 200; it++) {
            int flat = 0;
            @P@gen_constraint_residuals(t, x, u, (double *)p, g, w);
            @P@gen_constraint_jacobian(t, x, u, (double *)p, G, c);
            for (k = 0; k < LG_NH; k++)
                for (j = 0; j < nq; j++) A[k * nq + j] = G[lg_holonomic_rows[k] * LG_N + freeq[j]];
            if (!lg_finite(LG_NH, g) || !lg_finite(LG_NH * nq, A)) flat = 1;  /* 0/0 at a guess: move off it */
            else if (lg_max_abs(LG_NH, g) == 0.0) break;
            else if (lg_max_abs(LG_NH * nq, A) == 0.0) flat = 1;  /* constraints flat there (y = 0 on a circle) */
            else if (!lg_lstsq(LG_NH, nq, A, g, dq)) flat = 1;
            if (flat) {
                for (j = 0; j < nq; j++) x[freeq[j]] += (j % 2 ? -1e-3 : 1e-3);
                continue;
            }
            step = lg_max_abs(nq, dq);
            for (j = 0; j < nq; j++) x[freeq[j]] -= step > 1.0 ? dq[j] / step : dq[j];
            if (step <= 1e-15 * scale && lg_max_abs(LG_NH, g) <= 1e-13 * scale) break;
        }
    }
    @P@gen_constraint_residuals(t, x, u, (double *)p, g, w);
    if (!lg_finite(LG_NH, g)) return @UP@_NOT_FINITE;
    for (k = 0; k < LG_NH; k++)
        if (!(fabs(g[k]) <= 1e-9 * scale)) return @UP@_POSITION_NOT_MET;"""


def runtime(eq: Equations, ident: str) -> str:
    """The C, written once for every model and sized for this one, of the saddle-point solve, the
    projection and the consistent state (the public functions the header declares)."""
    n, m = eq.n, len(eq.model.constraints)
    hol = holonomic_rows(eq)
    nh = len(hol)
    text = _RUNTIME
    if nh:
        rows = f"static const int lg_holonomic_rows[LG_NH] = {{{', '.join(map(str, hol))}}};"
        text = text.replace("@PROJECT_POSITIONS@", _PROJECT_POSITIONS)
        text = text.replace("@CONSISTENT_POSITIONS@", _CONSISTENT_POSITIONS)
    else:
        rows = "/* no holonomic constraints: the coordinates are never projected */"
        text = text.replace("@PROJECT_POSITIONS@\n", "")
        text = text.replace("@CONSISTENT_POSITIONS@\n", "    (void)freeq;\n    (void)nq;\n    (void)scale;\n")
    return (text.replace("@HOLONOMIC_ROWS@", rows).replace("@N@", str(n)).replace("@NC@", str(m))
            .replace("@NH@", str(nh)).replace("@MAXK@", str(max(n, m))).replace("@NU1@", str(max(1, len(eq.inputs))))
            .replace("@P@", f"{ident}_").replace("@ID@", ident).replace("@UP@", ident.upper()))


def tables(eq: Equations, ident: str) -> str:
    """The names and flags the header declares for a constrained model."""
    from ._common import held_names

    held = held_names(eq)
    hol = set(holonomic_rows(eq))
    flags = ", ".join("1" if s in held else "0" for s in eq.state_names)
    kinds = ", ".join("1" if k in hol else "0" for k in range(len(eq.multipliers)))
    return f"""
const char *const {ident}_constraint_names[] = {{{c_strings(c.name for c in eq.model.constraints)}}};
const char *const {ident}_multiplier_names[] = {{{c_strings(m.name for m in eq.multipliers)}}};
const int {ident}_constraint_holonomic[] = {{{kinds}}};
const int {ident}_independent[] = {{{flags}}};
"""


def example_main(eq: Equations, ident: str, energy: str) -> str:
    """main.c of a constrained model: RK4 with the projection after every step."""
    up = ident.upper()
    m = len(eq.inputs)
    return f"""/* Generated by lagrangian. An example: integrate the constrained model '{comment_text(eq.model.name)}' from its initial state, inputs 0,
   with the classical Runge-Kutta method of order 4 (fixed step), projecting the state onto the
   constraints after every step ({ident}_project, as lagrangian's simulation does), and print t,
   the state, the {energy.replace('_', ' ')} and the multipliers as CSV.

   Build:  cmake -S . -B build && cmake --build build && ./build/{ident}_example [t_end] [step] [every]
   or:     cc -std=c99 -O2 -o example main.c {ident}.c -lm && ./example 1 0.001 10 */

#include <stdio.h>
#include <stdlib.h>

#include "{ident}.h"

#define NX {up}_NX
#define NC {up}_NC

static const char *failure(int status) {{
    switch (status) {{
    case {up}_POSITION_NOT_MET: return "the coordinates cannot meet the holonomic constraints";
    case {up}_VELOCITY_NOT_MET: return "the velocities cannot meet the constraints";
    case {up}_SINGULAR: return "a singular system (the constraints dependent, or M singular)";
    default: return "a residual or a Jacobian entry is not finite";
    }}
}}

static int rhs(double t, const double *x, const double *u, double *dx, double *lambda) {{
    double r = {ident}_rhs_multipliers(t, x, u, {ident}_parameter_values, dx, lambda);
    if (r <= 1e-12) {{
        fprintf(stderr, "at t = %g: %s\\n", t, r < 0 ? "M, f, G or c is not finite" :
                "the system [M G^T; G 0] is singular (M singular, or the constraints dependent: a dead point)");
        return 0;
    }}
    return 1;
}}

int main(int argc, char **argv) {{
    double t_end = argc > 1 ? atof(argv[1]) : 1.0;
    double h = argc > 2 ? atof(argv[2]) : 1e-3;
    long every = argc > 3 ? atol(argv[3]) : 10, steps, k;
    double x[NX], k1[NX], k2[NX], k3[NX], k4[NX], xs[NX], lambda[NC], t = 0.0;
    double u[{max(1, m)}] = {{0.0}};
    int i, status;
    if (!(t_end > 0.0) || !(h > 0.0) || every < 1) {{
        fprintf(stderr, "usage: %s [t_end > 0] [step > 0] [every >= 1]\\n", argv[0]);
        return 2;
    }}
    steps = (long)(t_end / h + 0.5);
    for (i = 0; i < NX; i++) x[i] = {ident}_initial_state[i];
    status = {ident}_consistent_state(0.0, x, {ident}_parameter_values, {ident}_independent);
    if (status != {up}_MET) {{
        fprintf(stderr, "the initial state: %s\\n", failure(status));
        return 1;
    }}
    printf("t");
    for (i = 0; i < NX; i++) printf(",%s", {ident}_state_names[i]);
    printf(",{energy}");
    for (i = 0; i < NC; i++) printf(",%s", {ident}_multiplier_names[i]);
    printf("\\n");
    for (k = 0; k <= steps; k++) {{
        t = k * h;
        if (!rhs(t, x, u, k1, lambda)) return 1;
        if (k % every == 0 || k == steps) {{
            printf("%.17g", t);
            for (i = 0; i < NX; i++) printf(",%.17g", x[i]);
            printf(",%.17g", {ident}_energy(t, x, u, {ident}_parameter_values));
            for (i = 0; i < NC; i++) printf(",%.17g", lambda[i]);
            printf("\\n");
        }}
        if (k == steps) break;
        for (i = 0; i < NX; i++) xs[i] = x[i] + 0.5 * h * k1[i];
        if (!rhs(t + 0.5 * h, xs, u, k2, lambda)) return 1;
        for (i = 0; i < NX; i++) xs[i] = x[i] + 0.5 * h * k2[i];
        if (!rhs(t + 0.5 * h, xs, u, k3, lambda)) return 1;
        for (i = 0; i < NX; i++) xs[i] = x[i] + h * k3[i];
        if (!rhs(t + h, xs, u, k4, lambda)) return 1;
        for (i = 0; i < NX; i++) x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        status = {ident}_project((k + 1) * h, x, {ident}_parameter_values);
        if (status != {up}_MET) {{
            fprintf(stderr, "at t = %g: the projection onto the constraints failed: %s\\n", (k + 1) * h,
                    failure(status));
            return 1;
        }}
    }}
    return 0;
}}
"""
