"""Compiled (numba) core of :class:`daebench.integrators.baumgarte.BaumgarteABM4`: the
Baumgarte right-hand side, one ABM4-PECE / RK4 step, and a fixed-step *phase runner*.

Same algorithm as ``BaumgarteABM4._rhs`` / ``_step_impl`` / ``_rk4`` / ``_check``,
operation for operation where it matters (the element-wise updates are evaluated in
the same order as the numpy expressions, so they are bit-identical); differences are
round-off only: the augmented system is solved by the partial-pivoting LU of
:mod:`daebench.integrators._compiled_newmark` (LAPACK's dgesv makes the same pivot
choices, its summation order differs) and C_q v is a loop.

State that the Python implementation keeps in attributes lives in arrays owned by the
integrator, so that single compiled steps and the phase runner interleave within a phase:

``hist`` float64[4, 2n]  the f history, oldest first, f_n in row ``hn[0] − 1``
``hn``   int64[1]        how many rows of ``hist`` are valid (1 after a restart; ≤ N_START
                         means the next step is an RK4 step)
``cnt``  int64[2]        [right-hand sides (= force evaluations), LU factorizations]

Status codes: 0 ok, ``ST_NOT_FINITE`` / ``ST_EXPLODED`` (the Python ``_check``: the
message starts with "diverged:"), ``ST_SINGULAR`` (singular augmented matrix); each
comes with the time the Python path would put in its message.

Phase runner (:func:`run_fixed`): the stopping rules and the bookkeeping of quiet steps
are those of :func:`daebench.integrators._compiled_newmark.run_fixed` (see
:class:`daebench.integrators.base.BatchWatch`). No allocation per step.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from daebench.integrators import _compiled_models as cm
from daebench.integrators import _compiled_watch as cw
from daebench.integrators._compiled_newmark import lu_factor, lu_solve

# the constants of the Python path (kept equal by tests/test_compiled_baumgarte.py)
SNAP = 1e-6
N_START = 3
AB0, AB1, AB2, AB3 = 55.0 / 24.0, -59.0 / 24.0, 37.0 / 24.0, -9.0 / 24.0
AM0, AM1, AM2, AM3 = 9.0 / 24.0, 19.0 / 24.0, -5.0 / 24.0, 1.0 / 24.0

ST_OK, ST_NOT_FINITE, ST_EXPLODED, ST_SINGULAR = range(4)
C_RES, C_LU = range(2)


@njit(cache=True)
def workspace(n, m):
    """Scratch arrays of the right-hand side and of one step (allocated once, by the caller)."""
    nm = n + m
    mm = max(m, 1)
    rhs_ws = (np.empty((n, n)), np.empty(n), np.empty((nm, nm)), np.zeros(nm, dtype=np.int64), np.empty(nm),
              np.empty(mm), np.empty((mm, n)), np.empty(mm), np.empty(mm))
    # M, Q, A, piv, b, C, Cq, Ct, gam
    n2 = 2 * n
    step_ws = (np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2), np.empty(n2), np.empty(m))
    # k2 (RK4) / f_p (ABM), k3, k4, RK4 stage argument, y_{n+1} (and y_p), f_{n+1}, λ scratch
    return rhs_ws, step_ws


@njit(cache=True)
def rhs(md, active, t, y, delta, eps, rws, f, lam, cnt):
    """ẏ = (v, q̈) into ``f`` and λ into ``lam`` at (t, y = (q, v)); returns 0 or ST_SINGULAR.

    [[M, C_qᵀ], [C_q, 0]] [q̈; λ] = [Q; γ − 2δ (C_q v + C_t) − ε² C]."""
    M, Q, A, piv, b, C, Cq, Ct, gam = rws
    n = M.shape[0]
    m = lam.shape[0]
    q = y[:n]
    v = y[n:]
    # the pendulum's kernels take its parameter array only (see cm.mass_force: passing the
    # descriptor to a kernel costs reference counts on its ~20 arrays)
    pend = md[0] == cm.KIND_PENDULUM
    if pend:
        cm.pendulum_mass_force(md[1], M, Q)
    else:
        cm.mass_force(md, t, q, v, M, Q)
    cnt[C_RES] += 1
    for i in range(n):
        f[i] = v[i]
    for i in range(n):
        for j in range(n):
            A[i, j] = M[i, j]
        b[i] = Q[i]
    if m:
        if pend:
            cm.pendulum_constraints(md[1], q, v, C, Cq, Ct, gam)
        else:
            cm.constraints(md, t, q, v, active, C, Cq, Ct, gam)
        d2 = 2.0 * delta
        e2 = eps ** 2
        for k in range(m):
            rc = gam[k]
            if delta:
                cv = 0.0
                for j in range(n):
                    cv += Cq[k, j] * v[j]
                rc = rc - d2 * (cv + Ct[k])
            if eps:
                rc = rc - e2 * C[k]
            b[n + k] = rc
            for j in range(n):
                A[j, n + k] = Cq[k, j]
                A[n + k, j] = Cq[k, j]
            for l in range(m):
                A[n + k, n + l] = 0.0
    info = lu_factor(A, piv)
    cnt[C_LU] += 1
    if info != 0:
        return ST_SINGULAR
    lu_solve(A, piv, b)
    for i in range(n):
        f[n + i] = b[i]
    for k in range(m):
        lam[k] = b[n + k]
    return ST_OK


@njit(cache=True)
def check(y, blowup):
    """The Python ``_check``: ST_NOT_FINITE, ST_EXPLODED or ST_OK."""
    ymax = 0.0
    for i in range(y.shape[0]):
        if not math.isfinite(y[i]):
            return ST_NOT_FINITE
        ymax = max(ymax, abs(y[i]))
    if ymax > blowup:
        return ST_EXPLODED
    return ST_OK


@njit(cache=True)
def _rk4(md, active, t, y, h, f0, delta, eps, rws, sws, lam_s, cnt, y1):
    """Classical RK4 from (t, y) with k1 = f0 into ``y1``; returns (status, t of failure)."""
    k2, k3, k4, yt = sws[0], sws[1], sws[2], sws[3]
    nn = y.shape[0]
    hh = 0.5 * h
    th = t + 0.5 * h
    for i in range(nn):
        yt[i] = y[i] + hh * f0[i]
    if rhs(md, active, th, yt, delta, eps, rws, k2, lam_s, cnt):
        return ST_SINGULAR, th
    for i in range(nn):
        yt[i] = y[i] + hh * k2[i]
    if rhs(md, active, th, yt, delta, eps, rws, k3, lam_s, cnt):
        return ST_SINGULAR, th
    for i in range(nn):
        yt[i] = y[i] + h * k3[i]
    if rhs(md, active, t + h, yt, delta, eps, rws, k4, lam_s, cnt):
        return ST_SINGULAR, t + h
    h6 = h / 6.0
    for i in range(nn):
        y1[i] = y[i] + h6 * (((f0[i] + 2.0 * k2[i]) + 2.0 * k3[i]) + k4[i])  # numpy's order
    return ST_OK, t


@njit(cache=True)
def step(md, active, t, t_stop, h_fix, y, lam, hist, hn, delta, eps, blowup, cnt, ws):
    """One step of ``BaumgarteABM4._step_impl`` from (t, y), not past ``t_stop``; on success
    y, λ and the history are advanced in place. Returns (status, t_new, t of failure)."""
    rws, sws = ws
    fp, yp, f1, lam_s = sws[0], sws[4], sws[5], sws[6]
    nn = y.shape[0]
    remaining = t_stop - t
    h = h_fix
    last = hn[0] - 1
    if h * (1.0 + SNAP) >= remaining and remaining < h * (1.0 - SNAP):
        # a short final step: RK4 of that size, then rebuild the history
        st, tf = _rk4(md, active, t, y, remaining, hist[last], delta, eps, rws, sws, lam_s, cnt, yp)
        if st:
            return st, t, tf
        st = check(yp, blowup)
        if st:
            return st, t, t_stop
        if rhs(md, active, t_stop, yp, delta, eps, rws, f1, lam, cnt):
            return ST_SINGULAR, t, t_stop
        for i in range(nn):
            y[i] = yp[i]
            hist[0, i] = f1[i]
        hn[0] = 1
        return ST_OK, t_stop, t_stop
    t1 = t_stop if h * (1.0 + SNAP) >= remaining else t + h
    h = t1 - t
    if hn[0] <= N_START:
        st, tf = _rk4(md, active, t, y, h, hist[last], delta, eps, rws, sws, lam_s, cnt, yp)
        if st:
            return st, t, tf
    else:
        fn, fn1, fn2, fn3 = hist[3], hist[2], hist[1], hist[0]
        for i in range(nn):
            yp[i] = y[i] + h * (((AB0 * fn[i] + AB1 * fn1[i]) + AB2 * fn2[i]) + AB3 * fn3[i])
        st = check(yp, blowup)
        if st:
            return st, t, t1
        if rhs(md, active, t1, yp, delta, eps, rws, fp, lam_s, cnt):
            return ST_SINGULAR, t, t1
        for i in range(nn):
            yp[i] = y[i] + h * (((AM0 * fp[i] + AM1 * fn[i]) + AM2 * fn1[i]) + AM3 * fn2[i])
    st = check(yp, blowup)
    if st:
        return st, t, t1
    if rhs(md, active, t1, yp, delta, eps, rws, f1, lam, cnt):
        return ST_SINGULAR, t, t1
    for i in range(nn):
        y[i] = yp[i]
    if hn[0] < 4:
        row = hn[0]
        hn[0] += 1
    else:
        # drop f_{n−3}: shift the rows (4 × 2n copies, cheaper than indexing a ring everywhere)
        for r in range(3):
            for i in range(nn):
                hist[r, i] = hist[r + 1, i]
        row = 3
    for i in range(nn):
        hist[row, i] = f1[i]
    return ST_OK, t1, t1


@njit(cache=True)
def restart(md, active, t, y, lam, hist, hn, delta, eps, cnt):
    """Forget the history: f at (t, y) is its only row (the Python ``_restart``)."""
    ws = workspace(y.shape[0] // 2, lam.shape[0])
    st = rhs(md, active, t, y, delta, eps, ws[0], hist[0], lam, cnt)
    hn[0] = 1
    return st


@njit(cache=True)
def step_once(md, active, t, t_stop, h_fix, y, lam, hist, hn, delta, eps, blowup, cnt):
    """:func:`step` with its own workspace (single steps called from Python)."""
    ws = workspace(y.shape[0] // 2, lam.shape[0])
    return step(md, active, t, t_stop, h_fix, y, lam, hist, hn, delta, eps, blowup, cnt, ws)


@njit(cache=True)
def run_fixed(md, active, inactive, lam_rows, armed, continuous, track, cmax,
              t, y, a, lam, h_fix, t_stop, t_out_next, t_end, max_steps,
              delta, eps, blowup, hist, hn, cnt, py, pa, plam):
    """Fixed-step phase runner (module docstring). (y, a, λ) hold the current state and
    are advanced in place (``a`` is carried, not read from the history: at a phase start
    the driver's state has the unstabilized q̈ of ``Problem.acceleration``, which the Python
    path hands on as the previous state's a); (py, pa, plam) receive the state before the
    last step. Returns (status, steps taken, t before the
    last step, t now, t of the failure)."""
    nn = y.shape[0]
    n = nn // 2
    m = lam.shape[0]
    ws = workspace(n, m)
    g = np.empty(max(armed.shape[0], 1))
    zeros = np.zeros(n)
    C, Ct, gam = np.empty(max(m, 1)), np.empty(max(m, 1)), np.empty(max(m, 1))
    Cq = np.empty((max(m, 1), n))
    nsteps = 0
    t_prev = t
    while True:
        for i in range(nn):
            py[i] = y[i]
        for i in range(n):
            pa[i] = a[i]
        for k in range(m):
            plam[k] = lam[k]
        status, t_new, t_fail = step(md, active, t, t_stop, h_fix, y, lam, hist, hn, delta, eps, blowup, cnt, ws)
        if status != ST_OK:
            return status, nsteps, t_prev, t, t_fail
        t_prev = t
        t = t_new
        nsteps += 1
        last = hn[0] - 1
        for i in range(n):
            a[i] = hist[last, n + i]
        q = y[:n]
        v = y[n:]
        # -- does the driver need to see this step? (else: the quiet step's bookkeeping)
        if nsteps >= max_steps or not cw.quiet(md, active, inactive, lam_rows, armed, continuous, track, cmax,
                                               t, q, v, a, lam, t_out_next, t_end, g, zeros, C, Cq, Ct, gam):
            break
    return ST_OK, nsteps, t_prev, t, t_fail
