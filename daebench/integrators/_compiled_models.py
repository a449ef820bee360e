"""Model kernels behind one compiled calling convention (numba).

Why a fixed-shape tuple instead of passing model functions to the integrator loops:
numba types every dispatcher passed as an argument by its identity, so a loop that takes
``mass_force`` as an argument can never be served from the on-disk cache (measured: a
cache miss on every new process). Here instead each model packs its data into the same
*type* of tuple, the **model descriptor** ``md``::

    md = (kind, prm, ip, a1, a2, a3)
      kind : int            0 = hub–beam, 1 = pendulum (branch selected at run time)
      prm  : float64[:]     model parameters
      ip   : int64[:]       (foreshortening flag, n_contacts, n_bilateral, power-free flag)
      a1   : 11 × float64[:] one-dimensional tables and scratch; a1[9] the continuous
                            contact law's state, a1[10] its scratch (see below)
      a2   : 8 × float64[:, :] two-dimensional tables and scratch
      a3   : float64[:, :, :]

so the integrator loops in :mod:`daebench.integrators._compiled_newmark` compile once
(``cache=True``) for every model, and the second process starts from the cache. A model
joins the compiled path by returning such a descriptor from ``system.kernels()`` and
adding its branch below; any other model (a plugin's, Andrews, the chains) runs through
the Python protocol unchanged.

The functions mirror the Python protocol of :class:`daebench.system.Problem` call for
call (same kernels, same order of operations where it matters), so that the compiled
and the Python paths agree to round-off (tests/test_compiled.py).

Continuous contact laws (Hertz with any damping law, penalty) are in the kernels too:
``mass_force`` adds g_qᵀF of an engaged, penetrating contact and ``force_jacobian`` its
central differences, exactly as :meth:`daebench.system.MechanicalSystem.force` and
:meth:`daebench.models.hubbeam.HubBeam.force_jacobian` do (same formula and order of
operations, same difference steps; tests/test_compiled_contact.py). The law's state is a
float array in the descriptor, ``a1[A1_LAW]``::

    [law kind (LAW_NONE | LAW_HERTZ | LAW_PENALTY), K, exponent, c,
     engaged₀, χ₀, engaged₁, χ₁, …]          (one (engaged, χ) pair per contact)

Why an array refreshed in place rather than the law's numbers in ``prm``: the descriptor
is packed once per system and cached (its tables are large), while ``engaged`` and the
hysteresis factor χ (from the approach speed of the current episode) change at every
contact event. :func:`descriptor` copies them from the law each time it is called; every
integrator calls it when a phase starts, and the driver sets ``law.engaged`` and the
approach speed before that (they are constant within a phase). A law of another class
(a plugin's subclass may change the force) keeps the Python path while engaged.
The contact Jacobian stays a central difference (not analytic) so that the two paths
iterate with the same matrix and take the same Newton iterations.
"""

from __future__ import annotations

import os

import numpy as np
from numba import njit

from daebench.contact import ContactLaw, HertzLaw, PenaltyLaw
from daebench.models import _hubbeam_kernels as hk
from daebench.system import FD_REL_STEP

KIND_HUBBEAM = 0
KIND_PENDULUM = 1
IP_FORE, IP_NCONTACTS, IP_NBILATERAL, IP_POWER_FREE = range(4)
N_A1, N_A2 = 11, 8
A1_LAW, A1_LAW_WORK = 9, 10
LAW_NONE, LAW_HERTZ, LAW_PENALTY = 0, 1, 2
CL_KIND, CL_K, CL_EXP, CL_C, CL_HEAD = 0, 1, 2, 3, 4  # law slot header; then (engaged, χ) per contact


def enabled() -> bool:
    """Compiled paths on unless the environment sets DAEBENCH_COMPILED=0 (or false/no/off)."""
    return os.environ.get("DAEBENCH_COMPILED", "1").strip().lower() not in ("0", "false", "no", "off")


def descriptor(system) -> tuple | None:
    """The model descriptor of ``system`` for compiled integrator loops, or None (Python path).

    None when compiled paths are disabled, when the model has no ``kernels()``, or when a
    continuous contact law that the kernels do not implement has an engaged contact (with
    no engaged contact the law's force is exactly zero, as in the Python path). Otherwise
    the descriptor's contact-law state is refreshed from ``system.contact_law`` (engaged
    contacts, χ) — call this again whenever those change (integrators: at each start)."""
    if not enabled():
        return None
    fn = getattr(system, "kernels", None)
    if fn is None:
        return None
    md = fn()
    if not load_contact_law(md, getattr(system, "contact_law", None)):
        return None
    return md


def contact_law_slots(n: int, n_contacts: int) -> tuple[np.ndarray, np.ndarray]:
    """(law state, law scratch) arrays for ``a1[A1_LAW]``, ``a1[A1_LAW_WORK]`` of a model
    with ``n`` coordinates whose kernels add continuous contact forces."""
    return np.zeros(CL_HEAD + 2 * n_contacts), np.zeros(3 * n)


def load_contact_law(md: tuple, law: ContactLaw | None) -> bool:
    """Copy ``law``'s current state into the descriptor (in place). False when the kernels
    cannot reproduce its force while a contact is engaged (the caller takes the Python path)."""
    cl = md[3][A1_LAW]
    cl[CL_KIND] = LAW_NONE
    if law is None or not law.continuous:
        return True  # no force of a law (constraint: the driver's business)
    engaged = np.asarray(law.engaged, dtype=bool)
    nc = engaged.size
    # exact classes only: a subclass may override the force
    if type(law) not in (HertzLaw, PenaltyLaw) or cl.size < CL_HEAD + 2 * nc:
        return not bool(np.any(engaged))
    if type(law) is HertzLaw:
        cl[CL_KIND] = LAW_HERTZ
        cl[CL_K] = law.stiffness
        cl[CL_EXP] = law.exponent
        cl[CL_C] = 0.0
        chi = law._chi()  # the Python path's own χ (approach speed floored at APPROACH_SPEED_MIN)
    else:
        cl[CL_KIND] = LAW_PENALTY
        cl[CL_K] = law.stiffness
        cl[CL_EXP] = 1.0
        cl[CL_C] = law.damping_coefficient
        chi = np.zeros(nc)
    for i in range(nc):
        cl[CL_HEAD + 2 * i] = 1.0 if engaged[i] else 0.0
        cl[CL_HEAD + 2 * i + 1] = chi[i]
    return True


def pack(kind: int, prm, ip, a1: list, a2: list, a3) -> tuple:
    """A model descriptor with every array C-contiguous, writable float64 (padded with dummies)."""
    def c(x, nd):
        x = np.require(np.asarray(x, dtype=np.float64), np.float64, ["C", "W"])  # no copy of big tables
        assert x.ndim == nd
        return x
    a1 = [c(x, 1) for x in a1] + [np.zeros(1) for _ in range(N_A1 - len(a1))]
    a2 = [c(x, 2) for x in a2] + [np.zeros((1, 1)) for _ in range(N_A2 - len(a2))]
    return (int(kind), c(prm, 1), np.array(ip, dtype=np.int64), tuple(a1), tuple(a2), c(a3, 3))


# -- hub–beam: md layout -----------------------------------------------------------------------
# a1: xs, wm, phx_bar, phy_bar, phx_p, phy_p, [x_p], gq scratch, G1 scratch, law state, law scratch (3n)
# a2: phx, phy, Mc, K1, K2, Hbar, H_p, work scratch;  a3: H (nB, nB, nq)


@njit(cache=True)
def mass_force(md, t, q, v, M, Q):
    """M(q) and the force Q(t, q, v) (with the force of an engaged continuous contact law).

    Hot loops call the pendulum's kernels (``pendulum_*``, parameter array only) directly
    when ``md[0] == KIND_PENDULUM``: every njit call that receives ``md`` increfs and
    decrefs its ~20 arrays atomically on entry and exit, and on the pendulum those
    reference counts were most of the step (measured with perf)."""
    if md[0] == KIND_PENDULUM:
        pendulum_mass_force(md[1], M, Q)
    else:
        _mass_force(md, t, q, v, M, Q)


@njit(cache=True)
def pendulum_mass_force(prm, M, Q):
    m = prm[0]
    M[0, 0] = m
    M[0, 1] = 0.0
    M[1, 0] = 0.0
    M[1, 1] = m
    Q[0] = 0.0
    Q[1] = -m * prm[2]


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    kind, prm, ip, a1, a2, a3 = md
    hk.mass_force(t, q, v, prm, ip[IP_FORE], a1[0], a1[1], a2[0], a2[1], a3, a2[2], a2[3], a2[4],
                  a1[2], a1[3], a2[5], True, M, Q, a2[7])
    cl = a1[A1_LAW]
    if cl[CL_KIND] != LAW_NONE and ip[IP_NCONTACTS] > 0 and cl[CL_HEAD] != 0.0:
        # as MechanicalSystem.force: Q + g_qᵀF only while the gap is negative
        gq = a1[A1_LAW_WORK][:q.shape[0]]
        g, F = _hb_contact(prm, ip[IP_FORE], a1, a2, cl, q, v, gq)
        if g < 0.0:
            for i in range(q.shape[0]):
                Q[i] = Q[i] + gq[i] * F


@njit(cache=True)
def law_force(cl, i, g, gdot):
    """Normal force of contact i of the law in ``cl`` at gap g < 0 and gap rate ġ: the
    formulas of HertzLaw.force / PenaltyLaw.force, operation for operation."""
    engaged = cl[CL_HEAD + 2 * i] != 0.0
    delta = max(-g, 0.0)
    if cl[CL_KIND] == LAW_HERTZ:
        elastic = cl[CL_K] * delta ** cl[CL_EXP] if engaged else 0.0
        ddot = -gdot
        return max(elastic * (1.0 + cl[CL_HEAD + 2 * i + 1] * ddot), 0.0)
    if cl[CL_KIND] == LAW_PENALTY:
        F = cl[CL_K] * delta + cl[CL_C] * (-gdot)
        return max(F, 0.0) if (engaged and delta > 0.0) else 0.0
    return 0.0


@njit(cache=True)
def _hb_contact(prm, fore, a1, a2, cl, q, v, gq):
    """(g, F) of the hub–beam contact point at (q, v); g_q is left in ``gq``."""
    g, _ = hk.gap_kernel(q, v, prm, fore, a1[6][0], a1[4], a1[5], a2[6], gq, a1[8])
    gdot = 0.0
    for j in range(q.shape[0]):
        gdot += gq[j] * v[j]
    return g, law_force(cl, 0, g, gdot)


@njit(cache=True)
def force_jacobian(md, t, q, v, Kq, Kv):
    if md[0] == KIND_HUBBEAM:
        kind, prm, ip, a1, a2, a3 = md
        hk.force_jacobian(t, q, v, prm, ip[IP_FORE], a1[0], a1[1], a2[0], a2[1], a3, a2[3], a2[4],
                          a1[2], a1[3], a2[5], Kq, Kv)
        cl = a1[A1_LAW]
        if cl[CL_KIND] != LAW_NONE and ip[IP_NCONTACTS] > 0 and cl[CL_HEAD] != 0.0:
            _hb_contact_jacobian(prm, ip[IP_FORE], a1, a2, cl, q, v, Kq, Kv)
    else:
        Kq[:, :] = 0.0
        Kv[:, :] = 0.0


@njit(cache=True)
def _hb_contact_jacobian(prm, fore, a1, a2, cl, q, v, Kq, Kv):
    """Kq, Kv += central differences of g_qᵀF(q, v), as HubBeam.force_jacobian does (same
    steps FD_REL_STEP·max(1, |x_j|), same (f₊ − f₋)/(2 dx), added column by column)."""
    n = q.shape[0]
    w = a1[A1_LAW_WORK]
    xp, gp, gm = w[:n], w[n:2 * n], w[2 * n:3 * n]
    g0, _ = _hb_contact(prm, fore, a1, a2, cl, q, v, gp)
    if not g0 < 0.0:
        return  # open: the Python path adds nothing either
    for wrt_v in (False, True):  # ∂/∂q into Kq, then ∂/∂v into Kv
        x = v if wrt_v else q
        K = Kv if wrt_v else Kq
        for j in range(n):
            dx = FD_REL_STEP * max(1.0, abs(x[j]))
            xp[:] = x
            xp[j] = x[j] + dx
            g1, F1 = _hb_contact(prm, fore, a1, a2, cl, q if wrt_v else xp, xp if wrt_v else v, gp)
            xp[j] = x[j] - dx
            g2, F2 = _hb_contact(prm, fore, a1, a2, cl, q if wrt_v else xp, xp if wrt_v else v, gm)
            for i in range(n):
                fp = gp[i] * F1 if g1 < 0.0 else 0.0
                fm = gm[i] * F2 if g2 < 0.0 else 0.0
                K[i, j] = K[i, j] + (fp - fm) / (2.0 * dx)


@njit(cache=True)
def mass_jacobian_product(md, q, acc, out):
    if md[0] == KIND_HUBBEAM:
        kind, prm, ip, a1, a2, a3 = md
        hk.mass_jacobian_product(q, acc, prm, ip[IP_FORE], a1[0], a1[1], a2[0], a2[1], a3, out)
    else:
        out[:, :] = 0.0


@njit(cache=True)
def _gap_point(md, q, v):
    """(g, γ_g) of the hub–beam contact point; its Jacobian is left in a1[7]."""
    kind, prm, ip, a1, a2, a3 = md
    return hk.gap_kernel(q, v, prm, ip[IP_FORE], a1[6][0], a1[4], a1[5], a2[6], a1[7], a1[8])


@njit(cache=True)
def gaps(md, q, zeros, g):
    """All contact gaps g(q) (``zeros``: a zero velocity of length n)."""
    kind = md[0]
    if kind == KIND_HUBBEAM and md[2][IP_NCONTACTS] > 0:
        gi, _ = _gap_point(md, q, zeros)
        g[0] = gi


@njit(cache=True)
def constraints(md, t, q, v, active, C, Cq, Ct, gam):
    """Rows of the active constraints (bilateral first, then C = −g of the closed contacts
    in ``active``): C, C_q, C_t and γ."""
    if md[0] == KIND_PENDULUM:
        pendulum_constraints(md[1], q, v, C, Cq, Ct, gam)
    else:
        _constraints(md, t, q, v, active, C, Cq, Ct, gam)


@njit(cache=True)
def pendulum_constraints(prm, q, v, C, Cq, Ct, gam):
    """The rod (the pendulum has no contacts)."""
    l = prm[1]
    C[0] = 0.5 * (q[0] * q[0] + q[1] * q[1] - l * l)
    Cq[0, 0] = q[0]
    Cq[0, 1] = q[1]
    Ct[0] = 0.0
    gam[0] = -(v[0] * v[0] + v[1] * v[1])


@njit(cache=True)
def _constraints(md, t, q, v, active, C, Cq, Ct, gam):
    kind, prm, ip, a1, a2, a3 = md
    n = q.shape[0]
    r = 0
    for c in active:
        if kind == KIND_HUBBEAM:
            g, gamma = _gap_point(md, q, v)
            gq = a1[7]
            C[r] = -g
            for j in range(n):
                Cq[r, j] = -gq[j]
            Ct[r] = 0.0
            gam[r] = -gamma
        r += 1


@njit(cache=True)
def constraint_jacobian(md, t, q, active, Cq, scratch_m, scratch_v):
    """C_q only (``scratch_m``: length m, ``scratch_v``: zero velocity of length n)."""
    constraints(md, t, q, scratch_v, active, scratch_m, Cq, scratch_m, scratch_m)
