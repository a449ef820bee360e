"""Compiled (numba) core of the Newmark family: the scaled Newton iteration of one step
and a *phase runner* that takes many steps in one call, at fixed step or with the
Zienkiewicz–Xie step-size control of the adaptive mode.

This is the same algorithm as :meth:`NewmarkFamily._newton` / ``_factor`` /
``_constraints_ok`` in :mod:`daebench.integrators._newmark_family` — the same
predictor, residual scaling, convergence test, modified-Newton refresh rules and
finite differences — line for line, with the model evaluated through the descriptor
of :mod:`daebench.integrators._compiled_models`. Differences are round-off only: the
LU factorization is our own partial-pivoting Doolittle (LAPACK's dgetrf makes the same
pivot choices, its summation order differs) and matrix–vector products are loops.

State that the Python implementation keeps in attributes lives here in arrays owned by
the integrator (so that single compiled steps and the phase runner interleave):

``st``  = [LU valid (0/1), h of the LU, previous step known (0/1), h of the previous step]
``cnt`` = [Newton iterations, LU factorizations, force evaluations, Jacobian evaluations]

Status codes (0 = converged) map to the messages of the Python path in ``FAIL_MESSAGES``.

Phase runner (:func:`run_phase`): steps (fixed h, or adaptive with the same rejections,
Newton-failure cuts and step-size factors as ``NewmarkFamily._step_impl``) until
something the event-driven driver must see happens — a gap of an open contact below its closing threshold (−0, or
−GAP_BAND while the contact is not re-armed; any negative gap with a continuous law),
a closed contact's λ < 0, an output time reached, t_end reached, non-finite state,
or ``max_steps`` (which keeps the driver's wall-time cap responsive). The step that
triggers the stop is handed back as (prev, new), and the driver processes it exactly
as a step returned by ``Integrator.step``; every earlier step of the batch is "quiet",
and for it the runner does the only bookkeeping the driver would have done: re-arming
gaps that left the band (gap > GAP_BAND) and the running maxima of |C|, |Ċ|, |C̈|.
No allocation per step: the workspace is allocated once per call.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from daebench.integrators import _compiled_models as cm
from daebench.integrators import _compiled_watch as cw

# the constants of the Python path (kept equal by tests/test_compiled.py)
NEWTON_RATE_REFRESH = 0.1
NEWTON_RATE_DIVERGE = 2.0
JAC_H_RATIO = 2.0
VEL_TOL_FACTOR = 10.0
ROUNDOFF = 50.0 * np.finfo(float).eps
SNAP = 1e-6
FD_REL_STEP = 1e-7
GAP_BAND = cw.GAP_BAND

SAFETY = 0.9
FAC_MIN, FAC_MAX = 0.2, 5.0
FAC_NEWTON_FAIL = 0.25
ZX_MIN_COEFF = 1.0 / 24.0

ST_LU, ST_LUH, ST_PREV, ST_HOLD = range(4)
# step-size control of run_phase: ctl = [adaptive (0/1), rtol, atol, h_min, h_next, rejected,
# Newton status of the last failure, local error of the last rejection]
CTL_ADAPTIVE, CTL_RTOL, CTL_ATOL, CTL_HMIN, CTL_HNEXT, CTL_REJECTED, CTL_NEWTON, CTL_ERR = range(8)
UNDERFLOW_NEWTON, UNDERFLOW_ERROR = 100, 101  # run_phase statuses beyond the Newton ones
C_NEWTON, C_LU, C_RES, C_JAC = range(4)

FAIL_MESSAGES = {
    1: "non-finite residual in Newton iteration",
    2: "non-finite Newton iterate",
    3: "Newton did not converge in {maxiter} iterations",
    4: "non-finite iteration matrix",
    5: "singular iteration matrix (dependent constraints?)",
}


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
def workspace(n, m, nx):
    """Scratch arrays of one step (allocated once per phase-runner call)."""
    v1 = (np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.zeros(n),
          np.empty(n), np.empty(n))
    # q_hat, v_hat, qa, aa, va, Q, zeros, tmp_n, qpert
    vm = (np.empty(max(m, 1)), np.empty(max(m, 1)), np.empty(max(m, 1)), np.empty(max(m, 1)),
          np.empty(max(m, 1)), np.empty(max(m, 1)))
    # C, Ct, gam, scratch, fp, fm
    vx = (np.empty(nx), np.empty(nx), np.empty(nx), np.empty(nx))
    # x0, x, r, dx
    mn = (np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)),
          np.empty((nx, nx)), np.empty((max(m, 1), n)), np.empty((max(m, 1), n)), np.empty((max(m, 1), n)))
    # M, Kq, Kv, KM, KC, J, Cq, Cq_pert, FD(Cq v)
    return v1, vm, vx, mn


@njit(cache=True)
def _unpack(n, m, ggl, x, Cq, q_hat, v_hat, bh2, gah, qa, aa, va):
    """q, a, v of the iterate x (GGL: a = (q − q̂ − C_qᵀμ)/βh²)."""
    for i in range(n):
        mu = 0.0
        if ggl:
            for k in range(m):
                mu += Cq[k, i] * x[n + m + k]
        qa[i] = x[i]
        aa[i] = (x[i] - q_hat[i] - mu) / bh2
        va[i] = v_hat[i] + gah * aa[i]


@njit(cache=True)
def _cq(md, t, q, active, Cq, ws):
    v1, vm, vx, mn = ws
    cm.constraints(md, t, q, v1[6], active, vm[3], Cq, vm[3], vm[3])


@njit(cache=True)
def _constraints_ok(n, m, ggl, t1, t0, tol, qscale, Cq, C, Ct, va, be, ga):
    """The constraint part of the convergence test, on C, C_q, C_t and v evaluated at the
    iterate by the caller."""
    if m == 0:
        return True
    pos = 0.0
    vel = 0.0
    for k in range(m):
        rn = 0.0
        cv = 0.0
        for j in range(n):
            rn += abs(Cq[k, j])
            cv += Cq[k, j] * va[j]
        rn = max(rn, 1e-300)
        pos = max(pos, abs(C[k]) / rn)
        vel = max(vel, abs(cv + Ct[k]) / rn)
    if pos > max(tol, ROUNDOFF) * qscale:
        return False
    if ggl:
        floor = ROUNDOFF * qscale * ga / (be * (t1 - t0))
        vmax = 0.0
        for j in range(n):
            vmax = max(vmax, abs(va[j]))
        if vel > max(VEL_TOL_FACTOR * tol * max(1.0, vmax), floor):
            return False
    return True


@njit(cache=True)
def _factor(md, active, n, m, nx, ggl, t1, h, al, be, ga, q, v, a, lt, bh2, M, Cq, LU, piv, st, cnt, ws):
    """Build and factorize the scaled iteration matrix J into LU; returns a status."""
    v1, vm, vx, mn = ws
    Kq, Kv, KM, KC, Cqp, FDv = mn[1], mn[2], mn[3], mn[4], mn[7], mn[8]
    J = mn[5][:nx, :nx]
    qp = v1[8]
    fp, fm = vm[4], vm[5]
    w1 = 1.0 / (1.0 + al)
    cm.force_jacobian(md, t1, q, v, Kq, Kv)
    cnt[C_JAC] += 1
    cm.mass_jacobian_product(md, q, a, KM)
    J[:, :] = 0.0
    gah = ga * h
    for i in range(n):
        for j in range(n):
            J[i, j] = w1 * M[i, j] + bh2 * (w1 * KM[i, j] - Kq[i, j]) - gah * Kv[i, j]
    if m:
        # ∂(C_qᵀλ)/∂q by central differences (λ = λ̃/βh²)
        for j in range(n):
            qp[:] = q
            dx = FD_REL_STEP * max(1.0, abs(q[j]))
            qp[j] = q[j] + dx
            _cq(md, t1, qp, active, Cqp, ws)
            for i in range(n):
                s = 0.0
                for k in range(m):
                    s += Cqp[k, i] * (lt[k] / bh2)
                KC[i, j] = s
            qp[j] = q[j] - dx
            _cq(md, t1, qp, active, Cqp, ws)
            for i in range(n):
                s = 0.0
                for k in range(m):
                    s += Cqp[k, i] * (lt[k] / bh2)
                KC[i, j] = (KC[i, j] - s) / (2.0 * dx)
        for i in range(n):
            for j in range(n):
                J[i, j] = J[i, j] + bh2 * KC[i, j]
        for k in range(m):
            for i in range(n):
                J[i, n + k] = Cq[k, i]
                J[n + k, i] = Cq[k, i]
        if ggl:
            # J[:n, n+m:] = −(w1 M − γh K_v) C_qᵀ
            for i in range(n):
                for k in range(m):
                    s = 0.0
                    for j in range(n):
                        s += (w1 * M[i, j] - gah * Kv[i, j]) * Cq[k, j]
                    J[i, n + m + k] = -s
            # J[n+m:, :n] = C_q + (βh/γ) ∂(C_q v)/∂q  (central differences)
            for j in range(n):
                qp[:] = q
                dx = FD_REL_STEP * max(1.0, abs(q[j]))
                qp[j] = q[j] + dx
                _cq(md, t1, qp, active, Cqp, ws)
                for k in range(m):
                    s = 0.0
                    for i in range(n):
                        s += Cqp[k, i] * v[i]
                    fp[k] = s
                qp[j] = q[j] - dx
                _cq(md, t1, qp, active, Cqp, ws)
                for k in range(m):
                    s = 0.0
                    for i in range(n):
                        s += Cqp[k, i] * v[i]
                    FDv[k, j] = (fp[k] - s) / (2.0 * dx)
            c = be * h / ga
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
                return 4
    LU[:, :] = J
    info = lu_factor(LU, piv)
    if info > 0:
        st[ST_LU] = 0.0
        return 5
    st[ST_LU] = 1.0
    st[ST_LUH] = h
    cnt[C_LU] += 1
    return 0


@njit(cache=True)
def newton(md, active, t, q, v, a, lam, F_old, h, al, be, ga, ggl, tol, maxiter, reuse,
           st, LU, piv, a_old, l_old, cnt, ws, out_q, out_v, out_a, out_lam, out_F):
    """One step t → t + h (see the module docstring); returns a status (0 = converged)."""
    v1, vm, vx, mn = ws
    n = q.shape[0]
    m = lam.shape[0]
    nx = n + m + (m if ggl else 0)
    q_hat, v_hat, qa, aa, va, Q = v1[0], v1[1], v1[2], v1[3], v1[4], v1[5]
    C, Ct, gam = vm[0], vm[1], vm[2]
    x0, x, r, dx = vx[0][:nx], vx[1][:nx], vx[2][:nx], vx[3][:nx]
    M, Cq, Cq2 = mn[0], mn[6], mn[7]
    zeros, scratch = v1[6], vm[3]
    # the descriptor is passed on only off the pendulum's branch: every njit call that
    # receives ``md`` increfs/decrefs its ~20 arrays (atomics), measured (perf) to be most
    # of the pendulum's step when done several times per Newton iteration
    kind = md[0]
    prm = md[1]
    t1 = t + h
    bh2 = be * h * h
    w1 = 1.0 / (1.0 + al)
    wF = al / (1.0 + al)
    vs = be * h / ga
    gah = ga * h
    c2 = (0.5 - be) * h * h
    c1 = (1.0 - ga) * h
    for i in range(n):
        q_hat[i] = q[i] + h * v[i] + c2 * a[i]
        v_hat[i] = v[i] + c1 * a[i]
    # predictor: a, λ extrapolated linearly from the last two steps (constant after a restart)
    have_prev = st[ST_PREV] != 0.0
    r_h = h / st[ST_HOLD] if have_prev else 0.0
    for i in range(n):
        ap = a[i] + r_h * (a[i] - a_old[i]) if have_prev else a[i]
        x0[i] = q_hat[i] + bh2 * ap
    for k in range(m):
        lp = lam[k] + r_h * (lam[k] - l_old[k]) if have_prev else lam[k]
        x0[n + k] = bh2 * lp
    for k in range(n + m, nx):
        x0[k] = 0.0
    if st[ST_LU] == 0.0 or not reuse or max(h / st[ST_LUH], st[ST_LUH] / h) > JAC_H_RATIO:
        st[ST_LU] = 0.0
    attempts = 0
    while True:
        attempts += 1
        x[:] = x0
        fresh = False
        since = 0
        d_prev = 0.0
        converged = False
        for it in range(maxiter):
            if m:
                if kind == cm.KIND_PENDULUM:
                    cm.pendulum_constraints(prm, x[:n], zeros, scratch, Cq, scratch, scratch)
                else:
                    cm.constraints(md, t1, x[:n], zeros, active, scratch, Cq, scratch, scratch)
            _unpack(n, m, ggl, x, Cq, q_hat, v_hat, bh2, gah, qa, aa, va)
            if kind == cm.KIND_PENDULUM:
                cm.pendulum_mass_force(prm, M, Q)
            else:
                cm.mass_force(md, t1, qa, va, M, Q)
            cnt[C_RES] += 1
            finite = True
            for i in range(n):
                s = 0.0
                for j in range(n):
                    s += M[i, j] * aa[j]
                ri = bh2 * (s * w1 - Q[i] - wF * F_old[i])
                if m:
                    for k in range(m):
                        ri += Cq[k, i] * x[n + k]
                r[i] = ri
            if m:
                if kind == cm.KIND_PENDULUM:
                    cm.pendulum_constraints(prm, qa, va, C, Cq2, Ct, gam)
                else:
                    cm.constraints(md, t1, qa, va, active, C, Cq2, Ct, gam)
                for k in range(m):
                    r[n + k] = C[k]
                    if ggl:
                        s = 0.0
                        for j in range(n):
                            s += Cq[k, j] * va[j]
                        r[n + m + k] = vs * (s + Ct[k])
            for i in range(nx):
                if not math.isfinite(r[i]):
                    finite = False
            if not finite:
                return 1
            if st[ST_LU] == 0.0 or not reuse:
                lt = x[n:n + m]
                status = _factor(md, active, n, m, nx, ggl, t1, h, al, be, ga, qa, va, aa, lt, bh2, M, Cq,
                                 LU, piv, st, cnt, ws)
                if status:
                    return status
                fresh = True
                since = 0
            dx[:] = r
            lu_solve(LU, piv, dx)
            cnt[C_NEWTON] += 1
            since += 1
            for i in range(nx):
                x[i] -= dx[i]
                if not math.isfinite(x[i]):
                    finite = False
            if not finite:
                return 2
            qscale = 1.0
            d = 0.0
            for i in range(n):
                qscale = max(qscale, abs(x[i]))
                d = max(d, abs(dx[i]))
            if m:
                mscale = 0.0
                for i in range(n):
                    mscale = max(mscale, abs(M[i, i]))
                mscale = max(mscale, 1e-300)
                dl = 0.0
                for k in range(m):
                    dl = max(dl, abs(dx[n + k]))
                d = max(d, dl / mscale)
                if ggl:
                    for k in range(m):
                        d = max(d, abs(dx[n + m + k]))
            d /= qscale
            has_rate = d_prev != 0.0
            rate = d / d_prev if has_rate else 0.0
            small = d <= max(tol, ROUNDOFF) or (has_rate and rate < 1.0 and rate / (1.0 - rate) * d <= tol)
            if small:
                if m:
                    if kind == cm.KIND_PENDULUM:
                        cm.pendulum_constraints(prm, x[:n], zeros, scratch, Cq, scratch, scratch)
                    else:
                        cm.constraints(md, t1, x[:n], zeros, active, scratch, Cq, scratch, scratch)
                    _unpack(n, m, ggl, x, Cq, q_hat, v_hat, bh2, gah, qa, aa, va)
                    if kind == cm.KIND_PENDULUM:
                        cm.pendulum_constraints(prm, qa, va, C, Cq2, Ct, gam)
                    else:
                        cm.constraints(md, t1, qa, va, active, C, Cq2, Ct, gam)
                if _constraints_ok(n, m, ggl, t1, t, tol, qscale, Cq, C, Ct, va, be, ga):
                    converged = True
                    break
            if has_rate:
                slow = rate >= 1.0 or d * rate ** (maxiter - it - 1) > tol * (1.0 - rate)
                if not fresh and (rate > NEWTON_RATE_REFRESH or slow):
                    st[ST_LU] = 0.0
                elif fresh and rate > NEWTON_RATE_DIVERGE:
                    break
            d_prev = d
        if converged:
            break
        if attempts > 1 or (fresh and since >= 3):
            return 3
        st[ST_LU] = 0.0
    if m:
        if kind == cm.KIND_PENDULUM:
            cm.pendulum_constraints(prm, x[:n], zeros, scratch, Cq, scratch, scratch)
        else:
            cm.constraints(md, t1, x[:n], zeros, active, scratch, Cq, scratch, scratch)
    _unpack(n, m, ggl, x, Cq, q_hat, v_hat, bh2, gah, out_q, out_a, out_v)
    for k in range(m):
        out_lam[k] = x[n + k] / bh2
    if al != 0.0:
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += M[i, j] * out_a[j]
            out_F[i] = wF * F_old[i] - w1 * s
    else:
        out_F[:] = F_old
    return 0


@njit(cache=True)
def newton_once(md, active, t, q, v, a, lam, F_old, h, al, be, ga, ggl, tol, maxiter, reuse,
                st, LU, piv, a_old, l_old, cnt, out_q, out_v, out_a, out_lam, out_F):
    """:func:`newton` with its own workspace (for single steps called from Python)."""
    n = q.shape[0]
    m = lam.shape[0]
    ws = workspace(n, m, n + 2 * m)
    return newton(md, active, t, q, v, a, lam, F_old, h, al, be, ga, ggl, tol, maxiter, reuse,
                  st, LU, piv, a_old, l_old, cnt, ws, out_q, out_v, out_a, out_lam, out_F)


@njit(cache=True)
def error_norm(be, h, q_new, q_old, a_new, a_old, rtol, atol):
    """Zienkiewicz–Xie local error estimate in the weighted RMS norm (as
    ``NewmarkFamily._error_norm``)."""
    c = abs(be - 1.0 / 6.0)
    if c < 1e-3:
        c = ZX_MIN_COEFF
    n = q_new.shape[0]
    acc = 0.0
    for i in range(n):
        e = (c * h * h) * (a_new[i] - a_old[i])
        w = atol + rtol * max(abs(q_new[i]), abs(q_old[i]))
        acc += (e / w) ** 2
    return math.sqrt(acc / n)


@njit(cache=True)
def run_phase(md, active, inactive, lam_rows, armed, continuous, track, cmax,
              t, q, v, a, lam, F, h_fix, t_stop, t_out_next, t_end, max_steps,
              al, be, ga, ggl, tol, maxiter, reuse, st, LU, piv, a_old, l_old, cnt,
              pq, pv, pa, plam, ctl):
    """Phase runner (module docstring): fixed steps h_fix, or with ``ctl[CTL_ADAPTIVE]``
    the Zienkiewicz–Xie step-size control of ``NewmarkFamily._step_impl`` (rejections,
    Newton-failure cuts, ``ctl[CTL_HNEXT]`` carried in and out). (q, v, a, λ, F) hold the
    current state and are advanced in place; (pq, pv, pa, plam) receive the state before
    the last step. Returns (status, steps taken, t before the last step, t now, h of the
    failed step); status UNDERFLOW_* leaves the Newton status / local error in ``ctl``."""
    n = q.shape[0]
    m = lam.shape[0]
    ws = workspace(n, m, n + 2 * m)
    nq, nv, na, nl, nF = np.empty(n), np.empty(n), np.empty(n), np.empty(m), np.empty(n)
    g = np.empty(max(armed.shape[0], 1))
    zeros = np.zeros(n)
    C, Ct, gam = np.empty(max(m, 1)), np.empty(max(m, 1)), np.empty(max(m, 1))
    Cq = np.empty((max(m, 1), n))
    adaptive = ctl[CTL_ADAPTIVE] != 0.0
    nsteps = 0
    t_prev = t
    hh = h_fix
    while True:
        h_min = ctl[CTL_HMIN] * max(1.0, abs(t))
        while True:  # attempts of one step (one, at fixed step)
            remaining = t_stop - t
            h_try = ctl[CTL_HNEXT] if adaptive else h_fix
            hh = remaining if h_try * (1.0 + SNAP) >= remaining else h_try
            status = newton(md, active, t, q, v, a, lam, F, hh, al, be, ga, ggl, tol, maxiter, reuse,
                            st, LU, piv, a_old, l_old, cnt, ws, nq, nv, na, nl, nF)
            if status != 0:
                if not adaptive:
                    return status, nsteps, t_prev, t, hh
                ctl[CTL_REJECTED] += 1.0
                ctl[CTL_HNEXT] = FAC_NEWTON_FAIL * hh
                if ctl[CTL_HNEXT] < h_min:
                    ctl[CTL_NEWTON] = status
                    return UNDERFLOW_NEWTON, nsteps, t_prev, t, hh
                continue
            if adaptive:
                err = error_norm(be, hh, nq, q, na, a, ctl[CTL_RTOL], ctl[CTL_ATOL])
                if err > 1.0:
                    ctl[CTL_REJECTED] += 1.0
                    ctl[CTL_HNEXT] = hh * max(FAC_MIN, SAFETY * err ** (-1.0 / 3.0))
                    if ctl[CTL_HNEXT] < h_min:
                        ctl[CTL_ERR] = err
                        return UNDERFLOW_ERROR, nsteps, t_prev, t, hh
                    continue
                fac = FAC_MAX if err == 0.0 else min(FAC_MAX, SAFETY * err ** (-1.0 / 3.0))
                ctl[CTL_HNEXT] = max(hh * fac, h_try) if hh < h_try else hh * fac
            break
        t_new = t_stop if hh == remaining else t + hh
        for i in range(n):
            a_old[i] = a[i]
            pq[i] = q[i]
            pv[i] = v[i]
            pa[i] = a[i]
            q[i] = nq[i]
            v[i] = nv[i]
            a[i] = na[i]
            F[i] = nF[i]
        for k in range(m):
            l_old[k] = lam[k]
            plam[k] = lam[k]
            lam[k] = nl[k]
        st[ST_PREV] = 1.0
        st[ST_HOLD] = hh
        t_prev = t
        t = t_new
        nsteps += 1
        # -- does the driver need to see this step? (else: the quiet step's bookkeeping)
        if nsteps >= max_steps or not cw.quiet(md, active, inactive, lam_rows, armed, continuous, track, cmax,
                                               t, q, v, a, lam, t_out_next, t_end, g, zeros, C, Cq, Ct, gam):
            break
    return 0, nsteps, t_prev, t, hh
