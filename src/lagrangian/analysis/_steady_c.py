"""The steady-state residual's compiled loops (``_steady_kernel``) in C, loaded with ctypes: the same
operations in the same order, so the same numbers bit for bit, without numba's start.

numba's import, its typing and target registries and the load of the cached kernels took 0.45-0.6 s
of CPU in every process that searched a constrained model's equilibria or steady motions (the
bicycle's `report` and `steady`), more than the search's arithmetic. This module's C source is a
constant of the package (no name or text of a model enters it); the system's C compiler (``$CC``,
``cc`` or ``gcc``: numeric._cbackend.c_compiler) builds it once into the compile cache (its key: the
source, the compiler and the flags), and every later process loads the library in a millisecond.

Compiled with ``-O2 -ffp-contract=off`` and no ``-march``: no fused multiply-add and no reassociation,
IEEE arithmetic as numba's (which emits neither without ``fastmath``); Python's and numba's
``max(a, b)`` (b where b > a, else a) and ``min(a, b)`` (b where b < a) written as such, so NaN and
-0.0 take the same way. tests/analysis/test_steady_c.py compares every kernel with numba's bit for bit
on random batches with singular and non-finite points.

:func:`kernels` returns the C kernels, or None where there is no compiler or the build fails
(the caller then uses ``_steady_kernel``, numba's). Besides the functions of ``_steady_kernel``'s
signatures (:class:`CKernels`: arrays converted to pointers at each call), :class:`Workspace` holds
one evaluator's arrays for the search's repeated calls (their addresses taken once).
"""

from __future__ import annotations

import ctypes
import functools
import os
import stat
import subprocess
import tempfile

import numpy as np

__all__ = ["kernels", "CKernels", "Workspace", "SOURCE"]

SOURCE = r"""/* lagrangian: the steady-state residual's loops (analysis/_steady_kernel.py, numba), the same operations
   in the same order. Compiled with -O2 -ffp-contract=off. */
#include <math.h>
#include <stdint.h>

typedef int64_t i64;

/* Python's and numba's max(acc, v) and min(acc, v) */
static double mx(double acc, double v) { return v > acc ? v : acc; }
static double mn(double acc, double v) { return v < acc ? v : acc; }

void lg_points(double *A, i64 rows, i64 cols, double t, const double *u, i64 nu, const double *p, i64 np_,
               const double *q, i64 n, const i64 *shape, i64 ks, const double *h, i64 nh, const i64 *given,
               const double *given_values, i64 ng)
{
    if (rows != 2 * ks + 1 || cols != 1 + 2 * n + nu + np_ || nh < ks) return;
    for (i64 i = 0; i < rows; i++) {
        double *a = A + i * cols;
        a[0] = t;
        for (i64 j = 0; j < n; j++) { a[1 + j] = q[j]; a[1 + n + j] = 0.0; }
        for (i64 j = 0; j < ng; j++) a[1 + n + given[j]] = given_values[j];
        for (i64 j = 0; j < nu; j++) a[1 + 2 * n + j] = u[j];
        for (i64 j = 0; j < np_; j++) a[1 + 2 * n + nu + j] = p[j];
    }
    for (i64 j = 0; j < ks; j++) {
        A[(2 * j + 1) * cols + 1 + shape[j]] = q[shape[j]] + h[j];
        A[(2 * j + 2) * cols + 1 + shape[j]] = q[shape[j]] - h[j];
    }
}

/* the steps of SteadyState.__call__: h = 1e-5 (1 + |q[shape]|) (NumPy's operations), then lg_points */
void lg_steps_points(double *A, i64 rows, i64 cols, double t, const double *u, i64 nu, const double *p, i64 np_,
                     const double *q, i64 n, const i64 *shape, i64 ks, double *h, const i64 *given,
                     const double *given_values, i64 ng)
{
    for (i64 j = 0; j < ks; j++) h[j] = 1e-5 * (1.0 + fabs(q[shape[j]]));
    lg_points(A, rows, cols, t, u, nu, p, np_, q, n, shape, ks, h, ks, given, given_values, ng);
}

static void jacobi_svd(double *B, i64 r, i64 c, double *V)
{
    for (i64 i = 0; i < c; i++)
        for (i64 j = 0; j < c; j++) V[i * c + j] = i == j ? 1.0 : 0.0;
    for (int sweep = 0; sweep < 60; sweep++) {
        int rotated = 0;
        for (i64 i = 0; i < c - 1; i++) {
            for (i64 j = i + 1; j < c; j++) {
                double alpha = 0.0, beta = 0.0, gamma = 0.0;
                for (i64 k = 0; k < r; k++) {
                    alpha += B[k * c + i] * B[k * c + i];
                    beta += B[k * c + j] * B[k * c + j];
                    gamma += B[k * c + i] * B[k * c + j];
                }
                if (gamma == 0.0 || fabs(gamma) <= 1e-15 * sqrt(alpha * beta)) continue;
                rotated = 1;
                double zeta = (beta - alpha) / (2.0 * gamma);
                double tn = (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                double cs = 1.0 / sqrt(1.0 + tn * tn);
                double sn = cs * tn;
                for (i64 k = 0; k < r; k++) {
                    double bi = B[k * c + i], bj = B[k * c + j];
                    B[k * c + i] = cs * bi - sn * bj;
                    B[k * c + j] = sn * bi + cs * bj;
                }
                for (i64 k = 0; k < c; k++) {
                    double vi = V[k * c + i], vj = V[k * c + j];
                    V[k * c + i] = cs * vi - sn * vj;
                    V[k * c + j] = sn * vi + cs * vj;
                }
            }
        }
        if (!rotated) break;
    }
}

/* C (k, cc) rows of (W, g, w); X (k, xc); w (k, m) out; Wf, B (m, nf), V (nf, nf), rates (nf): work */
void lg_free_rates(const double *C, i64 k, i64 cc, double *X, i64 xc, const i64 *free_, i64 nf, i64 n, i64 m,
                   uint8_t *bad, double *w, double *Wf, double *B, double *V, double *rates)
{
    for (i64 i = 0; i < m * nf; i++) Wf[i] = 0.0;
    for (i64 i = 0; i < k; i++) {
        const double *ci = C + i * cc;
        int finite = 1;
        for (i64 j = 0; j < cc; j++)
            if (!isfinite(ci[j])) { finite = 0; break; }
        if (!finite) bad[i] = 1;
        int rest = 1;
        for (i64 r = 0; r < m; r++) {
            w[i * m + r] = ci[m * n + m + r];
            if (w[i * m + r] != 0.0) rest = 0;
        }
        if (nf == 0 || !finite || rest) continue;
        double big = 0.0;
        for (i64 r = 0; r < m; r++) {
            for (i64 j = 0; j < n; j++) big = mx(big, fabs(ci[r * n + j]));
            for (i64 j = 0; j < nf; j++) {
                Wf[r * nf + j] = ci[r * n + free_[j]];
                B[r * nf + j] = Wf[r * nf + j];
            }
        }
        big = mx(big, 1e-300);
        jacobi_svd(B, m, nf, V);
        for (i64 j = 0; j < nf; j++) rates[j] = 0.0;
        for (i64 s = 0; s < nf; s++) {
            double norm2 = 0.0, dot = 0.0;
            for (i64 r = 0; r < m; r++) {
                norm2 += B[r * nf + s] * B[r * nf + s];
                dot -= B[r * nf + s] * w[i * m + r];
            }
            if (sqrt(norm2) > 1e-10 * big) {
                double coef = dot / norm2;
                for (i64 j = 0; j < nf; j++) rates[j] += V[j * nf + s] * coef;
            }
        }
        for (i64 j = 0; j < nf; j++) X[i * xc + 1 + n + free_[j]] = rates[j];
        for (i64 r = 0; r < m; r++) {
            double acc = 0.0;
            for (i64 j = 0; j < nf; j++) acc += Wf[r * nf + j] * rates[j];
            w[i * m + r] += acc;
        }
    }
}

static int cholesky(const double *M, double *L, i64 n)
{
    for (i64 j = 0; j < n; j++) {
        double s = M[j * n + j];
        for (i64 p = 0; p < j; p++) s -= L[j * n + p] * L[j * n + p];
        if (!(s > 0.0)) return 0;
        double d = sqrt(s);
        L[j * n + j] = d;
        for (i64 i = j + 1; i < n; i++) {
            double t = M[i * n + j];
            for (i64 p = 0; p < j; p++) t -= L[i * n + p] * L[j * n + p];
            L[i * n + j] = t / d;
        }
    }
    return 1;
}

static void lower_solve(const double *L, double *b, i64 n)
{
    for (i64 i = 0; i < n; i++) {
        double s = b[i];
        for (i64 p = 0; p < i; p++) s -= L[i * n + p] * b[p];
        b[i] = s / L[i * n + i];
    }
}

static void lower_transpose_solve(const double *L, double *b, i64 n)
{
    for (i64 i = n - 1; i >= 0; i--) {
        double s = b[i];
        for (i64 p = i + 1; p < n; p++) s -= L[p * n + i] * b[p];
        b[i] = s / L[i * n + i];
    }
}

/* B (n, m) = Q (n, m) R (m, m); A, V (n, m), beta (m): work */
static void householder_qr(const double *B, i64 n, i64 m, double *Q, double *R, double *A, double *V, double *beta)
{
    for (i64 i = 0; i < n; i++)
        for (i64 j = 0; j < m; j++) { A[i * m + j] = B[i * m + j]; V[i * m + j] = 0.0; }
    for (i64 j = 0; j < m; j++) beta[j] = 0.0;
    for (i64 j = 0; j < m; j++) {
        double norm = 0.0;
        for (i64 i = j; i < n; i++) norm += A[i * m + j] * A[i * m + j];
        norm = sqrt(norm);
        double alpha = A[j * m + j] >= 0.0 ? -norm : norm;
        double vnorm = 0.0;
        for (i64 i = j; i < n; i++) V[i * m + j] = A[i * m + j];
        V[j * m + j] -= alpha;
        for (i64 i = j; i < n; i++) vnorm += V[i * m + j] * V[i * m + j];
        if (vnorm > 0.0) {
            beta[j] = 2.0 / vnorm;
            for (i64 c = j; c < m; c++) {
                double s = 0.0;
                for (i64 i = j; i < n; i++) s += V[i * m + j] * A[i * m + c];
                s *= beta[j];
                for (i64 i = j; i < n; i++) A[i * m + c] -= s * V[i * m + j];
            }
        }
    }
    for (i64 r = 0; r < m; r++)
        for (i64 c = 0; c < m; c++) R[r * m + c] = c >= r ? A[r * m + c] : 0.0;
    for (i64 i = 0; i < n; i++)
        for (i64 c = 0; c < m; c++) Q[i * m + c] = i == c ? 1.0 : 0.0;
    for (i64 j = m - 1; j >= 0; j--) {
        if (beta[j] == 0.0) continue;
        for (i64 c = 0; c < m; c++) {
            double s = 0.0;
            for (i64 i = j; i < n; i++) s += V[i * m + j] * Q[i * m + c];
            s *= beta[j];
            for (i64 i = j; i < n; i++) Q[i * m + c] -= s * V[i * m + j];
        }
    }
}

/* P (k, pc) rows of (M, f, G, c); w (k, m); g: G_(i, r) at g[i * gs + r]; rows (k, rc), scale (k) out.
   work: at least 3 n n + 4 n m + m m + 4 n + 3 m + m n doubles */
void lg_steady_rows(const double *P, i64 k, i64 pc, const double *w, const double *g, i64 gs, const i64 *held,
                    i64 a_held, const i64 *hol, i64 kh, i64 n, i64 m, double singular_ratio, uint8_t *bad,
                    double *rows, i64 rc, double *scale, double *work)
{
    double *M = work, *L = M + n * n, *f = L + n * n, *G = f + n, *c = G + m * n, *B = c + m, *Q = B + n * m;
    double *R = Q + n * m, *wk = R + m * m, *V = wk + n * m, *beta = V + n * m, *col = beta + m, *a = col + n;
    double *y = a + n, *wr = y + n;
    for (i64 i = 0; i < n * n; i++) L[i] = 0.0;
    for (i64 i = 0; i < k; i++) {
        const double *pi = P + i * pc;
        int finite = 1;
        for (i64 j = 0; j < pc; j++)
            if (!isfinite(pi[j])) { finite = 0; break; }
        for (i64 r = 0; r < n; r++) {
            for (i64 s = 0; s < n; s++) M[r * n + s] = pi[r * n + s];
            f[r] = pi[n * n + r];
        }
        for (i64 r = 0; r < m; r++) {
            for (i64 s = 0; s < n; s++) G[r * n + s] = pi[n * n + n + r * n + s];
            c[r] = pi[n * n + n + m * n + r];
        }
        double mass = 0.0, forces = 0.0, bias = 0.0;
        for (i64 r = 0; r < n; r++) { mass = mx(mass, fabs(M[r * n + r])); forces = mx(forces, fabs(f[r])); }
        for (i64 r = 0; r < m; r++) bias = mx(bias, fabs(c[r]));
        scale[i] = (mass > 0.0 ? forces / mass : 0.0) + bias;
        int ok = finite && !bad[i] && m <= n;
        if (ok)
            for (i64 r = 0; r < n; r++)
                if (!(M[r * n + r] > 0.0)) ok = 0;
        if (ok) ok = cholesky(M, L, n);
        if (ok) {
            double ratio = INFINITY;
            for (i64 r = 0; r < n; r++) ratio = mn(ratio, L[r * n + r] * L[r * n + r] / M[r * n + r]);
            for (i64 s = 0; s < m; s++) {
                for (i64 r = 0; r < n; r++) col[r] = G[s * n + r];
                lower_solve(L, col, n);
                for (i64 r = 0; r < n; r++) B[r * m + s] = col[r];
            }
            double big = 0.0;
            for (i64 s = 0; s < m; s++) {
                double t = 0.0;
                for (i64 r = 0; r < n; r++) t += B[r * m + s] * B[r * m + s];
                big = mx(big, t);
            }
            householder_qr(B, n, m, Q, R, wk, V, beta);
            double rho = INFINITY;
            for (i64 s = 0; s < m; s++) rho = mn(rho, fabs(R[s * m + s]));
            rho = m ? rho / sqrt(big) : 1.0;
            ok = ratio > singular_ratio && rho > singular_ratio && isfinite(rho);
        }
        if (!ok) {
            bad[i] = 1;
            for (i64 r = 0; r < rc; r++) rows[i * rc + r] = NAN;
            continue;
        }
        for (i64 r = 0; r < n; r++) a[r] = f[r];
        lower_solve(L, a, n);
        lower_transpose_solve(L, a, n);
        for (i64 s = 0; s < m; s++) {
            double t = c[s];
            for (i64 r = 0; r < n; r++) t -= G[s * n + r] * a[r];
            for (i64 p = 0; p < s; p++) t -= R[p * m + s] * wr[p];
            wr[s] = t / R[s * m + s];
        }
        for (i64 r = 0; r < n; r++) {
            double t = 0.0;
            for (i64 s = 0; s < m; s++) t += Q[r * m + s] * wr[s];
            y[r] = t;
        }
        lower_transpose_solve(L, y, n);
        for (i64 j = 0; j < a_held; j++) rows[i * rc + j] = a[held[j]] + y[held[j]];
        for (i64 j = 0; j < kh; j++) rows[i * rc + a_held + j] = g[i * gs + hol[j]];
        for (i64 j = 0; j < m; j++) rows[i * rc + a_held + kh + j] = w[i * m + j];
    }
}

/* R (kr, rows); A0: the arguments of q; W0 (wm, wn): its constraint Jacobian; J (rows, k) out */
int lg_central_jacobian(const double *R, i64 kr, i64 rc, const double *A0, const double *W0, i64 wm, i64 wn,
                        const double *scale, const double *q, i64 nq, const double *h, i64 nh, i64 n, i64 held,
                        i64 hol, double *J, i64 rows, i64 k)
{
    if (kr < 2 * k + 1 || rc != rows || nh < k) return 0;
    for (i64 i = 0; i < kr * rc; i++)
        if (!isfinite(R[i])) return 0;
    double rates2 = 0.0, rates = 0.0;
    for (i64 j = 0; j < n; j++) {
        double v = A0[1 + n + j];
        rates2 = mx(rates2, v * v);
        rates = mx(rates, fabs(v));
    }
    double big_q = 0.0;
    for (i64 j = 0; j < nq; j++) big_q = mx(big_q, fabs(q[j]));
    double big_w = 0.0;
    for (i64 r = 0; r < wm; r++)
        for (i64 j = 0; j < wn; j++) big_w = mx(big_w, fabs(W0[r * wn + j]));
    for (i64 r = 0; r < rows; r++) {
        double floor_;
        if (r < held) floor_ = scale[0] + rates2;
        else if (r < held + hol) floor_ = 1.0 + big_q;
        else floor_ = (1.0 + rates) * (1.0 + big_w);
        for (i64 j = 0; j < k; j++) {
            double d = (R[(2 * j + 1) * rc + r] - R[(2 * j + 2) * rc + r]) / (2.0 * h[j]);
            J[r * k + j] = fabs(d) <= 1e-8 * floor_ ? 0.0 : d;
        }
    }
    return 1;
}

void lg_differences(const double *R, i64 rc, const double *h, const double *floor_, double *J, i64 rows, i64 k)
{
    for (i64 j = 0; j < k; j++)
        for (i64 r = 0; r < rows; r++) {
            double d = (R[(2 * j + 1) * rc + r] - R[(2 * j + 2) * rc + r]) / (2.0 * h[j]);
            J[r * k + j] = fabs(d) <= 1e-8 * floor_[r] ? 0.0 : d;
        }
}
"""

#: The flags (part of the cache key): no fused multiply-add, no -march (see the module).
FLAGS = ("-O2", "-ffp-contract=off", "-shared", "-fPIC")

_P = ctypes.c_void_p
_I = ctypes.c_int64
_D = ctypes.c_double
_SIGNATURES = {
    "lg_points": (None, [_P, _I, _I, _D, _P, _I, _P, _I, _P, _I, _P, _I, _P, _I, _P, _P, _I]),
    "lg_steps_points": (None, [_P, _I, _I, _D, _P, _I, _P, _I, _P, _I, _P, _I, _P, _P, _P, _I]),
    "lg_free_rates": (None, [_P, _I, _I, _P, _I, _P, _I, _I, _I, _P, _P, _P, _P, _P, _P]),
    "lg_steady_rows": (None, [_P, _I, _I, _P, _P, _I, _P, _I, _P, _I, _I, _I, _D, _P, _P, _I, _P, _P]),
    "lg_central_jacobian": (ctypes.c_int, [_P, _I, _I, _P, _P, _I, _I, _P, _P, _I, _P, _I, _I, _I, _I, _P, _I, _I]),
    "lg_differences": (None, [_P, _I, _P, _P, _P, _I, _I]),
}


def _address(a: np.ndarray) -> int:
    return a.__array_interface__["data"][0]


def _c_array(a, dtype=np.float64) -> np.ndarray:
    """`a` as a C-contiguous array of `dtype` (the same array where it is one already)."""
    return np.ascontiguousarray(a, dtype=dtype)


def _work_size(n: int, m: int) -> int:
    return 3 * n * n + 4 * n * m + m * m + 4 * n + 3 * m + m * n


class CKernels:
    """The C library's functions with ``_steady_kernel``'s signatures (arrays in, outputs written in place;
    an output that is not a C-contiguous array of its type is computed into a copy and written back)."""

    def __init__(self, lib: ctypes.CDLL):
        self.lib = lib

    def points(self, A, t, u, p, q, shape, h, given, given_values) -> None:
        out, u, p, q, h, gv = (_c_array(x) for x in (A, u, p, q, h, given_values))
        shape, given = _c_array(shape, np.int64), _c_array(given, np.int64)
        self.lib.lg_points(_address(out), out.shape[0], out.shape[1], float(t), _address(u), len(u), _address(p),
                           len(p), _address(q), len(q), _address(shape), len(shape), _address(h), len(h),
                           _address(given), _address(gv), len(given))
        _written_back(A, out)

    def free_rates(self, C, X, free, n, m, bad) -> np.ndarray:
        C, out, free_, flags = _c_array(C), _c_array(X), _c_array(free, np.int64), _c_array(bad, np.bool_)
        k, nf = C.shape[0], len(free_)
        w = np.empty((k, m))
        work = np.empty(2 * m * nf + nf * nf + nf + 1)
        self.lib.lg_free_rates(_address(C), k, C.shape[1], _address(out), out.shape[1], _address(free_), nf, n, m,
                               _address(flags), _address(w), _address(work), _address(work[m * nf:]),
                               _address(work[2 * m * nf:]), _address(work[2 * m * nf + nf * nf:]))
        _written_back(X, out)
        _written_back(bad, flags)
        return w

    def steady_rows(self, P, w, g, held, hol, n, m, singular_ratio, bad, rows, scale) -> None:
        P, w, g = _c_array(P), _c_array(w), _c_array(g)
        held_, hol_ = _c_array(held, np.int64), _c_array(hol, np.int64)
        flags, out, sc = _c_array(bad, np.bool_), _c_array(rows), _c_array(scale)
        work = np.empty(_work_size(n, m) + 1)
        self.lib.lg_steady_rows(_address(P), P.shape[0], P.shape[1], _address(w), _address(g), g.shape[1],
                                _address(held_), len(held_), _address(hol_), len(hol_), n, m, float(singular_ratio),
                                _address(flags), _address(out), out.shape[1], _address(sc), _address(work))
        for a, b in ((bad, flags), (rows, out), (scale, sc)):
            _written_back(a, b)

    def central_jacobian(self, R, A, W, scale, q, h, n, held, hol, J) -> bool:
        R, A0, W0 = _c_array(R), _c_array(A[0]), _c_array(W[0])
        sc, q, h, out = _c_array(scale), _c_array(q), _c_array(h), _c_array(J)
        done = self.lib.lg_central_jacobian(_address(R), R.shape[0], R.shape[1], _address(A0), _address(W0),
                                            W0.shape[0], W0.shape[1], _address(sc), _address(q), len(q), _address(h),
                                            len(h), n, held, hol, _address(out), out.shape[0], out.shape[1])
        if done:
            _written_back(J, out)
        return bool(done)

    def differences(self, R, h, floor, J) -> None:
        R, h, fl, out = _c_array(R), _c_array(h), _c_array(floor), _c_array(J)
        self.lib.lg_differences(_address(R), R.shape[1], _address(h), _address(fl), _address(out), out.shape[0],
                                out.shape[1])
        _written_back(J, out)


def _written_back(target: np.ndarray, result: np.ndarray) -> None:
    if result is not target:
        target[...] = result


class Workspace:
    """One steady-state evaluator's batch arrays, allocated once, and the calls of the search's fast path on
    them: (2 k + 1) points of the shape's k coordinates, n coordinates, m constraints, `nu` inputs, `np_`
    parameters, `cc` and `pc` the outputs of the constraints' and of the saddle-point parts' functions."""

    def __init__(self, lib: ctypes.CDLL, n, m, shape, free, held, hol, given, given_values, nu, np_, cc, pc):
        k = len(shape)
        rows = 2 * k + 1
        self.lib, self.n, self.m, self.k = lib, n, m, k
        self.shape, self.free, self.held, self.hol = (np.array(v, dtype=np.int64) for v in (shape, free, held, hol))
        self.given, self.given_values = np.array(given, dtype=np.int64), np.array(given_values, dtype=float)
        self.q, self.h, self.u, self.p = np.empty(n), np.empty(k), np.empty(nu), np.empty(np_)
        self.A = np.empty((rows, 1 + 2 * n + nu + np_))
        self.C, self.P = np.empty(rows * cc), np.empty(rows * pc)
        self.cc, self.pc = cc, pc
        self.w, self.bad = np.empty((rows, m)), np.zeros(rows, dtype=np.bool_)
        self.R, self.scale = np.empty((rows, len(held) + len(hol) + m)), np.empty(rows)
        self.J = np.empty((self.R.shape[1], k))
        nf = len(free)
        self._svd = np.empty(2 * m * nf + nf * nf + nf + 1)
        self._work = np.empty(_work_size(n, m) + 1)
        self.setting = None
        a = _address
        sv = self._svd
        self._points_args = (a(self.A), rows, self.A.shape[1], 0.0, a(self.u), nu, a(self.p), np_, a(self.q), n,
                             a(self.shape), k, a(self.h), a(self.given), a(self.given_values), len(self.given))
        self._free_args = (a(self.C), rows, cc, a(self.A), self.A.shape[1], a(self.free), nf, n, m, a(self.bad),
                           a(self.w), a(sv), a(sv[m * nf:]), a(sv[2 * m * nf:]), a(sv[2 * m * nf + nf * nf:]))
        self._rows_args = (a(self.P), rows, pc, a(self.w), a(self.C[m * n:]), cc, a(self.held), len(self.held),
                           a(self.hol), len(self.hol), n, m)
        self._rows_tail = (a(self.bad), a(self.R), self.R.shape[1], a(self.scale), a(self._work))
        self._jac_args = (a(self.R), rows, self.R.shape[1], a(self.A), a(self.C), m, n, a(self.scale), a(self.q), n,
                          a(self.h), k, n, len(self.held), len(self.hol), a(self.J), self.J.shape[0], k)

    def points(self, t: float, q: np.ndarray) -> None:
        """A: q and q +- h_j (h in self.h) with the given rates, u and p (set by the caller in self.u, self.p)."""
        self.q[:] = q
        args = self._points_args
        self.lib.lg_steps_points(*args[:3], t, *args[4:])

    def free_rates(self) -> None:
        """From C (the constraints at A): the free rates written into A, w, bad."""
        self.bad[:] = False
        self.lib.lg_free_rates(*self._free_args)

    def rows_jacobian(self, singular_ratio: float) -> bool:
        """From P (the saddle-point parts at A): R and scale; then J where every row is finite (True)."""
        self.lib.lg_steady_rows(*self._rows_args, singular_ratio, *self._rows_tail)
        return bool(self.lib.lg_central_jacobian(*self._jac_args))


@functools.cache
def kernels() -> CKernels | None:
    """The C kernels (built into the compile cache on the first call of a machine), or None: no C compiler,
    or its build or load failed (the caller uses numba's ``_steady_kernel``)."""
    lib = _library()
    if lib is None:
        return None
    for name, (restype, argtypes) in _SIGNATURES.items():
        fun = getattr(lib, name)
        fun.restype, fun.argtypes = restype, argtypes
    return CKernels(lib)


def _library() -> ctypes.CDLL | None:
    try:
        from ..numeric._cbackend import c_compiler
        from ..numeric._codegen import cache_dir, source_key, store
    except ImportError:  # the C backend's helpers not there: numba's kernels (tests/analysis/test_steady_c.py
        return None      # asserts the C kernels load where a compiler is)

    cc = c_compiler()
    if cc is None:
        return None
    try:
        folder = cache_dir()
        key = source_key(SOURCE, "steady", cc, *FLAGS)
        src, path = folder / f"lagrangian_steady_{key}.c", folder / f"lagrangian_steady_{key}.so"
        if not path.exists():  # stored only once the compiler built it
            store(src, SOURCE)
            fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".so", dir=folder)
            os.close(fd)
            run = subprocess.run([*cc.split(), *FLAGS, "-o", tmp, str(src), "-lm"], capture_output=True, text=True)
            if run.returncode != 0:
                os.unlink(tmp)
                return None
            os.replace(tmp, path)
        if not _own_file(path):  # machine code from the cache is run: only the user's own, as _lambdify reads
            return None
        try:
            return ctypes.CDLL(str(path))
        except OSError:  # a broken entry is removed, never reused
            path.unlink(missing_ok=True)
            return None
    except OSError:
        return None


def _own_file(path) -> bool:
    """Whether `path` is a regular file of this user's that nobody else can write (equations._lambdify's rule for
    the machine code it loads from the cache)."""
    st = os.lstat(path)
    if not stat.S_ISREG(st.st_mode) or st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return False
    return not hasattr(os, "getuid") or st.st_uid == os.getuid()
