"""The energy scale of a run: what its energy-balance residual is measured against.

A run has diverged when its energy residual |E − E0 − W_nc + D_impacts| exceeds
``DIVERGENCE_ENERGY`` (the driver's) × this scale plus the work booked since the start.
The scale is fixed by the start (never by the current energy, which grows with a
blow-up):

* the size of the start's energy terms, Σ|E_i(q0, v0)| (a system starting at E0 = 0 with
  large opposite terms still has a scale), or, where the start has no energy at all,
* a floor from the model's own scales: the kinetic energy its applied forces at the start
  (gravity, springs, drives) give the unconstrained system in ``FLOOR_TIME`` seconds,
  ½ (τ Q0)ᵀ M(q0)⁻¹ (τ Q0). A start with no energy at all — a hub–beam at θ = 0 at rest,
  whose gravity and kinetic terms are both zero at t = 0 — otherwise had a scale of
  1e-12 J, and the round-off of its first fall (3e-9 J) was called a divergence.

The floor is for zero-energy starts only: for a stiff spring (frequency ω, τω > 1) it is
(τω)² times the spring's own energy — a mass on a 1e8 N/m spring started 0.1 m from rest
(5e5 J) got a floor of 5e7 J, so that a run whose energy grew 600-fold still passed. On
the zero-energy start it exists for, the beam of beam-impact at θ = 0 with contact off gets
4.1e-5 J instead of 1e-12 J. One rule for the driver and the stability study (which
predicts when a mode passes the same threshold).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from daebench.core.linalg import solve_structured

FLOOR_TIME = 1e-3        # s: the floor is the energy the start's forces give the free system in this time
ABSOLUTE_FLOOR = 1e-12   # J: a system with neither energy nor force at the start


def energy_scale(system: Any, q0: np.ndarray, v0: np.ndarray, t0: float = 0.0) -> float:
    """Σ|E_i(q0, v0)|, or where that is below 1e-12 J, max(½ (τ Q0)ᵀ M⁻¹ (τ Q0), 1e-12 J) [J]
    (see the module docstring)."""
    terms = sum(abs(float(x)) for x in system.energy(q0, v0).values())
    return terms if terms > ABSOLUTE_FLOOR else max(force_floor(system, q0, v0, t0), ABSOLUTE_FLOOR)


def force_floor(system: Any, q0: np.ndarray, v0: np.ndarray, t0: float = 0.0) -> float:
    """½ (τ Q0)ᵀ M(q0)⁻¹ (τ Q0) with τ = FLOOR_TIME; 0 when it cannot be evaluated."""
    try:
        M = np.asarray(system.mass(q0), float)
        Q = np.asarray(system.applied_force(t0, q0, v0), float)
        a = solve_structured(M, Q)
    except (np.linalg.LinAlgError, ValueError, NotImplementedError, AttributeError):
        return 0.0
    e = 0.5 * FLOOR_TIME ** 2 * float(Q @ a)
    return e if np.isfinite(e) and e > 0 else 0.0
