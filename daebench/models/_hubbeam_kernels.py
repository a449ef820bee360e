"""Compiled per-evaluation kernels of the hub–beam model (numba, plain float64 arrays).

Everything here is a pure function of arrays so that compiled integrator loops can
call it directly. The physics and notation are those of :mod:`daebench.models.hubbeam`:
q = (θ, A, B), quadrature weights ``wm`` already multiplied by ρS, point-contiguous
tables ``phx`` (nA, nq), ``phy`` (nB, nq), ``H`` (nB, nB, nq) (ignored when ``fore == 0``).

The parameter vector ``prm`` holds, by index (see ``P_*`` below):
hub radius a, hub inertia J_h, gravity g (0 = off), torque τ0, torque period T,
torque on (0/1), damping β, plane height h0, ∫ρS (a + x) dx.

Per-evaluation cost with foreshortening: O(nq·nB²) for a fixed number nq of
quadrature points; without it O(nq·n).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from daebench.core import kernels as _kernels

# Reassociation and fused multiply-add only (SIMD reductions); no "no-NaN/no-inf"
# assumptions, so a diverging run still shows NaN/inf instead of garbage.
FASTMATH = {"reassoc", "contract"}

P_A, P_JH, P_G, P_TAU0, P_T, P_TORQUE, P_BETA, P_H0, P_M1 = range(9)
N_PRM = 9


@njit(cache=True, fastmath=FASTMATH)
def torque(t: float, prm: np.ndarray) -> float:
    """τ(t) = τ0 sin(2πt/T) for t ≤ T, 0 after (0 when the torque is off)."""
    if prm[P_TORQUE] == 0.0 or t > prm[P_T]:
        return 0.0
    return prm[P_TAU0] * math.sin(2.0 * math.pi * t / prm[P_T])


@njit(cache=True, fastmath=FASTMATH)
def mass_force(t, q, v, prm, fore, xs, wm, phx, phy, H, Mc, K1, K2, phx_bar, phy_bar, Hbar,
               want_m, M, Q, work):
    """Fill M(q) (when ``want_m``) and the applied force Q(t, q, v) (no contact).

    Tables are point-contiguous: ``phx`` (nA, nq), ``phy`` (nB, nq), ``H`` (nB, nB, nq),
    so every inner loop runs over the quadrature points and vectorizes. ``Mc`` is the
    constant part of M (J_h, ∫ρS ΦxᵀΦx, ∫ρS ΦyᵀΦy); ``work`` is scratch of shape
    (nB + 8, nq). M and Q are overwritten.
    """
    nq = xs.shape[0]
    nA = phx.shape[0]
    nB = phy.shape[0]
    n = 1 + nA + nB
    iA = 1
    iB = 1 + nA
    a = prm[P_A]
    thd = v[0]
    for i in range(n):
        Q[i] = 0.0
    if want_m:
        for i in range(n):
            for j in range(n):
                M[i, j] = 0.0
    # per-point fields, each a row of work
    p1 = work[nB]
    p2 = work[nB + 1]
    pd1 = work[nB + 2]
    pd2 = work[nB + 3]
    c0 = work[nB + 4]
    c1 = work[nB + 5]
    bdhbd = work[nB + 6]  # Ḃᵀ H Ḃ
    tmp = work[nB + 7]
    for k in range(nq):
        p1[k] = a + xs[k]
        p2[k] = 0.0
        pd1[k] = 0.0
        pd2[k] = 0.0
        bdhbd[k] = 0.0
    for i in range(nA):
        qi = q[iA + i]
        vi = v[iA + i]
        for k in range(nq):
            p1[k] += phx[i, k] * qi
            pd1[k] += phx[i, k] * vi
    for i in range(nB):
        qi = q[iB + i]
        vi = v[iB + i]
        for k in range(nq):
            p2[k] += phy[i, k] * qi
            pd2[k] += phy[i, k] * vi
    if fore:
        # hb[i, k] = (H_k B)_i (rows 0..nB−1 of work), p1 −= ½ BᵀHB, ṗ1 −= (HB)ᵀḂ
        for i in range(nB):
            hb = work[i]
            for k in range(nq):
                hb[k] = 0.0
            for j in range(nB):
                qj = q[iB + j]
                wij = v[iB + i] * v[iB + j]
                for k in range(nq):
                    h = H[i, j, k]
                    hb[k] += h * qj
                    bdhbd[k] += h * wij
            qi = q[iB + i]
            vi = v[iB + i]
            for k in range(nq):
                p1[k] -= 0.5 * qi * hb[k]
                pd1[k] -= vi * hb[k]
    # r̈ = R (G q̈ + c),  c = −θ̇² p + 2θ̇ E ṗ + [−ḂᵀHḂ, 0];  G = [[−p2, Φx, −(HB)ᵀ], [p1, 0, Φy]]
    s0 = 0.0
    for k in range(nq):
        c0[k] = wm[k] * (-thd * thd * p1[k] - 2.0 * thd * pd2[k] - bdhbd[k])  # weighted
        c1[k] = wm[k] * (-thd * thd * p2[k] + 2.0 * thd * pd1[k])
        s0 += -p2[k] * c0[k] + p1[k] * c1[k]
    Q[0] -= s0
    for i in range(nA):
        s0 = 0.0
        for k in range(nq):
            s0 += phx[i, k] * c0[k]
        Q[iA + i] -= s0
    for i in range(nB):
        s0 = 0.0
        for k in range(nq):
            s0 += phy[i, k] * c1[k]
        if fore:
            hb = work[i]
            for k in range(nq):
                s0 -= hb[k] * c0[k]
        Q[iB + i] -= s0
    if want_m:
        s0 = 0.0
        for k in range(nq):
            s0 += wm[k] * (p1[k] * p1[k] + p2[k] * p2[k])
            tmp[k] = wm[k] * p2[k]
        M[0, 0] += s0
        for i in range(nA):
            s0 = 0.0
            for k in range(nq):
                s0 += tmp[k] * phx[i, k]
            M[0, iA + i] -= s0
        for i in range(nB):
            s0 = 0.0
            for k in range(nq):
                s0 += wm[k] * p1[k] * phy[i, k]
            if fore:
                hb = work[i]
                for k in range(nq):
                    s0 += tmp[k] * hb[k]
            M[0, iB + i] += s0
        if fore:
            for j in range(nB):
                hbj = work[j]
                for k in range(nq):
                    tmp[k] = wm[k] * hbj[k]
                for i in range(nA):
                    s0 = 0.0
                    for k in range(nq):
                        s0 += phx[i, k] * tmp[k]
                    M[iA + i, iB + j] -= s0
                for i in range(j + 1):
                    hbi = work[i]
                    s0 = 0.0
                    for k in range(nq):
                        s0 += hbi[k] * tmp[k]
                    M[iB + i, iB + j] += s0
        for i in range(n):
            for j in range(i + 1, n):
                M[j, i] = M[i, j]
        for i in range(n):
            for j in range(n):
                M[i, j] += Mc[i, j]
    # -- elastic and structural damping ------------------------------------------
    beta = prm[P_BETA]
    for i in range(nA):
        s = 0.0
        for j in range(nA):
            s += K1[i, j] * (q[iA + j] + beta * v[iA + j])
        Q[iA + i] -= s
    for i in range(nB):
        s = 0.0
        for j in range(nB):
            s += K2[i, j] * (q[iB + j] + beta * v[iB + j])
        Q[iB + i] -= s
    # -- gravity: V_g = g (sinθ P1 + cosθ P2), P1 = ∫ρS p1, P2 = ∫ρS p2 ------------
    g = prm[P_G]
    if g != 0.0:
        st = math.sin(q[0])
        ct = math.cos(q[0])
        P1 = prm[P_M1]
        for i in range(nA):
            P1 += phx_bar[i] * q[iA + i]
        P2 = 0.0
        for i in range(nB):
            P2 += phy_bar[i] * q[iB + i]
        for i in range(nB):
            Q[iB + i] -= g * ct * phy_bar[i]
        if fore:
            for i in range(nB):
                s = 0.0
                for j in range(nB):
                    s += Hbar[i, j] * q[iB + j]
                P1 -= 0.5 * q[iB + i] * s  # P1 = ∫ρS p1 includes −½ BᵀH̄B
                Q[iB + i] += g * st * s
        Q[0] -= g * (ct * P1 - st * P2)
        for i in range(nA):
            Q[iA + i] -= g * st * phx_bar[i]
    # -- drive torque ------------------------------------------------------------------
    Q[0] += torque(t, prm)


@njit(cache=True, fastmath=FASTMATH)
def point_kinematics(q, v, prm, fore, xp, phx_p, phy_p, H_p, G0, G1):
    """Position, velocity, field Jacobian G and c at one material point.

    Fills ``G0``, ``G1`` (the rows of G, length n) and returns
    (p1, p2, ṗ1, ṗ2, c0, c1) in the floating frame.
    """
    nA = phx_p.shape[0]
    nB = phy_p.shape[0]
    iA = 1
    iB = 1 + nA
    thd = v[0]
    p1 = prm[P_A] + xp
    pd1 = 0.0
    p2 = 0.0
    pd2 = 0.0
    bdhbd = 0.0
    G0[0] = 0.0
    G1[0] = 0.0
    for i in range(nA):
        p1 += phx_p[i] * q[iA + i]
        pd1 += phx_p[i] * v[iA + i]
        G0[iA + i] = phx_p[i]
        G1[iA + i] = 0.0
    for i in range(nB):
        p2 += phy_p[i] * q[iB + i]
        pd2 += phy_p[i] * v[iB + i]
        G1[iB + i] = phy_p[i]
        hbi = 0.0
        hbdi = 0.0
        if fore:
            for j in range(nB):
                hbi += H_p[i, j] * q[iB + j]
                hbdi += H_p[i, j] * v[iB + j]
        G0[iB + i] = -hbi
        p1 -= 0.5 * q[iB + i] * hbi
        pd1 -= hbi * v[iB + i]
        bdhbd += v[iB + i] * hbdi
    G0[0] = -p2
    G1[0] = p1
    c0 = -thd * thd * p1 - 2.0 * thd * pd2 - bdhbd
    c1 = -thd * thd * p2 + 2.0 * thd * pd1
    return p1, p2, pd1, pd2, c0, c1


@njit(cache=True, fastmath=FASTMATH)
def gap_kernel(q, v, prm, fore, xp, phx_p, phy_p, H_p, gq, G1):
    """Gap g = e_Yᵀ R p + h0, its Jacobian (into ``gq``) and γ_g = −e_Yᵀ R c.
    ``G1`` is scratch of length n."""
    p1, p2, pd1, pd2, c0, c1 = point_kinematics(q, v, prm, fore, xp, phx_p, phy_p, H_p, gq, G1)
    st = math.sin(q[0])
    ct = math.cos(q[0])
    for i in range(gq.shape[0]):
        gq[i] = st * gq[i] + ct * G1[i]  # e_Yᵀ R G = [sinθ, cosθ] G
    g = st * p1 + ct * p2 + prm[P_H0]
    gamma = -(st * c0 + ct * c1)
    return g, gamma


@njit(cache=True)
def _quadratic(K, x, off, k):
    """xᵀKx over x[off:off + k] (the sum over i of x_i times row i of K times x)."""
    s = 0.0
    for i in range(k):
        r = 0.0
        for j in range(k):
            r += K[i, j] * x[off + j]
        s += x[off + i] * r
    return s


#: the observables :func:`output_rows` writes, by column (then ``gap`` with a contact, then
#: W1 … WnB with cantilever modes)
OBS_FIXED = ("theta_deg", "omega", "tip_x", "tip_y", "tip_w2")
#: the energy terms it writes, by column (the contact potential is the contact law's)
ENERGY_TERMS = ("kinetic", "elastic", "gravity")


@njit(cache=True)
def output_rows(t, qs, vs, md, prm, fore, K1, K2, phx_bar, phy_bar, Hbar, tip, phx_t, phy_t, H_t, gap_on, modes,
                obs, energy):
    """Observables and energy terms of the states ``qs[r]``, ``vs[r]`` (one row each):
    the model's only formulas for them (:meth:`daebench.models.hubbeam.HubBeam.output_rows`;
    its ``energy`` and ``observables`` are one row of it).

    ``obs[r]``: θ in degrees, θ̇, the tip's inertial position r(L) = R(θ) p(L), its
    deflection w2(L) = Φy(L)·B, then the gap (``gap_on``) and the modal participations
    W_i = Φy_i(L) B_i / Σ_j |Φy_j(L) B_j| (``modes``). ``energy[r]``: T = ½ q̇ᵀM(q)q̇,
    U = ½(AᵀK1A + BᵀK2B), V_g = g (sinθ P1 + cosθ P2) with P1 = ∫ρS p1 =
    ∫ρS (a + x) + Φ̄x·A − ½ BᵀH̄B, P2 = Φ̄y·B. M(q) and the gap come from the model's
    registered kernels through its handle ``md`` (:func:`daebench.core.kernels.mass_force`,
    :func:`~daebench.core.kernels.gap`: the same compiled code as every other caller's,
    called through its address, so this function does not compile them again — it did,
    at 6.9 s of CPU, when it called :func:`mass_force` directly); the tip's tables
    (``tip``, ``phx_t``, ``phy_t``, ``H_t``) as for :func:`point_kinematics`. Compiled
    without fast-math: the observables are those of the earlier Python formulas to the
    last bit.
    """
    n = qs.shape[1]
    nA = phx_t.shape[0]
    nB = phy_t.shape[0]
    iA = 1
    iB = 1 + nA
    M = np.empty((n, n))
    Q = np.empty(n)
    G0 = np.empty(n)
    G1 = np.empty(n)
    zeros = np.zeros(n)
    g = prm[P_G]
    for r in range(qs.shape[0]):
        q = qs[r]
        v = vs[r]
        o = obs[r]
        th = q[0]
        o[0] = math.degrees(th)
        o[1] = v[0]
        p1, p2, _, _, _, _ = point_kinematics(q, zeros, prm, fore, tip, phx_t, phy_t, H_t, G0, G1)
        c = math.cos(th)
        s = math.sin(th)
        o[2] = c * p1 - s * p2
        o[3] = s * p1 + c * p2
        w2 = 0.0
        for i in range(nB):
            w2 += phy_t[i] * q[iB + i]
        o[4] = w2
        col = 5
        if gap_on:
            gp, _ = _kernels.gap(md, 0, q, zeros, G0)
            o[col] = gp
            col += 1
        if modes:
            total = 0.0
            for i in range(nB):
                total += abs(phy_t[i] * q[iB + i])
            for i in range(nB):
                o[col + i] = phy_t[i] * q[iB + i] / total if total > 0.0 else 0.0
        # -- energy terms ----------------------------------------------------------------------
        _kernels.mass_force(md, 0.0, q, zeros, M, Q)
        e = energy[r]
        e[0] = 0.5 * _quadratic(M, v, 0, n)
        e[1] = 0.5 * (_quadratic(K1, q, iA, nA) + _quadratic(K2, q, iB, nB))
        e[2] = 0.0
        if g != 0.0:
            P1 = prm[P_M1]
            for i in range(nA):
                P1 += phx_bar[i] * q[iA + i]
            if fore:
                P1 -= 0.5 * _quadratic(Hbar, q, iB, nB)
            P2 = 0.0
            for i in range(nB):
                P2 += phy_bar[i] * q[iB + i]
            e[2] = g * (s * P1 + c * P2)
