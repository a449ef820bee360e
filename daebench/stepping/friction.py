"""Planar Coulomb friction in an event-capturing step: the contact impulses of one
linearization as one LCP (normal and tangential impulses together), solved by Lemke's
method (:func:`daebench.core.lcp.solve_lcp_lemke`).

Per active contact i, with the gap Jacobian row G_i, the tangent row T_i
(:func:`daebench.core.kernels.tangent`: slip velocity U_T = T_i v, friction coefficient
μ_i), the step's free velocity v_free and the iteration matrix S::

    v_{k+1} = v_free + S⁻¹ (Σ G_iᵀ P_N,i + Σ T_iᵀ P_T,i),     P_T,i = β⁺_i − β⁻_i

    0 ≤ G_i v_{k+1} + e G_i v_k   ⟂  P_N,i ≥ 0        (Newton's law at velocity level)
    0 ≤   T_i v_{k+1} + σ_i       ⟂  β⁺_i ≥ 0
    0 ≤ − T_i v_{k+1} + σ_i       ⟂  β⁻_i ≥ 0
    0 ≤ μ_i P_N,i − β⁺_i − β⁻_i   ⟂  σ_i ≥ 0

The last three are Coulomb's law exactly in 2-D (the cone has two generators): σ_i is
the sliding speed |U_T,i|; while the contact slides |P_T| = μ P_N against U_T, while it
sticks (U_T = 0) |P_T| ≤ μ P_N (Stewart & Trinkle 1996; Anitescu & Potra 1997; Acary &
Brogliato 2008 §13). Contacts with μ_i = 0 carry only their normal row. The LCP matrix is
copositive-plus and the LCP always has a solution (Stewart & Trinkle), which Lemke finds;
a ray end (LCP_RAY) is reported as a failed step with a named status. Two guards against a
degenerate tableau (contacts on one line — the slider's two corners on a wall — have
identical tangent rows, and Lemke's ratio test ties): no LCP at all when no active contact
needs a normal impulse (P = 0 solves it), and one retry with b perturbed by TIE_BREAK
relative after a ray end.

Layout of the unknowns z (m = n_a + 3 n_f of them for n_a active contacts, n_f of them
with friction): the n_a normal impulses first (in contact order), then (β⁺, β⁻, σ) of
each frictional active contact.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.core.lcp import LCP_DEGENERATE, LCP_RAY, LemkeWork, lemke_work, solve_lcp_lemke

TIE_BREAK = 1e-10   # relative perturbation of b that breaks Lemke's degenerate ties (impulses(), a retry)
from daebench.core.linalg import lu_solve


class FrictionWork(NamedTuple):
    T: np.ndarray       # nc × n: tangent rows at the iterate
    mu: np.ndarray      # nc: friction coefficients
    PT: np.ndarray      # nc: tangential impulses of the step (P_T = β⁺ − β⁻)
    ST: np.ndarray      # n × nc: S⁻¹ T_iᵀ
    SG: np.ndarray      # n × nc: S⁻¹ G_iᵀ
    slot: np.ndarray    # int64 nc: position of contact i's normal impulse in z (−1: inactive)
    fslot: np.ndarray   # int64 nc: position of its β⁺ (−1: no friction row)
    A: np.ndarray       # m × m (m ≤ 4 nc)
    b: np.ndarray
    z: np.ndarray
    w: np.ndarray
    col: np.ndarray     # n: scratch
    lemke: LemkeWork


def friction_work(n: int, nc: int) -> FrictionWork:
    k = max(nc, 1)
    m = 4 * k
    z = np.zeros
    return FrictionWork(T=z((k, n)), mu=z(k), PT=z(k), ST=z((n, k)), SG=z((n, k)), slot=-np.ones(k, np.int64),
                        fslot=-np.ones(k, np.int64), A=z((m, m)), b=z(m), z=z(m), w=z(m), col=z(n),
                        lemke=lemke_work(m))


@njit(cache=True)
def has_friction(model, nc, n, q, v, fw):
    """Whether any contact point of the model has μ > 0 (at q)."""
    for i in range(nc):
        if kernels.tangent(model, i, q, v, fw.col) > 0.0:
            return True
    return False


@njit(cache=True)
def _dot(a, b, n):
    s = 0.0
    for r in range(n):
        s += a[r] * b[r]
    return s


@njit(cache=True)
def impulses(model, fw, G, active, LU, piv, n, nc, q1, v1, v0, vfree, e, P):
    """Solve the frictional contact LCP of one linearization (module docstring) at the
    iterate (q1, v1): G (nc × n) is filled with the gap rows of the active contacts, P
    (nc) and fw.PT with the normal and tangential impulses, and vfree becomes v_{k+1}.
    Returns the LCP status (< 0: no solution found)."""
    m = 0
    for i in range(nc):
        fw.slot[i] = -1
        fw.fslot[i] = -1
        P[i] = 0.0
        fw.PT[i] = 0.0
        if active[i]:
            fw.slot[i] = m
            m += 1
    for i in range(nc):
        if not active[i]:
            continue
        kernels.gap(model, i, q1, v1, G[i])
        fw.mu[i] = kernels.tangent(model, i, q1, v1, fw.T[i])
        if fw.mu[i] > 0.0:
            fw.fslot[i] = m
            m += 3
        for r in range(n):
            fw.col[r] = G[i, r]
        lu_solve(LU, piv, fw.col)
        for r in range(n):
            fw.SG[r, i] = fw.col[r]
        if fw.fslot[i] >= 0:
            for r in range(n):
                fw.col[r] = fw.T[i, r]
            lu_solve(LU, piv, fw.col)
            for r in range(n):
                fw.ST[r, i] = fw.col[r]
    A, b = fw.A, fw.b
    for a in range(m):
        b[a] = 0.0
        for c in range(m):
            A[a, c] = 0.0
    for i in range(nc):
        si = fw.slot[i]
        if si < 0:
            continue
        fi = fw.fslot[i]
        b[si] = _dot(G[i], vfree, n) + e * _dot(G[i], v0, n)
        if fi >= 0:
            ut = _dot(fw.T[i], vfree, n)
            b[fi] = ut
            b[fi + 1] = -ut
            A[fi, fi + 2] = 1.0       # + σ in both tangential rows
            A[fi + 1, fi + 2] = 1.0
            A[fi + 2, si] = fw.mu[i]  # μ P_N − β⁺ − β⁻
            A[fi + 2, fi] = -1.0
            A[fi + 2, fi + 1] = -1.0
        for j in range(nc):
            sj = fw.slot[j]
            if sj < 0:
                continue
            fj = fw.fslot[j]
            gg = 0.0
            for r in range(n):
                gg += G[i, r] * fw.SG[r, j]
            A[si, sj] = gg
            if fj >= 0:
                gt = 0.0
                for r in range(n):
                    gt += G[i, r] * fw.ST[r, j]
                A[si, fj] = gt
                A[si, fj + 1] = -gt
            if fi >= 0:
                tg = 0.0
                for r in range(n):
                    tg += fw.T[i, r] * fw.SG[r, j]
                A[fi, sj] = tg
                A[fi + 1, sj] = -tg
                if fj >= 0:
                    tt = 0.0
                    for r in range(n):
                        tt += fw.T[i, r] * fw.ST[r, j]
                    A[fi, fj] = tt
                    A[fi, fj + 1] = -tt
                    A[fi + 1, fj] = -tt
                    A[fi + 1, fj + 1] = tt
    need = False
    for i in range(nc):
        if fw.slot[i] >= 0 and b[fw.slot[i]] < 0.0:
            need = True
    if not need:
        # no active contact needs a normal impulse: P = 0 (with σ = |U_T|) solves the LCP, and
        # Lemke need not pivot through the identical tangent rows of contacts on one line
        return 0
    st = solve_lcp_lemke(A, b, m, fw.z, fw.w, fw.lemke)
    if st == LCP_RAY or st == LCP_DEGENERATE:
        # degenerate ties (contacts on one line have identical tangent rows) can end Lemke on a
        # ray, or at a point that is not a solution, although a solution exists: break them by a perturbation of b of order TIE_BREAK
        # relative (the lexicographic rule's intent), then solve again
        scale = 0.0
        for a in range(m):
            scale = max(scale, abs(b[a]))
        for a in range(m):
            b[a] += TIE_BREAK * scale * (a + 1) / m
        st = solve_lcp_lemke(A, b, m, fw.z, fw.w, fw.lemke)
    if st < 0:
        return st
    for i in range(nc):
        si = fw.slot[i]
        if si < 0:
            continue
        P[i] = fw.z[si]
        fi = fw.fslot[i]
        for r in range(n):
            vfree[r] += fw.SG[r, i] * P[i]
        if fi >= 0:
            fw.PT[i] = fw.z[fi] - fw.z[fi + 1]
            for r in range(n):
                vfree[r] += fw.ST[r, i] * fw.PT[i]
    return st


@njit(cache=True)
def tangential_work(fw, active, nc, n, v0, v1, per_contact):
    """Σ_i P_T,i (U_T,i⁻ + U_T,i⁺)/2 over the active contacts (≤ 0: friction dissipates);
    each contact's term is added to ``per_contact[i, 0]``."""
    work = 0.0
    for i in range(nc):
        if active[i] and fw.PT[i] != 0.0:
            u = 0.0
            for r in range(n):
                u += fw.T[i, r] * (v0[r] + v1[r])
            per_contact[i, 0] += 0.5 * fw.PT[i] * u
            work += 0.5 * fw.PT[i] * u
    return work
