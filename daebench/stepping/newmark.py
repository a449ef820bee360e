"""The Newmark family as one compiled stepper: Newmark-β, HHT-α, generalized-α, each a
coefficient set (α_m, α_f, β, γ) with GGL stabilization on or off.

One step from (q_n, v_n, a_n, λ_n) to t_{n+1} = t_n + h solves, for the unknowns
x = (q_{n+1}, λ̃ = βh² λ_{n+1}, μ):

    a_{n+1} = (q_{n+1} − q̂ − C_qᵀ μ) / (βh²),       q̂ = q_n + h v_n + (½ − β) h² a_n
    v_{n+1} = v̂ + γ h a_{n+1},                         v̂ = v_n + (1 − γ) h a_n

    r1 = βh² [ M_{n+1} (w₁ a_{n+1} + h_M) + F_{n+1} + h_F ] = 0      (n),  F = C_qᵀλ − Q
    r2 = C(t_{n+1}, q_{n+1})                                  = 0      (m)
    r3 = (βh/γ) [ C_q v_{n+1} + C_t ]                         = 0      (m, GGL only)

with w₁ = (1 − α_m)/(1 − α_f) and the history terms h_M, h_F of one of two conventions:

* **force averaging** (Chung & Hulbert 1993 applied to the nonlinear equations; HHT-α
  in the form of Negrut et al. 2007): M[(1−α_m)a_{n+1} + α_m a_n] = −[(1−α_f)F_{n+1}
  + α_f F_n], i.e. h_M = α_m/(1−α_f) a_n, h_F = α_f/(1−α_f) F_n. HHT-α is α_m = 0,
  α_f = −α; Newmark-β is α_m = α_f = 0.
* **acceleration averaging** (Arnold & Brüls 2007): the equations of motion hold at
  t_{n+1} with the true acceleration q̈_{n+1}, and a is an acceleration-like variable,
  (1−α_m)a_{n+1} + α_m a_n = (1−α_f)q̈_{n+1} + α_f q̈_n, i.e. q̈_{n+1} = w₁a_{n+1} + h_M
  with h_M = [α_m a_n − α_f q̈_n]/(1−α_f), h_F = 0; a_0 = q̈_0 at every (re)start.
  The state handed on carries the true q̈.

With r3 (GGL, Arnold & Brüls 2007; Gear, Gupta & Leimkuhler 1985) q_{n+1} gets the
correction C_qᵀμ so that C = 0 and Ċ = 0 both hold at every step; μ = O(h³) on smooth
solutions, the order is unchanged.

Scaling (why the iteration matrix stays well conditioned as h → 0): the unknown is
q_{n+1} itself, the equations of motion are multiplied by βh² and λ̃ = βh²λ, so

    J = [[ w₁M + βh²(K_M − K_q + K_C) − γh K_v ,  C_qᵀ ,  −(w₁M − γh K_v) C_qᵀ ],
         [ C_q                                 ,  0    ,  0                     ],
         [ C_q + (βh/γ) ∂(C_q v + C_t)/∂q      ,  0    ,  −C_q C_qᵀ             ]]

with K_q = ∂Q/∂q, K_v = ∂Q/∂v, K_M = ∂(M(w₁a + h_M))/∂q, K_C = ∂(C_qᵀλ)/∂q: every block
O(1) (the 1/(βh²) row / βh² column scaling of Bottasso, Bauchau & Cardona 2007 through
the choice of unknowns). ∂(C_qᵀμ)/∂q is left out (μ = O(h³)).

Newton: the factorized J is kept across iterations and steps (modified Newton) while
the contraction rate stays below ``NEWTON_RATE_REFRESH``; a poor rate, a step size far
from the one J was built for, or a failed iteration with a stale J triggers a refresh.
Convergence: the scaled increment max(|Δq|, |Δμ|, |Δλ̃|/m_s)/max(1, |q|) (m_s the
largest diagonal of M) — or its rate-based estimate ρ/(1−ρ)|Δ| — is below ``tol``, and
the constraint residuals of the new iterate, normalized by the row norms of C_q, are
below ``tol`` too (positions relative to max(1,|q|); velocities ``VEL_TOL_FACTOR``·tol
relative to max(1,|v|), never below the round-off of a velocity computed as a
displacement difference times γ/(βh)). The default tol = 1e-12 keeps the accumulated
Newton error near 1 % of the discretization error on the pendulum at h = 1.25e-3; the
velocity test binds, because a velocity error δv per step grows into a position error
~ T²δv/(2h).

Predictor: a and λ extrapolated linearly from the last two steps (constant after a
restart), μ = 0; q_{n+1} is then accurate to O(h⁴), so that the modified Newton
iteration usually needs one or two corrections.

Local error estimate (adaptive control): Zienkiewicz & Xie (1991),
e = h² |β − ⅙| (a_{n+1} − a_n), with ``ZX_MIN_COEFF`` when |β − ⅙| < 10⁻³ (never zero).

References
----------
Newmark (1959), J. Eng. Mech. Div. ASCE 85, 67–94.
Hilber, Hughes & Taylor (1977), Earthquake Eng. Struct. Dyn. 5, 283–292.
Chung & Hulbert (1993), J. Appl. Mech. 60, 371–375.
Negrut, Rampalli, Ottarsson & Sajdak (2007), J. Comput. Nonlinear Dyn. 2, 73–85.
Arnold & Brüls (2007), Multibody Syst. Dyn. 18, 185–202.
Bottasso, Bauchau & Cardona (2007), SIAM J. Sci. Comput. 29, 397–414.
Zienkiewicz & Xie (1991), Earthquake Eng. Struct. Dyn. 20, 871–887.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import phase
from daebench.core.borrow import copy_to, uncounted
from daebench.core.linalg import BorderedWork, bordered_solve, lu_solve
from daebench.stepping import control, methods
from daebench.stepping.methods import C_NEWTON, C_RES
from daebench.stepping.newmark_matrix import (ST_BAND, ST_HOLD, ST_LU, ST_LUH, ST_PREV, band_mass, factor, mass_row,
                                             mass_rows, structure, uses_hM, weights)

NEWTON_RATE_REFRESH = 0.1    # contraction rate above which a reused iteration matrix is rebuilt
NEWTON_RATE_DIVERGE = 2.0    # rate above which a fresh-matrix iteration is declared divergent
JAC_H_RATIO = 2.0            # rebuild the matrix when h differs by more than this factor from its h
VEL_TOL_FACTOR = 10.0        # velocity-constraint residual tolerance relative to tol·max(1, |v|)
ROUNDOFF = 50.0 * np.finfo(float).eps  # relative residual floor the Newton test never asks to beat
ZX_MIN_COEFF = 1.0 / 24.0    # error coefficient used when β = 1/6 makes h²(β − 1/6) vanish

FAIL_MESSAGES = {
    1: "non-finite residual in Newton iteration",
    2: "non-finite Newton iterate",
    3: "Newton did not converge in {maxiter} iterations",
    4: "non-finite iteration matrix",
    5: "singular iteration matrix (dependent constraints?)",
}


class NewmarkMethod(NamedTuple):
    """A member of the family (see the module docstring)."""

    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float
    ggl: bool
    accel_avg: bool     # acceleration averaging (Arnold–Brüls) instead of force averaging
    tol: float
    maxiter: int
    reuse: bool         # modified Newton: keep J across iterations and steps


class NewmarkWork(NamedTuple):
    st: np.ndarray      # [LU valid, h of the LU, previous step known, its h]
    LU: np.ndarray
    piv: np.ndarray
    acc: np.ndarray     # a_n (the family's acceleration variable)
    acc_new: np.ndarray
    a_old: np.ndarray   # a_{n−1}, λ_{n−1}: the predictor's history
    l_old: np.ndarray
    hM: np.ndarray      # history terms h_M, h_F of the residual
    hF: np.ndarray
    F: np.ndarray       # F_n = (C_qᵀλ − Q)_n (force averaging with α_f ≠ 0)
    F_new: np.ndarray
    q_hat: np.ndarray   # scratch (n)
    v_hat: np.ndarray
    Q: np.ndarray
    zeros: np.ndarray
    tmp: np.ndarray
    C: np.ndarray       # scratch (m)
    Ct: np.ndarray
    gam: np.ndarray
    lam_s: np.ndarray
    x0: np.ndarray      # scratch (nx)
    x: np.ndarray
    r: np.ndarray
    dx: np.ndarray
    M: np.ndarray       # scratch (n × n, m × n)
    Kq: np.ndarray
    Kv: np.ndarray
    KM: np.ndarray
    KC: np.ndarray
    Cq: np.ndarray
    FDv: np.ndarray
    bw: BorderedWork    # factors through the model's declared structure (newmark_matrix.factor)
    sp: np.ndarray      # int64[3]: structure declared, mass half-bandwidth (−1 dense), constant mass
    M0: np.ndarray      # (0 × n): the mass_force argument "force only" (constant mass)
    ij: np.ndarray      # int64 (2, P): the n × n entries inside the declared structure
    pos: np.ndarray     # int64[n]: each DOF's place in the declared order
    Mb: np.ndarray      # (n, 2 mb + 1): a declared constant banded M in band storage, Mb[i, j − i + mb] = M[i, j]


def workspace(n: int, m: int, ggl: bool, sparsity=None) -> NewmarkWork:
    """Scratch and history of one phase; ``sparsity`` (a
    :class:`daebench.core.linalg.Sparsity` of the model) makes the iteration matrix
    factorize through its bordered-banded structure and the residual skip M's zeros."""
    nx = n + m + (m if ggl else 0)
    mm = max(m, 1)
    e = np.empty
    bw, sp, ij, pos = structure(sparsity, n, nx)
    return NewmarkWork(np.zeros(5), e((nx, nx)), np.zeros(nx, np.int64), e(n), e(n), e(n), e(m), np.zeros(n),
                       np.zeros(n), np.zeros(n), np.zeros(n), e(n), e(n), e(n), np.zeros(n), e(n), e(mm), e(mm),
                       e(mm), e(m), e(nx), e(nx), e(nx), e(nx), e((n, n)), e((n, n)), e((n, n)), e((n, n)),
                       e((n, n)), e((mm, n)), e((mm, n)), bw, sp, np.zeros((0, n)), ij, pos,
                       np.zeros((n, 2 * max(int(sp[1]), 0) + 1)))


@uncounted
def _start(meth, ws, ph, t, cur, cnt):
    """Forget the history; h_M, h_F (and F_n) from the consistent start state."""
    n = cur.q.shape[0]
    w1, wm, wf = weights(meth)
    ws.st[:] = 0.0
    copy_to(ws.acc, cur.a)
    if ws.sp[2]:  # constant M: filled once here, the iterations ask for the force only
        phase.mass_force(ph, t, cur.q, cur.v, ws.M, ws.Q)
        band_mass(ws.M, ws.sp[1], ws.Mb)
    for i in range(n):
        ws.hM[i] = (wm - wf) * cur.a[i] if meth.accel_avg else wm * cur.a[i]
        ws.hF[i] = 0.0
    if meth.alpha_f != 0.0 and not meth.accel_avg:
        # F_n = (C_qᵀλ − Q)_n, the force average needs it
        phase.mass_force(ph, t, cur.q, cur.v, ws.M, ws.Q)
        cnt[C_RES] += 1
        m = cur.lam.shape[0]
        if m:
            phase.constraints(ph, t, cur.q, ws.zeros, ws.C, ws.Cq, ws.Ct, ws.gam)
        for i in range(n):
            f = -ws.Q[i]
            for k in range(m):
                f += ws.Cq[k, i] * cur.lam[k]
            ws.F[i] = f
            ws.hF[i] = wf * f
    return 0


@uncounted(no_cpython_wrapper=True, inline="always")
def _unpack(meth, n, m, x, Cq, q_hat, v_hat, bh2, gah, qa, aa, va):
    """q, a, v of the iterate x (GGL: a = (q − q̂ − C_qᵀμ)/βh²)."""
    for i in range(n):
        mu = 0.0
        if meth.ggl:
            for k in range(m):
                mu += Cq[k, i] * x[n + m + k]
        qa[i] = x[i]
        aa[i] = (x[i] - q_hat[i] - mu) / bh2
        va[i] = v_hat[i] + gah * aa[i]


@uncounted(no_cpython_wrapper=True, inline="always")
def _constraints_ok(meth, n, m, h, tol, qscale, Cq, C, Ct, va):
    """The constraint part of the convergence test, on C, C_q, C_t at the iterate."""
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
    if meth.ggl:
        floor = ROUNDOFF * qscale * meth.gamma / (meth.beta * h)
        vmax = 0.0
        for j in range(n):
            vmax = max(vmax, abs(va[j]))
        if vel > max(VEL_TOL_FACTOR * tol * max(1.0, vmax), floor):
            return False
    return True


@uncounted(no_cpython_wrapper=True)
def _step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    """One step t → t + h (module docstring); returns (status, local error estimate)."""
    n = cur.q.shape[0]
    m = cur.lam.shape[0]
    ggl = meth.ggl and m > 0
    nx = n + m + (m if ggl else 0)
    q_hat, v_hat, Q, zeros = ws.q_hat, ws.v_hat, ws.Q, ws.zeros
    qa, aa, va = new.q, ws.acc_new, new.v
    C, Ct, gam = ws.C, ws.Ct, ws.gam
    x0, x, r, dx = ws.x0, ws.x, ws.r, ws.dx
    M, Cq = ws.M, ws.Cq
    st = ws.st
    tol = meth.tol
    maxiter = meth.maxiter
    w1, wm, wf = weights(meth)
    hM_on = uses_hM(meth)
    mb = ws.sp[1]
    Mr, compact = mass_rows(ws)
    t1 = t + h
    be, ga = meth.beta, meth.gamma
    bh2 = be * h * h
    vs = be * h / ga
    gah = ga * h
    c2 = (0.5 - be) * h * h
    c1 = (1.0 - ga) * h
    a_n = ws.acc
    for i in range(n):
        q_hat[i] = cur.q[i] + h * cur.v[i] + c2 * a_n[i]
        v_hat[i] = cur.v[i] + c1 * a_n[i]
    # predictor: a, λ extrapolated linearly from the last two steps (constant after a restart)
    have_prev = st[ST_PREV] != 0.0
    r_h = h / st[ST_HOLD] if have_prev else 0.0
    for i in range(n):
        ap = a_n[i] + r_h * (a_n[i] - ws.a_old[i]) if have_prev else a_n[i]
        x0[i] = q_hat[i] + bh2 * ap
    for k in range(m):
        lp = cur.lam[k] + r_h * (cur.lam[k] - ws.l_old[k]) if have_prev else cur.lam[k]
        x0[n + k] = bh2 * lp
    for k in range(n + m, nx):
        x0[k] = 0.0
    if st[ST_LU] == 0.0 or not meth.reuse or max(h / st[ST_LUH], st[ST_LUH] / h) > JAC_H_RATIO:
        st[ST_LU] = 0.0
    attempts = 0
    while True:
        attempts += 1
        copy_to(x[:nx], x0[:nx])
        fresh = False
        since = 0
        d_prev = 0.0
        converged = False
        for it in range(maxiter):
            if m:
                phase.constraints(ph, t1, x[:n], zeros, C, Cq, Ct, gam)
            _unpack(meth, n, m, x, Cq, q_hat, v_hat, bh2, gah, qa, aa, va)
            phase.mass_force(ph, t1, qa, va, ws.M0 if ws.sp[2] else M, Q)
            cnt[C_RES] += 1
            finite = True
            for i in range(n):
                j0, j1 = mass_row(mb, i, n)
                o = mb - i if compact else 0
                s = 0.0
                for j in range(j0, j1):
                    s += Mr[i, j + o] * aa[j]
                s = s * w1
                if hM_on:
                    for j in range(j0, j1):
                        s += Mr[i, j + o] * ws.hM[j]
                ri = bh2 * (s - Q[i] + ws.hF[i])
                for k in range(m):
                    ri += Cq[k, i] * x[n + k]
                r[i] = ri
            if m:
                # C, C_q, C_t depend on (t, q) only and qa = x[:n]: the rows computed above
                # serve (γ, the one row that needs v, is not used by the step)
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
                return 1, 0.0
            if st[ST_LU] == 0.0 or not meth.reuse:
                status = factor(meth, ws, ph, n, m, nx, t1, h, qa, va, aa, x[n:n + m], bh2, cnt)
                if status:
                    return status, 0.0
                fresh = True
                since = 0
            copy_to(dx[:nx], r[:nx])
            if st[ST_BAND] != 0.0:
                bordered_solve(ws.bw, dx[:nx])
            else:
                lu_solve(ws.LU, ws.piv, dx[:nx])
            cnt[C_NEWTON] += 1
            since += 1
            for i in range(nx):
                x[i] -= dx[i]
                if not math.isfinite(x[i]):
                    finite = False
            if not finite:
                return 2, 0.0
            qscale = 1.0
            d = 0.0
            for i in range(n):
                qscale = max(qscale, abs(x[i]))
                d = max(d, abs(dx[i]))
            if m:
                mscale = 0.0
                for i in range(n):
                    mscale = max(mscale, abs(Mr[i, (mb if compact else i)]))
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
                    phase.constraints(ph, t1, x[:n], zeros, C, Cq, Ct, gam)
                    _unpack(meth, n, m, x, Cq, q_hat, v_hat, bh2, gah, qa, aa, va)
                if _constraints_ok(meth, n, m, h, tol, qscale, Cq, C, Ct, va):
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
            return 3, 0.0
        st[ST_LU] = 0.0
    # converged: with constraints the test above left C_q and (q, a, v) at the final x
    if not m:
        _unpack(meth, n, m, x, Cq, q_hat, v_hat, bh2, gah, qa, aa, va)
    for k in range(m):
        new.lam[k] = x[n + k] / bh2
    # the state handed on: a (force averaging) or the true q̈ = w₁a + h_M (acceleration averaging)
    for i in range(n):
        new.a[i] = w1 * aa[i] + ws.hM[i] if meth.accel_avg else aa[i]
    if meth.alpha_f != 0.0 and not meth.accel_avg:
        # F_{n+1} = (C_qᵀλ − Q)_{n+1} from the converged equations of motion (no extra force call)
        for i in range(n):
            j0, j1 = mass_row(mb, i, n)
            o = mb - i if compact else 0
            s = 0.0
            for j in range(j0, j1):
                s += Mr[i, j + o] * aa[j]
            f = (-wf) * ws.F[i] - w1 * s
            if hM_on:
                for j in range(j0, j1):
                    f -= Mr[i, j + o] * ws.hM[j]
            ws.F_new[i] = f
    err = 0.0
    if ctl.adaptive:
        c = abs(be - 1.0 / 6.0)
        if c < 1e-3:
            c = ZX_MIN_COEFF
        for i in range(n):
            ws.tmp[i] = (c * h * h) * (aa[i] - a_n[i])
        err = control.weighted_rms(ws.tmp, new.q, cur.q, ctl.rtol, ctl.atol)
    return 0, err


@uncounted(no_cpython_wrapper=True)
def _accept(meth, ws, h, prev, cur):
    n = cur.q.shape[0]
    w1, wm, wf = weights(meth)
    for i in range(n):
        ws.a_old[i] = ws.acc[i]
        if meth.accel_avg:
            # h_M = (α_m a_{n+1} − α_f q̈_{n+1})/(1 − α_f)
            ws.hM[i] = wm * ws.acc_new[i] - wf * cur.a[i]
        elif meth.alpha_m != 0.0:
            ws.hM[i] = wm * ws.acc_new[i]
        ws.acc[i] = ws.acc_new[i]
    copy_to(ws.l_old, prev.lam)
    if meth.alpha_f != 0.0 and not meth.accel_avg:
        for i in range(n):
            ws.F[i] = ws.F_new[i]
            ws.hF[i] = wf * ws.F[i]
    ws.st[ST_PREV] = 1.0
    ws.st[ST_HOLD] = h


methods.start.register(NewmarkMethod, _start)
methods.step.register(NewmarkMethod, _step)
methods.accept.register(NewmarkMethod, _accept)
