"""Shared by the IVP-test-set mechanisms (``crank``, ``caraxis``): the multipliers of
rheonomic constraints, which do work on the system.

A constraint C(t, q) = 0 that moves with time (a driven crank, a road profile) exerts
the force −C_qᵀλ (convention M q̈ + C_qᵀλ = Q), whose power along the motion is
−λᵀ C_q q̇ = λᵀ C_t because C_q q̇ + C_t = 0. The model reports it as a work term so
that the driver's energy balance E(t) − E(0) − W(t) stays a real check. λ is the
multiplier consistent with (t, q, q̇) — the index-1 solve

    [[M, C_qᵀ], [C_q, 0]] [q̈; λ] = [Q; γ],

the same λ every exact solution carries (not an integrator's own algebraic variable).
"""

from __future__ import annotations

import numpy as np


def consistent_multipliers(system, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """λ of the bilateral constraints consistent with (t, q, v) (see the module docstring)."""
    M, Q = system.mass_force(t, q, v)
    _, Cq, _, gam = system._constraint_rows(t, q, v)
    m = Cq.shape[0]
    A = np.zeros((M.shape[0] + m, M.shape[0] + m))
    A[:M.shape[0], :M.shape[0]] = M
    A[:M.shape[0], M.shape[0]:] = Cq.T
    A[M.shape[0]:, :M.shape[0]] = Cq
    return np.linalg.solve(A, np.concatenate([Q, gam]))[M.shape[0]:]


def constraint_power(system, t: float, q: np.ndarray, v: np.ndarray) -> float:
    """λᵀ C_t: the power the moving constraints put into the system [W]."""
    Ct = system._constraint_rows(t, q)[2]
    return float(consistent_multipliers(system, t, q, v) @ Ct)
