"""The continuous contact forces of a phase's engaged, penetrating contacts (g_qᵀF_N + t_qᵀF_T),
their power and their Jacobian by central differences; a phase without a continuous law
(``law`` None) compiles none of it."""

from __future__ import annotations

from daebench.core import kernels
from daebench.core.borrow import copy_to, uncounted
from daebench.core.kernels import fd_step
from daebench.core.phase.laws import friction_force, law_force


@uncounted
def contact_force(ph, i, q, v, gq, tq, fric=True):
    """(g_i, F_N,i, F_T,i) at (q, v); g_q,i left in gq, the tangent row in tq (zero
    without friction; with ``fric`` False the tangent kernel is not called, tq not
    written and F_T = 0)."""
    g, _ = kernels.gap(ph.model, i, q, v, gq)
    gdot = 0.0
    for j in range(q.shape[0]):
        gdot += gq[j] * v[j]
    fn = law_force(ph.law, ph.engaged[i] != 0.0, ph.chi[i], g, gdot)
    if not fric:
        return g, fn, 0.0
    mu = kernels.tangent(ph.model, i, q, v, tq)
    if mu == 0.0 or fn == 0.0:
        return g, fn, 0.0
    vt = 0.0
    for j in range(q.shape[0]):
        vt += tq[j] * v[j]
    return g, fn, friction_force(ph.law, mu, fn, vt)


@uncounted
def force_without_slip(ph, t, q, v, M, Q):
    """M(q) and the phase's force without the slip friction of closed contacts."""
    kernels.mass_force(ph.model, t, q, v, M, Q)
    add_contact_forces(ph.law, ph, q, v, Q)


@uncounted
def add_contact_forces(law, ph, q, v, Q):
    """Q += g_qᵀF_N + t_qᵀF_T of the engaged, penetrating contacts (``law`` None: no
    continuous law, nothing compiled)."""
    if law is None:
        return
    n = q.shape[0]
    gq, tq = ph.gq, ph.work[3 * n:4 * n]
    for i in range(ph.engaged.shape[0]):
        if ph.engaged[i] != 0.0:
            g, F, FT = contact_force(ph, i, q, v, gq, tq)
            if g < 0.0:
                for j in range(n):
                    Q[j] += gq[j] * F + tq[j] * FT


@uncounted
def friction_power(ph, q, v):
    """Σ F_T,i v_T,i ≤ 0: the power of the regularised friction forces (the friction
    work's rate, booked with the contact dissipation)."""
    return _friction_power(ph.law, ph, q, v)


@uncounted
def _friction_power(law, ph, q, v):
    if law is None:
        return 0.0
    n = q.shape[0]
    gq, tq = ph.gq, ph.work[3 * n:4 * n]
    P = 0.0
    for i in range(ph.engaged.shape[0]):
        if ph.engaged[i] != 0.0:
            g, _, FT = contact_force(ph, i, q, v, gq, tq)
            if g < 0.0 and FT != 0.0:
                for j in range(n):
                    P += FT * tq[j] * v[j]
    return P


@uncounted
def has_law(ph):
    """Whether the phase has a continuous contact law (its data's ``law`` is None without)."""
    return _has_law(ph.law)


@uncounted
def _has_law(law):
    if law is None:
        return False
    return True


@uncounted
def add_contact_jacobian(law, ph, q, v, Kq, Kv):
    """Central differences of each engaged, penetrating contact force, added to Kq, Kv."""
    if law is None:
        return
    n = q.shape[0]
    xp, gp, gm = ph.work[:n], ph.work[n:2 * n], ph.work[2 * n:3 * n]
    tp, tm = ph.work[3 * n:4 * n], ph.work[4 * n:5 * n]
    for i in range(ph.engaged.shape[0]):
        if ph.engaged[i] == 0.0:
            continue
        g0, _, _ = contact_force(ph, i, q, v, gp, tp, False)
        if not g0 < 0.0:
            continue
        fric = kernels.tangent(ph.model, i, q, v, tp) != 0.0   # μ_i: a frictionless contact skips the rows
        for wrt_v in (False, True):
            x = v if wrt_v else q
            K = Kv if wrt_v else Kq
            for j in range(n):
                dx = fd_step(x[j])
                copy_to(xp, x)
                xp[j] = x[j] + dx
                g1, F1, T1 = contact_force(ph, i, q if wrt_v else xp, xp if wrt_v else v, gp, tp, fric)
                xp[j] = x[j] - dx
                g2, F2, T2 = contact_force(ph, i, q if wrt_v else xp, xp if wrt_v else v, gm, tm, fric)
                for r in range(n):
                    fp = gp[r] * F1 + (tp[r] * T1 if fric else 0.0) if g1 < 0.0 else 0.0
                    fm = gm[r] * F2 + (tm[r] * T2 if fric else 0.0) if g2 < 0.0 else 0.0
                    K[r, j] = K[r, j] + (fp - fm) / (2.0 * dx)
