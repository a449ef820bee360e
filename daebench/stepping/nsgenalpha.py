"""Nonsmooth generalized-α (Capobianco, Harsch, Eugster & Leine 2021), frictionless normal
contact with Newton restitution, as a compiled stepper (:mod:`daebench.stepping.methods`).

Unknowns of a step t_n → t_{n+1} (equation numbers of the paper), 3n + 3 n_c of them::

    x = (a_{n+1}, U_{n+1}, Q_{n+1}, κ_{n+1}, Λ_{n+1}, λ_{n+1})

the smooth acceleration, the velocity jump, the position correction and, per contact, the
position-level percussion κ, the impulse Λ and the force λ — the three levels of contact
unknowns. With the Chung–Hulbert coefficients (α_m, α_f, β, γ) of
:func:`daebench.integrators.family.chung_hulbert` and c = (1 − α_f)/(1 − α_m)::

    ā_{n+1} = (α_f a_n + (1−α_f) a_{n+1} − α_m ā_n)/(1−α_m)            (71)
    u_{n+1} = u_n + h [(1−γ) ā_n + γ ā_{n+1}] + U_{n+1}                   (73)
    q_{n+1} = q_n + h u_n + h² [(½−β) ā_n + β ā_{n+1}] + Q_{n+1}          (125)
    λ̄_{n+1} from λ as ā from a;   P = Λ + h [(1−γ) λ̄_n + γ λ̄_{n+1}]      (95, 96)
    κ̂ = κ + h² [(½−β) λ̄_n + β λ̄_{n+1}]                                  (102)

    M a_{n+1} − Q(t_{n+1}, q_{n+1}, u_{n+1}) − g_qᵀ λ = 0,   M U − g_qᵀ Λ = 0,   M Q − g_qᵀ κ = 0   (127)

and per contact, with the prox parameter r > 0 and the index sets (130), (133), (136)

    A: r g − κ̂ ≤ 0        A ? g(q_{n+1}) = 0 : κ̂ = 0                          (129)
    B: A ∧ r ξ − P ≤ 0     B ? ξ = g_q u_{n+1} + e g_q(q_n) u_n = 0 : P = 0     (132)
    C: B ∧ r g̈ − λ ≤ 0     C ? g̈ = g_q a_{n+1} − γ_g = 0 : λ = 0               (135)

(M, g_q at q_{n+1}). These are the normal-cone inclusions of the paper written with the
proximal point map on ℝ⁺; their solution has g ≥ 0, P ≥ 0, κ̂ ≥ 0, λ ≥ 0 whatever r,
and g(q_{n+1}) < 0 is impossible (outside A the gap is > κ̂/r = 0): no penetration
beyond the Newton tolerance.

Solution: semismooth Newton (the paper's eq. (126)–(142) as cardillo's "newton" method):
each iteration evaluates the residual with the index sets of the current iterate and
solves with the Jacobian of that branch (∂(g_qᵀλ)/∂q and ∂ξ/∂q left out: a
quasi-Newton iteration that converges linearly where they matter). The factorized
Jacobian is kept across iterations and steps while the index sets and h are unchanged
and the contraction is good. Converged when the scaled increment of q_{n+1} and of
h·u_{n+1} is below tol and the index sets agree over the last two evaluations.
r_i = 1 / Σ_j g_{q,ij}² / M_jj (the diagonal estimate of the contact's effective mass, the
scale cardillo's estimate_prox_parameter gives), fixed within a step.

The state handed on carries a = a_{n+1} (the smooth acceleration); ā, λ, λ̄ live in the
workspace. A restart sets ā = a (the consistent acceleration) and λ = λ̄ = 0.

Reference: G. Capobianco, J. Harsch, S. R. Eugster, R. I. Leine, "A nonsmooth
generalized-alpha method for mechanical systems with frictional contact", Int. J.
Numer. Meth. Eng. 122 (2021) 6497–6526, doi 10.1002/nme.6801.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels, phase
from daebench.stepping import episodes as _ep
from daebench.core.linalg import factor_flagged, lu_solve
from daebench.stepping import methods
from daebench.stepping import nsga_friction as _nf
from daebench.stepping.methods import C_JAC, C_LU, C_NEWTON, C_RES

NEWTON_RATE_REFRESH = 0.1   # contraction rate above which a reused Jacobian is rebuilt

ST_NOT_FINITE, ST_NEWTON, ST_SINGULAR = 1, 2, 3
FAIL_MESSAGES = {
    ST_NOT_FINITE: "non-finite iterate in the nonsmooth generalized-α Newton iteration",
    ST_NEWTON: "semismooth Newton did not converge in {newton_maxiter} iterations",
    ST_SINGULAR: "singular Jacobian of the nonsmooth generalized-α step",
}
W_LU, W_LUH, W_G0, W_PREV, W_HPREV = range(5)  # ws.st (W_LU, W_LUH first: linalg.factor_flagged): LU, its h; start gaps known; last step known, its h


class NsgaMethod(NamedTuple):
    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float
    e: float
    tol: float
    maxiter: int
    reuse: bool
    friction: bool        # μ > 0 at some contact: the friction unknowns of stepping.nsga_friction


class NsgaWork(NamedTuple):
    st: np.ndarray
    J: np.ndarray
    piv: np.ndarray
    x: np.ndarray
    dx: np.ndarray
    r: np.ndarray
    abar: np.ndarray      # ā_n
    abar_new: np.ndarray
    lam: np.ndarray       # λ_n, λ̄_n per contact
    lbar: np.ndarray
    lam_new: np.ndarray
    lbar_new: np.ndarray
    qhat: np.ndarray
    uhat: np.ndarray
    q1: np.ndarray
    u1: np.ndarray
    f: np.ndarray
    M: np.ndarray
    Kq: np.ndarray
    Kv: np.ndarray
    KM: np.ndarray
    W: np.ndarray         # nc × n
    gq: np.ndarray
    g0: np.ndarray        # per contact: gap and ġ at the step's start
    gdm: np.ndarray
    gn: np.ndarray        # per contact: gap and ġ at the proposed step's end (the next start)
    gdn: np.ndarray
    a_old: np.ndarray     # a_{n−1}, λ_{n−1}: the predictor's history
    lam_old: np.ndarray
    phat: np.ndarray      # history parts of P and κ̂
    khat: np.ndarray
    rprox: np.ndarray
    P: np.ndarray
    kh: np.ndarray
    g1: np.ndarray
    sets: np.ndarray      # int64 nc: 0 none, 1 A, 2 A∧B, 3 A∧B∧C
    sets_prev: np.ndarray
    sets_lu: np.ndarray
    ep: _ep.Episodes
    fr: _nf.NsgaFriction


def workspace(n: int, nc: int, steps_per_call: int, friction: bool = False) -> NsgaWork:
    k = max(nc, 1)
    nx = 3 * n + 3 * k + (2 * k if friction else 0)
    z = np.zeros
    per_n = ("abar", "abar_new", "qhat", "uhat", "q1", "u1", "f", "gq", "a_old")
    per_k = ("lam", "lbar", "lam_new", "lbar_new", "g0", "gdm", "gn", "gdn", "lam_old", "phat", "khat", "rprox",
             "P", "kh", "g1")
    return NsgaWork(st=z(5), J=z((nx, nx)), piv=z(nx, np.int64), x=z(nx), dx=z(nx), r=z(nx),
                    M=z((n, n)), Kq=z((n, n)), Kv=z((n, n)), KM=z((n, n)), W=z((k, n)),
                    sets=z(k, np.int64), sets_prev=z(k, np.int64), sets_lu=z(k, np.int64),
                    ep=_ep.episodes(n, nc, steps_per_call), fr=_nf.friction_work(n, nc), **{f: z(n) for f in per_n}, **{f: z(k) for f in per_k})


@njit(cache=True)
def _start(meth, ws, ph, t, cur, cnt):
    ws.st[:] = 0.0
    ws.abar[:] = cur.a
    ws.lam[:] = 0.0
    ws.lbar[:] = 0.0
    _nf.restart(ws.fr)
    _ep.reset(ws.ep)
    return 0


@njit(cache=True)
def _jacobian(meth, ws, ph, n, nc, t1, h, cnt):
    """The Jacobian of the residual for the current index sets, factorized; a status."""
    J = ws.J
    nx = 3 * n + 3 * nc + (2 * nc if meth.friction else 0)
    c = (1.0 - meth.alpha_f) / (1.0 - meth.alpha_m)
    cq = meth.beta * h * h * c
    cu = meth.gamma * h * c
    phase.force_jacobian(ph, t1, ws.q1, ws.u1, ws.Kq, ws.Kv)
    cnt[C_JAC] += 1
    phase.mass_jacobian_product(ph, ws.q1, ws.x[:n], ws.KM)
    J[:, :] = 0.0
    iU, iQ, ik, iL, il = n, 2 * n, 3 * n, 3 * n + nc, 3 * n + 2 * nc
    for i in range(n):
        for j in range(n):
            dq = ws.KM[i, j] - ws.Kq[i, j]
            J[i, j] = ws.M[i, j] + cq * dq - cu * ws.Kv[i, j]
            J[i, iU + j] = -ws.Kv[i, j]
            J[i, iQ + j] = dq
            J[iU + i, iU + j] = ws.M[i, j]
            J[iQ + i, iQ + j] = ws.M[i, j]
        for k in range(nc):
            J[i, il + k] = -ws.W[k, i]
            J[iU + i, iL + k] = -ws.W[k, i]
            J[iQ + i, ik + k] = -ws.W[k, i]
    for k in range(nc):
        s = ws.sets[k]
        if s >= 1:
            for j in range(n):
                J[ik + k, j] = cq * ws.W[k, j]
                J[ik + k, iQ + j] = ws.W[k, j]
        else:
            J[ik + k, ik + k] = 1.0
            J[ik + k, il + k] = cq
        if s >= 2:
            for j in range(n):
                J[iL + k, j] = cu * ws.W[k, j]
                J[iL + k, iU + j] = ws.W[k, j]
        else:
            J[iL + k, iL + k] = 1.0
            J[iL + k, il + k] = cu
        if s >= 3:
            for j in range(n):
                J[il + k, j] = ws.W[k, j]
        else:
            J[il + k, il + k] = 1.0
        ws.sets_lu[k] = s
    if meth.friction:
        _nf.jacobian(ws.fr, J, n, nc, h, cu)
    for i in range(nx):
        for j in range(nx):
            if not math.isfinite(J[i, j]):
                ws.st[W_LU] = 0.0
                return ST_NOT_FINITE
    cnt[C_LU] += 1
    return ST_SINGULAR if factor_flagged(J, ws.piv, ws.st, h) != 0 else 0   # st[W_LU], st[W_LUH]


@njit(cache=True)
def _residual(meth, ws, ph, n, nc, t1, h, first, cnt):
    """q_{n+1}, u_{n+1} of the iterate, the residual into ws.r and the index sets."""
    x = ws.x
    c = (1.0 - meth.alpha_f) / (1.0 - meth.alpha_m)
    cq = meth.beta * h * h * c
    cu = meth.gamma * h * c
    iU, iQ, ik, iL, il = n, 2 * n, 3 * n, 3 * n + nc, 3 * n + 2 * nc
    for i in range(n):
        ws.q1[i] = ws.qhat[i] + cq * x[i] + x[iQ + i]
        ws.u1[i] = ws.uhat[i] + cu * x[i] + x[iU + i]
    phase.mass_force(ph, t1, ws.q1, ws.u1, ws.M, ws.f)
    cnt[C_RES] += 1
    for k in range(nc):
        g, gam = kernels.gap(ph.model, k, ws.q1, ws.u1, ws.W[k])
        ws.g1[k] = g
        if first:
            s = 0.0
            for j in range(n):
                if ws.M[j, j] > 0.0:  # a massless coordinate adds no inertia to the estimate
                    s += ws.W[k, j] ** 2 / ws.M[j, j]
            ws.rprox[k] = 1.0 / s if s > 0.0 else 1.0
        xi = meth.e * ws.gdm[k]
        gdd = -gam
        for j in range(n):
            xi += ws.W[k, j] * ws.u1[j]
            gdd += ws.W[k, j] * x[j]
        lam = x[il + k]
        P = x[iL + k] + ws.phat[k] + cu * lam
        kh = x[ik + k] + ws.khat[k] + cq * lam
        ws.P[k] = P
        ws.kh[k] = kh
        rp = ws.rprox[k]
        s = 0
        if rp * g - kh <= 0.0:
            s = 1
            if rp * xi - P <= 0.0:
                s = 2
                if rp * gdd - lam <= 0.0:
                    s = 3
        ws.sets[k] = s
        ws.r[ik + k] = g if s >= 1 else kh
        ws.r[iL + k] = xi if s >= 2 else P
        ws.r[il + k] = gdd if s >= 3 else lam
    for i in range(n):
        r1 = -ws.f[i]
        r2 = 0.0
        r3 = 0.0
        for j in range(n):
            r1 += ws.M[i, j] * x[j]
            r2 += ws.M[i, j] * x[iU + j]
            r3 += ws.M[i, j] * x[iQ + j]
        for k in range(nc):
            r1 -= ws.W[k, i] * x[il + k]
            r2 -= ws.W[k, i] * x[iL + k]
            r3 -= ws.W[k, i] * x[ik + k]
        ws.r[i] = r1
        ws.r[iU + i] = r2
        ws.r[iQ + i] = r3
    if meth.friction:
        _nf.residual(ph.model, ws.fr, x, ws.r, ws.M, ws.q1, ws.u1, ws.sets, ws.P, n, nc, h, cu, first)
    for i in range(ws.x.shape[0]):
        if not math.isfinite(ws.r[i]):
            return ST_NOT_FINITE
    return 0


@njit(cache=True)
def _step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    n = cur.q.shape[0]
    nc = ph.engaged.shape[0]
    nx = 3 * n + 3 * nc + (2 * nc if meth.friction else 0)
    am, af, be, ga = meth.alpha_m, meth.alpha_f, meth.beta, meth.gamma
    t1 = t + h
    x = ws.x
    c = (1.0 - af) / (1.0 - am)
    for i in range(n):
        da = (af * cur.a[i] - am * ws.abar[i]) / (1.0 - am)
        ws.qhat[i] = cur.q[i] + h * cur.v[i] + h * h * ((0.5 - be) * ws.abar[i] + be * da)
        ws.uhat[i] = cur.v[i] + h * ((1.0 - ga) * ws.abar[i] + ga * da)
    for k in range(nc):
        dl = (af * ws.lam[k] - am * ws.lbar[k]) / (1.0 - am)
        ws.phat[k] = h * ((1.0 - ga) * ws.lbar[k] + ga * dl)
        ws.khat[k] = h * h * ((0.5 - be) * ws.lbar[k] + be * dl)
        if ws.st[W_G0] == 0.0:
            ws.g0[k], _ = kernels.gap(ph.model, k, cur.q, cur.v, ws.gq)
            gd = 0.0
            for j in range(n):
                gd += ws.gq[j] * cur.v[j]
            ws.gdm[k] = gd
    # predictor: a and λ extrapolated linearly from the last two steps, no jump, no correction
    x[:] = 0.0
    rh = h / ws.st[W_HPREV] if ws.st[W_PREV] != 0.0 else 0.0
    for i in range(n):
        x[i] = cur.a[i] + rh * (cur.a[i] - ws.a_old[i])
    for k in range(nc):
        x[3 * n + 2 * nc + k] = max(0.0, ws.lam[k] + rh * (ws.lam[k] - ws.lam_old[k]))
        ws.sets_prev[k] = -1
    if meth.friction:
        _nf.prepare(ws.fr, nc, h, am, af, ga)
        _nf.predict(ws.fr, x, n, nc, rh)
    if ws.st[W_LU] != 0.0 and (not meth.reuse or ws.st[W_LUH] != h):
        ws.st[W_LU] = 0.0
    d_prev = 0.0
    fresh = False
    converged = False
    for it in range(meth.maxiter):
        st = _residual(meth, ws, ph, n, nc, t1, h, it == 0, cnt)
        if st:
            return st, 0.0
        stable = True
        same_lu = True
        for k in range(nc):
            if ws.sets[k] != ws.sets_prev[k]:
                stable = False
            if ws.sets[k] != ws.sets_lu[k]:
                same_lu = False
            ws.sets_prev[k] = ws.sets[k]
            if meth.friction:
                fr = ws.fr
                if fr.fsets[k] != fr.fsets_prev[k]:
                    stable = False
                if fr.fsets[k] != fr.fsets_lu[k]:
                    same_lu = False
                fr.fsets_prev[k] = fr.fsets[k]
        if ws.st[W_LU] == 0.0 or not same_lu:
            st = _jacobian(meth, ws, ph, n, nc, t1, h, cnt)
            if st:
                return st, 0.0
            fresh = True
        ws.dx[:] = ws.r
        lu_solve(ws.J, ws.piv, ws.dx)
        cnt[C_NEWTON] += 1
        cq = be * h * h * c
        cu = ga * h * c
        qscale = 1.0
        d = 0.0
        for i in range(n):
            qscale = max(qscale, abs(ws.q1[i]))
            d = max(d, abs(cq * ws.dx[i] + ws.dx[2 * n + i]), h * abs(cu * ws.dx[i] + ws.dx[n + i]))
        for i in range(nx):
            x[i] -= ws.dx[i]
        d /= qscale
        if not math.isfinite(d):
            return ST_NOT_FINITE, 0.0
        rate = d / d_prev if d_prev > 0.0 else 0.0
        small = d <= meth.tol or (d_prev > 0.0 and rate < 1.0 and rate / (1.0 - rate) * d <= meth.tol)
        if small and stable:
            converged = True
            break
        if d_prev > 0.0 and rate > NEWTON_RATE_REFRESH and not fresh:
            ws.st[W_LU] = 0.0
        d_prev = d
    if not converged:
        ws.st[W_LU] = 0.0
        return ST_NEWTON, 0.0
    # the converged state (q, u from the final x)
    cq = be * h * h * c
    cu = ga * h * c
    for i in range(n):
        new.q[i] = ws.qhat[i] + cq * x[i] + x[2 * n + i]
        new.v[i] = ws.uhat[i] + cu * x[i] + x[n + i]
        new.a[i] = x[i]
        ws.abar_new[i] = (af * cur.a[i] + (1.0 - af) * x[i] - am * ws.abar[i]) / (1.0 - am)
    work = 0.0
    for k in range(nc):
        lam = x[3 * n + 2 * nc + k]
        ws.lam_new[k] = lam
        ws.lbar_new[k] = (af * ws.lam[k] + (1.0 - af) * lam - am * ws.lbar[k]) / (1.0 - am)
        P = x[3 * n + nc + k] + ws.phat[k] + cu * lam
        kh = x[3 * n + k] + ws.khat[k] + cq * lam
        ws.gn[k], _ = kernels.gap(ph.model, k, new.q, new.v, ws.gq)
        gd = 0.0
        for j in range(n):
            gd += ws.gq[j] * new.v[j]
        ws.gdn[k] = gd
        u = 0.0
        for j in range(n):
            u += ws.W[k, j] * (cur.v[j] + new.v[j])
        work += 0.5 * P * u
        touching = ws.sets[k] >= 1 and (P > 0.0 or kh > 0.0)
        _ep.propose(ws.ep, k, t, touching, P, ws.g0[k], ws.gn[k], ws.gdm[k])
    if meth.friction:
        work += _nf.finish(ws.fr, x, n, nc, am, af, cu, cur.v, new.v)
    _ep.propose_work(ws.ep, work)
    return 0, 0.0


@njit(cache=True)
def _accept(meth, ws, h, prev, cur):
    ws.a_old[:] = prev.a
    ws.lam_old[:] = ws.lam
    ws.abar[:] = ws.abar_new
    ws.lam[:] = ws.lam_new
    ws.lbar[:] = ws.lbar_new
    if meth.friction:
        _nf.accept(ws.fr)
    _ep.commit(ws.ep, ws.ep.step.shape[0], prev, cur)
    ws.g0[:] = ws.gn
    ws.gdm[:] = ws.gdn
    ws.st[W_G0] = 1.0
    ws.st[W_PREV] = 1.0
    ws.st[W_HPREV] = h


methods.start.register(NsgaMethod, _start)
methods.step.register(NsgaMethod, _step)
methods.accept.register(NsgaMethod, _accept)
