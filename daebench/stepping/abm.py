"""Baumgarte-stabilized acceleration form + Adams–Bashforth–Moulton 4 (PECE), as a
compiled stepper (:mod:`daebench.stepping.methods`).

Each right-hand side solves [[M, C_qᵀ], [C_q, 0]] [q̈; λ] = [Q; γ − 2δ(C_q v + C_t) − ε²C]
(:func:`daebench.core.phase.solve_augmented`) and y = (q, v) advances with ẏ = (v, q̈): AB4
predictor, evaluate, AM4 corrector, evaluate — two right-hand sides per step. After a
(re)start the history f_{n−3..n} is built by ``N_START`` classical RK4 steps; a step
shorter than the method's h (landing on t_stop) is an RK4 step of that size, after which
the history is rebuilt. Method analysis and references:
:class:`daebench.integrators.baumgarte.BaumgarteABM4`.

Workspace: ``hist`` [4, 2n] the f history, oldest first, f_n in row ``hn[0] − 1``;
``hn[0]`` the valid rows (≤ N_START: the next step is an RK4 step); ``flags[0]`` set when
the proposed step was short (the history restarts at its acceptance); ``blowup[0]`` the
|y| beyond which the state counts as exploded (set at start).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import phase
from daebench.stepping import control, methods
from daebench.stepping.methods import C_LU, C_RES

N_START = 3            # RK4 steps that build the history after every (re)start
BLOWUP = 1e10          # |y| above BLOWUP·max(1, |y_start|) is divergence
AB0, AB1, AB2, AB3 = 55.0 / 24.0, -59.0 / 24.0, 37.0 / 24.0, -9.0 / 24.0   # on f_n … f_{n−3}
AM0, AM1, AM2, AM3 = 9.0 / 24.0, 19.0 / 24.0, -5.0 / 24.0, 1.0 / 24.0      # on f_{n+1}^P, f_n … f_{n−2}

ST_NOT_FINITE, ST_EXPLODED, ST_SINGULAR = 1, 2, 3
FAIL_MESSAGES = {
    ST_NOT_FINITE: "diverged: state not finite (explicit ABM4 needs h·ω_max < 1)",
    ST_EXPLODED: "diverged: state exploded (explicit ABM4 needs h·ω_max < 1)",
    ST_SINGULAR: "singular augmented mass matrix",
}


class AbmMethod(NamedTuple):
    delta: float   # Baumgarte δ in C̈ + 2δĊ + ε²C = 0 [1/s]
    eps: float     # Baumgarte ε [rad/s]
    h: float       # the fixed step of the history


class AbmWork(NamedTuple):
    hist: np.ndarray
    hn: np.ndarray
    flags: np.ndarray
    blowup: np.ndarray
    aug: phase.AugmentedWork
    y: np.ndarray
    yp: np.ndarray
    yt: np.ndarray
    f1: np.ndarray
    fp: np.ndarray
    k2: np.ndarray
    k3: np.ndarray
    k4: np.ndarray
    lam_s: np.ndarray


def workspace(n: int, m: int) -> AbmWork:
    e = np.empty
    return AbmWork(np.zeros((4, 2 * n)), np.zeros(1, np.int64), np.zeros(1, np.int64), np.zeros(1),
                   phase.augmented_work(n, m), e(2 * n), e(2 * n), e(2 * n), e(2 * n), e(2 * n), e(2 * n),
                   e(2 * n), e(2 * n), e(m))


@njit(cache=True)
def rhs(meth, ws, ph, t, y, f, lam, cnt):
    """ẏ = (v, q̈) into f and λ into lam at (t, y); returns 0 or ST_SINGULAR."""
    n = y.shape[0] // 2
    cnt[C_RES] += 1
    cnt[C_LU] += 1
    if phase.solve_augmented(ph, t, y[:n], y[n:], meth.delta, meth.eps, ws.aug, f[n:], lam):
        return ST_SINGULAR
    for i in range(n):
        f[i] = y[n + i]
    return 0


@njit(cache=True)
def check(y, blowup):
    ymax = 0.0
    for i in range(y.shape[0]):
        if not math.isfinite(y[i]):
            return ST_NOT_FINITE
        ymax = max(ymax, abs(y[i]))
    return ST_EXPLODED if ymax > blowup else 0


@njit(cache=True)
def _rk4(meth, ws, ph, t, y, h, f0, y1, cnt):
    """Classical RK4 from (t, y) with k1 = f0 into y1; returns a status."""
    k2, k3, k4, yt, lam = ws.k2, ws.k3, ws.k4, ws.yt, ws.lam_s
    nn = y.shape[0]
    hh = 0.5 * h
    for i in range(nn):
        yt[i] = y[i] + hh * f0[i]
    if rhs(meth, ws, ph, t + 0.5 * h, yt, k2, lam, cnt):
        return ST_SINGULAR
    for i in range(nn):
        yt[i] = y[i] + hh * k2[i]
    if rhs(meth, ws, ph, t + 0.5 * h, yt, k3, lam, cnt):
        return ST_SINGULAR
    for i in range(nn):
        yt[i] = y[i] + h * k3[i]
    if rhs(meth, ws, ph, t + h, yt, k4, lam, cnt):
        return ST_SINGULAR
    h6 = h / 6.0
    for i in range(nn):
        y1[i] = y[i] + h6 * (((f0[i] + 2.0 * k2[i]) + 2.0 * k3[i]) + k4[i])
    return 0


@njit(cache=True)
def _start(meth, ws, ph, t, cur, cnt):
    n = cur.q.shape[0]
    y = ws.y
    y[:n] = cur.q
    y[n:] = cur.v
    qmax = 0.0
    vmax = 0.0
    for i in range(n):
        qmax = max(qmax, abs(cur.q[i]))
        vmax = max(vmax, abs(cur.v[i]))
    ws.blowup[0] = BLOWUP * max(1.0, qmax, vmax)
    ws.hn[0] = 1
    return rhs(meth, ws, ph, t, y, ws.hist[0], ws.lam_s, cnt)


@njit(cache=True)
def _step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    n = cur.q.shape[0]
    y, yp, f1, fp, hist = ws.y, ws.yp, ws.f1, ws.fp, ws.hist
    nn = 2 * n
    y[:n] = cur.q
    y[n:] = cur.v
    last = ws.hn[0] - 1
    ws.flags[0] = 0
    t1 = t + h
    if h < meth.h * (1.0 - control.SNAP):
        # a short final step: RK4 of that size, then the history restarts
        st = _rk4(meth, ws, ph, t, y, h, hist[last], yp, cnt)
        ws.flags[0] = 1
    elif ws.hn[0] <= N_START:
        st = _rk4(meth, ws, ph, t, y, h, hist[last], yp, cnt)
    else:
        fn, fn1, fn2, fn3 = hist[3], hist[2], hist[1], hist[0]
        for i in range(nn):
            yp[i] = y[i] + h * (((AB0 * fn[i] + AB1 * fn1[i]) + AB2 * fn2[i]) + AB3 * fn3[i])
        st = check(yp, ws.blowup[0])
        if st:
            return st, 0.0
        if rhs(meth, ws, ph, t1, yp, fp, ws.lam_s, cnt):
            return ST_SINGULAR, 0.0
        for i in range(nn):
            yp[i] = y[i] + h * (((AM0 * fp[i] + AM1 * fn[i]) + AM2 * fn1[i]) + AM3 * fn2[i])
        st = 0
    if st:
        return st, 0.0
    st = check(yp, ws.blowup[0])
    if st:
        return st, 0.0
    if rhs(meth, ws, ph, t1, yp, f1, new.lam, cnt):
        return ST_SINGULAR, 0.0
    for i in range(n):
        new.q[i] = yp[i]
        new.v[i] = yp[n + i]
        new.a[i] = f1[n + i]
    return 0, 0.0


@njit(cache=True)
def _accept(meth, ws, h, prev, cur):
    hist, f1 = ws.hist, ws.f1
    nn = f1.shape[0]
    if ws.flags[0]:
        hist[0, :] = f1
        ws.hn[0] = 1
        return
    if ws.hn[0] < 4:
        row = ws.hn[0]
        ws.hn[0] += 1
    else:
        # drop f_{n−3}: shift the rows (4 × 2n copies, cheaper than indexing a ring everywhere)
        for r in range(3):
            for i in range(nn):
                hist[r, i] = hist[r + 1, i]
        row = 3
    for i in range(nn):
        hist[row, i] = f1[i]


methods.start.register(AbmMethod, _start)
methods.step.register(AbmMethod, _step)
methods.accept.register(AbmMethod, _accept)
