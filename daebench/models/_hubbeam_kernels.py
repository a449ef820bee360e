"""Compiled per-evaluation kernels of the hub–beam model (numba, plain float64 arrays).

Everything here is a pure function of arrays so that compiled integrator loops can
call it directly. The physics and notation are those of :mod:`daebench.models.hubbeam`:
q = (θ, A, B), quadrature weights ``wm`` already multiplied by ρS, tables
``phx`` (nq, nA), ``phy`` (nq, nB), ``H`` (nq, nB, nB) (ignored when ``fore == 0``).

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

P_A, P_JH, P_G, P_TAU0, P_T, P_TORQUE, P_BETA, P_H0, P_M1 = range(9)
N_PRM = 9


@njit(cache=True)
def torque(t: float, prm: np.ndarray) -> float:
    """τ(t) = τ0 sin(2πt/T) for t ≤ T, 0 after (0 when the torque is off)."""
    if prm[P_TORQUE] == 0.0 or t > prm[P_T]:
        return 0.0
    return prm[P_TAU0] * math.sin(2.0 * math.pi * t / prm[P_T])


@njit(cache=True)
def mass_force(t, q, v, prm, fore, xs, wm, phx, phy, H, Mc, K1, K2, phx_bar, phy_bar, Hbar,
               want_m, M, Q, hb):
    """Fill M(q) (when ``want_m``) and the applied force Q(t, q, v) (no contact).

    ``Mc`` is the constant part of M (J_h, ∫ρS ΦxᵀΦx, ∫ρS ΦyᵀΦy); ``hb`` is scratch of
    length nB. M and Q are overwritten.
    """
    nq = xs.shape[0]
    nA = phx.shape[1]
    nB = phy.shape[1]
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
    for i in range(nB):
        hb[i] = 0.0
    # -- inertia: M = ∫ρS GᵀG (variable part), Q_v = −∫ρS Gᵀc -----------------
    for k in range(nq):
        w = wm[k]
        xa = 0.0
        xad = 0.0
        for i in range(nA):
            xa += phx[k, i] * q[iA + i]
            xad += phx[k, i] * v[iA + i]
        yb = 0.0
        ybd = 0.0
        for i in range(nB):
            yb += phy[k, i] * q[iB + i]
            ybd += phy[k, i] * v[iB + i]
        bhb = 0.0    # Bᵀ H B
        bdhbd = 0.0  # Ḃᵀ H Ḃ
        hbbd = 0.0   # (H B)ᵀ Ḃ
        if fore:
            for i in range(nB):
                s1 = 0.0
                s2 = 0.0
                for j in range(nB):
                    h = H[k, i, j]
                    s1 += h * q[iB + j]
                    s2 += h * v[iB + j]
                hb[i] = s1
                bhb += q[iB + i] * s1
                bdhbd += v[iB + i] * s2
                hbbd += s1 * v[iB + i]
        p1 = a + xs[k] + xa - 0.5 * bhb
        p2 = yb
        pd1 = xad - hbbd
        pd2 = ybd
        # r̈ = R (G q̈ + c),  c = −θ̇² p + 2θ̇ E ṗ + [−ḂᵀHḂ, 0]
        c0 = -thd * thd * p1 - 2.0 * thd * pd2 - bdhbd
        c1 = -thd * thd * p2 + 2.0 * thd * pd1
        # G = [[−p2, Φx, −(HB)ᵀ], [p1, 0, Φy]]
        Q[0] -= w * (-p2 * c0 + p1 * c1)
        for i in range(nA):
            Q[iA + i] -= w * phx[k, i] * c0
        for i in range(nB):
            Q[iB + i] -= w * (phy[k, i] * c1 - hb[i] * c0)
        if want_m:
            M[0, 0] += w * (p1 * p1 + p2 * p2)
            for i in range(nA):
                M[0, iA + i] -= w * p2 * phx[k, i]
            for i in range(nB):
                M[0, iB + i] += w * (p2 * hb[i] + p1 * phy[k, i])
            if fore:
                for i in range(nA):
                    wi = w * phx[k, i]
                    for j in range(nB):
                        M[iA + i, iB + j] -= wi * hb[j]
                for i in range(nB):
                    wi = w * hb[i]
                    for j in range(i, nB):
                        M[iB + i, iB + j] += wi * hb[j]
    if want_m:
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
        if fore:
            for i in range(nB):
                s = 0.0
                for j in range(nB):
                    s += Hbar[i, j] * q[iB + j]
                hb[i] = s  # Hbar B
                P1 -= 0.5 * q[iB + i] * s
        Q[0] -= g * (ct * P1 - st * P2)
        for i in range(nA):
            Q[iA + i] -= g * st * phx_bar[i]
        for i in range(nB):
            Q[iB + i] -= g * ct * phy_bar[i]
            if fore:
                Q[iB + i] += g * st * hb[i]
    # -- drive torque ------------------------------------------------------------------
    Q[0] += torque(t, prm)


@njit(cache=True)
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


@njit(cache=True)
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
def _point_fields(k, q, fore, xs, phx, phy, H, a, vec, P0, P1, G0, G1, D0):
    """At quadrature point k: P = ∂p/∂q rows (P0, P1), G rows, D0 = −(H vec_B)ᵀ in the
    B columns (row 0 of ∂(P vec)/∂q). Returns (p1, p2)."""
    nA = phx.shape[1]
    nB = phy.shape[1]
    iA = 1
    iB = 1 + nA
    p1 = a + xs[k]
    p2 = 0.0
    P0[0] = 0.0
    P1[0] = 0.0
    D0[0] = 0.0
    for i in range(nA):
        P0[iA + i] = phx[k, i]
        P1[iA + i] = 0.0
        D0[iA + i] = 0.0
        p1 += phx[k, i] * q[iA + i]
    for i in range(nB):
        hbi = 0.0
        hvi = 0.0
        if fore:
            for j in range(nB):
                hbi += H[k, i, j] * q[iB + j]
                hvi += H[k, i, j] * vec[iB + j]
        P0[iB + i] = -hbi
        P1[iB + i] = phy[k, i]
        D0[iB + i] = -hvi
        p1 -= 0.5 * q[iB + i] * hbi
        p2 += phy[k, i] * q[iB + i]
    for i in range(P0.shape[0]):
        G0[i] = P0[i]
        G1[i] = P1[i]
    G0[0] = -p2
    G1[0] = p1
    return p1, p2


@njit(cache=True)
def force_jacobian(t, q, v, prm, fore, xs, wm, phx, phy, H, K1, K2, phx_bar, phy_bar, Hbar, Kq, Kv):
    """Analytic (∂Q/∂q, ∂Q/∂v) of the applied force (no contact). Kq, Kv overwritten.

    With d = c (+ gravity handled from V_g) and Q_v = −∫ρS Gᵀc:
    ∂Q_v/∂q = −∫ρS [ (∂G/∂q)ᵀc + Gᵀ ∂c/∂q ],  ∂c/∂q = −θ̇² P + 2θ̇ E D,
    ∂Q_v/∂v = −∫ρS Gᵀ [ (−2θ̇p + 2Eṗ) e₁ᵀ + 2θ̇ E P + 2D ],
    where P = ∂p/∂q and D = ∂ṗ/∂q (row 0, B columns: −(HḂ)ᵀ).
    """
    nq = xs.shape[0]
    nA = phx.shape[1]
    nB = phy.shape[1]
    n = 1 + nA + nB
    iA = 1
    iB = 1 + nA
    a = prm[P_A]
    thd = v[0]
    P0 = np.empty(n)
    P1 = np.empty(n)
    G0 = np.empty(n)
    G1 = np.empty(n)
    D0 = np.empty(n)
    dc0 = np.empty(n)
    dc1 = np.empty(n)
    for i in range(n):
        for j in range(n):
            Kq[i, j] = 0.0
            Kv[i, j] = 0.0
    for k in range(nq):
        w = wm[k]
        p1, p2 = _point_fields(k, q, fore, xs, phx, phy, H, a, v, P0, P1, G0, G1, D0)
        pd1 = 0.0
        pd2 = 0.0
        bdhbd = 0.0
        for i in range(1, n):
            pd1 += P0[i] * v[i]
            pd2 += P1[i] * v[i]
        for i in range(nB):
            bdhbd -= v[iB + i] * D0[iB + i]
        c0 = -thd * thd * p1 - 2.0 * thd * pd2 - bdhbd
        c1 = -thd * thd * p2 + 2.0 * thd * pd1
        # ∂Q/∂q
        for j in range(n):
            dc0[j] = -thd * thd * P0[j]
            dc1[j] = -thd * thd * P1[j] + 2.0 * thd * D0[j]
        for j in range(n):
            Kq[0, j] -= w * (c1 * P0[j] - c0 * P1[j])
        for i in range(n):
            gi0 = w * G0[i]
            gi1 = w * G1[i]
            if gi0 != 0.0 or gi1 != 0.0:
                for j in range(n):
                    Kq[i, j] -= gi0 * dc0[j] + gi1 * dc1[j]
        if fore:
            for i in range(nB):
                for j in range(nB):
                    Kq[iB + i, iB + j] += w * c0 * H[k, i, j]
        # ∂Q/∂v
        for j in range(n):
            dc0[j] = -2.0 * thd * P1[j] + 2.0 * D0[j]
            dc1[j] = 2.0 * thd * P0[j]
        dc0[0] += -2.0 * thd * p1 - 2.0 * pd2
        dc1[0] += -2.0 * thd * p2 + 2.0 * pd1
        for i in range(n):
            gi0 = w * G0[i]
            gi1 = w * G1[i]
            if gi0 != 0.0 or gi1 != 0.0:
                for j in range(n):
                    Kv[i, j] -= gi0 * dc0[j] + gi1 * dc1[j]
    # elastic and damping
    beta = prm[P_BETA]
    for i in range(nA):
        for j in range(nA):
            Kq[iA + i, iA + j] -= K1[i, j]
            Kv[iA + i, iA + j] -= beta * K1[i, j]
    for i in range(nB):
        for j in range(nB):
            Kq[iB + i, iB + j] -= K2[i, j]
            Kv[iB + i, iB + j] -= beta * K2[i, j]
    # gravity: Kq_g = −Hess V_g
    g = prm[P_G]
    if g != 0.0:
        st = math.sin(q[0])
        ct = math.cos(q[0])
        P1s = prm[P_M1]
        for i in range(nA):
            P1s += phx_bar[i] * q[iA + i]
        P2s = 0.0
        for i in range(nB):
            P2s += phy_bar[i] * q[iB + i]
        hbar = np.zeros(nB)
        if fore:
            for i in range(nB):
                s = 0.0
                for j in range(nB):
                    s += Hbar[i, j] * q[iB + j]
                hbar[i] = s
                P1s -= 0.5 * q[iB + i] * s
        Kq[0, 0] -= g * (-st * P1s - ct * P2s)
        for i in range(nA):
            Kq[0, iA + i] -= g * ct * phx_bar[i]
            Kq[iA + i, 0] -= g * ct * phx_bar[i]
        for i in range(nB):
            hth = g * (-ct * hbar[i] - st * phy_bar[i])
            Kq[0, iB + i] -= hth
            Kq[iB + i, 0] -= hth
        if fore:
            for i in range(nB):
                for j in range(nB):
                    Kq[iB + i, iB + j] += g * st * Hbar[i, j]


@njit(cache=True)
def mass_jacobian_product(q, acc, prm, fore, xs, wm, phx, phy, H, out):
    """∂(M(q) acc)/∂q = ∫ρS [ (∂G/∂q)ᵀ(G acc) + Gᵀ (acc₀ E P + D_acc) ]. ``out`` overwritten."""
    nq = xs.shape[0]
    nA = phx.shape[1]
    nB = phy.shape[1]
    n = 1 + nA + nB
    iB = 1 + nA
    a = prm[P_A]
    a0 = acc[0]
    P0 = np.empty(n)
    P1 = np.empty(n)
    G0 = np.empty(n)
    G1 = np.empty(n)
    D0 = np.empty(n)
    d0 = np.empty(n)
    d1 = np.empty(n)
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.0
    for k in range(nq):
        w = wm[k]
        _point_fields(k, q, fore, xs, phx, phy, H, a, acc, P0, P1, G0, G1, D0)
        ga0 = 0.0
        ga1 = 0.0
        for i in range(n):
            ga0 += G0[i] * acc[i]
            ga1 += G1[i] * acc[i]
        for j in range(n):
            out[0, j] += w * (ga1 * P0[j] - ga0 * P1[j])
            d0[j] = -a0 * P1[j] + D0[j]
            d1[j] = a0 * P0[j]
        for i in range(n):
            gi0 = w * G0[i]
            gi1 = w * G1[i]
            if gi0 != 0.0 or gi1 != 0.0:
                for j in range(n):
                    out[i, j] += gi0 * d0[j] + gi1 * d1[j]
        if fore:
            for i in range(nB):
                for j in range(nB):
                    out[iB + i, iB + j] -= w * ga0 * H[k, i, j]
