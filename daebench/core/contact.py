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

Friction with the continuous laws: regularised Coulomb F_T = −μ F_N tanh(v_T / v_ε) along
each penetrating contact's tangent row (μ and the row from the model's ``tangent``
kernel; formula, Jacobian and power in :mod:`daebench.core.phase`). v_ε is the scene key
``contact.friction_velocity`` (default :data:`FRICTION_VELOCITY`).

The force formulas exist once, compiled, in :mod:`daebench.core.phase` (``law_force``);
the Python methods here evaluate them.

Scene keys: every model with contacts declares its ``contact.*`` keys through
:func:`contact_schema` (one set of keys, one default set, one validation); a model
passes only what differs for it (the laws it offers, a default restitution or stiffness).
``complementarity`` names no law: the contacts are left to an integrator that resolves
them itself (:attr:`daebench.core.system.MechanicalSystem.contacts_by_integrator`); the
restitution the scene gives is still the system's
(:attr:`daebench.core.system.MechanicalSystem.contact_restitution`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from daebench.core.linalg import solve_structured
from daebench.core.params import Param, ParamError
from daebench.core.phase import LAW_HERTZ, LAW_PENALTY, law_elastic, law_forces, law_potentials

if TYPE_CHECKING:  # pragma: no cover
    from daebench.core.scene import Scene

DAMPING_LAWS = ("lankarani-nikravesh", "hunt-crossley", "flores", "none")
#: the driver's laws for contacts that close at the same instant (scene key contact.impact_law;
#: daebench.driver.transitions): Newton's law for all at once (one LCP), one contact after another, or
#: the Liu–Zhao–Brogliato multiple-impact law (daebench.core.lzb: the model's contact stiffness)
IMPACT_LAWS = ("simultaneous", "sequential", "lzb")
#: default regularisation velocity v_ε of the compliant laws' Coulomb friction [m/s]: a held
#: block creeps at v_ε artanh(|F|/(μ F_N)) — about 1 mm/s, small against the cases' speeds
#: (m/s) — while the friction's time constant v_ε/(μ g) (≈ 3e-4 s at μ = 0.3) stays above
#: the default step h = 1e-4 s, so explicit schemes are stable at it too
FRICTION_VELOCITY = 1e-3
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
    """Base: a law applied at each of a system's contact points. Immutable parameters;
    what changes within a run (which contacts are engaged, the approach speed of the
    current episode) is phase data (:class:`daebench.core.problem.Problem`)."""

    name = ""
    continuous = False

    def __init__(self, restitution: float, n_contacts: int = 1, friction_velocity: float = FRICTION_VELOCITY):
        self.restitution = float(restitution)
        self.n_contacts = int(n_contacts)
        self.friction_velocity = float(friction_velocity)
        if not (math.isfinite(self.friction_velocity) and self.friction_velocity > 0.0):
            raise ParamError(f"friction regularisation velocity v_ε must be positive and finite, "
                             f"got {friction_velocity!r} (scene key contact.friction_velocity)")

    def chi(self, approach_speed: np.ndarray) -> np.ndarray:
        """Hysteresis factor per contact for the episodes' approach speeds (0 where none)."""
        return np.zeros(self.n_contacts)

    def parameters(self) -> np.ndarray:
        """[kind, K, exponent, c, v_ε] as the compiled phase reads them (kind 0: no force)."""
        return np.zeros(5)

    def force(self, g: np.ndarray, gdot: np.ndarray, engaged: np.ndarray | None = None,
              chi: np.ndarray | None = None) -> np.ndarray:
        """Normal force per contact (engaged: all by default; χ: 0 by default); ``g`` and
        ``gdot`` one value per contact, or rows × contacts (then so is the force)."""
        g2, gd2 = _rows2(g), _rows2(gdot)
        k = g2.shape[1]
        engaged = np.ones(k, bool) if engaged is None else np.ascontiguousarray(engaged, bool)
        chi = np.zeros(k) if chi is None else np.ascontiguousarray(chi, float)
        F = np.empty(g2.shape)
        law_forces(self.parameters(), engaged, chi, g2, gd2, F)
        return F if np.ndim(g) == 2 else F[0]

    def potential(self, g: np.ndarray) -> float | np.ndarray:
        """Energy stored in the springs at the gaps ``g`` (one per contact: a number; rows ×
        contacts: one per row)."""
        g2 = _rows2(g)
        U = np.empty(g2.shape[0])
        law_potentials(self.parameters(), g2, U)
        return U if np.ndim(g) == 2 else float(U[0])

    def dissipation_power(self, g: np.ndarray, gdot: np.ndarray, engaged: np.ndarray | None = None,
                          chi: np.ndarray | None = None) -> float:
        """Power into the system of the non-conservative part of the force (≤ 0)."""
        engaged = np.ones(g.size, bool) if engaged is None else np.asarray(engaged, bool)
        law = self.parameters()
        F = self.force(g, gdot, engaged, chi)
        elastic = np.array([law_elastic(law, bool(engaged[i]), float(g[i])) for i in range(g.size)])
        return float(np.sum((F - elastic) * gdot))


def _rows2(x: np.ndarray) -> np.ndarray:
    """One value per contact, or rows × contacts, as a C-contiguous float 2-D array."""
    x = np.asarray(x, dtype=float)
    return np.ascontiguousarray(x if x.ndim == 2 else x.reshape(1, -1))


class ConstraintLaw(ContactLaw):
    name = "constraint"
    continuous = False

    def __init__(self, restitution: float, n_contacts: int = 1, impact_law: str = "simultaneous"):
        super().__init__(restitution, n_contacts)
        if impact_law not in IMPACT_LAWS:
            from daebench.core.params import ParamError
            raise ParamError(f"contact.impact_law = {impact_law!r}: choose one of {', '.join(IMPACT_LAWS)}")
        self.impact_law = impact_law


class HertzLaw(ContactLaw):
    name = "hertz"
    continuous = True

    def __init__(self, restitution: float, stiffness: float, damping: str = "lankarani-nikravesh",
                 exponent: float = 1.5, n_contacts: int = 1, friction_velocity: float = FRICTION_VELOCITY):
        super().__init__(restitution, n_contacts, friction_velocity)
        self.stiffness = float(stiffness)
        self.damping = damping
        self.exponent = float(exponent)
        hysteresis_factor(damping, restitution, 1.0)  # validate early

    def parameters(self) -> np.ndarray:
        return np.array([LAW_HERTZ, self.stiffness, self.exponent, 0.0, self.friction_velocity])

    def chi(self, approach_speed: np.ndarray) -> np.ndarray:
        v0 = np.asarray(approach_speed, float)
        out = np.zeros(v0.size)
        for i in np.flatnonzero(np.isfinite(v0) & (v0 > 0.0)):
            out[i] = hysteresis_factor(self.damping, self.restitution, max(float(v0[i]), APPROACH_SPEED_MIN))
        return out


class PenaltyLaw(ContactLaw):
    name = "penalty"
    continuous = True

    def __init__(self, restitution: float, stiffness: float, damping_coefficient: float, n_contacts: int = 1,
                 friction_velocity: float = FRICTION_VELOCITY):
        super().__init__(restitution, n_contacts, friction_velocity)
        self.stiffness = float(stiffness)
        self.damping_coefficient = float(damping_coefficient)

    def parameters(self) -> np.ndarray:
        return np.array([LAW_PENALTY, self.stiffness, 1.0, self.damping_coefficient, self.friction_velocity])


def make_contact_law(law: str, restitution: float, n_contacts: int = 1, *, hertz_stiffness: float = 0.0,
                     hertz_damping: str = "lankarani-nikravesh", hertz_exponent: float = 1.5,
                     penalty_stiffness: float = 0.0, penalty_damping: float = 0.0,
                     friction_velocity: float = FRICTION_VELOCITY) -> ContactLaw | None:
    """The law a scene's ``contact.law`` names (None for ``complementarity``: no law, the
    contacts are left to an integrator that resolves them)."""
    if law == "complementarity":
        return None
    if law == "constraint":
        return ConstraintLaw(restitution, n_contacts)
    if law == "hertz":
        return HertzLaw(restitution, hertz_stiffness, hertz_damping, exponent=hertz_exponent, n_contacts=n_contacts,
                        friction_velocity=friction_velocity)
    if law == "penalty":
        return PenaltyLaw(restitution, penalty_stiffness, penalty_damping, n_contacts, friction_velocity)
    raise ValueError(f"unknown contact law '{law}' (one of {', '.join(CONTACT_LAWS)})")


# -- the contact keys of a scene ------------------------------------------------------------
CONTACT_LAWS = ("constraint", "hertz", "penalty", "complementarity")
LAW_MEANING = {
    "constraint": "unilateral constraint + Newton impact law (the driver)",
    "hertz": "Hertz force K δⁿ with hysteresis damping",
    "penalty": "linear spring-damper k δ + c δ̇",
    "complementarity": "left to an integrator that resolves contacts itself",
}
#: the one default set of the contact keys (a model overrides what differs for it)
CONTACT_DEFAULTS: dict[str, Any] = {
    "law": "constraint", "impact_law": "simultaneous", "restitution": 0.0, "hertz_stiffness": 0.0,
    "hertz_exponent": 1.5,
    "hertz_damping": "lankarani-nikravesh", "penalty_stiffness": 0.0, "penalty_damping": 0.0, "friction": 0.0,
    "friction_velocity": FRICTION_VELOCITY,
}


@dataclass(frozen=True)
class ContactSchema:
    """The ``contact.*`` keys of one model and their one validation (:func:`contact_schema`)."""

    laws: tuple[str, ...]
    defaults: dict[str, Any]
    hertz_rule: str = ""     # what contact.hertz_stiffness = 0 means ("": K must be > 0)
    exponent: bool = False   # declares contact.hertz_exponent
    friction: bool = False   # declares contact.friction
    impact_law: bool = False  # declares contact.impact_law (the driver's law for simultaneous impacts)

    @property
    def params(self) -> list[Param]:
        d = self.defaults
        out = [Param("contact.law", str, d["law"], "contact model: " + "; ".join(
                   f"{k} = {LAW_MEANING[k]}" for k in self.laws), choices=self.laws),
               Param("contact.restitution", float, d["restitution"],
                     "Newton coefficient of restitution e (constraint law, Hertz damping)", low=0.0, high=1.0)]
        if self.impact_law:
            out.append(Param("contact.impact_law", str, d["impact_law"], "constraint law, contacts closing at the "
                             "same instant: simultaneous = Newton's law for all at once (one LCP); sequential = "
                             "one contact after another; lzb = Liu–Zhao–Brogliato multiple impacts (the "
                             "contacts' stiffness ratios, energetic restitution)", choices=IMPACT_LAWS))
        if "hertz" in self.laws:
            rule = f" (0: {self.hertz_rule})" if self.hertz_rule else ""
            out.append(Param("contact.hertz_stiffness", float, d["hertz_stiffness"], "Hertz stiffness K" + rule,
                             low=0.0, high=1e18, unit="N/m^n"))
            if self.exponent:
                out.append(Param("contact.hertz_exponent", float, d["hertz_exponent"], "Hertz exponent n in F = K δⁿ",
                                 low=1.0, high=3.0))
            out.append(Param("contact.hertz_damping", str, d["hertz_damping"], "Hertz hysteresis damping law",
                             choices=DAMPING_LAWS))
        if "penalty" in self.laws:
            out += [Param("contact.penalty_stiffness", float, d["penalty_stiffness"],
                          "penalty stiffness k (per contact point)", low=0.0, high=1e18, unit="N/m"),
                    Param("contact.penalty_damping", float, d["penalty_damping"],
                          "penalty damping c (per contact point)", low=0.0, high=1e12, unit="N s/m")]
        if self.friction:
            out.append(Param("contact.friction", float, d["friction"], "Coulomb friction coefficient μ",
                             low=0.0))
            if "hertz" in self.laws or "penalty" in self.laws:
                out.append(Param("contact.friction_velocity", float, d["friction_velocity"],
                                 "regularisation velocity v_ε of the hertz/penalty laws' Coulomb friction "
                                 "F_T = −μ F_N tanh(v_T/v_ε): a held contact creeps at ~v_ε", low=1e-9, high=1e3,
                                 unit="m/s"))
        return out

    def check(self, scene: "Scene") -> None:
        """Cross-key checks of the contact keys (none when ``effects.contact`` is off);
        raise :class:`daebench.core.scene.SceneError` naming the key and the fix."""
        from daebench.core.scene import SceneError  # core: the scene module reads models' schemas

        if not scene.get("effects.contact", True):
            return
        law = scene["contact.law"]
        if law == "hertz":
            if not self.hertz_rule and scene["contact.hertz_stiffness"] <= 0.0:
                raise SceneError("scene key 'contact.hertz_stiffness' must be > 0 for contact.law = 'hertz'")
            if scene["contact.hertz_damping"] == "flores" and scene["contact.restitution"] <= 0.0:
                raise SceneError("scene key 'contact.restitution' must be > 0 with contact.hertz_damping = 'flores'")
        if law == "penalty" and scene["contact.penalty_stiffness"] <= 0.0:
            raise SceneError("scene key 'contact.penalty_stiffness' must be > 0 for contact.law = 'penalty'")

    def law(self, scene: "Scene", n_contacts: int, hertz_stiffness: float | None = None) -> ContactLaw | None:
        """The law of a scene with ``n_contacts`` contact points (None: no contact point, or
        ``complementarity``); ``hertz_stiffness``: the model's K when the key is 0."""
        if n_contacts == 0:
            return None
        d = {k: scene.get(f"contact.{k}", v) for k, v in self.defaults.items()}
        out = make_contact_law(d["law"], d["restitution"], n_contacts,
                                hertz_stiffness=d["hertz_stiffness"] or (hertz_stiffness or 0.0),
                                hertz_damping=d["hertz_damping"], hertz_exponent=d["hertz_exponent"],
                                penalty_stiffness=d["penalty_stiffness"], penalty_damping=d["penalty_damping"],
                                friction_velocity=d["friction_velocity"])

        if isinstance(out, ConstraintLaw):
            out.impact_law = d["impact_law"] if d["impact_law"] in IMPACT_LAWS else out.impact_law
        return out


def contact_schema(laws: tuple[str, ...] = CONTACT_LAWS, *, hertz_rule: str = "", exponent: bool = False,
                   friction: bool = False, impact_law: bool = False, **defaults: Any) -> ContactSchema:
    """The contact keys of a model offering ``laws``: ``contact.law``, ``contact.restitution``,
    the Hertz keys if it offers ``hertz`` (``contact.hertz_exponent`` with ``exponent``),
    the penalty keys if it offers ``penalty``, ``contact.friction`` (Coulomb μ) with
    ``friction``, ``contact.impact_law`` (simultaneous | sequential) with ``impact_law`` (and ``contact.friction_velocity``, the regularisation velocity v_ε, when
    it also offers ``hertz`` or ``penalty``). ``defaults`` override :data:`CONTACT_DEFAULTS` by key (without the
    ``contact.`` prefix); ``hertz_rule`` says what the model does with
    ``contact.hertz_stiffness = 0`` (none: K must be > 0)."""
    unknown = [k for k in laws if k not in CONTACT_LAWS] + [k for k in defaults if k not in CONTACT_DEFAULTS]
    if unknown:
        raise ValueError(f"contact_schema: unknown law or key {unknown}; laws: {CONTACT_LAWS}, "
                         f"keys: {tuple(CONTACT_DEFAULTS)}")
    return ContactSchema(tuple(laws), {**CONTACT_DEFAULTS, **defaults}, hertz_rule, exponent, friction, impact_law)


@dataclass
class Impact:
    """One contact episode: an impact (constraint law), a penetration episode
    (continuous laws), or an episode an integrator resolved itself."""

    t: float
    contact: int
    vn_minus: float          # normal velocity ġ before (negative: approaching)
    vn_plus: float           # after the impact (constraint law) or at separation (continuous laws)
    energy_loss: float       # kinetic energy lost (constraint law) or dissipated in the episode
    closed: bool = False     # the contact stayed closed after the impact
    impulse: float = math.nan      # normal impulse of the impact or of the whole episode [N s]
    t_end: float = math.nan        # end of the episode (separation), when known
    min_gap: float = math.nan      # smallest gap during the episode (penetration < 0)
    impact_impulse: float = math.nan  # impulse of the impact itself: the map's Λ (driver), the first
                                      # step's of an episode (event-capturing; ``impulse`` is the episode's)
    restitution: float = math.nan  # the restitution Newton's law applied (driver: the scene's, or 0 where
                                   # the rebound was too slow or too short to resolve — Zeno's accumulation)
    law: str = ""                  # the driver's impact law: "newton" or "lzb" ("": an episode an
                                   # integrator resolved itself, or a continuous-law episode)
    impact_work: float = math.nan  # work of the contact impulses over an event-capturing episode's impact
                                   # step, Σ P (U⁻ + U⁺)/2 (Kelvin: their kinetic-energy change; no smooth force in it)
    u_law: float = math.nan        # the normal velocity U⁻ that step's impact law used (Moreau–Jean: g_q v_k
                                   # with its own g_q; NaN where the stepper books no impact-alone work)
    q: np.ndarray | None = field(default=None, repr=False)        # configuration at the impact
    v_minus: np.ndarray | None = field(default=None, repr=False)  # velocities before / after
    v_plus: np.ndarray | None = field(default=None, repr=False)

    def as_dict(self) -> dict[str, Any]:
        return {k: v for k, v in asdict(self).items() if k not in ("q", "v_minus", "v_plus")}


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
    sol = solve_structured(A, rhs, n)
    v_plus = sol[:n]
    loss = 0.5 * float(v_minus @ M @ v_minus - v_plus @ M @ v_plus)
    return ImpactResult(v_plus, sol[n + mb:], vn_minus, Gq @ v_plus, loss)
