"""Contact laws and the impact map.

Sign conventions: a contact point has gap g ≥ 0 (open), penetration δ = −g > 0
(continuous laws only), δ̇ = −ġ. A continuous law returns the normal force F ≥ 0,
which acts on the system as ``g_qᵀ F`` (it pushes the gap open).

Laws
----
``constraint``  unilateral constraint (index-3 DAE while closed) + Newton impact law
                M(v⁺ − v⁻) = g_qᵀ Λ,  g_q v⁺ = −e g_q v⁻.
``hertz``       F = K δ^{3/2} (1 + χ δ̇), χ from the damping law and the approach
                speed v₀ recorded when the gap closed (Lankarani & Nikravesh 1990;
                Hunt & Crossley 1975; Flores et al. 2011). F is clipped at 0 (no
                adhesion) and the clipped work is booked as dissipation.
``penalty``     F = k δ + c δ̇ (clipped at 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DAMPING_LAWS = ("lankarani-nikravesh", "hunt-crossley", "flores", "none")
APPROACH_SPEED_MIN = 1e-3  # m/s: the hysteresis factors scale as 1/v0; a grazing or resting
                           # contact (v0 → 0) gets the damping of a 1 mm/s impact instead of ∞


def hysteresis_factor(law: str, e: float, v0: float) -> float:
    """χ in F = K δⁿ (1 + χ δ̇) for an approach speed v0 > 0 and restitution e."""
    if law == "none" or e >= 1.0:
        return 0.0
    if law == "lankarani-nikravesh":
        return 3.0 * (1.0 - e * e) / (4.0 * v0)
    if law == "hunt-crossley":
        return 3.0 * (1.0 - e) / (2.0 * v0)
    if law == "flores":
        if e <= 0.0:
            raise ValueError("the Flores damping law needs restitution e > 0")
        return 8.0 * (1.0 - e) / (5.0 * e * v0)
    raise ValueError(f"unknown damping law '{law}'; choose one of {', '.join(DAMPING_LAWS)}")


class ContactLaw:
    """Base: a law applied at each of a system's contact points."""

    name = ""
    continuous = False

    def __init__(self, restitution: float, n_contacts: int = 1):
        self.restitution = float(restitution)
        # approach speed v0 > 0 of the current contact episode, set by the driver
        self.approach_speed = np.full(n_contacts, np.nan)
        # contacts whose continuous force acts in the current phase. The driver engages a
        # contact when its gap closes and releases it when it separates, so that a phase
        # never contains the switch (default: all engaged, for use without the driver)
        self.engaged = np.ones(n_contacts, dtype=bool)

    def force(self, g: np.ndarray, gdot: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError

    def potential(self, g: np.ndarray) -> float:
        return 0.0

    def dissipation_power(self, g: np.ndarray, gdot: np.ndarray) -> float:
        """Power into the system of the non-conservative part of the force (≤ 0)."""
        return 0.0


class ConstraintLaw(ContactLaw):
    name = "constraint"
    continuous = False


class HertzLaw(ContactLaw):
    name = "hertz"
    continuous = True

    def __init__(self, restitution: float, stiffness: float, damping: str = "lankarani-nikravesh",
                 exponent: float = 1.5, n_contacts: int = 1):
        super().__init__(restitution, n_contacts)
        self.stiffness = float(stiffness)
        self.damping = damping
        self.exponent = float(exponent)
        hysteresis_factor(damping, restitution, 1.0)  # validate early

    def _chi(self) -> np.ndarray:
        v0 = self.approach_speed
        ok = np.isfinite(v0) & (v0 > 0.0)
        chi = np.zeros_like(v0)
        for i in np.flatnonzero(ok):
            chi[i] = hysteresis_factor(self.damping, self.restitution, max(float(v0[i]), APPROACH_SPEED_MIN))
        return chi

    def force(self, g: np.ndarray, gdot: np.ndarray) -> np.ndarray:
        ddot = -gdot
        elastic = self._elastic(g)
        return np.maximum(elastic * (1.0 + self._chi() * ddot), 0.0)

    def _elastic(self, g: np.ndarray) -> np.ndarray:
        return np.where(self.engaged, self.stiffness * np.maximum(-g, 0.0) ** self.exponent, 0.0)

    def potential(self, g: np.ndarray) -> float:
        delta = np.maximum(-g, 0.0)
        n = self.exponent
        return float(np.sum(self.stiffness * delta ** (n + 1.0) / (n + 1.0)))

    def dissipation_power(self, g: np.ndarray, gdot: np.ndarray) -> float:
        # power into the system is F ġ; its conservative part is elastic·ġ
        return float(np.sum((self.force(g, gdot) - self._elastic(g)) * gdot))


class PenaltyLaw(ContactLaw):
    name = "penalty"
    continuous = True

    def __init__(self, restitution: float, stiffness: float, damping_coefficient: float, n_contacts: int = 1):
        super().__init__(restitution, n_contacts)
        self.stiffness = float(stiffness)
        self.damping_coefficient = float(damping_coefficient)

    def force(self, g: np.ndarray, gdot: np.ndarray) -> np.ndarray:
        delta = np.maximum(-g, 0.0)
        F = self.stiffness * delta + self.damping_coefficient * (-gdot)
        return np.where(self.engaged & (delta > 0.0), np.maximum(F, 0.0), 0.0)

    def potential(self, g: np.ndarray) -> float:
        delta = np.maximum(-g, 0.0)
        return float(np.sum(0.5 * self.stiffness * delta**2))

    def dissipation_power(self, g: np.ndarray, gdot: np.ndarray) -> float:
        elastic = np.where(self.engaged, self.stiffness * np.maximum(-g, 0.0), 0.0)
        return float(np.sum((self.force(g, gdot) - elastic) * gdot))


def make_contact_law(law: str, restitution: float, n_contacts: int = 1, *, hertz_stiffness: float = 0.0,
                     hertz_damping: str = "lankarani-nikravesh", penalty_stiffness: float = 0.0,
                     penalty_damping: float = 0.0) -> ContactLaw:
    if law == "constraint":
        return ConstraintLaw(restitution, n_contacts)
    if law == "hertz":
        return HertzLaw(restitution, hertz_stiffness, hertz_damping, n_contacts=n_contacts)
    if law == "penalty":
        return PenaltyLaw(restitution, penalty_stiffness, penalty_damping, n_contacts)
    raise ValueError(f"unknown contact law '{law}' (constraint | hertz | penalty)")


@dataclass
class ImpactResult:
    v_plus: np.ndarray
    impulse: np.ndarray          # Λ for each impacting contact
    vn_minus: np.ndarray         # g_q v⁻ per impacting contact (< 0: approaching)
    vn_plus: np.ndarray
    energy_loss: float           # T⁻ − T⁺ ≥ 0


def impact_map(M: np.ndarray, Gq: np.ndarray, v_minus: np.ndarray, e: float,
               Cb: np.ndarray | None = None) -> ImpactResult:
    """Newton impact law for the contacts whose gap Jacobians are the rows of ``Gq``,
    respecting bilateral velocity constraints ``Cb v = 0`` if given:

        [M   Cbᵀ  −Gqᵀ] [v⁺]   [M v⁻     ]
        [Cb   0    0  ] [μ ] = [0        ]
        [Gq   0    0  ] [Λ ]   [−e Gq v⁻ ]

    For one contact and no bilateral constraints the kinetic-energy loss is
    ½ (1 − e²) (g_q v⁻)² / (g_q M⁻¹ g_qᵀ).
    """
    n = M.shape[0]
    Gq = np.atleast_2d(Gq)
    k = Gq.shape[0]
    Cb = np.zeros((0, n)) if Cb is None else np.atleast_2d(Cb)
    mb = Cb.shape[0]
    A = np.zeros((n + mb + k, n + mb + k))
    A[:n, :n] = M
    A[:n, n:n + mb] = Cb.T
    A[:n, n + mb:] = -Gq.T
    A[n:n + mb, :n] = Cb
    A[n + mb:, :n] = Gq
    vn_minus = Gq @ v_minus
    rhs = np.concatenate([M @ v_minus, np.zeros(mb), -e * vn_minus])
    sol = np.linalg.solve(A, rhs)
    v_plus = sol[:n]
    loss = 0.5 * float(v_minus @ M @ v_minus - v_plus @ M @ v_plus)
    return ImpactResult(v_plus, sol[n + mb:], vn_minus, Gq @ v_plus, loss)
