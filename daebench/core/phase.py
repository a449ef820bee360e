"""One smooth phase, compiled: the model's kernels plus the phase's active contact
constraints and continuous contact forces (numba).

Integrators see a *phase*: the model with a fixed set of closed contacts (constraint
law) and a fixed set of engaged contacts (continuous laws), never a switch. Its data,
:class:`PhaseData`, is built by :class:`daebench.core.problem.Problem` and fixed for the
phase; the functions here are the only place where the phase is assembled from the
model's kernels (:mod:`daebench.core.kernels`), for every integrator and for the Python
protocol alike:

* forces: Q = Q_model + Σ g_iᵀ F_i over engaged, penetrating contacts, F_i from the
  contact law (:func:`law_force` — the one implementation of the laws' formulas);
* constraints: the model's bilateral rows, then C = −g_i of each closed contact i, so
  that with M q̈ + C_qᵀ λ = Q the multiplier λ_i ≥ 0 is the compressive contact force;
* their Jacobians (contact force and ∂(C_qᵀλ)/∂q, ∂(C_q v)/∂q by central differences
  with the one step rule :func:`daebench.core.kernels.fd_step`).

Contact-law parameters ``law`` = [kind, K, exponent, c, v_ε]: Hertz F = K δⁿ (1 + χ δ̇),
penalty F = K δ + c δ̇, both clipped at 0 (no adhesion); δ = −g, χ per contact from the
approach speed of the episode (:func:`daebench.core.contact.hysteresis_factor`).

Regularised Coulomb friction (continuous laws only): at a penetrating contact with
friction coefficient μ_i > 0 (the model's ``tangent`` kernel, which also gives the
tangent row t_q with slip velocity v_T = t_q · v) the tangential force

    F_T = −μ_i F_N tanh(v_T / v_ε)

acts along t_q (:func:`friction_force`, the one implementation): the hyperbolic-tangent
characteristic of the smooth dry-friction models reviewed by Pennestrì, Rossi, Salvini
& Valentini (2016), "Review and comparison of dry friction force models", Nonlinear Dyn.
83, 1785–1801 (also Flores et al. 2011's regularised Coulomb law). |F_T| → μ F_N once
|v_T| ≫ v_ε (the deficit μ F_N (1 − tanh(|v_T|/v_ε)) ≤ 2 μ F_N e^{−2|v_T|/v_ε}); a
load below the cone is held by a creep speed v_T = v_ε artanh(|F|/(μ F_N)) ∝ v_ε,
never by an exact stick. Its power Σ F_T v_T ≤ 0 is the friction work the driver books
(:func:`friction_power`); its ∂/∂q, ∂/∂v enter :func:`force_jacobian` with the normal
force's (the slope μ F_N / v_ε at v_T = 0 is a stiff viscous term: implicit Newton loops
need it to converge at steps larger than the time constant v_ε / (μ g)).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core.borrow import copy_to, uncounted
from daebench.core import coulomb, kernels
from daebench.core.kernels import fd_step
from daebench.core.linalg import lu_factor, lu_solve

LAW_NONE, LAW_HERTZ, LAW_PENALTY = 0, 1, 2


class PhaseData(NamedTuple):
    model: tuple            # the model's kernel data (a registered NamedTuple)
    nb: int                 # bilateral constraints (rows 0 … nb − 1)
    active: np.ndarray      # int64: closed contacts, constraint rows nb, nb + 1, …
    law: np.ndarray | None  # float64[5]: kind, K, exponent, c, v_ε (friction regularisation velocity); None: no continuous law
    engaged: np.ndarray     # float64 per contact: 1 = its continuous force acts in this phase
    chi: np.ndarray         # float64 per contact: hysteresis factor of the current episode
    gq: np.ndarray          # float64[n] scratch: one gap-Jacobian row
    work: np.ndarray        # float64[5n] scratch: contact-force differences, tangent rows
    friction: tuple         # coulomb.FrictionData: stick rows and slipping contacts (coulomb.NONE: none)
    lumped: np.ndarray | None  # float64[n]: a lumped model's constant diagonal mass (its kernel's M may have no rows); None: none


# -- contact laws ------------------------------------------------------------------------
@uncounted
def law_force(law, engaged, chi, g, gdot):
    """Normal force F ≥ 0 of a continuous law at gap g and gap rate ġ."""
    kind = law[0]
    delta = max(-g, 0.0)
    if kind == LAW_HERTZ:
        elastic = law[1] * delta ** law[2] if engaged else 0.0
        return max(elastic * (1.0 + chi * (-gdot)), 0.0)
    if kind == LAW_PENALTY:
        F = law[1] * delta + law[3] * (-gdot)
        return max(F, 0.0) if (engaged and delta > 0.0) else 0.0
    return 0.0


@uncounted
def law_elastic(law, engaged, g):
    """The conservative part of the force (its potential is :func:`law_potential`)."""
    if not engaged:
        return 0.0
    delta = max(-g, 0.0)
    if law[0] == LAW_HERTZ:
        return law[1] * delta ** law[2]
    if law[0] == LAW_PENALTY:
        return law[1] * delta
    return 0.0


@uncounted
def law_potential(law, g):
    """Energy stored in the contact spring at gap g."""
    delta = max(-g, 0.0)
    if law[0] == LAW_HERTZ:
        return law[1] * delta ** (law[2] + 1.0) / (law[2] + 1.0)
    if law[0] == LAW_PENALTY:
        return 0.5 * law[1] * delta * delta
    return 0.0


@uncounted
def friction_force(law, mu, fn, vt):
    """Tangential force F_T = −μ F_N tanh(v_T / v_ε) of the regularised Coulomb law at
    normal force F_N ≥ 0 and slip velocity v_T (module docstring); 0 for μ = 0."""
    if mu == 0.0 or fn == 0.0:
        return 0.0
    return -mu * fn * math.tanh(vt / law[4])


# -- forces ---------------------------------------------------------------------------------
@uncounted
def _contact_force(ph, i, q, v, gq, tq, fric=True):
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
def mass_force(ph, t, q, v, M, Q):
    """M(q) and the phase's force Q (model force + engaged contact forces g_qᵀF_N + t_qᵀF_T
    + the slip friction of closed contacts, :func:`add_slip_force`)."""
    _mass_force(ph, t, q, v, M, Q)
    _add_slip(coulomb.present(ph.friction), ph, t, q, v, M, Q)


@uncounted
def _add_slip(fr, ph, t, q, v, M, Q):
    """:func:`add_slip_force` when the phase has slipping contacts (``fr`` None: never; the
    branch is not compiled for a frictionless phase, :func:`daebench.core.coulomb.present`)."""
    if fr is None:
        return
    if fr.slip.shape[0]:
        add_slip_force(ph, t, q, v, M, Q)


@uncounted
def _mass_force(ph, t, q, v, M, Q):
    """M(q) and the phase's force without the slip friction of closed contacts."""
    kernels.mass_force(ph.model, t, q, v, M, Q)
    _add_contact_forces(ph.law, ph, q, v, Q)


@uncounted
def _add_contact_forces(law, ph, q, v, Q):
    """Q += g_qᵀF_N + t_qᵀF_T of the engaged, penetrating contacts (``law`` None: no
    continuous law, nothing compiled)."""
    if law is None:
        return
    n = q.shape[0]
    gq, tq = ph.gq, ph.work[3 * n:4 * n]
    for i in range(ph.engaged.shape[0]):
        if ph.engaged[i] != 0.0:
            g, F, FT = _contact_force(ph, i, q, v, gq, tq)
            if g < 0.0:
                for j in range(n):
                    Q[j] += gq[j] * F + tq[j] * FT


# -- Coulomb friction at closed contacts (daebench.core.coulomb, daebench.driver.stickslip) --------------
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
    _mass_force(ph, t, q, v, fr.M, fr.Q)
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
    _mass_force(ph, t, q, v, fr.M, fr.Q)
    info = slip_normal_forces(ph, t, q, v, fr.M, fr.Q)
    for j in range(n):
        out[j] = 0.0 if info == 0 else math.nan
    if info == 0:
        _subtract_slip(ph, n, out)


@uncounted
def _add_slip_jacobian(fr, ph, t, q, v, Kq, Kv):
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
            g, _, FT = _contact_force(ph, i, q, v, gq, tq)
            if g < 0.0 and FT != 0.0:
                for j in range(n):
                    P += FT * tq[j] * v[j]
    return P


@uncounted
def force_jacobian(ph, t, q, v, Kq, Kv):
    """∂Q/∂q, ∂Q/∂v of the phase's force: the model's kernel plus central differences of
    each engaged, penetrating contact force g_iᵀF_N,i + t_iᵀF_T,i."""
    kernels.force_jacobian(ph.model, t, q, v, Kq, Kv)
    _add_slip_jacobian(coulomb.present(ph.friction), ph, t, q, v, Kq, Kv)
    _add_contact_jacobian(ph.law, ph, q, v, Kq, Kv)


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
def _add_contact_jacobian(law, ph, q, v, Kq, Kv):
    """Central differences of each engaged, penetrating contact force, added to Kq, Kv."""
    if law is None:
        return
    n = q.shape[0]
    xp, gp, gm = ph.work[:n], ph.work[n:2 * n], ph.work[2 * n:3 * n]
    tp, tm = ph.work[3 * n:4 * n], ph.work[4 * n:5 * n]
    for i in range(ph.engaged.shape[0]):
        if ph.engaged[i] == 0.0:
            continue
        g0, _, _ = _contact_force(ph, i, q, v, gp, tp, False)
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
                g1, F1, T1 = _contact_force(ph, i, q if wrt_v else xp, xp if wrt_v else v, gp, tp, fric)
                xp[j] = x[j] - dx
                g2, F2, T2 = _contact_force(ph, i, q if wrt_v else xp, xp if wrt_v else v, gm, tm, fric)
                for r in range(n):
                    fp = gp[r] * F1 + (tp[r] * T1 if fric else 0.0) if g1 < 0.0 else 0.0
                    fm = gm[r] * F2 + (tm[r] * T2 if fric else 0.0) if g2 < 0.0 else 0.0
                    K[r, j] = K[r, j] + (fp - fm) / (2.0 * dx)


@uncounted
def mass_jacobian_product(ph, q, a, K):
    kernels.mass_jacobian_product(ph.model, q, a, K)


# -- constraints ----------------------------------------------------------------------------
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


# -- the augmented system [[M, C_qᵀ], [C_q, 0]] -----------------------------------------------
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


# -- gaps --------------------------------------------------------------------------------------
@uncounted
def gaps(ph, q, v, g, G, gam):
    """Every contact's gap, Jacobian row and γ_g (for the Python protocol)."""
    for i in range(g.shape[0]):
        g[i], gam[i] = kernels.gap(ph.model, i, q, v, G[i])
