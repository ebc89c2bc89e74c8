"""The steady-state residual of a constrained model at a batch of points, compiled (numba): the
arithmetic of ``_constrained_steady.SteadyState._rows_batch`` point by point in loops, without the
hundred NumPy calls a batch costs (about 0.4 ms, which made the multi-start search of the bicycle's
steady motions take 4 s: 7800 evaluations of 7 points, each point a microsecond of compiled M, f, G
and c).

Two steps, around the compiled evaluations of the model (SymEngine's LLVM functions, called by the
caller between them):

1. :func:`free_rates`: from (W, g, w) at each point, the rates of the free ignorable coordinates by
   least squares against W's columns of them (the SVD cut off at 1e-10 of max |W|), written into
   the points' states, and w with them.
2. :func:`steady_rows`: from (M, f, G, c) at each point, the saddle-point solve of
   ``numeric._constrained`` (Cholesky M = Lc Lc^T, Lc^-1 G^T = Q R, the measures r_M and rho_G
   against SINGULAR_RATIO) and the residual rows (q_ddot of the held coordinates, g of the
   holonomic constraints, w); NaN rows where a point is singular or not finite (the caller decides
   those points by the single-point path, as before).

Then :func:`central_jacobian` forms r and dr/dz from the rows at q and at the 2k points q +- h e_j
(the round-off floor of ``SteadyState.__call__``). The same operations as the NumPy batch, in the
same order; the factorizations are written out (Cholesky, Householder QR, triangular solves) and
agree with LAPACK's to round-off. Compiled once per machine (``cache=True``).

The search uses these where there is no C compiler: ``_steady_c`` holds the same loops in C (the same
numbers bit for bit, tests/analysis/test_steady_c.py), which start without numba's import.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["points", "free_rates", "steady_rows", "central_jacobian", "differences"]


@njit(cache=True)
def points(A, t, u, p, q, shape, h, given, given_values):  # pragma: no cover - compiled
    """Fill A (2 k + 1 rows) with the arguments (t, q, q_dot, u, p) of q and of the points q +- h_j
    along the shape coordinates (rows 2 j + 1 and 2 j + 2), the given rates set, the others 0. Nothing
    is written where A is not of that shape (compiled code does not check its indices)."""
    n = q.shape[0]
    nu = u.shape[0]
    if A.shape[0] != 2 * shape.shape[0] + 1 or A.shape[1] != 1 + 2 * n + nu + p.shape[0] or h.shape[0] < shape.shape[0]:
        return
    for i in range(A.shape[0]):
        A[i, 0] = t
        for j in range(n):
            A[i, 1 + j] = q[j]
            A[i, 1 + n + j] = 0.0
        for j in range(given.shape[0]):
            A[i, 1 + n + given[j]] = given_values[j]
        for j in range(nu):
            A[i, 1 + 2 * n + j] = u[j]
        for j in range(p.shape[0]):
            A[i, 1 + 2 * n + nu + j] = p[j]
    for j in range(shape.shape[0]):
        A[2 * j + 1, 1 + shape[j]] = q[shape[j]] + h[j]
        A[2 * j + 2, 1 + shape[j]] = q[shape[j]] - h[j]


@njit(cache=True)
def _jacobi_svd(B, V):  # pragma: no cover - compiled
    """One-sided Jacobi (Hestenes): B (r x c) is replaced by B V, whose columns are orthogonal, and V
    (c x c) by the rotations' product: B_in = (B V) V^T, the singular values are the columns' norms
    (high relative accuracy: the cut-off of small singular values is decided reliably)."""
    r, c = B.shape
    for i in range(c):
        for j in range(c):
            V[i, j] = 1.0 if i == j else 0.0
    for _sweep in range(60):
        rotated = False
        for i in range(c - 1):
            for j in range(i + 1, c):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for k in range(r):
                    alpha += B[k, i] * B[k, i]
                    beta += B[k, j] * B[k, j]
                    gamma += B[k, i] * B[k, j]
                if gamma == 0.0 or abs(gamma) <= 1e-15 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                tan = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                cos = 1.0 / math.sqrt(1.0 + tan * tan)
                sin = cos * tan
                for k in range(r):
                    bi, bj = B[k, i], B[k, j]
                    B[k, i] = cos * bi - sin * bj
                    B[k, j] = sin * bi + cos * bj
                for k in range(c):
                    vi, vj = V[k, i], V[k, j]
                    V[k, i] = cos * vi - sin * vj
                    V[k, j] = sin * vi + cos * vj
        if not rotated:
            break


@njit(cache=True)
def free_rates(C, X, free, n, m, bad):  # pragma: no cover - compiled
    """C: (k, m n + 2 m) rows of (W, g, w) of each point; X: (k, >= 1 + 2 n) the points' arguments
    (t, q, q_dot, ...): the free rates are written into X[:, 1 + n + free] (the least-squares
    solution of W_free rates = -w, singular values under 1e-10 max |W| cut off). Returns w (k, m) with
    the free rates' part added; bad[i] set where C's row is not finite."""
    k = C.shape[0]
    nf = free.shape[0]
    w = np.empty((k, m))
    Wf = np.zeros((m, nf))
    B = np.empty((m, nf))
    V = np.empty((nf, nf))
    rates = np.empty(nf)
    for i in range(k):
        finite = True
        for j in range(C.shape[1]):
            if not math.isfinite(C[i, j]):
                finite = False
                break
        if not finite:
            bad[i] = True
        rest = True
        for r in range(m):
            w[i, r] = C[i, m * n + m + r]
            if w[i, r] != 0.0:
                rest = False
        if nf == 0 or not finite or rest:  # no free rate, or nothing moves them: they stay 0
            continue
        big = 0.0
        for r in range(m):
            for j in range(n):
                big = max(big, abs(C[i, r * n + j]))
            for j in range(nf):
                Wf[r, j] = C[i, r * n + free[j]]
                B[r, j] = Wf[r, j]
        big = max(big, 1e-300)
        _jacobi_svd(B, V)
        for j in range(nf):
            rates[j] = 0.0
        for s in range(nf):
            norm2 = 0.0
            dot = 0.0
            for r in range(m):
                norm2 += B[r, s] * B[r, s]
                dot -= B[r, s] * w[i, r]
            if math.sqrt(norm2) > 1e-10 * big:
                coef = dot / norm2
                for j in range(nf):
                    rates[j] += V[j, s] * coef
        for j in range(nf):
            X[i, 1 + n + free[j]] = rates[j]
        for r in range(m):
            acc = 0.0
            for j in range(nf):
                acc += Wf[r, j] * rates[j]
            w[i, r] += acc
    return w


@njit(cache=True)
def _cholesky(M, L):  # pragma: no cover - compiled
    """L (lower) with M = L L^T; False where M is not positive definite."""
    n = M.shape[0]
    for j in range(n):
        s = M[j, j]
        for p in range(j):
            s -= L[j, p] * L[j, p]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            t = M[i, j]
            for p in range(j):
                t -= L[i, p] * L[j, p]
            L[i, j] = t / d
    return True


@njit(cache=True)
def _lower_solve(L, b):  # pragma: no cover - compiled
    """L^-1 b in place (L lower triangular)."""
    n = L.shape[0]
    for i in range(n):
        s = b[i]
        for p in range(i):
            s -= L[i, p] * b[p]
        b[i] = s / L[i, i]


@njit(cache=True)
def _lower_transpose_solve(L, b):  # pragma: no cover - compiled
    """L^-T b in place (L lower triangular)."""
    n = L.shape[0]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for p in range(i + 1, n):
            s -= L[p, i] * b[p]
        b[i] = s / L[i, i]


@njit(cache=True)
def _householder_qr(B, Q, R, A, V, beta):  # pragma: no cover - compiled
    """B = Q R (n x m, m <= n): Q (n, m) with orthonormal columns, R (m, m) upper triangular (A, V:
    (n, m) and beta (m,): work arrays)."""
    n, m = B.shape
    for i in range(n):
        for j in range(m):
            A[i, j] = B[i, j]
            V[i, j] = 0.0
    for j in range(m):
        beta[j] = 0.0
    for j in range(m):
        norm = 0.0
        for i in range(j, n):
            norm += A[i, j] * A[i, j]
        norm = math.sqrt(norm)
        alpha = -norm if A[j, j] >= 0.0 else norm
        vnorm = 0.0
        for i in range(j, n):
            V[i, j] = A[i, j]
        V[j, j] -= alpha
        for i in range(j, n):
            vnorm += V[i, j] * V[i, j]
        if vnorm > 0.0:
            beta[j] = 2.0 / vnorm
            for c in range(j, m):
                s = 0.0
                for i in range(j, n):
                    s += V[i, j] * A[i, c]
                s *= beta[j]
                for i in range(j, n):
                    A[i, c] -= s * V[i, j]
    for r in range(m):
        for c in range(m):
            R[r, c] = A[r, c] if c >= r else 0.0
    for i in range(n):
        for c in range(m):
            Q[i, c] = 1.0 if i == c else 0.0
    for j in range(m - 1, -1, -1):  # Q = H_0 H_1 ... H_(m-1) applied to the first m columns of I
        if beta[j] == 0.0:
            continue
        for c in range(m):
            s = 0.0
            for i in range(j, n):
                s += V[i, j] * Q[i, c]
            s *= beta[j]
            for i in range(j, n):
                Q[i, c] -= s * V[i, j]


@njit(cache=True)
def steady_rows(P, w, g, held, hol, n, m, singular_ratio, bad, rows, scale):  # pragma: no cover - compiled
    """P: (k, n n + n + m n + m) rows of (M, f, G, c) of each point; w (k, m), g (k, m) (all the
    constraints' residuals); writes rows (k, len(held) + len(hol) + m): q_ddot[held], g[hol], w
    (NaN where bad, or where the point is singular or not finite: bad[i] then set), and scale[i], the
    size of the accelerations the terms make at the point (max |f| / max |M_jj| + max |c| +
    max q_dot^2 is added by the caller)."""
    k = P.shape[0]
    a_held = held.shape[0]
    kh = hol.shape[0]
    M = np.empty((n, n))
    L = np.zeros((n, n))
    f = np.empty(n)
    G = np.empty((m, n))
    c = np.empty(m)
    B = np.empty((n, m))
    Q = np.empty((n, m))
    R = np.empty((m, m))
    work, V, beta = np.empty((n, m)), np.empty((n, m)), np.empty(m)
    col, a, y, wr = np.empty(n), np.empty(n), np.empty(n), np.empty(m)
    for i in range(k):
        finite = True
        for j in range(P.shape[1]):
            if not math.isfinite(P[i, j]):
                finite = False
                break
        for r in range(n):
            for s in range(n):
                M[r, s] = P[i, r * n + s]
            f[r] = P[i, n * n + r]
        for r in range(m):
            for s in range(n):
                G[r, s] = P[i, n * n + n + r * n + s]
            c[r] = P[i, n * n + n + m * n + r]
        mass = 0.0
        forces = 0.0
        bias = 0.0
        for r in range(n):
            mass = max(mass, abs(M[r, r]))
            forces = max(forces, abs(f[r]))
        for r in range(m):
            bias = max(bias, abs(c[r]))
        scale[i] = (forces / mass if mass > 0.0 else 0.0) + bias
        ok = finite and not bad[i] and m <= n
        if ok:
            for r in range(n):
                if not M[r, r] > 0.0:
                    ok = False
        if ok:
            ok = _cholesky(M, L)
        if ok:
            ratio = math.inf
            for r in range(n):
                ratio = min(ratio, L[r, r] * L[r, r] / M[r, r])
            for s in range(m):
                for r in range(n):
                    col[r] = G[s, r]
                _lower_solve(L, col)
                for r in range(n):
                    B[r, s] = col[r]
            big = 0.0
            for s in range(m):
                t = 0.0
                for r in range(n):
                    t += B[r, s] * B[r, s]
                big = max(big, t)
            _householder_qr(B, Q, R, work, V, beta)
            rho = math.inf
            for s in range(m):
                rho = min(rho, abs(R[s, s]))
            rho = rho / math.sqrt(big) if m else 1.0
            ok = ratio > singular_ratio and rho > singular_ratio and math.isfinite(rho)
        if not ok:
            bad[i] = True
            for r in range(rows.shape[1]):
                rows[i, r] = np.nan
            continue
        for r in range(n):
            a[r] = f[r]
        _lower_solve(L, a)
        _lower_transpose_solve(L, a)
        for s in range(m):  # R^-T (c - G a): forward substitution with R^T
            t = c[s]
            for r in range(n):
                t -= G[s, r] * a[r]
            for p in range(s):
                t -= R[p, s] * wr[p]
            wr[s] = t / R[s, s]
        for r in range(n):
            t = 0.0
            for s in range(m):
                t += Q[r, s] * wr[s]
            y[r] = t
        _lower_transpose_solve(L, y)
        for j in range(a_held):
            rows[i, j] = a[held[j]] + y[held[j]]
        for j in range(kh):
            rows[i, a_held + j] = g[i, hol[j]]
        for j in range(m):
            rows[i, a_held + kh + j] = w[i, j]


@njit(cache=True)
def central_jacobian(R, A, W, scale, q, h, n, held, hol, J):  # pragma: no cover - compiled
    """Where every row of R is finite (q, then q +- h_j e_j along the shape coordinates): J[:, j] =
    (R[2 j + 1] - R[2 j + 2]) / (2 h_j), with the entries at most 1e-8 of their row's floor set to 0
    (round-off of the differences as exact zeros): the floor is the size of the terms of the
    accelerations for the held rows (`scale` at q plus the largest squared rate), 1 + max |q| for the
    holonomic rows, (1 + max |q_dot|)(1 + max |W|) for the velocity rows, at q (A[0]: its arguments,
    W[0]: its constraint Jacobian). Returns False (J untouched) where a row is not finite."""
    rows, k = J.shape
    if R.shape[0] < 2 * k + 1 or R.shape[1] != rows or h.shape[0] < k:  # not the batch of q +- h_j
        return False
    for i in range(R.shape[0]):
        for r in range(R.shape[1]):
            if not math.isfinite(R[i, r]):
                return False
    rates2 = 0.0
    rates = 0.0
    for j in range(n):
        v = A[0, 1 + n + j]
        rates2 = max(rates2, v * v)
        rates = max(rates, abs(v))
    big_q = 0.0
    for j in range(q.shape[0]):
        big_q = max(big_q, abs(q[j]))
    big_w = 0.0
    for r in range(W.shape[1]):
        for j in range(W.shape[2]):
            big_w = max(big_w, abs(W[0, r, j]))
    a, kh = held, hol
    for r in range(rows):
        if r < a:
            floor = scale[0] + rates2
        elif r < a + kh:
            floor = 1.0 + big_q
        else:
            floor = (1.0 + rates) * (1.0 + big_w)
        for j in range(k):
            d = (R[2 * j + 1, r] - R[2 * j + 2, r]) / (2.0 * h[j])
            J[r, j] = 0.0 if abs(d) <= 1e-8 * floor else d
    return True


@njit(cache=True)
def differences(R, h, floor, J):  # pragma: no cover - compiled
    """J[:, j] = (R[2 j + 1] - R[2 j + 2]) / (2 h_j), entries at most 1e-8 of the row's floor set to
    0 (``central_jacobian`` where the floor is given)."""
    rows, k = J.shape
    for j in range(k):
        for r in range(rows):
            d = (R[2 * j + 1, r] - R[2 * j + 2, r]) / (2.0 * h[j])
            J[r, j] = 0.0 if abs(d) <= 1e-8 * floor[r] else d
