"""Dense LU with partial pivoting, compiled (numba): the one factorization every compiled
integrator uses. Same pivot rule as LAPACK's dgetf2; loops instead of BLAS, because the
systems here are small (n ≲ 100) and the calls many."""

from __future__ import annotations

from numba import njit


@njit(cache=True)
def lu_factor(A, piv):
    """In-place LU with partial pivoting (LAPACK dgetf2 pivot rule); returns info (0 = ok,
    k + 1 = exactly zero pivot in column k)."""
    n = A.shape[0]
    info = 0
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        piv[k] = p
        if A[p, k] == 0.0:
            if info == 0:
                info = k + 1
            continue
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            A[i, k] *= inv
        for i in range(k + 1, n):
            lik = A[i, k]
            if lik != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= lik * A[k, j]
    return info


@njit(cache=True)
def lu_solve(A, piv, b):
    """Solve in place with the factors of :func:`lu_factor`."""
    n = A.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= A[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= A[i, j] * b[j]
        b[i] = s / A[i, i]


@njit(cache=True)
def factor_flagged(A, piv, st, h):
    """LU-factor ``A`` in place and keep its state in ``st``: st[0] = 1 and st[1] = h (the
    step the factor belongs to) when it worked, st[0] = 0 when ``A`` is singular. Returns
    :func:`lu_factor`'s status. For steppers that reuse a factor across steps."""
    if lu_factor(A, piv) != 0:
        st[0] = 0.0
        return 1
    st[0] = 1.0
    st[1] = h
    return 0
