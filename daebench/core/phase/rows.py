"""The active constraints of a phase: the model's bilateral rows, the stick rows of sticking
contacts, then C = −g of each closed contact; their Jacobians by central differences and
residuals."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from daebench.core import coulomb, kernels
from daebench.core.borrow import uncounted
from daebench.core.kernels import fd_step


@uncounted
def constraints(ph, t, q, v, C, Cq, Ct, gam):
    """Rows of the active constraints: bilateral, the stick rows of sticking contacts
    (:func:`daebench.core.coulomb.stick_rows`), then C = −g of each closed contact."""
    kernels.constraints(ph.model, t, q, v, C, Cq, Ct, gam)
    _stick_rows(coulomb.present(ph.friction), ph, q, v, C, Cq, Ct, gam)
    r = ph.nb
    gq = ph.gq
    for c in ph.active:
        g, gamma = kernels.gap(ph.model, c, q, v, gq)
        C[r] = -g
        for j in range(q.shape[0]):
            Cq[r, j] = -gq[j]
        Ct[r] = 0.0
        gam[r] = -gamma
        r += 1


@uncounted
def _stick_rows(fr, ph, q, v, C, Cq, Ct, gam):
    if fr is None:
        return
    ns = fr.stick.shape[0]
    if ns:
        coulomb.stick_rows(ph.model, fr, ph.nb - ns, q, v, C, Cq, Ct, gam)


@uncounted
def constraint_jacobian(ph, t, q, Cq, scratch_m, zeros_n):
    """C_q only (``scratch_m``: length ≥ m, ``zeros_n``: a zero velocity)."""
    constraints(ph, t, q, zeros_n, scratch_m, Cq, scratch_m, scratch_m)


@njit(cache=True, _nrt=True)  # allocates its scratch
def constraint_force_jacobian(ph, t, q, lam, K):
    """∂(C_qᵀλ)/∂q at fixed λ, by central differences (n × n)."""
    n = q.shape[0]
    m = lam.shape[0]
    Cq = np.empty((max(m, 1), n))
    s = np.empty(max(m, 1))
    zeros = np.zeros(n)
    x = q.copy()
    for j in range(n):
        dx = fd_step(q[j])
        x[j] = q[j] + dx
        constraint_jacobian(ph, t, x, Cq, s, zeros)
        for i in range(n):
            acc = 0.0
            for k in range(m):
                acc += Cq[k, i] * lam[k]
            K[i, j] = acc
        x[j] = q[j] - dx
        constraint_jacobian(ph, t, x, Cq, s, zeros)
        for i in range(n):
            acc = 0.0
            for k in range(m):
                acc += Cq[k, i] * lam[k]
            K[i, j] = (K[i, j] - acc) / (2.0 * dx)
        x[j] = q[j]


@njit(cache=True, _nrt=True)  # allocates its scratch
def velocity_constraint_jacobian(ph, t, q, v, K):
    """∂(C_q v + C_t)/∂q at fixed v, by central differences (m × n)."""
    n = q.shape[0]
    m = K.shape[0]
    C, Ct, gam = np.empty(max(m, 1)), np.empty(max(m, 1)), np.empty(max(m, 1))
    Cq = np.empty((max(m, 1), n))
    fp = np.empty(max(m, 1))
    x = q.copy()
    for j in range(n):
        dx = fd_step(q[j])
        for side in (1.0, -1.0):
            x[j] = q[j] + side * dx
            constraints(ph, t, x, v, C, Cq, Ct, gam)
            for k in range(m):
                acc = Ct[k]
                for i in range(n):
                    acc += Cq[k, i] * v[i]
                if side > 0.0:
                    fp[k] = acc
                else:
                    K[k, j] = (fp[k] - acc) / (2.0 * dx)
        x[j] = q[j]


@uncounted
def constraint_residuals(ph, t, q, v, a, C, Cq, Ct, gam):
    """(max|C|, max|C_q v + C_t|, max|C_q a − γ|) of the active constraints (NaN for the
    last when ``a`` is empty)."""
    n = q.shape[0]
    m = C.shape[0]
    constraints(ph, t, q, v, C, Cq, Ct, gam)
    c0 = c1 = c2 = 0.0
    for k in range(m):
        cv = Ct[k]
        ca = -gam[k]
        for j in range(n):
            cv += Cq[k, j] * v[j]
            if a.shape[0] == n:
                ca += Cq[k, j] * a[j]
        c0 = max(c0, abs(C[k]))
        c1 = max(c1, abs(cv))
        c2 = max(c2, abs(ca))
    if a.shape[0] != n:
        c2 = math.nan
    return c0, c1, c2
