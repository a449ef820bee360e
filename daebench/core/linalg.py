"""Dense LU with partial pivoting, compiled (numba): the one factorization every compiled
integrator uses. Same pivot rule as LAPACK's dgetf2; loops instead of BLAS, because the
systems here are small (n ≲ 100) and the calls many.

For large, banded systems with a few dense rows and columns (finite-element bodies on a
floating frame, plus constraint rows) the bordered-banded factorization
(:func:`bordered_factor`, :func:`bordered_solve`): a banded LU with partial pivoting
(LAPACK dgbtf2/dgbtrs) of the banded block and a dense LU of the border's Schur
complement, O(n·b²) to factor and O(n·b) to solve instead of O(n³) and O(n²).
:func:`solve_structured` is the same factorization for the driver's one-off solves
(impact maps, projections, M⁻¹ products) with the band measured on the matrix."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from daebench.core.borrow import uncounted


@uncounted
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


@uncounted
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


@uncounted
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


# -- banded and bordered-banded systems ---------------------------------------------------------------
# Band storage (LAPACK's dgbtrf layout): A[i, j] (|i − j| within the band) lives in
# AB[kl + ku + i − j, j]; AB has 2·kl + ku + 1 rows, the first kl of them room for the
# fill-in that row interchanges bring into U.
@uncounted
def band_from_dense(A, order, nb, kl, ku, AB):
    """Copy the band of the leading ``nb`` × ``nb`` block of A[order][:, order] into ``AB``
    (zeros elsewhere)."""
    kv = kl + ku
    AB[:, :] = 0.0
    for j in range(nb):
        cj = order[j]
        for i in range(max(0, j - ku), min(nb, j + kl + 1)):
            AB[kv + i - j, j] = A[order[i], cj]


@uncounted
def band_lu_factor(AB, kl, ku, piv):
    """In-place banded LU with partial pivoting (LAPACK dgbtf2); returns info (0 = ok,
    k + 1 = exactly zero pivot in column k). ``AB`` in band storage, fill-in rows included."""
    n = AB.shape[1]
    kv = kl + ku
    info = 0
    for j in range(n):          # the fill-in rows start at zero
        for i in range(kl):
            AB[i, j] = 0.0
    ju = 0
    for j in range(n):
        km = min(kl, n - j - 1)
        p = 0
        amax = abs(AB[kv, j])
        for i in range(1, km + 1):
            if abs(AB[kv + i, j]) > amax:
                amax = abs(AB[kv + i, j])
                p = i
        piv[j] = p + j
        if AB[kv + p, j] == 0.0:
            if info == 0:
                info = j + 1
            continue
        ju = max(ju, min(j + ku + p, n - 1))
        if p != 0:
            for c in range(j, ju + 1):
                tmp = AB[kv + p + j - c, c]
                AB[kv + p + j - c, c] = AB[kv + j - c, c]
                AB[kv + j - c, c] = tmp
        inv = 1.0 / AB[kv, j]
        for i in range(1, km + 1):
            AB[kv + i, j] *= inv
        for c in range(j + 1, ju + 1):
            ujc = AB[kv + j - c, c]
            if ujc != 0.0:
                for i in range(1, km + 1):
                    AB[kv + i + j - c, c] -= AB[kv + i, j] * ujc
    return info


@uncounted
def band_lu_solve(AB, kl, ku, piv, b):
    """Solve in place with the factors of :func:`band_lu_factor` (LAPACK dgbtrs, no transpose)."""
    n = AB.shape[1]
    kv = kl + ku
    for j in range(n - 1):
        p = piv[j]
        if p != j:
            tmp = b[p]
            b[p] = b[j]
            b[j] = tmp
        bj = b[j]
        if bj != 0.0:
            for i in range(1, min(kl, n - j - 1) + 1):
                b[j + i] -= AB[kv + i, j] * bj
    for j in range(n - 1, -1, -1):
        if b[j] != 0.0:
            b[j] /= AB[kv, j]
            bj = b[j]
            for i in range(max(0, j - kv), j):
                b[i] -= AB[kv + i - j, j] * bj


class BorderedWork(NamedTuple):
    """Factors of a bordered-banded matrix P A Pᵀ = [[B, E], [F, D]] (B banded, the
    border E, F, D of k rows and columns): B = LU in band storage, W = B⁻¹E, the Schur
    complement S = D − F W factorized densely."""

    order: np.ndarray   # int64[nx]: P (banded unknowns first, then the border)
    kl: int
    ku: int
    AB: np.ndarray      # (2 kl + ku + 1, nb)
    piv: np.ndarray     # int64[nb]
    W: np.ndarray       # (k, nb): row r = B⁻¹ E[:, r]
    F: np.ndarray       # (k, nb)
    S: np.ndarray       # (k, k)
    spiv: np.ndarray    # int64[k]
    y: np.ndarray       # float64[nx] scratch


def bordered_work(order: np.ndarray, nb: int, kl: int, ku: int) -> BorderedWork:
    nx = order.shape[0]
    k = nx - nb
    return BorderedWork(np.asarray(order, np.int64), int(kl), int(ku), np.zeros((2 * kl + ku + 1, nb)),
                        np.zeros(nb, np.int64), np.zeros((max(k, 1), nb)), np.zeros((max(k, 1), nb)),
                        np.zeros((max(k, 1), max(k, 1))), np.zeros(max(k, 1), np.int64), np.zeros(nx))


@uncounted
def bordered_factor(A, bw):
    """Factorize the leading nx × nx block of the dense ``A`` (nx = len(bw.order)) through
    its declared bordered-banded structure; entries of the banded block outside the band
    are taken as zero. Returns info (0 = ok)."""
    order, kl, ku = bw.order, bw.kl, bw.ku
    nb = bw.AB.shape[1]
    nx = order.shape[0]
    k = nx - nb
    band_from_dense(A, order, nb, kl, ku, bw.AB)
    info = band_lu_factor(bw.AB, kl, ku, bw.piv)
    if info:
        return info
    for r in range(k):
        cr = order[nb + r]
        w = bw.W[r]
        for i in range(nb):
            w[i] = A[order[i], cr]
            bw.F[r, i] = A[cr, order[i]]
        band_lu_solve(bw.AB, kl, ku, bw.piv, w)
    S = bw.S
    for r in range(k):
        for c in range(k):
            s = A[order[nb + r], order[nb + c]]
            for i in range(nb):
                s -= bw.F[r, i] * bw.W[c, i]
            S[r, c] = s
    if k == 0:
        return 0
    info = lu_factor(S[:k, :k], bw.spiv)
    return nb + info if info else 0


@uncounted
def bordered_solve(bw, b):
    """Solve A x = b in place (``b`` of length nx) with :func:`bordered_factor`'s factors."""
    order = bw.order
    nb = bw.AB.shape[1]
    nx = order.shape[0]
    k = nx - nb
    y = bw.y
    for i in range(nx):
        y[i] = b[order[i]]
    yb = y[:nb]
    band_lu_solve(bw.AB, bw.kl, bw.ku, bw.piv, yb)
    if k:
        z = y[nb:nx]
        for r in range(k):
            s = z[r]
            for i in range(nb):
                s -= bw.F[r, i] * yb[i]
            z[r] = s
        lu_solve(bw.S[:k, :k], bw.spiv, z)
        for r in range(k):
            zr = z[r]
            if zr != 0.0:
                w = bw.W[r]
                for i in range(nb):
                    yb[i] -= w[i] * zr
    for i in range(nx):
        b[order[i]] = y[i]


@uncounted
def bordered_fits(A, bw):
    """Whether the banded block of A (through ``bw.order``) has no nonzero outside its band."""
    order, kl, ku = bw.order, bw.kl, bw.ku
    nb = bw.AB.shape[1]
    for i in range(nb):
        ri = order[i]
        for j in range(nb):
            if (i - j > kl or j - i > ku) and A[ri, order[j]] != 0.0:
                return False
    return True


@uncounted
def half_bandwidths(A, nb):
    """(kl, ku): the largest i − j and j − i over the nonzeros of A's leading nb × nb block
    (each row scanned from both ends to its first nonzero)."""
    kl = 0
    ku = 0
    for i in range(nb):
        for j in range(0, i):
            if A[i, j] != 0.0:
                kl = max(kl, i - j)
                break
        for j in range(nb - 1, i, -1):
            if A[i, j] != 0.0:
                ku = max(ku, j - i)
                break
    return kl, ku


# below this many banded unknowns, or above these fractions of them for the band or the
# border, LAPACK's dense solve is the cheaper (and the historical) one
STRUCTURED_MIN_N = 128
STRUCTURED_MAX_FRACTION = 0.125


class DiagonalMass:
    """A diagonal mass matrix M = diag(d) as an operator: ``M @ x``, ``x @ M`` and
    :meth:`solve` in O(n) per column, so that a lumped model's contact transitions (impacts,
    settling, projections) never build the dense n × n matrix. NumPy defers to it
    (``__array_ufunc__ = None``), so ``v @ M @ v`` works as with an array; there is no
    implicit conversion to a dense array — code that needs one asks for :meth:`dense`."""

    __array_ufunc__ = None

    def __init__(self, d: np.ndarray):
        self.d = np.ascontiguousarray(d, dtype=np.float64)
        if self.d.ndim != 1 or not np.all(np.isfinite(self.d)) or not np.all(self.d > 0.0):
            raise ValueError("DiagonalMass needs a 1-D array of positive, finite masses")
        self.shape = (self.d.size, self.d.size)

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        return self.d * x if x.ndim == 1 else self.d[:, None] * x

    def __rmatmul__(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x, dtype=np.float64) * self.d

    def solve(self, b: np.ndarray) -> np.ndarray:
        """M⁻¹ b for one right-hand side or columns of them."""
        b = np.asarray(b, dtype=np.float64)
        return b / self.d if b.ndim == 1 else b / self.d[:, None]

    def dense(self) -> np.ndarray:
        return np.diag(self.d)


def solve_structured(A: np.ndarray, b: np.ndarray, nb: int | None = None) -> np.ndarray:
    """x = A⁻¹ b (``b`` one right-hand side or columns of them) for a dense ``A`` whose
    leading ``nb`` × ``nb`` block (all of A by default) is banded: a mass matrix, or an
    augmented system [[M, Bᵀ], [B, 0]] with nb = n. The band is measured on A (O(n²)
    reads, no declaration to trust) and A is solved through :func:`bordered_factor`,
    O(n·b² + n·k²) instead of LAPACK's O(n³) — the same solution to round-off.

    LAPACK's dense solve (``numpy.linalg.solve``, with its errors: singular A raises
    ``LinAlgError``) is used instead where it is the cheaper one — fewer than
    ``STRUCTURED_MIN_N`` banded unknowns, or a band (kl + ku) or border wider than
    ``STRUCTURED_MAX_FRACTION`` of them — and where the banded block needs a pivot from
    outside itself (a zero pivot in it: the banded LU pivots within the block only)."""
    if isinstance(A, DiagonalMass):
        return A.solve(b)
    A = np.ascontiguousarray(A, dtype=np.float64)
    n = A.shape[0]
    nb = n if nb is None else int(nb)
    if A.ndim != 2 or A.shape[1] != n or not 0 <= nb <= n:
        raise ValueError(f"solve_structured needs a square A and 0 <= nb <= n; got A {A.shape}, nb = {nb}")
    k = n - nb
    if nb < STRUCTURED_MIN_N or k > STRUCTURED_MAX_FRACTION * nb:
        return np.linalg.solve(A, b)
    kl, ku = half_bandwidths(A, nb)
    if kl + ku > STRUCTURED_MAX_FRACTION * nb or not np.all(np.isfinite(A)):
        return np.linalg.solve(A, b)
    bw = bordered_work(np.arange(n, dtype=np.int64), nb, kl, ku)
    if bordered_factor(A, bw) != 0:
        return np.linalg.solve(A, b)
    x = np.array(b, dtype=np.float64, copy=True)
    if x.shape[0] != n:
        raise ValueError(f"solve_structured: b has {x.shape[0]} rows, A has {n}")
    if x.ndim == 1:
        bordered_solve(bw, x)
        return x
    for c in range(x.shape[1]):
        col = np.ascontiguousarray(x[:, c])
        bordered_solve(bw, col)
        x[:, c] = col
    return x


class Sparsity(NamedTuple):
    """The structure a model declares for its iteration matrices: the DOFs ``order[:n_banded]``
    couple only within half-bandwidths (kl, ku) in that order; the others (``order[n_banded:]``)
    form a dense border. ``mass_band``: M[i, j] = 0 for |i − j| > mass_band in the natural
    numbering (−1: dense); ``constant_mass``: M does not depend on q."""

    order: np.ndarray
    n_banded: int
    kl: int
    ku: int
    mass_band: int
    constant_mass: bool


def band_order(n: int, border: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, int]:
    """An order of the DOFs not in ``border`` (natural, or reverse Cuthill–McKee when that
    narrows the band) followed by ``border``, and the half-bandwidth of the coupling pattern
    (rows[k], cols[k]) among the banded DOFs in that order."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    border = np.unique(np.asarray(border, np.int64))
    inner = np.setdiff1d(np.arange(n, dtype=np.int64), border)
    keep = np.isin(rows, inner) & np.isin(cols, inner)
    r, c = np.asarray(rows)[keep], np.asarray(cols)[keep]

    def width(order: np.ndarray) -> int:
        pos = np.full(n, -1, np.int64)
        pos[order] = np.arange(order.size)
        return int(np.max(np.abs(pos[r] - pos[c]), initial=0))

    best, bw = inner, width(inner)
    if inner.size and r.size:
        local = np.full(n, -1, np.int64)
        local[inner] = np.arange(inner.size)
        G = sp.csr_matrix((np.ones(r.size), (local[r], local[c])), shape=(inner.size, inner.size))
        rcm = inner[reverse_cuthill_mckee((G + G.T).tocsr(), symmetric_mode=True)]
        if width(rcm) < bw:
            best, bw = rcm, width(rcm)
    return np.concatenate([best, border]).astype(np.int64), bw
