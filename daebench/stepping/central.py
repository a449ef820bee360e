"""Explicit central differences (velocity Verlet) for lumped-mass models, as a compiled
stepper (:mod:`daebench.stepping.methods`).

One step from (q_n, v_n, a_n)::

    v_{n+½} = v_n + (h/2) a_n
    q_{n+1} = q_n + h v_{n+½}
    a_{n+1} = M⁻¹ Q(t_{n+1}, q_{n+1}, v_{n+½})
    v_{n+1} = v_{n+½} + (h/2) a_{n+1}

with M the model's constant diagonal (lumped) mass: one force evaluation and O(n)
work per step, no matrix. It is Newmark's β = 0, γ = ½ (the explicit member the
implicit Newmark family refuses), the standard explicit scheme of structural and impact
dynamics (Belytschko, Liu & Moran 2000, §6.2). Velocity-dependent forces (penalty
damping) see the half-step velocity v_{n+½}: first order in that force only.

Order 2, symplectic for conservative forces; stable for h ω_max ≤ 2 (ω_max the largest
natural frequency of the linearized model: for lumped linear elements ω_max ≤ the
largest element frequency, h ≤ l/c in a bar). A penalty contact of stiffness ε_N on a
node of mass m adds ω² ≈ ε_N/m and lowers that bound. Non-finite states are reported
as divergence. Unconstrained problems only (m = 0): a constraint contact law needs an
implicit index-3 method (hht); penalty and interactive-mode contacts suit it.

The model must declare ``lumped_mass`` (the diagonal of its constant mass) and its
``mass_force`` kernel must accept an M with no rows (force only) — the planar FE models
(:mod:`daebench.models.planar`) do; this is what makes the step O(n) instead of O(n²)
(filling a dense M) under the generic kernel interface. Other models are refused.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import phase
from daebench.stepping import methods
from daebench.stepping.methods import C_RES

ST_NOT_FINITE = 1
FAIL_MESSAGES = {ST_NOT_FINITE: "diverged: state not finite (explicit central differences need h·ω_max ≤ 2)"}


class CentralMethod(NamedTuple):
    minv: np.ndarray     # inverse lumped mass per DOF


class CentralWork(NamedTuple):
    M0: np.ndarray       # (0, 0): ask the model for the force only
    Q: np.ndarray
    vh: np.ndarray


def workspace(n: int) -> CentralWork:
    return CentralWork(np.zeros((0, 0)), np.zeros(n), np.zeros(n))


@njit(cache=True)
def acceleration(meth, ws, ph, t, q, v, a, cnt):
    """a = M⁻¹ Q(t, q, v); returns 0 or ST_NOT_FINITE."""
    phase.mass_force(ph, t, q, v, ws.M0, ws.Q)
    cnt[C_RES] += 1
    for i in range(q.shape[0]):
        a[i] = meth.minv[i] * ws.Q[i]
        if not math.isfinite(a[i]):
            return ST_NOT_FINITE
    return 0


@njit(cache=True)
def _start(meth, ws, ph, t, cur, cnt):
    return acceleration(meth, ws, ph, t, cur.q, cur.v, cur.a, cnt)


@njit(cache=True)
def _step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    n = cur.q.shape[0]
    vh = ws.vh
    for i in range(n):
        vh[i] = cur.v[i] + 0.5 * h * cur.a[i]
        new.q[i] = cur.q[i] + h * vh[i]
        if not math.isfinite(new.q[i]):
            return ST_NOT_FINITE, 0.0
    st = acceleration(meth, ws, ph, t + h, new.q, vh, new.a, cnt)
    if st:
        return st, 0.0
    for i in range(n):
        new.v[i] = vh[i] + 0.5 * h * new.a[i]
    return 0, 0.0


@njit(cache=True)
def _accept(meth, ws, h, prev, cur):
    pass


methods.start.register(CentralMethod, _start)
methods.step.register(CentralMethod, _step)
methods.accept.register(CentralMethod, _accept)
