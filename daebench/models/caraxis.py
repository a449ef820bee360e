"""The car axis of the IVP test set: index-3 DAE, a rheonomic constraint (a bumpy road).

Source: F. Mazzia, C. Magherini, *Test Set for IVP Solvers*, release 2.4, University of
Bari (2008), problem "Car axis" (file caraxis.f, revision caraxis.F 1.2 2006/10/02);
after Schwarz & Rentrop's model in Hairer & Wanner, *Solving ODEs II*, §VII.1 and
Rentrop, Roche & Steinebach (1989). The axis of length L joins the left wheel point
(xl, yl), on a spring from the origin, to the right one (xr, yr), on a spring from the
road point B(t) = (xb, yb), yb = r sin(ωt), xb = √(L² − yb²) (the bump); both springs
have stiffness 1 and rest length L0, the bodies mass M ε²/2 = k, gravity g.

Coordinates q = (xl, yl, xr, yr), all [m]. Our equations (M q̈ + C_qᵀλ = Q, C = 0):

    M = k I₄,  k = M ε²/2,
    Q = ((L0 − ℓl) xl/ℓl,  (L0 − ℓl) yl/ℓl − k g,  (L0 − ℓr)(xr − xb)/ℓr,  (L0 − ℓr)(yr − yb)/ℓr − k g),
    C1 = xb(t) xl + yb(t) yl = 0,           C2 = (xl − xr)² + (yl − yr)² − L² = 0,

ℓl = |(xl, yl)|, ℓr = |(xr − xb, yr − yb)|. Map to the test set's y ∈ ℝ¹⁰: y1…4 = q,
y5…8 = q̇, and y9, y10 = −λ1, −λ2 (the test set writes k q̈ = f + Gᵀλ: the opposite sign
of our multipliers). C1 depends on t: C_t = ẋb xl + ẏb yl, and
γ1 = −2(ẋb ẋl + ẏb ẏl) − (ẍb xl + ÿb yl), γ2 = −2|q̇_l − q̇_r|².

Energy: E = ½ k|q̇|² + ½(ℓl − L0)² + k g (yl + yr). The right spring hangs on the moving
road point, so its potential depends on t; it is booked as a force with its work
(``power()["road_spring"]`` = Q_r·q̇), beside the work of the moving constraint
(``power()["road_constraint"]`` = λᵀC_t). The test set's start is consistent for its
data (rω = 1); :meth:`CarAxis.initial_state` takes q̇_l = q̇_r = (−rωL0/L, 0), which is
that start for rω = 1 and consistent for any r, ω.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.models._ivpset import constraint_power, consistent_multipliers
from daebench.core.params import Param
from daebench.core.scene import Scene
from daebench.core.system import KernelSystem

DESCRIPTION = "car axis on a bumpy road (IVP test set): 4 coordinates, 2 constraints (one moving), index 3"

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("caraxis.eps", float, 1e-2, "ε: the bodies' mass is M ε²/2", low=1e-6, high=1.0),
        Param("caraxis.mass", float, 10.0, "M in the mass M ε²/2", low=1e-9, high=1e9),
        Param("caraxis.length", float, 1.0, "axis length L", low=1e-6, high=1e3, unit="m"),
        Param("caraxis.rest_length", float, 0.5, "spring rest length L0", low=1e-6, high=1e3, unit="m"),
        Param("caraxis.bump_height", float, 0.1, "road bump amplitude r", low=0.0, high=1e3, unit="m"),
        Param("caraxis.bump_frequency", float, 10.0, "road bump angular frequency ω", low=0.0, high=1e6,
              unit="rad/s"),
        Param("caraxis.g", float, 1.0, "gravity", low=0.0, high=1e3, unit="m/s²"),
    )
}

NAMES = ("xl", "yl", "xr", "yr")


class CarAxisData(NamedTuple):
    """Kernel data of the car axis (:mod:`daebench.core.kernels`)."""

    k: float      # body mass M ε²/2
    L: float
    L0: float
    r: float
    w: float
    g: float


@njit(cache=True)
def road(md, t):
    """(xb, yb, ẋb, ẏb, ẍb, ÿb): the road point B(t) and its derivatives."""
    yb = md.r * math.sin(md.w * t)
    yd = md.r * md.w * math.cos(md.w * t)
    ydd = -md.w * md.w * yb
    xb = math.sqrt(md.L * md.L - yb * yb)
    xd = -yb * yd / xb
    xdd = -(yd * yd + yb * ydd + xd * xd) / xb
    return xb, yb, xd, yd, xdd, ydd


@njit(cache=True)
def _spring(md, dx, dy, F, K, i):
    """Force (L0 − ℓ) d/ℓ of a unit spring with end offset d into F[i:i+2], and its
    Jacobian L0 (I/ℓ − d dᵀ/ℓ³) − I into K[i:i+2, i:i+2]."""
    ell = math.sqrt(dx * dx + dy * dy)
    F[i] = (md.L0 - ell) * dx / ell
    F[i + 1] = (md.L0 - ell) * dy / ell
    c = md.L0 / ell
    c3 = md.L0 / ell**3
    K[i, i] = c - c3 * dx * dx - 1.0
    K[i, i + 1] = -c3 * dx * dy
    K[i + 1, i] = -c3 * dx * dy
    K[i + 1, i + 1] = c - c3 * dy * dy - 1.0


@njit(cache=True)
def _forces(md, t, q, Q, K):
    xb, yb, _, _, _, _ = road(md, t)
    K[:, :] = 0.0
    _spring(md, q[0], q[1], Q, K, 0)
    _spring(md, q[2] - xb, q[3] - yb, Q, K, 2)
    Q[1] -= md.k * md.g
    Q[3] -= md.k * md.g


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    M[:, :] = 0.0
    for i in range(4):
        M[i, i] = md.k
    K = np.empty((4, 4))
    _forces(md, t, q, Q, K)


@njit(cache=True)
def _force_jacobian(md, t, q, v, Kq, Kv):
    Q = np.empty(4)
    _forces(md, t, q, Q, Kq)
    Kv[:, :] = 0.0



@njit(cache=True)
def _constraints(md, t, q, v, C, Cq, Ct, gam):
    xb, yb, xd, yd, xdd, ydd = road(md, t)
    dx, dy = q[0] - q[2], q[1] - q[3]
    du, dv = v[0] - v[2], v[1] - v[3]
    C[0] = xb * q[0] + yb * q[1]
    C[1] = dx * dx + dy * dy - md.L * md.L
    Cq[0, 0] = xb
    Cq[0, 1] = yb
    Cq[0, 2] = 0.0
    Cq[0, 3] = 0.0
    Cq[1, 0] = 2.0 * dx
    Cq[1, 1] = 2.0 * dy
    Cq[1, 2] = -2.0 * dx
    Cq[1, 3] = -2.0 * dy
    Ct[0] = xd * q[0] + yd * q[1]
    Ct[1] = 0.0
    gam[0] = -2.0 * (xd * v[0] + yd * v[1]) - (xdd * q[0] + ydd * q[1])
    gam[1] = -2.0 * (du * du + dv * dv)


kernels.register(CarAxisData, mass_force=_mass_force, force_jacobian=_force_jacobian,
                 mass_jacobian_product=kernels.constant_mass, constraints=_constraints)


class CarAxis(KernelSystem):
    """The car axis (n = 4, two bilateral constraints, the first moving); see the module docstring."""

    n = 4
    n_bilateral = 2
    n_contacts = 0
    coordinate_names = NAMES
    #: the reference solver (daebench.harness.references): the index-1 ODE by DOP853, with
    #: absolute tolerances rtol × state_scale() (daebench.integrators.odeint)
    reference_solver = "dop853"

    def __init__(self, eps: float = 1e-2, mass: float = 10.0, length: float = 1.0, rest_length: float = 0.5,
                 bump_height: float = 0.1, bump_frequency: float = 10.0, g: float = 1.0) -> None:
        self.data = CarAxisData(float(mass) * float(eps) ** 2 / 2.0, float(length), float(rest_length),
                                float(bump_height), float(bump_frequency), float(g))

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        md = self.data
        return {"kinetic": 0.5 * md.k * float(v @ v),
                "elastic": 0.5 * (math.hypot(q[0], q[1]) - md.L0) ** 2,
                "gravity": md.k * md.g * float(q[1] + q[3])}

    def power(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        md = self.data
        xb, yb = road(md, float(t))[:2]
        dx, dy = q[2] - xb, q[3] - yb
        ell = math.hypot(dx, dy)
        f = (md.L0 - ell) / ell
        return {"road_spring": f * (dx * v[2] + dy * v[3]), "road_constraint": constraint_power(self, t, q, v)}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {name: float(x) for name, x in zip(NAMES, q)}

    def state_scale(self) -> tuple[np.ndarray, np.ndarray]:
        """Size of each q_i and q̇_i over the test set's run (max |·| on [0, 3] with its data,
        rounded up): the error weights of a reference (absolute tolerance rtol × scale)."""
        return np.array([0.05, 0.5, 1.05, 0.65]), np.array([0.5, 0.03, 0.6, 2.1])

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        md = self.data
        u = -md.r * md.w * md.L0 / md.L
        return np.array([0.0, md.L0, md.L, md.L0]), np.array([u, 0.0, u, 0.0])

    def test_set_vector(self, t: float, q: np.ndarray, v: np.ndarray, lam: np.ndarray | None = None) -> np.ndarray:
        """The test set's y ∈ ℝ¹⁰ from our (q, q̇, λ) (λ consistent with (t, q, q̇) if not given)."""
        lam = consistent_multipliers(self, t, q, v) if lam is None else np.asarray(lam, float)
        return np.concatenate([q, v, -lam[:2]])


def build(scene: Scene) -> CarAxis:
    """The car axis a scene describes."""
    return CarAxis(scene["caraxis.eps"], scene["caraxis.mass"], scene["caraxis.length"],
                   scene["caraxis.rest_length"], scene["caraxis.bump_height"], scene["caraxis.bump_frequency"],
                   scene["caraxis.g"])


def check_scene(scene: Scene) -> None:
    """The road point must stay on the axis circle: r < L."""
    from daebench.core.scene import SceneError

    if scene["caraxis.bump_height"] >= scene["caraxis.length"]:
        raise SceneError("scene key 'caraxis.bump_height' must be smaller than 'caraxis.length' "
                         "(the road point B(t) lies on the circle of radius L)")
