"""Planar Coulomb friction in the nonsmooth generalized-α step
(:mod:`daebench.stepping.nsgenalpha`), as in Capobianco, Harsch, Eugster & Leine (2021),
§5 and eq. (113)–(142).

Per contact k with μ_k > 0 two more unknowns: the friction percussion Λ_F and force λ_F
(the unknown vector becomes (a, U, Q, κ, Λ, λ, Λ_F, λ_F)). With the tangent row T_k
(:func:`daebench.core.kernels.tangent`), the slip velocity γ_F = T u and its rate
γ̇_F = T a + ζ_F (ζ_F = (∂T/∂q u) u, central differences)::

    λ̄_F from λ_F as ā from a;   P_F = Λ_F + h [(1−γ) λ̄_F,n + γ λ̄_F,n+1]        (113, 114)
    M a − Q − g_qᵀλ − Tᵀλ_F = 0,   M U − g_qᵀΛ − TᵀΛ_F = 0,
    M Q − g_qᵀκ − ½ h TᵀΛ_F = 0                                                 (127)

and the index sets (139), (141) with the prox parameter r_F = 1/Σ_j T_j²/M_jj:

    D (stick at velocity level): A ∧ |r_F ξ_F − P_F| ≤ μ P_N,     ξ_F = T u_{n+1}
    E (stick at acceleration level): D ∧ |r_F γ̇_F − λ_F| ≤ μ λ_N

    A ∧ D:  ξ_F = 0;   A ∧ D ∧ E: γ̇_F = 0;   A ∧ D ∧ ¬E: λ_F + μ λ_N sgn γ̇_F = 0     (138a, 142a, b)
    A ∧ ¬D: P_F + μ P_N sgn ξ_F = 0,   λ_F + μ λ_N sgn γ_F = 0                       (138b, 142c)
    ¬A:     P_F = 0,   λ_F = 0                                                       (138c, 142d)

The semismooth Newton Jacobian of these rows leaves out the derivatives of T and of the
signs (a quasi-Newton iteration, as the normal rows). Per contact ``branch`` is 0 (¬A or
μ = 0), 1 (slip), 2 (stick at velocity level only) or 3 (stick at both), ``sx``/``sg``
the signs in the P_F and λ_F rows; ``fsets`` one code of the three (compared to decide
whether the factorized Jacobian still holds).

Sticking contacts may be redundant (two corners of a block sliding together have the same
tangent row): the stick rows ξ_F = 0 and γ̇_F = 0 are then dependent and the Jacobian
singular. Its stick rows get a compliance STICK_COMPLIANCE/r_F on P_F (and λ_F): the
residual stays exact, the iteration picks one of the equivalent friction distributions
(the static indeterminacy of friction), and converges at the same rate elsewhere.

Reference: G. Capobianco, J. Harsch, S. R. Eugster, R. I. Leine, "A nonsmooth
generalized-alpha method for mechanical systems with frictional contact", Int. J. Numer.
Meth. Eng. 122 (2021) 6497–6526; cardillo (github.com/cardilloproject/cardillo),
solver/nonsmooth_generalized_alpha.py, read for the branches of (138) and (142).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels

STICK_COMPLIANCE = 1e-8   # relative compliance of the stick rows in the Jacobian only (module docstring)

class NsgaFriction(NamedTuple):
    T: np.ndarray         # nc × n: tangent rows at the iterate
    mu: np.ndarray        # nc
    rprox: np.ndarray     # nc: r_F
    lam: np.ndarray       # λ_F,n, λ̄_F,n
    lbar: np.ndarray
    lam_new: np.ndarray
    lbar_new: np.ndarray
    lam_old: np.ndarray   # λ_F,n−1 (predictor)
    phat: np.ndarray      # history part of P_F
    PF: np.ndarray        # P_F of the iterate
    branch: np.ndarray    # int64 nc (module docstring)
    sx: np.ndarray        # nc: sign in the P_F row (slip)
    sg: np.ndarray        # nc: sign in the λ_F row
    fsets: np.ndarray     # int64 nc: code of (branch, sx, sg)
    fsets_prev: np.ndarray
    fsets_lu: np.ndarray
    tp: np.ndarray        # n: scratch rows for ζ_F
    tm: np.ndarray
    qs: np.ndarray


def friction_work(n: int, nc: int) -> NsgaFriction:
    k = max(nc, 1)
    z = np.zeros
    return NsgaFriction(T=z((k, n)), mu=z(k), rprox=z(k), lam=z(k), lbar=z(k), lam_new=z(k), lbar_new=z(k),
                        lam_old=z(k), phat=z(k), PF=z(k), branch=z(k, np.int64), sx=z(k), sg=z(k),
                        fsets=z(k, np.int64), fsets_prev=z(k, np.int64),
                        fsets_lu=z(k, np.int64), tp=z(n), tm=z(n), qs=z(n))


@njit(cache=True)
def _sgn(x):
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@njit(cache=True)
def prepare(fw, nc, h, am, af, ga):
    """History part of P_F for the step (as phat of the normal percussion)."""
    for k in range(nc):
        dl = (af * fw.lam[k] - am * fw.lbar[k]) / (1.0 - am)
        fw.phat[k] = h * ((1.0 - ga) * fw.lbar[k] + ga * dl)


@njit(cache=True)
def predict(fw, x, n, nc, rh):
    """λ_F extrapolated linearly from the last two steps, Λ_F = 0."""
    for k in range(nc):
        x[3 * n + 3 * nc + k] = 0.0
        x[3 * n + 4 * nc + k] = fw.lam[k] + rh * (fw.lam[k] - fw.lam_old[k])
        fw.fsets_prev[k] = -1


@njit(cache=True)
def residual(model, fw, x, r, M, q1, u1, sets, P, n, nc, h, cu, first):
    """Friction rows of the residual, the friction terms of the three equations of motion
    (r[:3n] already holds the frictionless part) and the branch codes."""
    iLF, ilF, il = 3 * n + 3 * nc, 3 * n + 4 * nc, 3 * n + 2 * nc
    for k in range(nc):
        mu = kernels.tangent(model, k, q1, u1, fw.T[k])
        fw.mu[k] = mu
        if first:
            s = 0.0
            for j in range(n):
                if M[j, j] > 0.0:
                    s += fw.T[k, j] ** 2 / M[j, j]
            fw.rprox[k] = 1.0 / s if s > 0.0 else 1.0
        lamF = x[ilF + k]
        PF = x[iLF + k] + fw.phat[k] + cu * lamF
        fw.PF[k] = PF
        for i in range(n):
            r[i] -= fw.T[k, i] * lamF
            r[n + i] -= fw.T[k, i] * x[iLF + k]
            r[2 * n + i] -= 0.5 * h * fw.T[k, i] * x[iLF + k]
        fw.sx[k] = 0.0
        fw.sg[k] = 0.0
        if mu <= 0.0 or sets[k] < 1:
            fw.branch[k] = 0
            fw.fsets[k] = 0
            r[iLF + k] = PF
            r[ilF + k] = lamF
            continue
        xi = 0.0
        for j in range(n):
            xi += fw.T[k, j] * u1[j]
        gF = xi
        lamN = x[il + k]
        rF = fw.rprox[k]
        if abs(rF * xi - PF) <= mu * P[k]:
            # stick at velocity level; γ̇_F = T a + ζ_F
            qscale = 1.0
            uscale = 0.0
            for j in range(n):
                qscale = max(qscale, abs(q1[j]))
                uscale = max(uscale, abs(u1[j]))
            zeta = 0.0
            if uscale > 0.0:
                eps = kernels.FD_REL_STEP * qscale / uscale
                for j in range(n):
                    fw.qs[j] = q1[j] + eps * u1[j]
                kernels.tangent(model, k, fw.qs, u1, fw.tp)
                for j in range(n):
                    fw.qs[j] = q1[j] - eps * u1[j]
                kernels.tangent(model, k, fw.qs, u1, fw.tm)
                for j in range(n):
                    zeta += (fw.tp[j] - fw.tm[j]) / (2.0 * eps) * u1[j]
            gFd = zeta
            for j in range(n):
                gFd += fw.T[k, j] * x[j]
            r[iLF + k] = xi
            if abs(rF * gFd - lamF) <= mu * lamN:
                fw.branch[k] = 3
                r[ilF + k] = gFd
            else:
                fw.branch[k] = 2
                fw.sg[k] = _sgn(gFd)
                r[ilF + k] = lamF + mu * lamN * fw.sg[k]
        else:
            fw.branch[k] = 1
            fw.sx[k] = _sgn(xi)
            fw.sg[k] = _sgn(gF)
            r[iLF + k] = PF + mu * P[k] * fw.sx[k]
            r[ilF + k] = lamF + mu * lamN * fw.sg[k]
        fw.fsets[k] = fw.branch[k] + 4 * int(fw.sx[k] + 1.0) + 12 * int(fw.sg[k] + 1.0)


@njit(cache=True)
def jacobian(fw, J, n, nc, h, cu):
    """Friction columns of the equations of motion and the friction rows of the Jacobian."""
    iL, il = 3 * n + nc, 3 * n + 2 * nc
    iLF, ilF = 3 * n + 3 * nc, 3 * n + 4 * nc
    for k in range(nc):
        for i in range(n):
            J[i, ilF + k] = -fw.T[k, i]
            J[n + i, iLF + k] = -fw.T[k, i]
            J[2 * n + i, iLF + k] = -0.5 * h * fw.T[k, i]
        branch = fw.branch[k]
        fw.fsets_lu[k] = fw.fsets[k]
        if branch == 0:
            J[iLF + k, iLF + k] = 1.0
            J[iLF + k, ilF + k] = cu
            J[ilF + k, ilF + k] = 1.0
            continue
        mu = fw.mu[k]
        sx, sg = fw.sx[k], fw.sg[k]
        if branch == 1:
            J[iLF + k, iLF + k] = 1.0
            J[iLF + k, ilF + k] = cu
            J[iLF + k, iL + k] = mu * sx
            J[iLF + k, il + k] = mu * sx * cu
            J[ilF + k, ilF + k] = 1.0
            J[ilF + k, il + k] = mu * sg
            continue
        reg = STICK_COMPLIANCE / fw.rprox[k]   # see the module docstring
        for j in range(n):           # stick at velocity level: ξ_F = T u
            J[iLF + k, j] = cu * fw.T[k, j]
            J[iLF + k, n + j] = fw.T[k, j]
        J[iLF + k, iLF + k] = reg
        J[iLF + k, ilF + k] = reg * cu
        if branch == 3:
            for j in range(n):
                J[ilF + k, j] = fw.T[k, j]
            J[ilF + k, ilF + k] = reg
        else:
            J[ilF + k, ilF + k] = 1.0
            J[ilF + k, il + k] = mu * sg


@njit(cache=True)
def finish(fw, x, n, nc, am, af, cu, v0, v1):
    """λ_F, λ̄_F of the converged step; returns the friction work Σ P_F (γ_F,n + γ_F,n+1)/2."""
    ilF, iLF = 3 * n + 4 * nc, 3 * n + 3 * nc
    work = 0.0
    for k in range(nc):
        lam = x[ilF + k]
        fw.lam_new[k] = lam
        fw.lbar_new[k] = (af * fw.lam[k] + (1.0 - af) * lam - am * fw.lbar[k]) / (1.0 - am)
        PF = x[iLF + k] + fw.phat[k] + cu * lam
        u = 0.0
        for j in range(n):
            u += fw.T[k, j] * (v0[j] + v1[j])
        work += 0.5 * PF * u
    return work


@njit(cache=True)
def accept(fw):
    fw.lam_old[:] = fw.lam
    fw.lam[:] = fw.lam_new
    fw.lbar[:] = fw.lbar_new


@njit(cache=True)
def restart(fw):
    fw.lam[:] = 0.0
    fw.lbar[:] = 0.0
    fw.lam_old[:] = 0.0
