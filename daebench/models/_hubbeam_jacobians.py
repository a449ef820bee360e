"""Analytic Jacobians of the hub–beam applied force and of M(q)·a (numba), beside
:mod:`daebench.models._hubbeam_kernels` (same notation and tables)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from daebench.models._hubbeam_kernels import FASTMATH, P_A, P_BETA, P_G, P_M1


@njit(cache=True, fastmath=FASTMATH)
def _point_fields(k, q, fore, xs, phx, phy, H, a, vec, P0, P1, G0, G1, D0):
    """At quadrature point k: P = ∂p/∂q rows (P0, P1), G rows, D0 = −(H vec_B)ᵀ in the
    B columns (row 0 of ∂(P vec)/∂q). Returns (p1, p2)."""
    nA = phx.shape[0]
    nB = phy.shape[0]
    iA = 1
    iB = 1 + nA
    p1 = a + xs[k]
    p2 = 0.0
    P0[0] = 0.0
    P1[0] = 0.0
    D0[0] = 0.0
    for i in range(nA):
        P0[iA + i] = phx[i, k]
        P1[iA + i] = 0.0
        D0[iA + i] = 0.0
        p1 += phx[i, k] * q[iA + i]
    for i in range(nB):
        hbi = 0.0
        hvi = 0.0
        if fore:
            for j in range(nB):
                hbi += H[i, j, k] * q[iB + j]
                hvi += H[i, j, k] * vec[iB + j]
        P0[iB + i] = -hbi
        P1[iB + i] = phy[i, k]
        D0[iB + i] = -hvi
        p1 -= 0.5 * q[iB + i] * hbi
        p2 += phy[i, k] * q[iB + i]
    for i in range(P0.shape[0]):
        G0[i] = P0[i]
        G1[i] = P1[i]
    G0[0] = -p2
    G1[0] = p1
    return p1, p2


@njit(cache=True, fastmath=FASTMATH)
def force_jacobian(t, q, v, prm, fore, xs, wm, phx, phy, H, K1, K2, phx_bar, phy_bar, Hbar, Kq, Kv):
    """Analytic (∂Q/∂q, ∂Q/∂v) of the applied force (no contact). Kq, Kv overwritten.

    With d = c (+ gravity handled from V_g) and Q_v = −∫ρS Gᵀc:
    ∂Q_v/∂q = −∫ρS [ (∂G/∂q)ᵀc + Gᵀ ∂c/∂q ],  ∂c/∂q = −θ̇² P + 2θ̇ E D,
    ∂Q_v/∂v = −∫ρS Gᵀ [ (−2θ̇p + 2Eṗ) e₁ᵀ + 2θ̇ E P + 2D ],
    where P = ∂p/∂q and D = ∂ṗ/∂q (row 0, B columns: −(HḂ)ᵀ).
    """
    nq = xs.shape[0]
    nA = phx.shape[0]
    nB = phy.shape[0]
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
                    Kq[iB + i, iB + j] += w * c0 * H[i, j, k]
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


@njit(cache=True, fastmath=FASTMATH)
def mass_jacobian_product(q, acc, prm, fore, xs, wm, phx, phy, H, out):
    """∂(M(q) acc)/∂q = ∫ρS [ (∂G/∂q)ᵀ(G acc) + Gᵀ (acc₀ E P + D_acc) ]. ``out`` overwritten."""
    nq = xs.shape[0]
    nA = phx.shape[0]
    nB = phy.shape[0]
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
                    out[iB + i, iB + j] -= w * ga0 * H[i, j, k]
