"""The scaled iteration matrix of the Newmark-family step (:mod:`daebench.stepping.newmark`,
whose docstring gives J and why it stays well conditioned as h → 0)."""

from __future__ import annotations

import math

from numba import njit

from daebench.core import phase
from daebench.core.linalg import bordered_factor, bordered_fits, lu_factor
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


@njit(cache=True, no_cpython_wrapper=True)
def factor(meth, ws, ph, n, m, nx, t1, h, q, v, a, lt, bh2, cnt):
    """Build and factorize the scaled iteration matrix J; returns a status."""
    M, Kq, Kv, KM, KC, Cq = ws.M, ws.Kq, ws.Kv, ws.KM, ws.KC, ws.Cq
    J = ws.LU
    w1, wm, wf = weights(meth)
    phase.force_jacobian(ph, t1, q, v, Kq, Kv)
    cnt[C_JAC] += 1
    phase.mass_jacobian_product(ph, q, a, KM)
    gah = meth.gamma * h
    for i in range(n):
        for j in range(n):
            J[i, j] = w1 * M[i, j] + bh2 * (w1 * KM[i, j] - Kq[i, j]) - gah * Kv[i, j]
    for i in range(nx):
        for j in range(n, nx):
            J[i, j] = 0.0
    for i in range(n, nx):
        for j in range(n):
            J[i, j] = 0.0
    if uses_hM(meth):
        phase.mass_jacobian_product(ph, q, ws.hM, KM)
        for i in range(n):
            for j in range(n):
                J[i, j] += bh2 * KM[i, j]
    if m:
        lam = ws.lam_s
        for k in range(m):
            lam[k] = lt[k] / bh2
        phase.constraint_force_jacobian(ph, t1, q, lam, KC)
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
    for i in range(nx):
        for j in range(nx):
            if not math.isfinite(J[i, j]):
                ws.st[ST_LU] = 0.0
                return 4
    # through the model's declared structure when J keeps to it (a contact coupling nodes
    # far apart in the numbering does not: dense LU for that matrix)
    if ws.sp[0] != 0 and bordered_fits(J, ws.bw):
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
