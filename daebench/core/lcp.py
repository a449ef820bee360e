"""A compiled linear complementarity solver for contact impulses.

Find z with

    z ≥ 0,   w = A z + b ≥ 0,   zᵀ w = 0                          (LCP(A, b))

on the rows ``use[i]``; the other rows have z_i = 0 and their w_i is not constrained.

Method: Murty's least-index principal pivoting (Bard-type scheme). The rows are split
into a basis B (w_B = 0, z_B = −A_BB⁻¹ b_B) and its complement (z = 0); the lowest-index
row that violates its sign condition (z_i < 0 in B, w_i < 0 outside) changes side, until
none does. For a P-matrix A — here A = G S⁻¹ Gᵀ with S the (symmetric positive definite)
iteration matrix and independent gap Jacobians G — the solution is unique and the
scheme finds it in finitely many pivots from any start (Murty 1974); one contact is
z = max(0, −b/A) in closed form. Exact up to round-off, unlike projected Gauss–Seidel,
which converges only linearly and needs a tolerance; the price, a dense solve of the
basis per pivot, is negligible for the few contacts of daebench's cases.

Frictional contact (:func:`solve_lcp_lemke`): the planar Coulomb cone written as an LCP
(normal impulse, two tangential ones and the sliding-speed multiplier per contact,
:mod:`daebench.stepping.friction`) has a matrix that is copositive-plus but not a
P-matrix — Murty's scheme may meet a singular basis there. Lemke's complementary pivoting
with the covering vector of ones solves every such LCP that has a solution and ends on a
secondary ray otherwise (Cottle, Pang & Stone §4.4; Stewart & Trinkle 1996 and Anitescu &
Potra 1997 show the time-stepping friction LCP always has one). A ray end is returned as
LCP_RAY: the caller names it (an inconsistent or indeterminate frictional contact,
Painlevé's paradox), never loops. Its end point is checked: on degenerate data (identical
tangent rows, zero entries of b) finite-precision pivoting can end with z0 out of the basis
at a point that is not a solution, returned as LCP_DEGENERATE for the caller to break the
ties, never as a solution.

References
----------
C. E. Lemke, "Bimatrix equilibrium points and mathematical programming", Management
Science 11 (1965) 681–689.
D. E. Stewart, J. C. Trinkle, "An implicit time-stepping scheme for rigid body dynamics
with inelastic collisions and Coulomb friction", Int. J. Numer. Meth. Eng. 39 (1996)
2673–2691.
K. G. Murty, "Note on a Bard-type scheme for solving the complementarity problem",
Opsearch 11 (1974) 123–130.
R. W. Cottle, J.-S. Pang, R. E. Stone, The Linear Complementarity Problem (1992), §4.2.

For the few unknowns of an impact, :func:`enumerate_lcp` tries every complementary basis: the
check that an LCP on which Lemke's method ends on a ray really has no solution.
"""

from __future__ import annotations

import itertools

from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core.linalg import lu_factor, lu_solve

LCP_TOL = 1e-12            # sign tolerance relative to the size of b (w) and of z
LCP_MAX_PIVOTS = 200       # beyond this the matrix is not a P-matrix (dependent contacts)
LCP_SINGULAR, LCP_NO_CONVERGENCE, LCP_RAY, LCP_DEGENERATE = -1, -2, -3, -4
LEMKE_CHECK_TOL = 1e-9     # Lemke's end point is a solution to this, relative to |b| and |w|
LEMKE_MAX_PIVOTS = 1000    # per LCP; far above the few tens a contact set of daebench needs


class LcpWork(NamedTuple):
    """Scratch of :func:`solve_lcp` for up to k rows."""

    basis: np.ndarray   # bool[k]
    sub: np.ndarray     # float[k, k]: the basis block, factorized
    piv: np.ndarray     # int64[k]
    rhs: np.ndarray     # float[k]
    idx: np.ndarray     # int64[k]: rows of the basis


def lcp_work(k: int) -> LcpWork:
    kk = max(k, 1)
    return LcpWork(np.zeros(kk, np.bool_), np.zeros((kk, kk)), np.zeros(kk, np.int64), np.zeros(kk),
                   np.zeros(kk, np.int64))


@njit(cache=True)
def solve_lcp(A, b, use, z, w, lw):
    """Solve LCP(A, b) on the rows ``use`` into z (and w = A z + b); returns the number of
    pivots (≥ 0), LCP_SINGULAR (a basis block is singular) or LCP_NO_CONVERGENCE."""
    k = b.shape[0]
    basis = lw.basis
    nuse = 0
    only = -1
    bscale = 0.0
    for i in range(k):
        basis[i] = False
        z[i] = 0.0
        if use[i]:
            nuse += 1
            only = i
            bscale = max(bscale, abs(b[i]))
    if nuse == 0:
        for i in range(k):
            w[i] = b[i]
        return 0
    if nuse == 1 and A[only, only] > 0.0:  # closed form
        z[only] = max(0.0, -b[only] / A[only, only])
        for i in range(k):
            w[i] = b[i] + A[i, only] * z[only]
        return 0
    for pivots in range(LCP_MAX_PIVOTS):
        nb = 0
        for i in range(k):
            if basis[i]:
                lw.idx[nb] = i
                nb += 1
        for i in range(k):
            z[i] = 0.0
        if nb:
            sub = lw.sub[:nb, :nb]
            rhs = lw.rhs[:nb]
            for r in range(nb):
                rhs[r] = -b[lw.idx[r]]
                for c in range(nb):
                    sub[r, c] = A[lw.idx[r], lw.idx[c]]
            if lu_factor(sub, lw.piv[:nb]) != 0:
                return LCP_SINGULAR
            lu_solve(sub, lw.piv[:nb], rhs)
            for r in range(nb):
                z[lw.idx[r]] = rhs[r]
        zscale = 0.0
        for i in range(k):
            zscale = max(zscale, abs(z[i]))
        for i in range(k):
            s = b[i]
            for j in range(k):
                s += A[i, j] * z[j]
            w[i] = s
        bad = -1
        for i in range(k):
            if not use[i]:
                continue
            if basis[i] and z[i] < -LCP_TOL * zscale:
                bad = i
                break
            if not basis[i] and w[i] < -LCP_TOL * bscale:
                bad = i
                break
        if bad < 0:
            for i in range(k):
                if z[i] < 0.0:
                    z[i] = 0.0
            return pivots
        basis[bad] = not basis[bad]
    return LCP_NO_CONVERGENCE


class LemkeWork(NamedTuple):
    """Scratch of :func:`solve_lcp_lemke` for up to k rows."""

    tab: np.ndarray     # float[k, 2k + 2]: [w | z | z0 | rhs] tableau
    basis: np.ndarray   # int64[k]: the variable basic in each row (w_i = i, z_i = k + i, z0 = 2k)


def lemke_work(k: int) -> LemkeWork:
    kk = max(k, 1)
    return LemkeWork(np.zeros((kk, 2 * kk + 2)), np.zeros(kk, np.int64))


@njit(cache=True)
def _lemke_pivot(tab, r, c, m):
    piv = tab[r, c]
    for j in range(tab.shape[1]):
        tab[r, j] /= piv
    for i in range(m):
        if i != r:
            f = tab[i, c]
            if f != 0.0:
                for j in range(tab.shape[1]):
                    tab[i, j] -= f * tab[r, j]


@njit(cache=True)
def solve_lcp_lemke(A, b, m, z, w, lw):
    """Solve LCP(A[:m, :m], b[:m]) by Lemke's method into z[:m] (and w = A z + b);
    returns the number of pivots (≥ 0), LCP_RAY (a secondary ray: no solution found)
    or LCP_NO_CONVERGENCE."""
    for i in range(m):
        z[i] = 0.0
        w[i] = b[i]
    if m == 0:
        return 0
    r = 0
    bscale = 0.0
    for i in range(m):
        bscale = max(bscale, abs(b[i]))
        if b[i] < b[r]:
            r = i
    if b[r] >= -LCP_TOL * bscale:
        return 0
    tab = lw.tab
    cz0 = 2 * m
    crhs = 2 * m + 1
    for i in range(m):
        for j in range(2 * m + 2):
            tab[i, j] = 0.0
        tab[i, i] = 1.0
        for j in range(m):
            tab[i, m + j] = -A[i, j]
        tab[i, cz0] = -1.0
        tab[i, crhs] = b[i]
        lw.basis[i] = i
    _lemke_pivot(tab, r, cz0, m)
    leaving = lw.basis[r]
    lw.basis[r] = cz0
    for pivots in range(1, LEMKE_MAX_PIVOTS):
        enter = leaving + m if leaving < m else leaving - m
        cmax = 0.0
        for i in range(m):
            cmax = max(cmax, abs(tab[i, enter]))
        row = -1
        best = 0.0
        for i in range(m):
            a = tab[i, enter]
            if a <= 1e-12 * cmax:
                continue
            ratio = max(tab[i, crhs], 0.0) / a
            if row < 0 or ratio < best - 1e-12 * (1.0 + best):
                row, best = i, ratio
            elif ratio <= best + 1e-12 * (1.0 + best):
                # a tie: leave with z0 when it can (the end), else the larger pivot element
                if lw.basis[i] == cz0 or (lw.basis[row] != cz0 and a > tab[row, enter]):
                    row, best = i, min(best, ratio)
        if row < 0:
            return LCP_RAY
        leaving = lw.basis[row]
        _lemke_pivot(tab, row, enter, m)
        lw.basis[row] = enter
        if leaving == cz0:
            for i in range(m):
                v = lw.basis[i]
                if m <= v < 2 * m:
                    z[v - m] = max(tab[i, crhs], 0.0)
            for i in range(m):
                s = b[i]
                for j in range(m):
                    s += A[i, j] * z[j]
                w[i] = s
            return pivots if _complementary(b, z, w, m) else LCP_DEGENERATE
    return LCP_NO_CONVERGENCE


@njit(cache=True)
def _complementary(b, z, w, m):
    """Whether (z, w = A z + b) solves the LCP to LEMKE_CHECK_TOL of the problem's size: on
    degenerate data (identical tangent rows of contacts on one line, zero rows of b) the
    pivoting can end with z0 out of the basis at a point that is not a solution."""
    scale = 0.0
    for i in range(m):
        scale = max(scale, abs(b[i]), abs(w[i]))
    tol = LEMKE_CHECK_TOL * max(scale, 1e-300)
    for i in range(m):
        if w[i] < -tol or min(z[i], w[i]) > tol:
            return False
    return True


LCP_FAILURES = {LCP_SINGULAR: "a basis block of the LCP matrix is singular (dependent contacts?)",
                LCP_DEGENERATE: "Lemke's pivoting ended at a point that is not a solution (degenerate contact data)",
                LCP_NO_CONVERGENCE: f"no solution after {LCP_MAX_PIVOTS} pivots (the matrix is not a P-matrix?)"}


def lcp(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, int]:
    """The compiled :func:`solve_lcp` on all rows, from Python: (z, status), status the
    number of pivots (≥ 0) or LCP_SINGULAR / LCP_NO_CONVERGENCE (messages: LCP_FAILURES)."""
    b = np.ascontiguousarray(b, dtype=np.float64)
    k = b.size
    z, w = np.zeros(k), np.zeros(k)
    status = solve_lcp(np.ascontiguousarray(A, dtype=np.float64).reshape(k, k), b, np.ones(k, np.bool_), z, w,
                       lcp_work(k))
    return z, int(status)


def enumerate_lcp(A: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """A solution of LCP(A, b) by trying every complementary basis (smallest first), or
    None when there is none: exact, for the few unknowns of an impact (the caller bounds their number)."""
    m = b.size
    scale = max(float(np.abs(b).max()), 1e-300)
    for size in range(m + 1):
        for basis in itertools.combinations(range(m), size):
            z = np.zeros(m)
            if basis:
                idx = list(basis)
                try:
                    z[idx] = np.linalg.solve(A[np.ix_(idx, idx)], -b[idx])
                except np.linalg.LinAlgError:
                    continue
            w = A @ z + b
            if z.min() >= -1e-12 * max(1.0, float(np.abs(z).max())) and w.min() >= -1e-12 * scale:
                return np.maximum(z, 0.0)
    return None
