"""The event-driven driver's contact bookkeeping as one value, :class:`ContactState`: which
contacts are closed, which penetrate, which are near their surface, their episodes and
impacts, the stick/slip sets, and the Zeno and halving rules' state. The functions of
:mod:`daebench.driver.events` (where an event falls) and :mod:`daebench.driver.transitions`
(what it does) take it and the phase's :class:`daebench.core.problem.Problem`, through which
they see the system like every integrator does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from daebench.core.coulomb import cone_margin
from daebench.core.contact import Impact
from daebench.core.kernels import friction_coefficients
from daebench.core.problem import Problem
from daebench.core.system import MechanicalSystem
from daebench.driver.stickslip import SLIP_MIN, phase_friction, slip_velocity, stick_groups
from daebench.integrators.base import StepFailure
from daebench.stepping.watch import GAP_BAND, near

#: the revision of the contact law the driver applies (impacts, closing and opening): a
#: reference computed under another one is recomputed (daebench.harness.references.reference)
CONTACT_LAW_REVISION = 2  # 2: complementarity at velocity and acceleration level
EVENT_TOL = 1e-13        # event times located to this (seconds)
REBOUND_MIN = 1e-9       # a rebound slower than this (m/s) is treated as plastic (ends Zeno chatter)
ZENO_FLIGHT = 1e-9       # s: floor of the Zeno rule's time (ContactState.step: the step in force)
REIMPACT_MIN_DT = 1e-10  # a second impact of a contact within this time closes it (Zeno)
PROJECTION_ITERS = 3     # Newton iterations of the position projection onto C(q) = 0
MAX_HALVINGS = 10        # an approach not resolved at 2⁻¹⁰ of the contact step closes at that step's end
FLIGHT_SAMPLES = 40      # a rebound's return is searched down to 2⁻⁴⁰ of a step (≈ 1e-16 s at h = 1e-4)


class Event(NamedTuple):
    """An event located in a step: its time, its kind (close | open | separate | stop | slide |
    near | far | refine) and contact."""

    t: float
    kind: str
    contact: int


@dataclass
class ContactState:
    """The driver's contacts: which are closed or penetrating, and their episodes.

    ``constraint`` / ``continuous``: the driver closes contacts as constraints (the
    ``constraint`` law) / books continuous-law episodes; neither when the integrator
    resolves the contacts itself."""

    constraint: bool
    continuous: bool
    armed: np.ndarray                       # bool per contact: closing detected at g = 0 (else −GAP_BAND)
    last_impact_t: np.ndarray               # per contact
    last_release_t: np.ndarray              # per contact
    approach_speed: np.ndarray              # v₀ of each continuous-law episode
    active: list[int] = field(default_factory=list)        # closed (constraint law), in row order
    penetrating: set[int] = field(default_factory=set)     # continuous law: g < 0
    episode_start_W: dict[int, float] = field(default_factory=dict)  # contact work at first touch
    impacts: list[Impact] = field(default_factory=list)
    d_impacts: float = 0.0                  # kinetic energy removed by impact maps
    gap_cache: tuple | None = None          # (q, t, g(q)) of the last step's new state
    force_cache: tuple | None = None        # (q, t, λ) of the last step's new state (consistent multipliers)
    near_h: float = 0.0                     # proximity time: NEAR_STEPS free steps (0: no contact step)
    near: set[int] = field(default_factory=set)  # open contacts near their surface (stepping.watch.near)
    halvings: int = 0                       # the step halved this often (unresolved approaches)
    step: float = 0.0                       # the fixed step in force (the Zeno rule's time scale; 0: adaptive)
    force_release_t: np.ndarray = field(default_factory=lambda: np.zeros(0))  # per contact: its last
                                            # release located where its consistent force crossed zero
    changed_t: np.ndarray = field(default_factory=lambda: np.zeros(0))  # per contact: when it last
                                            # opened or closed
    impact_law: str = "simultaneous"        # contact.impact_law (constraint law)
    base: Problem | None = None             # the model's own problem (no contact closed)
    mu: np.ndarray = field(default_factory=lambda: np.zeros(0))   # Coulomb μ per contact
    stick: dict[int, np.ndarray] = field(default_factory=dict)    # sticking closed contacts: anchor q*
    slip: dict[int, float] = field(default_factory=dict)          # slipping closed contacts: direction s
    groups: dict[int, list[int]] = field(default_factory=dict)    # stick rows kept: their parallel groups

    @classmethod
    def start(cls, problem: Problem, q: np.ndarray, constraint: bool, continuous: bool,
              v: np.ndarray | None = None) -> "ContactState":
        """The contacts at t = 0 (continuous law: those already penetrating are engaged)."""
        nc = problem.n_contacts
        g = problem.gap(q) if nc else np.zeros(0)
        cs = cls(constraint, continuous, g > GAP_BAND if nc else np.zeros(0, bool),
                 np.full(max(nc, 1), -np.inf), np.full(max(nc, 1), -np.inf), np.full(nc, np.nan))
        if continuous:
            cs.penetrating = {int(i) for i in np.flatnonzero(g < 0.0)}
        cs.base = problem
        cs.force_release_t = np.full(max(nc, 1), -np.inf)
        cs.changed_t = np.full(max(nc, 1), -np.inf)
        law = problem.contact_law
        cs.impact_law = getattr(law, "impact_law", "simultaneous")
        cs.mu = friction_coefficients(problem.kernel.model, nc, q, np.zeros_like(q) if v is None else v) \
            if constraint else np.zeros(nc)
        return cs

    # -- stick and slip (daebench.driver.stickslip) ---------------------------------------------
    def set_friction_state(self, contacts: list[int], t: float, q: np.ndarray, v: np.ndarray) -> None:
        """Closed frictional ``contacts`` stick where their slip velocity is below SLIP_MIN,
        else slip in its direction; open ones leave both sets."""
        md = self.base.kernel.model
        for c in contacts:
            self.stick.pop(c, None)
            self.slip.pop(c, None)
            if c in self.active and self.mu[c] > 0.0:
                ut = slip_velocity(md, c, q, v)
                if abs(ut) < SLIP_MIN:
                    self.stick[c] = q.copy()
                else:
                    self.slip[c] = math.copysign(1.0, ut)
        self.regroup(t, q)

    def regroup(self, t: float, q: np.ndarray) -> None:
        """The stick rows kept and their parallel groups (stickslip.stick_groups)."""
        for c in [c for c in list(self.stick) + list(self.slip) if c not in self.active]:
            self.stick.pop(c, None)
            self.slip.pop(c, None)
        try:
            self.groups = stick_groups(self.base, self.base.kernel.model, t, q, self.active, list(self.stick)) \
                if self.stick else {}
        except ValueError as exc:
            raise StepFailure(str(exc), t) from None

    def cone_margins(self, problem: Problem, lam: np.ndarray) -> dict[int, tuple[float, float]]:
        """{kept stick contact: (μ Σ λ_N − |λ_T|, λ_T)} of each stick group at multipliers λ."""
        nb0, k = self.base.n_bilateral, problem.n_bilateral
        out = {}
        for r, (c, members) in enumerate(self.groups.items()):
            lam_t = float(lam[nb0 + r])
            lam_n = sum(float(lam[k + self.active.index(m)]) for m in members)
            mu = min(float(self.mu[m]) for m in members)
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
        if self.near_h <= 0.0 or not self.watched:
            return
        rows = problem.gap_rows(q, v)
        self.near = {i for i in range(problem.n_contacts) if i not in self.active and i not in self.penetrating
                     and is_near(problem, q, v, a, i, self.near_h, rows)}

    def close(self, contacts: list[int], t: float) -> None:
        """Close open contacts at t (they join the phase's constraints)."""
        self.active += contacts
        self.armed[contacts] = False
        self.changed_t[contacts] = t

    def release(self, contacts: list[int], t: float, q: np.ndarray | None = None) -> None:
        """Open closed contacts at t; their closed episodes end there."""
        self.active = [c for c in self.active if c not in contacts]
        self.armed[contacts] = False
        self.last_release_t[contacts] = t
        self.changed_t[contacts] = t
        for c in contacts:
            for imp in reversed(self.impacts):  # the closed episode of contact c ends here
                if imp.contact == c:
                    if imp.closed and math.isnan(imp.t_end):
                        imp.t_end = t
                    break
        if q is not None and (self.stick or self.slip):
            self.regroup(t, q)

    def phase(self, system: MechanicalSystem) -> Problem:
        """The phase these contacts define: closed contacts, engaged continuous contacts, χ."""
        nc = system.n_contacts
        engaged = np.zeros(nc)
        chi = np.zeros(nc)
        if self.continuous:
            engaged[list(self.penetrating)] = 1.0
            chi = system.contact_law.chi(self.approach_speed)
        return Problem(system, tuple(self.active), engaged, chi,
                       phase_friction(self.active, self.stick, self.groups, self.slip, self.mu))


def is_near(problem: Problem, q: np.ndarray, v: np.ndarray, a: np.ndarray, i: int, near_h: float,
            rows: tuple | None = None) -> bool:
    """:func:`daebench.stepping.watch.near` for contact i at (q, v, a) (a state without an
    acceleration: its gap moving at constant ġ); ``rows``: the gap rows at (q, v), when the
    caller asks about several contacts (each evaluation computes every contact's row)."""
    g, G, gam = problem.gap_rows(q, v) if rows is None else rows
    gdd = float(G[i] @ a - gam[i]) if np.size(a) == q.shape[0] else 0.0
    return bool(near(float(g[i]), float(G[i] @ v), gdd, near_h))
