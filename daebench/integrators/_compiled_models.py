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
      a1   : 9 × float64[:] one-dimensional tables and scratch
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
"""

from __future__ import annotations

import os

import numpy as np
from numba import njit

from daebench.models import _hubbeam_kernels as hk

KIND_HUBBEAM = 0
KIND_PENDULUM = 1
IP_FORE, IP_NCONTACTS, IP_NBILATERAL, IP_POWER_FREE = range(4)
N_A1, N_A2 = 9, 8


def enabled() -> bool:
    """Compiled paths on unless the environment sets DAEBENCH_COMPILED=0 (or false/no/off)."""
    return os.environ.get("DAEBENCH_COMPILED", "1").strip().lower() not in ("0", "false", "no", "off")


def descriptor(system) -> tuple | None:
    """The model descriptor of ``system`` for compiled integrator loops, or None (Python path).

    None when compiled paths are disabled, when the model has no ``kernels()``, or when a
    continuous contact law has an engaged contact (its force is not in the kernels; with no
    engaged contact the law's force is exactly zero, as in the Python path)."""
    if not enabled():
        return None
    fn = getattr(system, "kernels", None)
    if fn is None:
        return None
    law = getattr(system, "contact_law", None)
    if law is not None and law.continuous and bool(np.any(law.engaged)):
        return None
    return fn()


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
# a1: xs, wm, phx_bar, phy_bar, phx_p, phy_p, [x_p], gq scratch, G1 scratch
# a2: phx, phy, Mc, K1, K2, Hbar, H_p, work scratch;  a3: H (nB, nB, nq)


@njit(cache=True)
def mass_force(md, t, q, v, M, Q):
    """M(q) and the applied force Q(t, q, v) (without continuous contact forces).

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


@njit(cache=True)
def force_jacobian(md, t, q, v, Kq, Kv):
    if md[0] == KIND_HUBBEAM:
        kind, prm, ip, a1, a2, a3 = md
        hk.force_jacobian(t, q, v, prm, ip[IP_FORE], a1[0], a1[1], a2[0], a2[1], a3, a2[3], a2[4],
                          a1[2], a1[3], a2[5], Kq, Kv)
    else:
        Kq[:, :] = 0.0
        Kv[:, :] = 0.0


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
