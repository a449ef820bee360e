"""Rigid pendulum in Cartesian coordinates: the classic index-3 check.

A point mass m at q = (x, y) hangs on a massless rod of length l from the origin;
gravity g acts along −y. The rod is the bilateral constraint

    C(q) = ½ (x² + y² − l²) = 0,     C_q = [x, y],

so that  M q̈ + C_qᵀ λ = Q  with M = m I, Q = (0, −m g) and λ = (rod tension)/l
(λ > 0 when the rod pulls the mass towards the hinge). Differentiating twice,

    C̈ = C_q q̈ + v·v = 0    ⇒    C_q q̈ = γ,  γ = −v·v.

The angle θ from the downward vertical (x = l sin θ, y = −l cos θ) obeys
θ̈ = −(g/l) sin θ, whose exact solution (:func:`exact_theta`, Jacobi elliptic
functions) is the analytic truth of the order tests. The mechanical energy
E = ½ m |v|² + m g y is exactly conserved.
"""

from __future__ import annotations

import numpy as np
from scipy.special import ellipj, ellipk, ellipkinc

from typing import NamedTuple

from numba import njit

from daebench.core import kernels
from daebench.core.observables import Observable, Position
from daebench.core.params import Param
from daebench.core.scene import Scene, SceneError
from daebench.core.system import KernelSystem

DESCRIPTION = "rigid pendulum in Cartesian coordinates (index-3 DAE, exact energy conservation)"

#: the history's columns as the scorer reads them (daebench.core.observables)
OBSERVABLES = (
    Observable("theta_deg", "deg", "θ", short="theta", impact_windows=True, summary=True),
    Observable("x", "m", "bob x", summary=True),
    Observable("y", "m", "bob y", height=True, summary=True),
    Position("pos", "x", "y", label="bob position"),
)

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("pendulum.mass", float, 1.0, "mass of the bob", low=1e-9, high=1e9, unit="kg"),
        Param("pendulum.length", float, 1.0, "rod length", low=1e-9, high=1e9, unit="m"),
        Param("gravity.g", float, 9.81, "gravitational acceleration (along −y)", low=0.0, high=1e4, unit="m/s²"),
        Param("start.theta_deg", float, 30.0, "initial angle from the downward vertical", low=-180.0, high=180.0,
              unit="deg"),
        Param("start.omega", float, 0.0, "initial angular velocity dθ/dt", low=-1e6, high=1e6, unit="rad/s"),
    )
}


class PendulumData(NamedTuple):
    """Kernel data of the pendulum (:mod:`daebench.core.kernels`)."""

    m: float
    l: float
    g: float


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    M[0, 0] = md.m
    M[0, 1] = 0.0
    M[1, 0] = 0.0
    M[1, 1] = md.m
    Q[0] = 0.0
    Q[1] = -md.m * md.g


@njit(cache=True)
def _zero_jacobians(md, t, q, v, Kq, Kv):
    Kq[:, :] = 0.0
    Kv[:, :] = 0.0



@njit(cache=True)
def _constraints(md, t, q, v, C, Cq, Ct, gam):
    """The rod: C = ½(|q|² − l²), C_q = qᵀ, γ = −|v|²."""
    C[0] = 0.5 * (q[0] * q[0] + q[1] * q[1] - md.l * md.l)
    Cq[0, 0] = q[0]
    Cq[0, 1] = q[1]
    Ct[0] = 0.0
    gam[0] = -(v[0] * v[0] + v[1] * v[1])


kernels.register(PendulumData, mass_force=_mass_force, force_jacobian=_zero_jacobians,
                 mass_jacobian_product=kernels.constant_mass, constraints=_constraints)


class Pendulum(KernelSystem):
    """Point mass on a rigid rod, Cartesian coordinates q = (x, y)."""

    n = 2
    n_bilateral = 1
    n_contacts = 0
    coordinate_names = ("x", "y")
    power_free = True  # gravity only: no non-conservative effect

    def __init__(self, mass: float = 1.0, length: float = 1.0, g: float = 9.81,
                 theta0_deg: float = 30.0, omega0: float = 0.0) -> None:
        self.m = float(mass)
        self.l = float(length)
        self.g = float(g)
        self.theta0 = np.deg2rad(float(theta0_deg))
        self.omega0 = float(omega0)
        self.data = PendulumData(self.m, self.l, self.g)

    # -- bookkeeping ------------------------------------------------------------
    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {"kinetic": 0.5 * self.m * float(v @ v), "gravity": self.m * self.g * float(q[1])}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {"theta_deg": float(np.rad2deg(np.arctan2(q[0], -q[1]))), "x": float(q[0]), "y": float(q[1])}

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        th, om, l = self.theta0, self.omega0, self.l
        q = np.array([l * np.sin(th), -l * np.cos(th)])
        v = np.array([l * om * np.cos(th), l * om * np.sin(th)])
        return q, v

    # -- analytic truth -----------------------------------------------------------
    def exact_theta(self, t: np.ndarray | float) -> np.ndarray:
        """Exact θ(t) from this pendulum's start state (see :func:`exact_theta`)."""
        return exact_theta(t, self.theta0, self.omega0, self.g, self.l)

    def exact_position(self, t: np.ndarray | float) -> np.ndarray:
        """Exact (x, y) at t (shape (2,) or (2, len(t)))."""
        th = self.exact_theta(t)
        return np.array([self.l * np.sin(th), -self.l * np.cos(th)])

    def exact_observables(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """The observables' exact values at times ``t``: what runs are scored against
        (:mod:`daebench.harness.scoring`). Raises ValueError for a revolving pendulum."""
        th = self.exact_theta(t)
        return {"theta_deg": np.rad2deg(th), "x": self.l * np.sin(th), "y": -self.l * np.cos(th)}


def exact_theta(t: np.ndarray | float, theta0: float, omega0: float = 0.0,
                g: float = 9.81, length: float = 1.0) -> np.ndarray:
    """Exact angle θ(t) [rad] of the pendulum θ̈ = −(g/l) sin θ, θ(0) = θ0, θ̇(0) = ω0.

    For an oscillating (not revolving) pendulum with amplitude θ_max,
    k = sin(θ_max/2) and ω_n = √(g/l):

        θ(t) = 2 arcsin( k sn(ω_n t + u0 | m = k²) ),

    where the phase u0 places the start: sn(u0) = sin(θ0/2)/k, with cn(u0) of the
    sign of ω0 (released from rest, u0 = K(m) and θ falls back towards 0).

    Raises
    ------
    ValueError
        If the energy is at or above the separatrix (the pendulum revolves).
    """
    t = np.asarray(t, dtype=float)
    wn = np.sqrt(g / length)
    # energy: sin²(θmax/2) = sin²(θ0/2) + (ω0 / 2ωn)²
    k2 = np.sin(0.5 * theta0) ** 2 + (0.5 * omega0 / wn) ** 2
    if k2 >= 1.0:
        raise ValueError("the pendulum revolves (energy above the separatrix); exact_theta covers oscillation only")
    if k2 == 0.0:
        return np.zeros_like(t)
    k = np.sqrt(k2)
    K = ellipk(k2)
    s0 = np.clip(np.sin(0.5 * theta0) / k, -1.0, 1.0)
    u_first = ellipkinc(np.arcsin(s0), k2)  # cn(u) ≥ 0: θ increasing
    if omega0 > 0.0:
        u0 = u_first
    elif omega0 < 0.0:
        u0 = 2.0 * K - u_first
    else:
        # from rest: start at the turning point; θ0 > 0 ↔ u0 = K, θ0 < 0 ↔ u0 = −K
        u0 = K if theta0 > 0.0 else -K
    sn, _, _, _ = ellipj(wn * t + u0, k2)
    return 2.0 * np.arcsin(k * sn)


def build(scene: Scene) -> Pendulum:
    """The pendulum a scene describes."""
    return Pendulum(
        mass=scene["pendulum.mass"],
        length=scene["pendulum.length"],
        g=scene["gravity.g"],
        theta0_deg=scene["start.theta_deg"],
        omega0=scene["start.omega"],
    )


def check_scene(scene: Scene) -> None:
    """Refuse a start at the upright position (|θ0| = 180° with ω0 = 0 is an unstable rest)."""
    if abs(scene["start.theta_deg"]) == 180.0 and scene["start.omega"] == 0.0:
        raise SceneError("start.theta_deg = ±180 with start.omega = 0 is an unstable equilibrium; "
                         "nothing would move. Choose |start.theta_deg| < 180.")
