"""Simeon's slider crank with a flexible connecting rod, from the IVP test set.

Source: F. Mazzia, C. Magherini, *Test Set for IVP Solvers*, release 2.4, University of
Bari (2008), problem "Slider crank" (file crank.f, revision crank.F 1.2 2006/10/02,
subroutine RESMBS by B. Simeon, 1995/1997); model in B. Simeon, "Modelling a flexible
slider crank mechanism by a mixed system of DAEs and PDEs", Math. Modelling of
Systems 2 (1996) 1–18.

A rigid crank (mass M1, length L1, inertia J1) turns at the prescribed rate Ω; an
elastic connecting rod (M2, L2, J2; steel E, ρ, square section b × h) joins it to a
sliding block (M3). The rod's deformation relative to its rigid motion is discretized
by two lateral sine modes (q1, q2) and two quadratic longitudinal nodes (q3 at the
middle, q4 at the slider end); its mass, stiffness and coupling tables are those of
RESMBS (with its π = 3.1415927, kept so that the published reference applies).

Coordinates q = (φ1, φ2, x3, q1, q2, q3, q4): crank angle, rod angle [rad], slider
position [m], elastic coordinates [m]. Equations (M q̈ + C_qᵀλ = Q, C(t, q) = 0):
M(q) and Q(q, q̇) are RESMBS's ``AM`` and ``F`` (mass matrix with the rigid–elastic
coupling, Coriolis/centrifugal terms, −K q); the constraints are its position-level
ones,

    C1 = L1 sin φ1 + (L2 + q4) sin φ2,   C2 = x3 − L1 cos φ1 − (L2 + q4) cos φ2 − c0,
    C3 = φ1 − Ω t,

with C_q = RESMBS's ``GP`` and γ from its acceleration-level constraints (``ALC``).
The test set integrates the **index-2** form (C_q q̇ + C_t = 0 in place of C = 0) in
y ∈ ℝ²⁴ = (q, q̇, q̈, λ); its λ has our sign (its residual is M w − f + Gᵀλ).

The start (and c0) are the test set's reference start, exactly: its printed x3 is rounded
to 9 digits, leaving C2(q0) = c0 = 2.03e-10 m, which the index-2 form keeps for the whole
run (C_q q̇ + C_t = 0 holds C constant); our index-3 form has the same solution with the
offset in C2. Its printed q̇0 leaves C_q q̇0 + C_t = 1.19e-8 m/s in C1; an index-2 solver's
first step removes that with an impulse along M⁻¹C_qᵀ — the M-orthogonal projection
q̇0 ← q̇0 − M⁻¹C_qᵀ(C_q M⁻¹C_qᵀ)⁻¹(C_q q̇0 + C_t), which :meth:`SliderCrank.initial_state`
applies (Δφ̇2 = −4.0e-8 rad/s, Δq̇1 = 7.6e-9, Δq̇2 = −3.8e-9 m/s). Measured (DOP853 on the
index-1 ODE, rtol 1e-12): this start matches the published positions at t = 0.1 to ≥ 10.3
digits in all seven; with x3 and φ̇2 recomputed for C = 0 instead (the former start) q1, q2
came out at 7.5 digits and x3 at 8.9. Not implemented: the test set's
optional nonlinear stiffness term and 0.5 % damping (ipar = 1); its reference is for
neither.

Energy: E = ½ q̇ᵀMq̇ + ½ qᵀK q (+ gravity, zero in the test set). The drive C3 does work:
``power()["drive"]`` = λᵀC_t = −Ω λ3 (λ consistent with (t, q, q̇)).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.models._ivpset import constraint_power
from daebench.core.params import Param
from daebench.core.scene import Scene
from daebench.core.system import KernelSystem

DESCRIPTION = "Simeon's slider crank with an elastic rod (IVP test set): 7 coordinates, 3 constraints, driven"

PI_TESTSET = 3.1415927  # RESMBS's PARAMETER PI (the reference was computed with it)

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("crank.m1", float, 0.36, "crank mass M1", low=1e-9, high=1e6, unit="kg"),
        Param("crank.m2", float, 0.151104, "rod mass M2", low=1e-9, high=1e6, unit="kg"),
        Param("crank.m3", float, 0.075552, "slider mass M3", low=1e-9, high=1e6, unit="kg"),
        Param("crank.l1", float, 0.15, "crank length L1", low=1e-6, high=1e3, unit="m"),
        Param("crank.l2", float, 0.30, "rod length L2", low=1e-6, high=1e3, unit="m"),
        Param("crank.j1", float, 0.002727, "crank moment of inertia J1", low=1e-12, high=1e6, unit="kg m^2"),
        Param("crank.j2", float, 0.0045339259, "rod moment of inertia J2", low=1e-12, high=1e6, unit="kg m^2"),
        Param("crank.modulus", float, 0.20e12, "rod Young's modulus E", low=1.0, high=1e13, unit="Pa"),
        Param("crank.width", float, 0.008, "rod cross-section width b", low=1e-6, high=10.0, unit="m"),
        Param("crank.height", float, 0.008, "rod cross-section height h", low=1e-6, high=10.0, unit="m"),
        Param("crank.density", float, 7870.0, "rod density ρ", low=1.0, high=1e5, unit="kg/m^3"),
        Param("crank.gravity", float, 0.0, "gravity (the test set: 0)", low=0.0, high=1e3, unit="m/s^2"),
        Param("crank.omega", float, 150.0, "prescribed crank rate Ω (φ1 = Ω t)", low=-1e5, high=1e5, unit="rad/s"),
    )
}

NAMES = ("phi1", "phi2", "x3", "q1", "q2", "q3", "q4")

# the test set's start (crank.f init, ipar = 0, "first set"): q0 and q̇0 as printed
Q0 = np.array([0.0, 0.0, 0.450016933, 0.0, 0.0, 0.103339863e-4, 0.169327969e-4])
V0 = np.array([0.150000000e3, -0.749957670e2, -0.268938672e-5, 0.444896105, 0.463434311e-2,
               -0.178591076e-5, -0.268938672e-5])

#: C2(q0) of the printed start with the test set's L1, L2: the rounding of its x3, kept by
#: the index-2 form for the whole run (module docstring)
X3_OFFSET = 0.450016933 - (0.15 + 0.30 + 0.169327969e-4)

#: max |q_i|, max |q̇_i| over [0, 0.1] (DOP853 at rtol 1e-7), rounded up: the elastic
#: coordinates are 1e-5 … 2e-3 m, the crank angle reaches 15 rad
STATE_SCALE = (np.array([15.0, 0.6, 0.5, 2e-3, 5e-5, 1e-5, 2e-5]),
               np.array([150.0, 75.0, 30.0, 0.5, 6e-3, 3e-3, 5e-3]))


class CrankData(NamedTuple):
    """Kernel data of the slider crank: parameters and the rod's FE tables."""

    prm: np.ndarray   # m1, m2, m3, l1, l2, j1, j2, rho, grav, omega, c0 (X3_OFFSET)
    MQ: np.ndarray
    KQ: np.ndarray
    BQ: np.ndarray
    c1: np.ndarray
    c2: np.ndarray
    c12: np.ndarray
    c21: np.ndarray


def rod_tables(E: float, b: float, h: float, rho: float, L2: float) -> tuple[np.ndarray, ...]:
    """RESMBS's rod tables: MQ, KQ, BQ (4 × 4), c1, c2, c12, c21 (4)."""
    pi = PI_TESTSET
    facm, fack, facb = rho * b * h * L2, E * b * h / L2, b * h * L2
    MQ = facm * np.array([[0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 8.0, 1.0], [0, 0, 1.0, 2.0]])
    KQ = np.zeros((4, 4))
    KQ[0, 0] = fack * pi**4 / 24.0 * (h / L2) ** 2
    KQ[1, 1] = fack * pi**4 * 2.0 / 3.0 * (h / L2) ** 2
    KQ[2:, 2:] = fack * np.array([[16.0 / 3.0, -8.0 / 3.0], [-8.0 / 3.0, 7.0 / 3.0]])
    BQ = np.zeros((4, 4))
    BQ[0, 2] = -facb * 16.0 / pi**3
    BQ[0, 3] = facb * (8.0 / pi**3 - 1.0 / pi)
    BQ[1, 3] = facb * 0.5 / pi
    BQ[2:, :2] = -BQ[:2, 2:].T
    c1 = facb * np.array([0.0, 0.0, 2.0 / 3.0, 1.0 / 6.0])
    c2 = facb * np.array([2.0 / pi, 0.0, 0.0, 0.0])
    c12 = L2 * facb * np.array([0.0, 0.0, 1.0 / 3.0, 1.0 / 6.0])
    c21 = L2 * facb * np.array([1.0 / pi, -0.5 / pi, 0.0, 0.0])
    return MQ, KQ, BQ, c1, c2, c12, c21


@njit(cache=True)
def _mass_force(md, t, q, v, M, Q):
    m1, m2, m3, l1, l2, j1, j2, rho, grav = md.prm[0], md.prm[1], md.prm[2], md.prm[3], md.prm[4], \
        md.prm[5], md.prm[6], md.prm[7], md.prm[8]
    MQ, KQ, BQ, c1, c2, c12, c21 = md.MQ, md.KQ, md.BQ, md.c1, md.c2, md.c12, md.c21
    e = q[3:].copy()   # contiguous: the kernel is called with strided ('A') views, '@' wants contiguous
    ed = v[3:].copy()
    v1, v2 = v[0], v[1]
    cp1, cp2, sp2 = math.cos(q[0]), math.cos(q[1]), math.sin(q[1])
    c12_, s12 = math.cos(q[0] - q[1]), math.sin(q[0] - q[1])
    c1e, c1ed, c2e, c2ed, c12e, c12ed = c1 @ e, c1 @ ed, c2 @ e, c2 @ ed, c12 @ e, c12 @ ed
    MQe = MQ @ e          # MQ symmetric: MQQ(I) = Σ_J MQ(J, I) e_J
    eBQ = e @ BQ          # QTBQ(I) = Σ_J e_J BQ(J, I)
    BQed = BQ @ ed        # BQQD(I) = Σ_J BQ(I, J) ė_J
    M[:, :] = 0.0
    M[0, 0] = j1 + m2 * l1 * l1
    M[0, 1] = 0.5 * l1 * l2 * m2 * c12_ + rho * l1 * (s12 * c2e + c12_ * c1e)
    M[1, 1] = j2 + e @ MQe + 2.0 * rho * c12e
    M[2, 2] = m3
    for i in range(4):
        M[0, 3 + i] = rho * l1 * (-s12 * c1[i] + c12_ * c2[i])
        M[1, 3 + i] = rho * c21[i] + rho * eBQ[i]
        for j in range(4):
            M[3 + j, 3 + i] = MQ[j, i]
    for i in range(7):
        for j in range(i + 1, 7):
            M[j, i] = M[i, j]
    Q[0] = (-0.5 * l1 * grav * (m1 + 2.0 * m2) * cp1 - 0.5 * l1 * l2 * m2 * v2 * v2 * s12
            + rho * l1 * v2 * v2 * (-s12 * c1e + c12_ * c2e) - 2.0 * rho * l1 * v2 * (c12_ * c1ed + s12 * c2ed))
    Q[1] = (-0.5 * l2 * grav * m2 * cp2 + 0.5 * l1 * l2 * m2 * v1 * v1 * s12
            + rho * l1 * v1 * v1 * (s12 * c1e - c12_ * c2e) - 2.0 * rho * v2 * c12ed - 2.0 * v2 * (ed @ MQe)
            - rho * (ed @ BQed) - rho * grav * (cp2 * c1e - sp2 * c2e))
    Q[2] = 0.0
    KQe = KQ @ e
    for i in range(4):
        Q[3 + i] = (v2 * v2 * MQe[i] + rho * (v2 * v2 * c12[i] + l1 * v1 * v1 * (c12_ * c1[i] + s12 * c2[i])
                                              + 2.0 * v2 * BQed[i])
                    - rho * grav * (sp2 * c1[i] + cp2 * c2[i]) - KQe[i])


@njit(cache=True)
def _constraints(md, t, q, v, C, Cq, Ct, gam):
    l1, l2, omega = md.prm[3], md.prm[4], md.prm[9]
    cp1, sp1, cp2, sp2 = math.cos(q[0]), math.sin(q[0]), math.cos(q[1]), math.sin(q[1])
    r2 = l2 + q[6]
    C[0] = l1 * sp1 + r2 * sp2
    C[1] = q[2] - l1 * cp1 - r2 * cp2 - md.prm[10]
    C[2] = q[0] - omega * t
    Cq[:3, :] = 0.0
    Cq[0, 0] = l1 * cp1
    Cq[0, 1] = r2 * cp2
    Cq[0, 6] = sp2
    Cq[1, 0] = l1 * sp1
    Cq[1, 1] = r2 * sp2
    Cq[1, 2] = 1.0
    Cq[1, 6] = -cp2
    Cq[2, 0] = 1.0
    Ct[0] = 0.0
    Ct[1] = 0.0
    Ct[2] = -omega
    v1, v2, vq4 = v[0], v[1], v[6]
    gam[0] = l1 * sp1 * v1 * v1 + r2 * sp2 * v2 * v2 - 2.0 * v2 * cp2 * vq4
    gam[1] = -l1 * cp1 * v1 * v1 - r2 * cp2 * v2 * v2 - 2.0 * v2 * sp2 * vq4
    gam[2] = 0.0


kernels.register(CrankData, mass_force=_mass_force, constraints=_constraints)


class SliderCrank(KernelSystem):
    """The flexible slider crank (n = 7, three bilateral constraints, one driven)."""

    n = 7
    n_bilateral = 3
    n_contacts = 0
    coordinate_names = NAMES
    #: the reference solver (daebench.harness.references): the index-1 ODE by DOP853, with
    #: absolute tolerances rtol × state_scale() (daebench.integrators.odeint)
    reference_solver = "dop853"

    def __init__(self, m1: float = 0.36, m2: float = 0.151104, m3: float = 0.075552, l1: float = 0.15,
                 l2: float = 0.30, j1: float = 0.002727, j2: float = 0.0045339259, modulus: float = 0.20e12,
                 width: float = 0.008, height: float = 0.008, density: float = 7870.0, gravity: float = 0.0,
                 omega: float = 150.0) -> None:
        prm = np.array([m1, m2, m3, l1, l2, j1, j2, density, gravity, omega, X3_OFFSET], dtype=float)
        self.data = CrankData(prm, *rod_tables(modulus, width, height, density, l2))

    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        md = self.data
        m1, m2, l1, l2, rho, grav = md.prm[0], md.prm[1], md.prm[3], md.prm[4], md.prm[7], md.prm[8]
        e = q[3:]
        grav_pot = grav * (0.5 * l1 * (m1 + 2.0 * m2) * math.sin(q[0]) + 0.5 * l2 * m2 * math.sin(q[1])
                           + rho * (math.sin(q[1]) * (md.c1 @ e) + math.cos(q[1]) * (md.c2 @ e)))
        return {"kinetic": 0.5 * float(v @ self.mass(q) @ v), "elastic": 0.5 * float(e @ md.KQ @ e),
                "gravity": float(grav_pot)}

    def power(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {"drive": constraint_power(self, t, q, v)}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {name: float(x) for name, x in zip(NAMES, q)}

    def state_scale(self) -> tuple[np.ndarray, np.ndarray]:
        """Size of each q_i and q̇_i over the test set's run (max |·| on [0, 0.1], rounded
        up): the error weights of a reference (absolute tolerance rtol × scale)."""
        return STATE_SCALE

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The test set's reference start (module docstring): its printed q0 (x3 = its
        printed value for the test set's L1, L2: C2 = 0 with the offset c0) and its printed
        q̇0, M-orthogonally projected onto C_q q̇ + C_t = 0."""
        l1, l2 = self.data.prm[3], self.data.prm[4]
        q = Q0.copy()
        q[2] = l1 * math.cos(q[0]) + (l2 + q[6]) * math.cos(q[1]) + X3_OFFSET
        M = self.mass(q)
        _, Cq, Ct, _ = self._constraint_rows(0.0, q)
        MiG = np.linalg.solve(M, Cq.T)
        v = V0 - MiG @ np.linalg.solve(Cq @ MiG, Cq @ V0 + Ct)
        return q, v

def build(scene: Scene) -> SliderCrank:
    """The slider crank a scene describes."""
    return SliderCrank(*(scene[f"crank.{k}"] for k in ("m1", "m2", "m3", "l1", "l2", "j1", "j2", "modulus",
                                                      "width", "height", "density", "gravity", "omega")))
