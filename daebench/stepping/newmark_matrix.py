"""The scaled iteration matrix of the Newmark-family step (:mod:`daebench.stepping.newmark`,
whose docstring gives J and why it stays well conditioned as h → 0).

Through a model's declared structure (:class:`daebench.core.linalg.Sparsity`) J is
factorized bordered-banded. When the phase has no continuous contact law, only the
entries that structure holds are assembled (:func:`structure`: the band in the declared
order plus the border's rows and columns, O(n·(b + k)) instead of O(n²)); the contact
constraints are the one coupling the model cannot declare, and they fit when every pair
of DOFs in one constraint row's support is within the band or on the border
(:func:`_rows_fit`, O(m·n)); a constraint coupling DOFs far apart in the order, or a
continuous contact law, takes the dense assembly, where :func:`bordered_fits` checks J
itself before the structured factorization. A declared constant mass matrix skips
∂(M a)/∂q (zero). Every entry is the same expression in either assembly: the factors,
and the trajectories, are bitwise the same.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from daebench.core import phase
from daebench.core.borrow import uncounted
from daebench.core.linalg import Sparsity, bordered_factor, bordered_fits, bordered_work, lu_factor
from daebench.stepping.methods import C_JAC, C_LU

# ws.st: LU valid, h of the LU, previous step known, its h, the factors are bordered-banded (ws.bw)
ST_LU, ST_LUH, ST_PREV, ST_HOLD, ST_BAND = range(5)


@njit(cache=True, inline="always")
def weights(meth):
    """(w₁, w_m, w_f) = ((1−α_m), α_m, α_f) / (1−α_f)."""
    d = 1.0 - meth.alpha_f
    return (1.0 - meth.alpha_m) / d, meth.alpha_m / d, meth.alpha_f / d


@njit(cache=True, inline="always")
def uses_hM(meth):
    return meth.alpha_m != 0.0 or meth.accel_avg


@njit(cache=True, inline="always")
def mass_row(mb, i, n):
    """Columns j0 … j1 − 1 of row i of M that may be nonzero (all for mb < 0). Skipping
    exact zeros leaves every sum bitwise unchanged."""
    if mb < 0:
        return 0, n
    return max(0, i - mb), min(n, i + mb + 1)


@uncounted
def band_mass(M, mb, Mb):
    """Copy the band of a declared banded M (half-bandwidth mb ≥ 0) into band storage
    Mb[i, j − i + mb]; nothing for a dense M (mb < 0)."""
    n = M.shape[0]
    if mb < 0:
        return
    for i in range(n):
        j0, j1 = mass_row(mb, i, n)
        for j in range(j0, j1):
            Mb[i, j - i + mb] = M[i, j]


@njit(cache=True, inline="always")
def mass_rows(ws):
    """(rows, compact) for the residual's products with M: a declared constant banded M
    from its band storage (row i, column j at [i, j − i + mb]: one contiguous row instead
    of one cache line per row of an n × n array), else M itself."""
    compact = ws.sp[2] != 0 and ws.sp[1] >= 0
    return (ws.Mb if compact else ws.M), compact


_STRUCTURES: dict[tuple, tuple] = {}   # (id of the sparsity, n, nx) → (sparsity, order, sp, ij, pos)


def structure(sparsity: Sparsity | None, n: int, nx: int) -> tuple:
    """(bw, sp, ij, pos) of a workspace: the bordered-banded work (the constraint rows join
    the border), sp = [declared, mass half-bandwidth (−1 dense), constant mass], ij the
    (row, column) pairs of the n × n block inside the structure (2 × P), and pos the place
    of each DOF in the declared order. The index tables (read only) are computed once per
    model and phase size — a large model's take a sort of its whole band, every phase
    start otherwise; bw, the factors, is new each time."""
    if sparsity is not None:
        key = (id(sparsity), n, nx)
        hit = _STRUCTURES.get(key)
        if hit is None or hit[0] is not sparsity:
            if len(_STRUCTURES) > 64:
                _STRUCTURES.clear()
            hit = _STRUCTURES[key] = (sparsity, *_structure(sparsity, n, nx))
        _, order, sp, ij, pos = hit
        return bordered_work(order, int(sparsity.n_banded), int(sparsity.kl), int(sparsity.ku)), sp, ij, pos
    z = np.zeros(0, np.int64)
    return bordered_work(z, 0, 0, 0), np.array([0, -1, 0], np.int64), np.zeros((2, 0), np.int64), z


def _structure(sparsity: Sparsity, n: int, nx: int) -> tuple:
    """(order, sp, ij, pos) of :func:`structure`."""
    nb, kl, ku = int(sparsity.n_banded), int(sparsity.kl), int(sparsity.ku)
    order = np.concatenate([np.asarray(sparsity.order, np.int64), np.arange(n, nx, dtype=np.int64)])
    sp = np.array([1, int(sparsity.mass_band), int(bool(sparsity.constant_mass))], np.int64)
    jj, d = np.meshgrid(np.arange(nb), np.arange(-ku, kl + 1), indexing="ij")   # band: row pos jj + d
    ii = jj + d
    keep = (ii >= 0) & (ii < nb)
    rows, cols = [order[ii[keep]]], [order[jj[keep]]]
    full = np.arange(n, dtype=np.int64)
    for c in order[nb:]:
        if c < n:                                   # a model DOF on the border: its row and column
            rows += [full, np.full(n, c)]
            cols += [np.full(n, c), full]
    key = np.unique(np.concatenate(rows) * n + np.concatenate(cols))   # each entry once, row by row
    ij = np.vstack([key // n, key % n])
    pos = np.empty(n, np.int64)
    pos[order[order < n]] = np.arange(n)
    return order, sp, np.ascontiguousarray(ij, dtype=np.int64), pos


@uncounted
def _rows_fit(ws, n, m):
    """Whether ∂(C_qᵀλ)/∂q keeps to the declared structure: every pair of DOFs in the
    support of one constraint row of ws.Cq is within the band or on the border."""
    nb, kl, ku = ws.bw.AB.shape[1], ws.bw.kl, ws.bw.ku
    for k in range(m):
        for i in range(n):
            if ws.Cq[k, i] == 0.0 or ws.pos[i] >= nb:
                continue
            for j in range(n):
                if ws.Cq[k, j] != 0.0 and ws.pos[j] < nb:
                    d = ws.pos[i] - ws.pos[j]
                    if d > kl or -d > ku:
                        return False
    return True


@njit(cache=True, inline="always")
def _entry(ws, i, j, w1, bh2, gah, km):
    """J[i, j] of the n × n block before the history and constraint terms."""
    kmij = ws.KM[i, j] if km else 0.0
    return w1 * ws.M[i, j] + bh2 * (w1 * kmij - ws.Kq[i, j]) - gah * ws.Kv[i, j]


@uncounted(no_cpython_wrapper=True)
def factor(meth, ws, ph, n, m, nx, t1, h, q, v, a, lt, bh2, cnt):
    """Build and factorize the scaled iteration matrix J; returns a status."""
    M, Kq, Kv, KM, KC, Cq = ws.M, ws.Kq, ws.Kv, ws.KM, ws.KC, ws.Cq
    J = ws.LU
    w1, wm, wf = weights(meth)
    phase.force_jacobian(ph, t1, q, v, Kq, Kv)
    cnt[C_JAC] += 1
    km = ws.sp[2] == 0          # ∂(M a)/∂q: zero for a declared constant M
    if km:
        phase.mass_jacobian_product(ph, q, a, KM)
    gah = meth.gamma * h
    # only the declared structure's entries (module docstring), or all of them
    part = ws.sp[0] != 0 and not phase.has_law(ph) and _rows_fit(ws, n, m)
    ij = ws.ij
    P = ij.shape[1]
    if part:
        for p in range(P):
            J[ij[0, p], ij[1, p]] = _entry(ws, ij[0, p], ij[1, p], w1, bh2, gah, km)
    else:
        for i in range(n):
            for j in range(n):
                J[i, j] = _entry(ws, i, j, w1, bh2, gah, km)
    for i in range(nx):
        for j in range(n, nx):
            J[i, j] = 0.0
    for i in range(n, nx):
        for j in range(n):
            J[i, j] = 0.0
    if uses_hM(meth) and km:
        phase.mass_jacobian_product(ph, q, ws.hM, KM)
        if part:
            for p in range(P):
                J[ij[0, p], ij[1, p]] += bh2 * KM[ij[0, p], ij[1, p]]
        else:
            for i in range(n):
                for j in range(n):
                    J[i, j] += bh2 * KM[i, j]
    if m:
        lam = ws.lam_s
        for k in range(m):
            lam[k] = lt[k] / bh2
        phase.constraint_force_jacobian(ph, t1, q, lam, KC)
        if part:
            for p in range(P):
                J[ij[0, p], ij[1, p]] = J[ij[0, p], ij[1, p]] + bh2 * KC[ij[0, p], ij[1, p]]
        else:
            for i in range(n):
                for j in range(n):
                    J[i, j] = J[i, j] + bh2 * KC[i, j]
        for k in range(m):
            for i in range(n):
                J[i, n + k] = Cq[k, i]
                J[n + k, i] = Cq[k, i]
        if meth.ggl:
            for i in range(n):
                for k in range(m):
                    s = 0.0
                    for j in range(n):
                        s += (w1 * M[i, j] - gah * Kv[i, j]) * Cq[k, j]
                    J[i, n + m + k] = -s
            FDv = ws.FDv[:m]
            phase.velocity_constraint_jacobian(ph, t1, q, v, FDv)
            c = meth.beta * h / meth.gamma
            for k in range(m):
                for j in range(n):
                    J[n + m + k, j] = Cq[k, j] + c * FDv[k, j]
                for l in range(m):
                    s = 0.0
                    for j in range(n):
                        s += Cq[k, j] * Cq[l, j]
                    J[n + m + k, n + m + l] = -s
    finite = True
    if part:
        for p in range(P):
            finite = finite and math.isfinite(J[ij[0, p], ij[1, p]])
        for i in range(nx):
            for j in range(n, nx):
                finite = finite and math.isfinite(J[i, j]) and math.isfinite(J[j, i])
    else:
        for i in range(nx):
            for j in range(nx):
                finite = finite and math.isfinite(J[i, j])
    if not finite:
        ws.st[ST_LU] = 0.0
        return 4
    # through the model's declared structure when J keeps to it (a contact coupling nodes
    # far apart in the numbering does not: dense LU for that matrix)
    if part or (ws.sp[0] != 0 and bordered_fits(J, ws.bw)):
        ws.st[ST_BAND] = 1.0
        info = bordered_factor(J, ws.bw)
    else:
        ws.st[ST_BAND] = 0.0
        info = lu_factor(J, ws.piv)
    if info > 0:
        ws.st[ST_LU] = 0.0
        return 5
    ws.st[ST_LU] = 1.0
    ws.st[ST_LUH] = h
    cnt[C_LU] += 1
    return 0
