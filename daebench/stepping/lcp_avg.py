"""Dormand–Prince 5(4) with the time-averaged-gap contact LCP inside every right-hand
side, as a compiled stepper (:mod:`daebench.stepping.methods`). The method, its closed
form for one contact and its references: :class:`daebench.integrators.lcp_avg.LcpAvg`.

Right-hand side at (t, q, v), for contact window h = ``meth.h_avg``:
M(q) a_free = Q(t, q, v); per contact i: g_i, row G_i = ∂g_i/∂q, γ_i (g̈ = G q̈ − γ);

    b_i = g_i + (h/2) G_i v + (h²/6)(G_i a_free − γ_i),   A = (h²/6) G M⁻¹ Gᵀ,
    0 ≤ f ⟂ A f + b ≥ 0,   q̈ = a_free + M⁻¹ Gᵀ f,

solved by Murty's principal pivoting (:func:`daebench.core.lcp.solve_lcp`); when every
b_i ≥ 0 the answer f = 0 is immediate (no M⁻¹Gᵀ needed).

Bookkeeping (in ``accept``, on the accepted step's stage samples, in time order — the
stage times c = 0, 1/5, 3/10, 4/5, 8/9, 1 are increasing): a contact *episode* runs while
the contact force is positive; its start and end are interpolated where b_i changes sign
between samples, its impulse ∫f dt and work ∫f ġ dt are the step's own quadrature
h Σ b_s f_s (the 5th-order weights, so the impulse is exactly what changed the momentum
when M is constant). A finished episode is a row of ``log``: contact, start, ġ⁻, ġ⁺,
energy lost (−work), impulse, end, smallest gap. ``cw`` holds the cumulative contact work
before and after the last accepted step and the contact power Σ f_i ġ_i at its start.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels, phase
from daebench.core.lcp import LCP_MAX_PIVOTS, LcpWork, lcp_work, solve_lcp
from daebench.core.linalg import lu_factor, lu_solve
from daebench.stepping import control, methods
from daebench.stepping.methods import C_LU, C_RES

LOG_COLUMNS = 8         # contact, t_start, ġ⁻, ġ⁺, energy lost, impulse, t_end, min gap
ST_NOT_FINITE, ST_SINGULAR, ST_LCP = 1, 2, 3
FAIL_MESSAGES = {
    ST_NOT_FINITE: "diverged: state not finite",
    ST_SINGULAR: "singular mass matrix",
    ST_LCP: "contact LCP has no solution after {lcp_pivots} pivots (dependent contact Jacobians?)",
}

# Dormand & Prince (1980) 5(4), FSAL: stage nodes, coefficients, 5th-order weights (= the
# last row of A) and the error weights b − b̂.
DP_C = np.array([0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0])
DP_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0, 0.0],
    [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0, 0.0],
    [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0],
])
DP_B = np.array([35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0, 0.0])
DP_E = np.array([71.0 / 57600.0, 0.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0,
                 -1.0 / 40.0])


class LcpAvgMethod(NamedTuple):
    h_avg: float      # averaging window of the gap [s]


class LcpAvgWork(NamedTuple):
    k: np.ndarray       # [7, 2n] stage derivatives (row 0 valid from start/accept: FSAL)
    y0: np.ndarray
    ys: np.ndarray
    err: np.ndarray
    M: np.ndarray       # LU of M
    piv: np.ndarray
    Q: np.ndarray
    af: np.ndarray
    G: np.ndarray       # [nc, n] gap Jacobian rows
    W: np.ndarray       # [nc, n] rows (M⁻¹ G_iᵀ)ᵀ
    A: np.ndarray
    b: np.ndarray
    f: np.ndarray
    w: np.ndarray
    use: np.ndarray     # bool[nc]: every row of the LCP
    lw: LcpWork         # scratch of the LCP solver
    sf: np.ndarray      # [7, nc] per stage: force, gap, gap rate, b
    sg: np.ndarray
    sgd: np.ndarray
    sb: np.ndarray
    tstep: np.ndarray   # [1] start time of the proposed step
    fresh: np.ndarray   # [1] 1: stage 0 is a new sample (after start) to book
    ep: np.ndarray      # [nc, 6] open, t_start, ġ⁻, impulse, work, min gap
    log: np.ndarray     # [cap, LOG_COLUMNS] finished episodes
    nlog: np.ndarray    # [1]
    cw: np.ndarray      # [3] cumulative contact work before / after the last accepted step, power before


def workspace(n: int, nc: int, log_capacity: int) -> LcpAvgWork:
    e = np.empty
    k = max(nc, 1)
    return LcpAvgWork(np.zeros((7, 2 * n)), e(2 * n), e(2 * n), e(2 * n), e((n, n)), np.zeros(n, np.int64), e(n),
                      e(n), np.zeros((k, n)), np.zeros((k, n)), e((k, k)), e(k), np.zeros(k), e(k), np.ones(k, np.bool_),
                      lcp_work(k), np.zeros((7, k)),
                      np.zeros((7, k)), np.zeros((7, k)), np.zeros((7, k)), np.zeros(1), np.zeros(1, np.int64),
                      np.zeros((k, 6)), np.zeros((max(log_capacity, 1), LOG_COLUMNS)), np.zeros(1, np.int64),
                      np.zeros(3))


@njit(cache=True)
def rhs(meth, ws, ph, t, y, fy, s, cnt):
    """ẏ = (v, q̈) at (t, y) into fy with the contact forces of the averaged-gap LCP; the
    stage's per-contact force, gap, gap rate and b into row s of ws.sf/sg/sgd/sb.
    Returns 0 or a failure status."""
    n = y.shape[0] // 2
    nc = ph.engaged.shape[0]
    q = y[:n]
    v = y[n:]
    cnt[C_RES] += 1
    cnt[C_LU] += 1
    M, Q, af = ws.M, ws.Q, ws.af
    phase.mass_force(ph, t, q, v, M, Q)
    if lu_factor(M, ws.piv) != 0:
        return ST_SINGULAR
    for i in range(n):
        af[i] = Q[i]
    lu_solve(M, ws.piv, af)
    h = meth.h_avg
    c2 = h * h / 6.0
    any_neg = False
    for i in range(nc):
        gi = ws.G[i]
        g, gam = kernels.gap(ph.model, i, q, v, gi)
        gd = 0.0
        ga = 0.0
        for j in range(n):
            gd += gi[j] * v[j]
            ga += gi[j] * af[j]
        ws.b[i] = g + 0.5 * h * gd + c2 * (ga - gam)
        ws.sg[s, i] = g
        ws.sgd[s, i] = gd
        ws.sb[s, i] = ws.b[i]
        ws.f[i] = 0.0
        if ws.b[i] < 0.0:
            any_neg = True
    for j in range(n):
        fy[j] = v[j]
        fy[n + j] = af[j]
    if any_neg:
        for i in range(nc):
            wi = ws.W[i]
            for j in range(n):
                wi[j] = ws.G[i, j]
            lu_solve(M, ws.piv, wi)
        for i in range(nc):
            for k in range(nc):
                acc = 0.0
                for j in range(n):
                    acc += ws.G[i, j] * ws.W[k, j]
                ws.A[i, k] = c2 * acc
        A, b = ws.A[:nc, :nc], ws.b[:nc]
        if solve_lcp(A, b, ws.use, ws.f[:nc], ws.w[:nc], ws.lw) < 0:
            return ST_LCP
        for i in range(nc):
            fi = ws.f[i]
            if fi != 0.0:
                for j in range(n):
                    fy[n + j] += ws.W[i, j] * fi
    for i in range(nc):
        ws.sf[s, i] = ws.f[i]
    return 0


@njit(cache=True)
def _start(meth, ws, ph, t, cur, cnt):
    n = cur.q.shape[0]
    ws.y0[:n] = cur.q
    ws.y0[n:] = cur.v
    ws.fresh[0] = 1
    return rhs(meth, ws, ph, t, ws.y0, ws.k[0], 0, cnt)


@njit(cache=True)
def _step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    n = cur.q.shape[0]
    nn = 2 * n
    y0, ys, k = ws.y0, ws.ys, ws.k
    ws.tstep[0] = t
    for i in range(n):
        y0[i] = cur.q[i]
        y0[n + i] = cur.v[i]
    for s in range(1, 7):
        for i in range(nn):
            acc = 0.0
            for j in range(s):
                acc += DP_A[s, j] * k[j, i]
            ys[i] = y0[i] + h * acc
        st = rhs(meth, ws, ph, t + DP_C[s] * h, ys, k[s], s, cnt)
        if st:
            return st, 0.0
    for i in range(nn):  # ys is now the 5th-order solution (stage 7 is evaluated at it: FSAL)
        if not math.isfinite(ys[i]):
            return ST_NOT_FINITE, 0.0
        acc = 0.0
        for j in range(7):
            acc += DP_E[j] * k[j, i]
        ws.err[i] = h * acc
    for i in range(n):
        new.q[i] = ys[i]
        new.v[i] = ys[n + i]
        new.a[i] = k[6, n + i]
    # the error estimate only under error control: at fixed steps rtol = atol = 0 (a division by zero)
    return 0, control.weighted_rms(ws.err, ys, y0, ctl.rtol, ctl.atol) if ctl.adaptive else 0.0


@njit(cache=True)
def _cross(b0, b1):
    """Fraction of the way from a sample with b0 to one with b1 where b changes sign."""
    d = b0 - b1
    return 0.5 if d == 0.0 else min(1.0, max(0.0, b0 / d))


@njit(cache=True)
def _book(ws, h):
    """Episode bookkeeping of the accepted step (see the module docstring)."""
    nc = ws.ep.shape[0]
    t0 = ws.tstep[0]
    first = 0 if ws.fresh[0] else 1  # sample 0 is the previous step's last one, booked then
    for i in range(nc):
        imp = 0.0
        work = 0.0
        for s in range(7):
            imp += DP_B[s] * ws.sf[s, i]
            work += DP_B[s] * ws.sf[s, i] * ws.sgd[s, i]
        imp *= h
        work *= h
        ep = ws.ep[i]
        for s in range(first, 7):
            sp = s - 1 if s > 0 else 0
            ts = t0 + DP_C[s] * h
            tp = t0 + DP_C[sp] * h
            x = _cross(ws.sb[sp, i], ws.sb[s, i]) if s > 0 else 0.0
            on = ws.sf[s, i] > 0.0
            if on and ep[0] == 0.0:
                ep[0] = 1.0
                ep[1] = tp + x * (ts - tp)
                ep[2] = ws.sgd[sp, i] + x * (ws.sgd[s, i] - ws.sgd[sp, i])
                ep[3] = 0.0
                ep[4] = 0.0
                ep[5] = ws.sg[s, i]
            elif ep[0] != 0.0:
                ep[5] = min(ep[5], ws.sg[s, i])
                if not on:
                    row = ws.nlog[0]
                    if row < ws.log.shape[0]:
                        ws.log[row, 0] = i
                        ws.log[row, 1] = ep[1]
                        ws.log[row, 2] = ep[2]
                        ws.log[row, 3] = ws.sgd[sp, i] + x * (ws.sgd[s, i] - ws.sgd[sp, i])
                        ws.log[row, 4] = -(ep[4] + work)
                        ws.log[row, 5] = ep[3] + imp
                        ws.log[row, 6] = tp + x * (ts - tp)
                        ws.log[row, 7] = ep[5]
                    ws.nlog[0] = row + 1
                    ep[0] = 0.0
                    imp = 0.0
                    work = 0.0
        if ep[0] != 0.0:
            ep[3] += imp
            ep[4] += work
    total = 0.0
    p0 = 0.0
    for i in range(nc):
        p0 += ws.sf[0, i] * ws.sgd[0, i]
        for s in range(7):
            total += DP_B[s] * ws.sf[s, i] * ws.sgd[s, i]
    ws.cw[0] = ws.cw[1]
    ws.cw[1] += h * total
    ws.cw[2] = p0


@njit(cache=True)
def _accept(meth, ws, h, prev, cur):
    _book(ws, h)
    ws.fresh[0] = 0
    k = ws.k
    for i in range(k.shape[1]):
        k[0, i] = k[6, i]
    for i in range(ws.sf.shape[1]):  # stage 0 of the next step is this one's last sample
        ws.sf[0, i] = ws.sf[6, i]
        ws.sg[0, i] = ws.sg[6, i]
        ws.sgd[0, i] = ws.sgd[6, i]
        ws.sb[0, i] = ws.sb[6, i]


methods.start.register(LcpAvgMethod, _start)
methods.step.register(LcpAvgMethod, _step)
methods.accept.register(LcpAvgMethod, _accept)
