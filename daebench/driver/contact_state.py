"""The event-driven driver's contact bookkeeping as one value, :class:`ContactState`: which
contacts are closed, which penetrate, which are near their surface, their episodes and
impacts, the stick/slip sets, and the Zeno and halving rules' state. The functions of
:mod:`daebench.driver.events` (where an event falls) and :mod:`daebench.driver.transitions`
(what it does) take it and the phase's :class:`daebench.core.problem.Problem`, through which
they see the system like every integrator does.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from daebench.core.coulomb import cone_margin
from daebench.core.contact import Impact
from daebench.core.kernels import friction_coefficients
from daebench.core.problem import Problem
from daebench.core.system import MechanicalSystem
from daebench.driver.impact_laws import LAWS, ImpactLaw
from daebench.driver.stickslip import SLIP_MIN, phase_friction, slip_velocity, stick_groups
from daebench.integrators.base import StepFailure
from daebench.stepping.watch import GAP_BAND, near

#: the revision of the contact law the driver applies (impacts, closing and opening): a
#: reference computed under another one is recomputed (daebench.harness.references.reference)
CONTACT_LAW_REVISION = 2  # 2: complementarity at velocity and acceleration level
#: a continuous law's: 3, a contact touching at the start closes at g = 0 (ContactState.start)
CONTINUOUS_LAW_REVISION = 3

EVENT_TOL = 1e-13        # event times located to this (seconds)
REBOUND_MIN = 1e-9       # a rebound slower than this (m/s) is treated as plastic (ends Zeno chatter)
ZENO_FLIGHT = 1e-9       # s: floor of the Zeno rule's time (ContactState.step: the step in force)
REIMPACT_MIN_DT = 1e-10  # a second impact of a contact within this time closes it (Zeno)
PROJECTION_ITERS = 3     # Newton iterations of the position projection onto C(q) = 0
MAX_HALVINGS = 10        # an approach not resolved at 2⁻¹⁰ of the contact step closes at that step's end
FLIGHT_SAMPLES = 40      # a rebound's return is searched down to 2⁻⁴⁰ of a step (≈ 1e-16 s at h = 1e-4)


def contact_law_revision(system: Any) -> int:
    """The revision of the contact law a run of ``system`` is decided by (the constants above)."""
    law = getattr(system, "contact_law", None)
    continuous = law is not None and law.continuous and system.n_contacts > 0
    return CONTINUOUS_LAW_REVISION if continuous else CONTACT_LAW_REVISION


class EventKind(enum.Enum):
    """What happens at an event (the transition of each: :data:`daebench.driver.transitions.TRANSITIONS`)."""

    CLOSE = "close"         # a contact reaches its surface (an impact, or a continuous-law first touch)
    OPEN = "open"           # a closed contact's force crosses zero
    SEPARATE = "separate"   # a continuous-law contact stops penetrating
    STOP = "stop"           # a slipping contact comes to rest
    SLIDE = "slide"         # a sticking group leaves its friction cone
    NEAR = "near"           # an open contact comes near its surface (the contact step begins)
    FAR = "far"             # … and leaves it again
    REFINE = "refine"       # an approach the step did not resolve: halve it


class Event(NamedTuple):
    """An event located in a step: its time, its kind and contact."""

    t: float
    kind: EventKind
    contact: int


@dataclass
class Friction:
    """Coulomb friction at the closed contacts: μ per contact, the sticking contacts (their
    anchor q*), the slipping ones (their slip direction s) and the stick rows kept (each
    one's parallel group, :func:`daebench.driver.stickslip.stick_groups`)."""

    mu: np.ndarray
    stick: dict[int, np.ndarray] = field(default_factory=dict)
    slip: dict[int, float] = field(default_factory=dict)
    groups: dict[int, list[int]] = field(default_factory=dict)


@dataclass
class EventMemory:
    """What the event rules remember of each contact's past: when it last impacted, was
    released, was released where its force crossed zero, and changed at all (the Zeno and
    re-impact rules compare against these); the continuous-law episodes' approach speed and
    contact work at first touch; the step halvings spent on unresolved approaches."""

    last_impact_t: np.ndarray
    last_release_t: np.ndarray
    force_release_t: np.ndarray
    changed_t: np.ndarray
    approach_speed: np.ndarray
    episode_start_W: dict[int, float] = field(default_factory=dict)
    halvings: int = 0


@dataclass
class ContactRules:
    """The contact rules of the run: the impact law (``contact.impact_law``), the fixed step
    in force (the Zeno rule's time scale; 0: adaptive) and the proximity time of the contact
    step (NEAR_STEPS free steps; 0: no contact step)."""

    impact_law: ImpactLaw = field(default_factory=ImpactLaw)
    step: float = 0.0
    near_h: float = 0.0


@dataclass
class ContactState:
    """The driver's contacts: which are closed, penetrating or near their surface, whether
    armed, the impacts booked — with the friction state, the event memory and the rules
    apart (:class:`Friction`, :class:`EventMemory`, :class:`ContactRules`).

    ``constraint`` / ``continuous``: the driver closes contacts as constraints (the
    ``constraint`` law) / books continuous-law episodes; neither when the integrator
    resolves the contacts itself."""

    constraint: bool
    continuous: bool
    base: Problem                           # the model's own problem (no contact closed)
    armed: np.ndarray                       # bool per contact: closing detected at g = 0 (else −GAP_BAND)
    memory: EventMemory
    friction: Friction
    rules: ContactRules = field(default_factory=ContactRules)
    active: list[int] = field(default_factory=list)        # closed (constraint law), in row order
    penetrating: set[int] = field(default_factory=set)     # continuous law: g < 0
    near: set[int] = field(default_factory=set)  # open contacts near their surface (stepping.watch.near)
    impacts: list[Impact] = field(default_factory=list)
    d_impacts: float = 0.0                  # kinetic energy removed by impact maps
    gap_cache: tuple | None = None          # (q, t, g(q)) of the last step's new state
    force_cache: tuple | None = None        # (q, t, λ) of the last step's new state (consistent multipliers)

    @classmethod
    def start(cls, problem: Problem, q: np.ndarray, constraint: bool, continuous: bool,
              v: np.ndarray | None = None) -> "ContactState":
        """The contacts at t = 0 (continuous law: those already penetrating are engaged)."""
        nc = problem.n_contacts
        g = problem.gap(q) if nc else np.zeros(0)
        never = np.full(max(nc, 1), -np.inf)
        memory = EventMemory(never.copy(), never.copy(), never.copy(), never.copy(), np.full(nc, np.nan))
        mu = friction_coefficients(problem.kernel.model, nc, q, np.zeros_like(q) if v is None else v) \
            if constraint else np.zeros(nc)
        rules = ContactRules(LAWS[getattr(problem.contact_law, "impact_law", "simultaneous")])
        # armed: closing detected at g = 0, else at −GAP_BAND. A continuous law's contact on its
        # surface at the start (a chain of touching balls) closes as soon as it is pressed: the
        # band, against a constraint contact closing again right after it separated, has no
        # meaning there, and would leave it pressed GAP_BAND deep without force
        armed = (g >= 0.0 if continuous else g > GAP_BAND) if nc else np.zeros(0, bool)
        cs = cls(constraint, continuous, problem, armed, memory, Friction(mu), rules)
        if continuous:
            cs.penetrating = {int(i) for i in np.flatnonzero(g < 0.0)}
        return cs

    # -- stick and slip (daebench.driver.stickslip) ---------------------------------------------
    def set_friction_state(self, contacts: list[int], t: float, q: np.ndarray, v: np.ndarray) -> None:
        """Closed frictional ``contacts`` stick where their slip velocity is below SLIP_MIN,
        else slip in its direction; open ones leave both sets."""
        md = self.base.kernel.model
        for c in contacts:
            self.friction.stick.pop(c, None)
            self.friction.slip.pop(c, None)
            if c in self.active and self.friction.mu[c] > 0.0:
                ut = slip_velocity(md, c, q, v)
                if abs(ut) < SLIP_MIN:
                    self.friction.stick[c] = q.copy()
                else:
                    self.friction.slip[c] = math.copysign(1.0, ut)
        self.regroup(t, q)

    def regroup(self, t: float, q: np.ndarray) -> None:
        """The stick rows kept and their parallel groups (stickslip.stick_groups)."""
        for c in [c for c in list(self.friction.stick) + list(self.friction.slip) if c not in self.active]:
            self.friction.stick.pop(c, None)
            self.friction.slip.pop(c, None)
        try:
            self.friction.groups = stick_groups(self.base, self.base.kernel.model, t, q, self.active, list(self.friction.stick)) \
                if self.friction.stick else {}
        except ValueError as exc:
            raise StepFailure(str(exc), t) from None

    def cone_margins(self, problem: Problem, lam: np.ndarray) -> dict[int, tuple[float, float]]:
        """{kept stick contact: (μ Σ λ_N − |λ_T|, λ_T)} of each stick group at multipliers λ."""
        nb0, k = self.base.n_bilateral, problem.n_bilateral
        out = {}
        for r, (c, members) in enumerate(self.friction.groups.items()):
            lam_t = float(lam[nb0 + r])
            lam_n = sum(float(lam[k + self.active.index(m)]) for m in members)
            mu = min(float(self.friction.mu[m]) for m in members)
            out[c] = (float(cone_margin(mu, lam_n, lam_t)), lam_t)
        return out

    @property
    def watched(self) -> bool:
        """Whether the driver watches the contacts (it does not when the integrator resolves them)."""
        return self.constraint or self.continuous

    @property
    def in_contact(self) -> bool:
        """Whether the integrator takes its contact step: contacts closed, penetrating, or
        open and near their surface (:func:`daebench.stepping.watch.near`)."""
        return bool(self.active) or bool(self.penetrating) or bool(self.near)

    def update_near(self, problem: Problem, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> None:
        """The open contacts near their surface at (q, v) with acceleration a
        (:func:`daebench.stepping.watch.near`)."""
        if self.rules.near_h <= 0.0 or not self.watched:
            return
        rows = problem.gap_rows(q, v)
        self.near = {i for i in range(problem.n_contacts) if i not in self.active and i not in self.penetrating
                     and is_near(problem, q, v, a, i, self.rules.near_h, rows)}

    def close(self, contacts: list[int], t: float) -> None:
        """Close open contacts at t (they join the phase's constraints)."""
        self.active += contacts
        self.armed[contacts] = False
        self.memory.changed_t[contacts] = t

    def release(self, contacts: list[int], t: float, q: np.ndarray | None = None) -> None:
        """Open closed contacts at t; their closed episodes end there."""
        self.active = [c for c in self.active if c not in contacts]
        self.armed[contacts] = False
        self.memory.last_release_t[contacts] = t
        self.memory.changed_t[contacts] = t
        for c in contacts:
            for imp in reversed(self.impacts):  # the closed episode of contact c ends here
                if imp.contact == c:
                    if imp.closed and math.isnan(imp.t_end):
                        imp.t_end = t
                    break
        if q is not None and (self.friction.stick or self.friction.slip):
            self.regroup(t, q)

    def phase(self, system: MechanicalSystem) -> Problem:
        """The phase these contacts define: closed contacts, engaged continuous contacts, χ."""
        nc = system.n_contacts
        engaged = np.zeros(nc)
        chi = np.zeros(nc)
        if self.continuous:
            engaged[list(self.penetrating)] = 1.0
            chi = system.contact_law.chi(self.memory.approach_speed)
        return Problem(system, tuple(self.active), engaged, chi,
                       phase_friction(self.active, self.friction.stick, self.friction.groups, self.friction.slip, self.friction.mu))


def is_near(problem: Problem, q: np.ndarray, v: np.ndarray, a: np.ndarray, i: int, near_h: float,
            rows: tuple | None = None) -> bool:
    """:func:`daebench.stepping.watch.near` for contact i at (q, v, a) (a state without an
    acceleration: its gap moving at constant ġ); ``rows``: the gap rows at (q, v), when the
    caller asks about several contacts (each evaluation computes every contact's row)."""
    g, G, gam = problem.gap_rows(q, v) if rows is None else rows
    gdd = float(G[i] @ a - gam[i]) if np.size(a) == q.shape[0] else 0.0
    return bool(near(float(g[i]), float(G[i] @ v), gdd, near_h))
