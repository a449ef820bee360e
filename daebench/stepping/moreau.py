"""Moreau–Jean time stepping as a compiled stepper (:mod:`daebench.stepping.methods`).

One step t_k → t_{k+1} = t_k + h (θ-method on the smooth part, contact impulses P ≥ 0 of
the step, Newton's impact law at velocity level)::

    v_{k+1} − v_k = h [(1 − θ) a_k + θ a_{k+1}] + M_{k+1}⁻¹ Σ_i g_{q,i}ᵀ P_i,     a = M(q)⁻¹ Q(t, q, v)
    q_{k+1} = q_k + h [(1 − θ) v_k + θ v_{k+1}]
    i ∈ I:   0 ≤ U_i + e U_i⁻  ⟂  P_i ≥ 0,      U = g_q v_{k+1},  U⁻ = g_q v_k
    i ∉ I:   P_i = 0

M, g_q at q_{k+1}; solved in the form M_{k+1} (v_{k+1} − v_k − h(1−θ) a_k) = hθ Q_{k+1} + g_qᵀP.
The θ-method acts on the accelerations a = M⁻¹Q, each at its own configuration: the
form often written M(v_{k+1} − v_k) = h[(1−θ)Q_k + θQ_{k+1}] + g_qᵀP weighs Q_k with
M(q_{k+1})⁻¹, an O(h²) local error wherever M depends on q (the hub–beam's energy then
oscillated 40× more after an impact). a_k is M⁻¹Q of the last iterate of the previous
step (one small LU of M per step), recomputed after a restart or a projection. The index set I is fixed at the step's start by the predicted gap
g_i(q_k) + γ h ġ_i(q_k, v_k) ≤ 0 (Siconos' MoreauJeanOSI; γ = ½ there by default).

Solution: Newton on v_{k+1}, each linearization an LCP for P (:mod:`daebench.core.lcp`):
with S = M − hθ ∂Q/∂v − h²θ² ∂Q/∂q the iteration matrix and v_free the Newton update
without impulses, v_{k+1} = v_free + S⁻¹ g_qᵀ P and w = g_q v_free + e U⁻ + g_q S⁻¹ g_qᵀ P.
The factorized S is kept across iterations and steps while the contraction is good
(modified Newton, as :mod:`daebench.stepping.newmark`); at a fixed point the residual and
the complementarity hold exactly, whatever S. Linear systems converge in one correction.

Friction (``friction``: the model's contacts have Coulomb coefficients μ > 0,
:func:`daebench.core.kernels.tangent`): each linearization solves one LCP for the normal
and tangential impulses together — the planar Coulomb cone, exact in 2-D
(:mod:`daebench.stepping.friction`, Lemke's method); the tangential impulses P_T then act
through the tangent rows as the normal ones through g_q. The contact work booked adds
Σ P_T (U_T⁻ + U_T⁺)/2 (friction's dissipation). Without friction the path above is
unchanged (Murty's solver on the normal impulses only). With friction a contact resting
at g = 0 is kept in the index set when round-off makes its predicted gap slightly
positive (≤ ACTIVATION_ROUNDOFF · max(1, |q|)): a one-step lapse would drop that step's
friction impulse (a velocity error μ g h, a position error that stays).

Projection (``projection``, Siconos' MoreauJeanCombinedProjectionOSI): after the step,
positions with a negative gap are projected onto g ≥ 0 along the mass metric,
q = q̃ + M⁻¹ g_qᵀ μ with 0 ≤ g(q) ⟂ μ ≥ 0 (Newton–LCP, M at q̃), velocities untouched —
no penetration, at the price of a small energy change.

The state handed on: ``a`` = (v_{k+1} − v_k)/h (impulse included). Per-contact impulses
go to the episode book (:mod:`daebench.stepping.episodes`). Analysis and references:
:class:`daebench.integrators.moreau.MoreauJean`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels, phase
from daebench.stepping import episodes as _ep
from daebench.core.lcp import LcpWork, lcp_work, solve_lcp
from daebench.core.linalg import factor_flagged, lu_factor, lu_solve
from daebench.stepping import friction as _fr
from daebench.stepping import methods
from daebench.stepping.methods import C_JAC, C_LU, C_NEWTON, C_RES

NEWTON_RATE_REFRESH = 0.1   # contraction rate above which a reused S is rebuilt
PROJECTION_MAXITER = 20     # Newton–LCP iterations of the position projection
ACTIVATION_ROUNDOFF = 1e-12  # with friction: a predicted gap ≤ this × max(1, |q|) is closed

ST_NOT_FINITE, ST_NEWTON, ST_SINGULAR, ST_LCP, ST_PROJECTION, ST_FRICTION_LCP = 1, 2, 3, 4, 5, 6
FAIL_MESSAGES = {
    ST_NOT_FINITE: "non-finite state in the Moreau–Jean iteration",
    ST_NEWTON: "Newton–LCP did not converge in {newton_maxiter} iterations",
    ST_SINGULAR: "singular iteration matrix M − hθ∂Q/∂v − h²θ²∂Q/∂q",
    ST_LCP: "contact LCP unsolvable (dependent contact Jacobians?)",
    ST_FRICTION_LCP: "frictional contact LCP without a solution (Lemke's method ended on a ray): an "
                     "inconsistent or indeterminate frictional contact (Painlevé's paradox)",
    ST_PROJECTION: "position projection onto g ≥ 0 did not converge",
}
W_LU, W_LUH, W_A0, W_G0 = range(4)  # ws.st (W_LU, W_LUH first: linalg.factor_flagged): S factorized, its h; a = M⁻¹Q and gaps at the step start known


class MoreauMethod(NamedTuple):
    theta: float        # θ of the smooth part, ½ … 1
    gamma: float        # activation: g + γ h ġ ≤ 0 at the step's start
    e: float            # Newton restitution
    projection: bool    # project positions onto g ≥ 0 after each step
    tol: float          # Newton tolerance (scaled displacement increment)
    maxiter: int
    reuse: bool         # keep S across iterations and steps
    friction: bool      # the model's contacts have μ > 0: the frictional LCP (stepping.friction)


class MoreauWork(NamedTuple):
    st: np.ndarray
    LU: np.ndarray
    piv: np.ndarray
    M: np.ndarray
    Kq: np.ndarray
    Kv: np.ndarray
    a0: np.ndarray      # n: the smooth acceleration M⁻¹Q at the step's start
    a1: np.ndarray      # n: … at the proposed step's end (the next start)
    Q1: np.ndarray
    q1: np.ndarray
    v1: np.ndarray
    vfree: np.ndarray
    r: np.ndarray
    tmp: np.ndarray
    G: np.ndarray       # nc × n: gap Jacobians at the iterate
    gq: np.ndarray      # n: one row (scratch)
    g0: np.ndarray      # nc: gaps and ġ at the step's start
    gd0: np.ndarray
    g1: np.ndarray      # nc: gaps and ġ at the proposed step's end (the next start)
    gd1: np.ndarray
    apred: np.ndarray   # n: impulse-free (v_{k+1} − v_k)/h of the last step: the predictor
    active: np.ndarray  # bool nc: the index set I
    SG: np.ndarray      # n × nc: S⁻¹ g_qᵀ
    A: np.ndarray       # nc × nc
    b: np.ndarray
    P: np.ndarray
    w: np.ndarray
    z: np.ndarray
    lcp: LcpWork
    LUm: np.ndarray     # projection: M(q̃) factorized, q̃, μ, all-contacts mask
    pivm: np.ndarray
    qt: np.ndarray
    allc: np.ndarray
    ep: _ep.Episodes
    fr: _fr.FrictionWork


def workspace(n: int, nc: int, steps_per_call: int) -> MoreauWork:
    k = max(nc, 1)
    z = np.zeros
    per_n = ("a0", "a1", "Q1", "q1", "v1", "vfree", "r", "tmp", "gq", "apred", "qt")
    per_k = ("g0", "gd0", "g1", "gd1", "b", "P", "w", "z")
    return MoreauWork(st=z(4), LU=z((n, n)), piv=z(n, np.int64), M=z((n, n)), Kq=z((n, n)), Kv=z((n, n)),
                      G=z((k, n)), active=z(k, np.bool_), SG=z((n, k)), A=z((k, k)), lcp=lcp_work(k),
                      LUm=z((n, n)), pivm=z(n, np.int64), allc=np.ones(k, np.bool_),
                      ep=_ep.episodes(n, nc, steps_per_call), fr=_fr.friction_work(n, nc), **{f: z(n) for f in per_n}, **{f: z(k) for f in per_k})


@njit(cache=True)
def _start(meth, ws, ph, t, cur, cnt):
    ws.st[:] = 0.0
    _ep.reset(ws.ep)
    return 0


@njit(cache=True)
def _mass_solve(ws, x):
    """x ← M⁻¹x with M in ws.LUm (factorized here); returns 1 if M is singular."""
    if lu_factor(ws.LUm, ws.pivm) != 0:
        return 1
    lu_solve(ws.LUm, ws.pivm, x)
    return 0


@njit(cache=True)
def _lcp_matrix(ws, nc, n, use):
    """A = G S⁻¹ Gᵀ on the rows ``use`` (S⁻¹Gᵀ into ws.SG)."""
    for j in range(nc):
        if not use[j]:
            continue
        col = ws.tmp
        for r in range(n):
            col[r] = ws.G[j, r]
        lu_solve(ws.LU, ws.piv, col)
        for r in range(n):
            ws.SG[r, j] = col[r]
    for i in range(nc):
        for j in range(nc):
            s = 0.0
            if use[i] and use[j]:
                for r in range(n):
                    s += ws.G[i, r] * ws.SG[r, j]
            ws.A[i, j] = s


@njit(cache=True)
def _factor(meth, ws, ph, n, t1, h, q1, v1, cnt):
    phase.force_jacobian(ph, t1, q1, v1, ws.Kq, ws.Kv)
    cnt[C_JAC] += 1
    th = meth.theta
    for i in range(n):
        for j in range(n):
            ws.LU[i, j] = ws.M[i, j] - h * th * ws.Kv[i, j] - (h * th) ** 2 * ws.Kq[i, j]
    cnt[C_LU] += 1
    return ST_SINGULAR if factor_flagged(ws.LU, ws.piv, ws.st, h) != 0 else 0   # st[W_LU], st[W_LUH]


@njit(cache=True)
def _positions(meth, q, v, v1, h, q1):
    th = meth.theta
    for i in range(q.shape[0]):
        q1[i] = q[i] + h * ((1.0 - th) * v[i] + th * v1[i])


@njit(cache=True)
def _project(meth, ws, ph, t1, n, nc, q, cnt):
    """Project q onto g ≥ 0 in the metric M(q̃) (in place); returns a status."""
    neg = False
    for i in range(nc):
        g, _ = kernels.gap(ph.model, i, q, ws.v1, ws.gq)
        if g < 0.0:
            neg = True
    if not neg:
        return 0
    ws.qt[:] = q
    phase.mass_force(ph, t1, q, ws.v1, ws.LUm, ws.tmp)
    cnt[C_RES] += 1
    if lu_factor(ws.LUm, ws.pivm) != 0:
        return ST_SINGULAR
    cnt[C_LU] += 1
    qscale = 1.0
    for j in range(n):
        qscale = max(qscale, abs(q[j]))
    gtol = meth.tol * qscale
    for it in range(PROJECTION_MAXITER):
        worst = 0.0
        for i in range(nc):
            g, _ = kernels.gap(ph.model, i, q, ws.v1, ws.G[i])
            d = 0.0
            for j in range(n):
                d += ws.G[i, j] * (ws.qt[j] - q[j])
            ws.b[i] = g + d
            worst = min(worst, g)
        if it > 0 and worst >= -gtol:
            return 0
        for j in range(nc):
            for r in range(n):
                ws.tmp[r] = ws.G[j, r]
            lu_solve(ws.LUm, ws.pivm, ws.tmp)
            for r in range(n):
                ws.SG[r, j] = ws.tmp[r]
        for i in range(nc):
            for j in range(nc):
                s = 0.0
                for r in range(n):
                    s += ws.G[i, r] * ws.SG[r, j]
                ws.A[i, j] = s
        if solve_lcp(ws.A, ws.b, ws.allc, ws.z, ws.w, ws.lcp) < 0:
            return ST_LCP
        for r in range(n):
            s = ws.qt[r]
            for j in range(nc):
                s += ws.SG[r, j] * ws.z[j]
            q[r] = s
    return ST_PROJECTION


@njit(cache=True)
def _step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    n = cur.q.shape[0]
    nc = ph.engaged.shape[0]
    th = meth.theta
    t1 = t + h
    q, v = cur.q, cur.v
    q1, v1, r, vfree = ws.q1, ws.v1, ws.r, ws.vfree
    # the index set, from the state at the step's start (the last step's end when known);
    # with friction a round-off gap counts as closed (module docstring)
    thr = 0.0
    if meth.friction:
        for j in range(n):
            thr = max(thr, abs(q[j]))
        thr = ACTIVATION_ROUNDOFF * max(1.0, thr)
    for i in range(nc):
        if ws.st[W_G0] == 0.0:
            ws.g0[i], _ = kernels.gap(ph.model, i, q, v, ws.gq)
            gd = 0.0
            for j in range(n):
                gd += ws.gq[j] * v[j]
            ws.gd0[i] = gd
        ws.active[i] = ws.g0[i] + meth.gamma * h * ws.gd0[i] <= thr
    if th < 1.0 and ws.st[W_A0] == 0.0:
        phase.mass_force(ph, t, q, v, ws.LUm, ws.a0)
        cnt[C_RES] += 1
        if _mass_solve(ws, ws.a0):
            return ST_SINGULAR, 0.0
    if ws.st[W_LU] != 0.0 and (not meth.reuse or max(h / ws.st[W_LUH], ws.st[W_LUH] / h) > 2.0):
        ws.st[W_LU] = 0.0
    for i in range(n):
        v1[i] = v[i] + h * ws.apred[i]
    for i in range(nc):
        ws.P[i] = 0.0
    d_prev = 0.0
    fresh = False
    converged = False
    it = 0
    while it < meth.maxiter:
        it += 1
        _positions(meth, q, v, v1, h, q1)
        phase.mass_force(ph, t1, q1, v1, ws.M, ws.Q1)
        cnt[C_RES] += 1
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += ws.M[i, j] * (v1[j] - v[j] - h * (1.0 - th) * ws.a0[j])
            s -= h * th * ws.Q1[i]
            if not math.isfinite(s):
                return ST_NOT_FINITE, 0.0
            r[i] = s
        if ws.st[W_LU] == 0.0:
            st = _factor(meth, ws, ph, n, t1, h, q1, v1, cnt)
            if st:
                return st, 0.0
            fresh = True
        lu_solve(ws.LU, ws.piv, r)
        cnt[C_NEWTON] += 1
        for i in range(n):
            vfree[i] = v1[i] - r[i]
            ws.apred[i] = (vfree[i] - v[i]) / h
        any_active = False
        for i in range(nc):
            if ws.active[i]:
                any_active = True
        if any_active and meth.friction:
            st = _fr.impulses(ph.model, ws.fr, ws.G, ws.active, ws.LU, ws.piv, n, nc, q1, v1, v, vfree,
                              meth.e, ws.P)
            if st < 0:
                return ST_FRICTION_LCP, 0.0
        elif any_active:
            for i in range(nc):
                kernels.gap(ph.model, i, q1, v1, ws.G[i])
            _lcp_matrix(ws, nc, n, ws.active)
            for i in range(nc):
                s = 0.0
                s0 = 0.0
                for j in range(n):
                    s += ws.G[i, j] * vfree[j]
                    s0 += ws.G[i, j] * v[j]
                ws.b[i] = s + meth.e * s0
            if solve_lcp(ws.A, ws.b, ws.active, ws.P, ws.w, ws.lcp) < 0:
                return ST_LCP, 0.0
            for i in range(n):
                s = vfree[i]
                for j in range(nc):
                    if ws.active[j]:
                        s += ws.SG[i, j] * ws.P[j]
                vfree[i] = s
        qscale = 1.0
        d = 0.0
        for i in range(n):
            qscale = max(qscale, abs(q1[i]))
            d = max(d, abs(vfree[i] - v1[i]))
            v1[i] = vfree[i]
        d = h * d / qscale
        if not math.isfinite(d):
            return ST_NOT_FINITE, 0.0
        rate = d / d_prev if d_prev > 0.0 else 0.0
        if d <= meth.tol or (d_prev > 0.0 and rate < 1.0 and rate / (1.0 - rate) * d <= meth.tol):
            converged = True
            break
        if d_prev > 0.0 and rate > NEWTON_RATE_REFRESH and not fresh:
            ws.st[W_LU] = 0.0  # a stale S: rebuild it and go on
        d_prev = d
    if not converged:
        ws.st[W_LU] = 0.0
        return ST_NEWTON, 0.0
    _positions(meth, q, v, v1, h, new.q)
    for i in range(n):
        new.v[i] = v1[i]
        new.a[i] = (v1[i] - v[i]) / h
    if th < 1.0 and not meth.projection:
        # a_{k+1} = M⁻¹Q of the last iterate (within the Newton tolerance of the solution)
        ws.LUm[:, :] = ws.M
        ws.a1[:] = ws.Q1
        if _mass_solve(ws, ws.a1):
            return ST_SINGULAR, 0.0
    if meth.projection:
        st = _project(meth, ws, ph, t1, n, nc, new.q, cnt)
        if st:
            return st, 0.0
    work = 0.0
    for i in range(nc):
        wi, um = 0.0, 0.0
        if ws.active[i] and ws.P[i] > 0.0:
            u = 0.0
            for j in range(n):
                u += ws.G[i, j] * (v[j] + v1[j])
                um += ws.G[i, j] * v[j]
            wi = 0.5 * ws.P[i] * u
        ws.ep.cwork[i, 0] = wi
        ws.ep.cwork[i, 1] = um
        work += wi
    if meth.friction:
        work += _fr.tangential_work(ws.fr, ws.active, nc, n, v, v1, ws.ep.cwork)
    _ep.propose_work(ws.ep, work)
    for i in range(nc):
        ws.g1[i], _ = kernels.gap(ph.model, i, new.q, new.v, ws.gq)
        gd = 0.0
        for j in range(n):
            gd += ws.gq[j] * new.v[j]
        ws.gd1[i] = gd
        imp = ws.P[i] if ws.active[i] else 0.0
        _ep.propose(ws.ep, i, t, imp > 0.0, imp, ws.g0[i], ws.g1[i], ws.gd0[i])
    return 0, 0.0


@njit(cache=True)
def _accept(meth, ws, h, prev, cur):
    _ep.commit(ws.ep, ws.ep.step.shape[0], prev, cur)
    ws.g0[:] = ws.g1
    ws.gd0[:] = ws.gd1
    ws.st[W_G0] = 1.0
    # a_{k+1} of the last iterate starts the next step; a projection moved q: evaluate again
    if meth.projection or meth.theta == 1.0:
        ws.st[W_A0] = 0.0
    else:
        ws.a0[:] = ws.a1
        ws.st[W_A0] = 1.0


methods.start.register(MoreauMethod, _start)
methods.step.register(MoreauMethod, _step)
methods.accept.register(MoreauMethod, _accept)
