"""Coulomb friction at closed contacts (:mod:`daebench.core.coulomb`, :mod:`daebench.driver.stickslip`):
the slipping contacts' force from the consistent normal multipliers, its power, Jacobian and
booked work, and the stick/slip switch test; a frictionless phase compiles none of it."""

from __future__ import annotations

import math

from daebench.core import coulomb, kernels
from daebench.core.borrow import copy_to, uncounted
from daebench.core.kernels import fd_step
from daebench.core.linalg import lu_factor, lu_solve
from daebench.core.phase import compliant
from daebench.core.phase.rows import constraints


@uncounted
def add_slip(fr, ph, t, q, v, M, Q):
    """:func:`add_slip_force` when the phase has slipping contacts (``fr`` None: never; the
    branch is not compiled for a frictionless phase, :func:`daebench.core.coulomb.present`)."""
    if fr is None:
        return
    if fr.slip.shape[0]:
        add_slip_force(ph, t, q, v, M, Q)


@uncounted
def slip_normal_forces(ph, t, q, v, M, Q):
    """The consistent multipliers of the phase at (t, q, v) with the slip friction columns,
    [[M, C_qᵀ + Σ μ s t_qᵀ e_Nᵀ], [C_q, 0]] [a; λ] = [Q; γ] (M, Q without the slip force):
    λ into ``friction.b[n:]``, the slipping contacts' tangent rows into ``friction.T``.
    Returns the LU info (0 = solved)."""
    fr = ph.friction
    n = q.shape[0]
    m = fr.C.shape[0]
    A, b = fr.A, fr.b
    constraints(ph, t, q, v, fr.C, fr.Cq, fr.Ct, fr.gam)
    for i in range(n):
        for j in range(n):
            A[i, j] = M[i, j]
        b[i] = Q[i]
    for k in range(m):
        for j in range(n):
            A[j, n + k] = fr.Cq[k, j]
            A[n + k, j] = fr.Cq[k, j]
        for l in range(m):
            A[n + k, n + l] = 0.0
        b[n + k] = fr.gam[k]
    for k in range(fr.slip.shape[0]):
        tq = fr.T[k]
        kernels.tangent(ph.model, fr.slip[k], q, v, tq)
        col = n + ph.nb + fr.slip_act[k]
        ms = fr.slip_mu[k] * fr.slip_s[k]
        for j in range(n):
            A[j, col] += ms * tq[j]
    info = lu_factor(A, fr.piv)
    if info != 0:
        return info
    lu_solve(A, fr.piv, b)
    return 0


@uncounted
def add_slip_force(ph, t, q, v, M, Q):
    """Q −= Σ μ s λ_N t_q over the slipping contacts, λ_N their consistent normal forces
    (:func:`slip_normal_forces` at this M and Q); a singular system leaves NaN (the step
    fails on it). An M without rows (a lumped mass) is evaluated here."""
    fr = ph.friction
    n = q.shape[0]
    if M.shape[0] != n:
        kernels.mass_force(ph.model, t, q, v, fr.M, fr.Q)
        M = fr.M
    if slip_normal_forces(ph, t, q, v, M, Q) != 0:
        for j in range(n):
            Q[j] = math.nan
        return
    _subtract_slip(ph, n, Q)


@uncounted
def _subtract_slip(ph, n, Q):
    """Q −= Σ μ s λ_N t_q with the λ and tangent rows :func:`slip_normal_forces` left."""
    fr = ph.friction
    for k in range(fr.slip.shape[0]):
        f = fr.slip_mu[k] * fr.slip_s[k] * fr.b[n + ph.nb + fr.slip_act[k]]
        for j in range(n):
            Q[j] = Q[j] - f * fr.T[k, j]


@uncounted
def slip_power(ph, t, q, v):
    """Power of the slip friction forces, −Σ μ λ_N |t_q v| ≤ 0 (0 without slip)."""
    return _slip_power(coulomb.present(ph.friction), ph, t, q, v)


@uncounted
def _slip_power(fr, ph, t, q, v):
    if fr is None:
        return 0.0
    if fr.slip.shape[0] == 0:
        return 0.0
    n = q.shape[0]
    compliant.force_without_slip(ph, t, q, v, fr.M, fr.Q)
    if slip_normal_forces(ph, t, q, v, fr.M, fr.Q) != 0:
        return math.nan
    P = 0.0
    for k in range(fr.slip.shape[0]):
        u = 0.0
        for j in range(n):
            u += fr.T[k, j] * v[j]
        P += -fr.slip_mu[k] * fr.slip_s[k] * fr.b[n + ph.nb + fr.slip_act[k]] * u
    return P


@uncounted
def _slip_force(ph, t, q, v, out):
    """The slip friction force alone into ``out`` (NaN where its system is singular)."""
    fr = ph.friction
    n = q.shape[0]
    compliant.force_without_slip(ph, t, q, v, fr.M, fr.Q)
    info = slip_normal_forces(ph, t, q, v, fr.M, fr.Q)
    for j in range(n):
        out[j] = 0.0 if info == 0 else math.nan
    if info == 0:
        _subtract_slip(ph, n, out)


@uncounted
def add_slip_jacobian(fr, ph, t, q, v, Kq, Kv):
    if fr is None:
        return
    if fr.slip.shape[0]:
        _slip_force_jacobian(ph, t, q, v, Kq, Kv)


@uncounted
def _slip_force_jacobian(ph, t, q, v, Kq, Kv):
    """Central differences of the slip friction force, added to Kq and Kv."""
    fr = ph.friction
    n = q.shape[0]
    x, fp, fm = fr.xd, fr.fp, fr.fm
    for wrt_v in (False, True):
        base = v if wrt_v else q
        K = Kv if wrt_v else Kq
        for j in range(n):
            dx = fd_step(base[j])
            copy_to(x, base)
            x[j] = base[j] + dx
            if wrt_v:
                _slip_force(ph, t, q, x, fp)
            else:
                _slip_force(ph, t, x, v, fp)
            x[j] = base[j] - dx
            if wrt_v:
                _slip_force(ph, t, q, x, fm)
            else:
                _slip_force(ph, t, x, v, fm)
            for r in range(n):
                K[r, j] = K[r, j] + (fp[r] - fm[r]) / (2.0 * dx)


@uncounted
def book_friction(ph, t0, t1, q, v):
    """Book the slip friction's work over the step t0 → t1 ending at (q, v)
    (:func:`daebench.core.coulomb.book_step`); nothing without slip."""
    _book_friction(coulomb.present(ph.friction), ph, t0, t1, q, v)


@uncounted
def _book_friction(fr, ph, t0, t1, q, v):
    if fr is None:
        return
    if fr.slip.shape[0]:
        coulomb.book_step(fr, t0, t1, slip_power(ph, t1, q, v))


@uncounted
def book_rows(ph, t0, t1, t_out, oi, j, nrow):
    """Book the slip friction's work at the output rows oi … j − 1 written over the step
    t0 → t1 (:func:`daebench.core.coulomb.book_rows`); False when it cannot (no room)."""
    return _book_rows(coulomb.present(ph.friction), t0, t1, t_out, oi, j, nrow)


@uncounted
def _book_rows(fr, t0, t1, t_out, oi, j, nrow):
    if fr is None:
        return True
    if fr.slip.shape[0] == 0:
        return True
    return coulomb.book_rows(fr, t0, t1, t_out, oi, j, nrow)


@uncounted
def friction_switches(ph, q, v, lam):
    """Whether a stick/slip switch happened at (q, v), λ the consistent multipliers there
    (:func:`daebench.core.coulomb.switches`)."""
    return _switches(coulomb.present(ph.friction), ph, q, v, lam)


@uncounted
def _switches(fr, ph, q, v, lam):
    if fr is None:
        return False
    return coulomb.switches(ph.model, fr, ph.nb, q, v, lam)
