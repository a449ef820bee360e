"""The augmented system [[M, C_qᵀ], [C_q, 0]] of a phase: consistent accelerations and
multipliers, dense or through a lumped mass's Schur complement."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core.borrow import uncounted
from daebench.core.linalg import lu_factor, lu_solve
from daebench.core.phase.forces import mass_force
from daebench.core.phase.rows import constraints


class AugmentedWork(NamedTuple):
    M: np.ndarray
    Q: np.ndarray
    A: np.ndarray
    piv: np.ndarray
    b: np.ndarray
    C: np.ndarray
    Cq: np.ndarray
    Ct: np.ndarray
    gam: np.ndarray


@njit(cache=True)
def augmented_work(n, m):
    mm = max(m, 1)
    return AugmentedWork(np.empty((n, n)), np.empty(n), np.empty((n + m, n + m)), np.zeros(n + m, np.int64),
                         np.empty(n + m), np.empty(mm), np.empty((mm, n)), np.empty(mm), np.empty(mm))


@uncounted
def solve_augmented(ph, t, q, v, delta, eps, w, acc, lam):
    """q̈ and λ from [[M, C_qᵀ], [C_q, 0]] [q̈; λ] = [Q; γ − 2δ(C_q v + C_t) − ε²C];
    δ = ε = 0 gives the consistent acceleration of the phase. Returns the LU info
    (0 = solved). A lumped model's (diagonal M) goes through the Schur complement
    (:func:`_solve_lumped`): O(n·m + m³) instead of the dense O((n + m)³)."""
    return _solve_augmented(ph.lumped, ph, t, q, v, delta, eps, w, acc, lam)


@uncounted
def _solve_augmented(d, ph, t, q, v, delta, eps, w, acc, lam):
    """:func:`solve_augmented` through the lumped mass ``d``, or dense (``d`` None: the
    Schur complement is not compiled)."""
    if d is not None:
        return _solve_lumped(ph, d, t, q, v, delta, eps, w, acc, lam)
    n = q.shape[0]
    m = lam.shape[0]
    mass_force(ph, t, q, v, w.M, w.Q)
    A, b = w.A, w.b
    for i in range(n):
        for j in range(n):
            A[i, j] = w.M[i, j]
        b[i] = w.Q[i]
    if m:
        C, Cq, Ct, gam = w.C, w.Cq, w.Ct, w.gam
        constraints(ph, t, q, v, C, Cq, Ct, gam)
        for k in range(m):
            b[n + k] = _rhs_row(delta, eps, k, n, v, C, Cq, Ct, gam)
            for j in range(n):
                A[j, n + k] = Cq[k, j]
                A[n + k, j] = Cq[k, j]
            for l in range(m):
                A[n + k, n + l] = 0.0
    info = lu_factor(A, w.piv)
    if info != 0:
        return info
    lu_solve(A, w.piv, b)
    for i in range(n):
        acc[i] = b[i]
    for k in range(m):
        lam[k] = b[n + k]
    return 0


@uncounted
def _rhs_row(delta, eps, k, n, v, C, Cq, Ct, gam):
    """Row k of the constraint right-hand side γ − 2δ(C_q v + C_t) − ε²C."""
    rc = gam[k]
    if delta:
        cv = 0.0
        for j in range(n):
            cv += Cq[k, j] * v[j]
        rc = rc - 2.0 * delta * (cv + Ct[k])
    if eps:
        rc = rc - eps ** 2 * C[k]
    return rc


@uncounted
def _solve_lumped(ph, d, t, q, v, delta, eps, w, acc, lam):
    """:func:`solve_augmented` for a diagonal M = diag(d) (``ph.lumped``, n > 0): the Schur complement
    (C_q D⁻¹ C_qᵀ) λ = C_q D⁻¹ Q − r, q̈ = D⁻¹ (Q − C_qᵀ λ), over the nonzeros of each
    constraint row (a contact row touches a few nodes). Neither M nor the n × n parts of the
    workspace are touched (the kernel's force alone: a lumped model's M may have no rows)."""
    n = q.shape[0]
    m = lam.shape[0]
    mass_force(ph, t, q, v, w.M[:0], w.Q)
    Q = w.Q
    if m:
        C, Cq, Ct, gam = w.C, w.Cq, w.Ct, w.gam
        constraints(ph, t, q, v, C, Cq, Ct, gam)
        S, b, idx = w.A[:m, :m], w.b, w.piv[m:]
        for k in range(m):
            nz = 0
            s = 0.0
            for j in range(n):
                if Cq[k, j] != 0.0:
                    idx[nz] = j
                    nz += 1
                    s += Cq[k, j] * (Q[j] / d[j])
            b[k] = s - _rhs_row(delta, eps, k, n, v, C, Cq, Ct, gam)
            for l in range(m):
                s = 0.0
                for a in range(nz):
                    j = idx[a]
                    s += Cq[k, j] * Cq[l, j] / d[j]
                S[k, l] = s
        info = lu_factor(S, w.piv[:m])
        if info != 0:
            return info
        lu_solve(S, w.piv[:m], b[:m])
        for k in range(m):
            lam[k] = b[k]
    for j in range(n):
        f = Q[j]
        for k in range(m):
            f -= w.Cq[k, j] * lam[k]
        acc[j] = f / d[j]
    return 0
