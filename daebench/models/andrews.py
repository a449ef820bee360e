"""Andrews' squeezing mechanism: 7 rigid bodies, 7 angles, 6 constraints, index 3.

The planar seven-body mechanism of Giles (1978) and Manning (1981), driven by a
constant torque on the crank and loaded by a spring, as published in

* F. Mazzia, C. Magherini, *Test Set for IVP Solvers*, release 2.4, University
  of Bari (2008), problem "Andrews' squeezing mechanism" (source file andrews.f);
* E. Hairer, G. Wanner, *Solving Ordinary Differential Equations II*, 2nd ed.,
  Springer 1996, §VII.7.

Coordinates q = (β, Θ, γ, Φ, δ, Ω, ε) [rad]. Equations of motion

    M(q) q̈ = f(q, q̇) − Gᵀ(q) λ,     g(q) = 0  (6 loop-closure equations),

with the mass matrix, force and constraints exactly as in the test set (f holds
the Coriolis/centrifugal terms, the driving torque ``mom`` on β and the spring
force on γ; there is no gravity). Time interval [0, 0.03] s.

Energy: E = ½ q̇ᵀ M q̇ + ½ c0 (ℓ − l0)², where ℓ is the spring length. The system
is *not* conservative: the motor torque does work, dE/dt = mom · β̇, reported as
``power()["torque"]``.

Note: the spring's unstretched length is l0 = 0.07785 m in both sources (the
test set's ``l0 = 7785e-5``).
"""

from __future__ import annotations

import numpy as np

from daebench.core.params import Param
from daebench.core.system import MechanicalSystem

DESCRIPTION = "Andrews' squeezing mechanism (IVP test set): 7 bodies, 6 constraints, index 3, t in [0, 0.03]"

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("andrews.mom", float, 0.033, "driving torque on the crank β", low=-10.0, high=10.0, unit="N m"),
    )
}

NAMES = ("beta", "theta", "gamma", "phi", "delta", "omega", "epsilon")

# -- the test set's data (andrews.f) -----------------------------------------------------
M1, M2, M3, M4, M5, M6, M7 = 0.04325, 0.00365, 0.02373, 0.00706, 0.07050, 0.00706, 0.05498
XA, YA = -0.06934, -0.00227
XB, YB = -0.03635, 0.03273
XC, YC = 0.014, 0.072
C0 = 4530.0
I1, I2, I3, I4, I5, I6, I7 = 2.194e-6, 4.410e-7, 5.255e-6, 5.667e-7, 1.169e-5, 5.667e-7, 1.912e-5
D, DA, E, EA = 28e-3, 115e-4, 2e-2, 1421e-5
RR, RA = 7e-3, 92e-5
L0 = 7785e-5
SS, SA, SB, SC, SD = 35e-3, 1874e-5, 1043e-5, 18e-3, 2e-2
TA, TB = 2308e-5, 916e-5
U, UA, UB = 4e-2, 1228e-5, 449e-5
ZF, ZT = 2e-2, 4e-2
FA = 1421e-5
MOM = 33e-3

# consistent initial values (test set): q0, q̇0 = 0, and the resulting q̈0, λ0
Q0 = np.array([
    -0.0617138900142764496358948458001,
    0.0,
    0.455279819163070380255912382449,
    0.222668390165885884674473185609,
    0.487364979543842550225598953530,
    -0.222668390165885884674473185609,
    1.23054744454982119249735015568,
])
A0 = np.array([14222.4439199541138705911625887, -10666.8329399655854029433719415, 0, 0, 0, 0, 0])
LAM0 = np.array([98.5668703962410896057654982170, -6.12268834425566265503114393122, 0, 0, 0, 0])


class Andrews(MechanicalSystem):
    """Andrews' squeezing mechanism (n = 7 angles, 6 bilateral constraints)."""

    n = 7
    n_bilateral = 6
    n_contacts = 0
    coordinate_names = NAMES
    #: the reference solver (daebench.harness.references): the index-1 ODE by DOP853, with
    #: absolute tolerances rtol × state_scale() (daebench.integrators.odeint)
    reference_solver = "dop853"

    def __init__(self, mom: float = MOM) -> None:
        self.mom = float(mom)

    # -- dynamics -----------------------------------------------------------------------
    def mass(self, q: np.ndarray) -> np.ndarray:
        coth, siph, siom = np.cos(q[1]), np.sin(q[3]), np.sin(q[5])
        m = np.zeros((7, 7))
        m[0, 0] = M1 * RA**2 + M2 * (RR**2 - 2 * DA * RR * coth + DA**2) + I1 + I2
        m[1, 0] = m[0, 1] = M2 * (DA**2 - DA * RR * coth) + I2
        m[1, 1] = M2 * DA**2 + I2
        m[2, 2] = M3 * (SA**2 + SB**2) + I3
        m[3, 3] = M4 * (E - EA) ** 2 + I4
        m[4, 3] = m[3, 4] = M4 * ((E - EA) ** 2 + ZT * (E - EA) * siph) + I4
        m[4, 4] = M4 * (ZT**2 + 2 * ZT * (E - EA) * siph + (E - EA) ** 2) + M5 * (TA**2 + TB**2) + I4 + I5
        m[5, 5] = M6 * (ZF - FA) ** 2 + I6
        m[6, 5] = m[5, 6] = M6 * ((ZF - FA) ** 2 - U * (ZF - FA) * siom) + I6
        m[6, 6] = M6 * ((ZF - FA) ** 2 - 2 * U * (ZF - FA) * siom + U**2) + M7 * (UA**2 + UB**2) + I6 + I7
        return m

    def mass_jacobian_product(self, q: np.ndarray, a: np.ndarray) -> np.ndarray:
        """∂(M(q) a)/∂q: M depends on Θ, Φ, Ω only."""
        k2 = M2 * DA * RR * np.sin(q[1])
        k4 = M4 * ZT * (E - EA) * np.cos(q[3])
        k6 = -M6 * U * (ZF - FA) * np.cos(q[5])
        J = np.zeros((7, 7))
        J[0, 1] = 2 * k2 * a[0] + k2 * a[1]
        J[1, 1] = k2 * a[0]
        J[3, 3] = k4 * a[4]
        J[4, 3] = k4 * (a[3] + 2 * a[4])
        J[5, 5] = k6 * a[6]
        J[6, 5] = k6 * (a[5] + 2 * a[6])
        return J

    def _spring(self, q: np.ndarray) -> tuple[float, float, float, float, float]:
        """Spring point D, its length ℓ and ∂(xd, yd)/∂γ."""
        coga, siga = np.cos(q[2]), np.sin(q[2])
        xd = SD * coga + SC * siga + XB
        yd = SD * siga - SC * coga + YB
        length = float(np.hypot(xd - XC, yd - YC))
        return xd - XC, yd - YC, length, SC * coga - SD * siga, SD * coga + SC * siga

    def applied_force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        sith, coph, coom = np.sin(q[1]), np.cos(q[3]), np.cos(q[5])
        bep, thp, php, dep, omp, epp = v[0], v[1], v[3], v[4], v[5], v[6]
        dx, dy, length, dxg, dyg = self._spring(q)
        force = -C0 * (length - L0) / length
        f = np.empty(7)
        f[0] = self.mom - M2 * DA * RR * thp * (thp + 2 * bep) * sith
        f[1] = M2 * DA * RR * bep**2 * sith
        f[2] = force * (dx * dxg + dy * dyg)
        f[3] = M4 * ZT * (E - EA) * dep**2 * coph
        f[4] = -M4 * ZT * (E - EA) * php * (php + 2 * dep) * coph
        f[5] = -M6 * U * (ZF - FA) * epp**2 * coom
        f[6] = M6 * U * (ZF - FA) * omp * (omp + 2 * epp) * coom
        return f

    def force_jacobian(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∂f/∂q, ∂f/∂q̇), analytic."""
        sith, coth = np.sin(q[1]), np.cos(q[1])
        siph, coph = np.sin(q[3]), np.cos(q[3])
        siom, coom = np.sin(q[5]), np.cos(q[5])
        bep, thp, php, dep, omp, epp = v[0], v[1], v[3], v[4], v[5], v[6]
        k2, k4, k6 = M2 * DA * RR, M4 * ZT * (E - EA), M6 * U * (ZF - FA)
        Kq = np.zeros((7, 7))
        Kv = np.zeros((7, 7))
        # crank / coupler (β, Θ)
        Kq[0, 1] = -k2 * thp * (thp + 2 * bep) * coth
        Kv[0, 0] = -2 * k2 * thp * sith
        Kv[0, 1] = -k2 * (2 * thp + 2 * bep) * sith
        Kq[1, 1] = k2 * bep**2 * coth
        Kv[1, 0] = 2 * k2 * bep * sith
        # spring on γ: f3 = −c0 (ℓ − l0) ∂ℓ/∂γ
        coga, siga = np.cos(q[2]), np.sin(q[2])
        dx, dy, length, dxg, dyg = self._spring(q)
        dxgg, dygg = -SC * siga - SD * coga, -SD * siga + SC * coga
        dl = (dx * dxg + dy * dyg) / length
        dll = (dxg**2 + dyg**2 + dx * dxgg + dy * dygg - dl**2) / length
        Kq[2, 2] = -C0 * (dl**2 + (length - L0) * dll)
        # (Φ, δ)
        Kq[3, 3] = -k4 * dep**2 * siph
        Kv[3, 4] = 2 * k4 * dep * coph
        Kq[4, 3] = k4 * php * (php + 2 * dep) * siph
        Kv[4, 3] = -k4 * (2 * php + 2 * dep) * coph
        Kv[4, 4] = -2 * k4 * php * coph
        # (Ω, ε)
        Kq[5, 5] = k6 * epp**2 * siom
        Kv[5, 6] = -2 * k6 * epp * coom
        Kq[6, 5] = -k6 * omp * (omp + 2 * epp) * siom
        Kv[6, 5] = k6 * (2 * omp + 2 * epp) * coom
        Kv[6, 6] = 2 * k6 * omp * coom
        return Kq, Kv

    # -- constraints ---------------------------------------------------------------------
    def constraint(self, t: float, q: np.ndarray) -> np.ndarray:
        be, th, ga, ph, de, om, ep = q
        cobe, sibe = np.cos(be), np.sin(be)
        cobeth, sibeth = np.cos(be + th), np.sin(be + th)
        a = RR * cobe - D * cobeth  # crank + coupler tip, x
        b = RR * sibe - D * sibeth  # ... y
        return np.array([
            a - SS * np.sin(ga) - XB,
            b + SS * np.cos(ga) - YB,
            a - E * np.sin(ph + de) - ZT * np.cos(de) - XA,
            b + E * np.cos(ph + de) - ZT * np.sin(de) - YA,
            a - ZF * np.cos(om + ep) - U * np.sin(ep) - XA,
            b - ZF * np.sin(om + ep) + U * np.cos(ep) - YA,
        ])

    def constraint_jacobian(self, t: float, q: np.ndarray) -> np.ndarray:
        be, th, ga, ph, de, om, ep = q
        sibe, cobe = np.sin(be), np.cos(be)
        sibeth, cobeth = np.sin(be + th), np.cos(be + th)
        siphde, cophde = np.sin(ph + de), np.cos(ph + de)
        siomep, coomep = np.sin(om + ep), np.cos(om + ep)
        G = np.zeros((6, 7))
        for i in (0, 2, 4):  # x rows share the crank/coupler terms
            G[i, 0] = -RR * sibe + D * sibeth
            G[i, 1] = D * sibeth
            G[i + 1, 0] = RR * cobe - D * cobeth
            G[i + 1, 1] = -D * cobeth
        G[0, 2] = -SS * np.cos(ga)
        G[1, 2] = -SS * np.sin(ga)
        G[2, 3] = -E * cophde
        G[2, 4] = -E * cophde + ZT * np.sin(de)
        G[3, 3] = -E * siphde
        G[3, 4] = -E * siphde - ZT * np.cos(de)
        G[4, 5] = ZF * siomep
        G[4, 6] = ZF * siomep - U * np.cos(ep)
        G[5, 5] = -ZF * coomep
        G[5, 6] = -ZF * coomep - U * np.sin(ep)
        return G

    def constraint_gamma(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """γ = −(G q̇)_q q̇: minus the velocity-squared part of g̈."""
        be, th, ga, ph, de, om, ep = q
        bep, thp, gap, php, dep, omp, epp = v
        bt, pd, oe = bep + thp, php + dep, omp + epp
        ca = RR * np.cos(be) * bep**2 - D * np.cos(be + th) * bt**2
        sa = RR * np.sin(be) * bep**2 - D * np.sin(be + th) * bt**2
        return np.array([
            ca - SS * np.sin(ga) * gap**2,
            sa + SS * np.cos(ga) * gap**2,
            ca - E * np.sin(ph + de) * pd**2 - ZT * np.cos(de) * dep**2,
            sa + E * np.cos(ph + de) * pd**2 - ZT * np.sin(de) * dep**2,
            ca - ZF * np.cos(om + ep) * oe**2 - U * np.sin(ep) * epp**2,
            sa - ZF * np.sin(om + ep) * oe**2 + U * np.cos(ep) * epp**2,
        ])

    # -- bookkeeping -------------------------------------------------------------------------
    def energy(self, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        length = self._spring(q)[2]
        return {
            "kinetic": float(0.5 * v @ self.mass(q) @ v),
            "elastic": float(0.5 * C0 * (length - L0) ** 2),
        }

    def power(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {"torque": float(self.mom * v[0])}

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        return {name: float(x) for name, x in zip(NAMES, q)}

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        return Q0.copy(), np.zeros(7)

    def state_scale(self) -> tuple[np.ndarray, np.ndarray]:
        """Size of each q_i and q̇_i over the test set's run (max |·| on [0, 0.03], rounded
        up): the error weights of a reference (absolute tolerance rtol × scale)."""
        return (np.array([16.0, 16.0, 0.5, 0.55, 0.55, 0.55, 1.25]),
                np.array([1200.0, 1500.0, 170.0, 300.0, 18.0, 300.0, 75.0]))


def build(scene) -> Andrews:
    """The mechanism with the scene's driving torque."""
    return Andrews(mom=float(scene.get("andrews.mom", MOM)))
