"""Events of the event-driven driver (:mod:`daebench.driver.simulate`): where in a step a gap
closes, a contact force turns tensile, a penetrating contact separates, a slipping contact
stops or a sticking one's force leaves the friction cone — located on the integrator's
dense output by Brent's method — and what each does to the state: the impact law of the
``constraint`` law, the start and end of a continuous-law episode, the switch between
stick and slip (:mod:`daebench.driver.stickslip`), and the projection back onto the
constraints of the phase that ends.

Contact physics is decided by complementarity, on the state, never by an integrator's
internals:

* **impacts** — Newton's law at velocity level, 0 ≤ ġ⁺ + e ġ⁻ ⟂ Λ ≥ 0, for one contact as
  for many (:func:`daebench.core.frictional_impact.frictional_impact`; with planar Coulomb
  friction in the manner of Pfeiffer & Glocker where μ > 0). A contact that does not
  approach (ġ⁻ ≥ 0) receives no impulse and no impact is recorded; if its gap drifted below
  zero, that is a position error of the integration, projected away (:func:`lift`);
* **which contacts are closed** — the contact law at acceleration level on the current
  state, 0 ≤ g̈ ⟂ λ_N ≥ 0 (:func:`settle`, :mod:`daebench.core.resting_contacts`), at the
  start of every phase for the closed contacts and the open ones at rest on their surface
  (after an impact, a release, or a grazing touch);
* **releases** — a closed contact opens when its *consistent* force (the phase's
  acceleration-level multiplier at the step's (t, q, v), :func:`contact_forces`) turns
  tensile, located on the dense output. The multiplier an index-3 step returns is not
  used: at small h it is dominated by the step's position correction (∝ C/(βh²)) and
  changes sign from step to step.

The impact law (scene key ``contact.impact_law``, named in the run record by
:func:`impact_law_name`): where several contacts close at the same instant — the
impacting one, the open contacts at g = 0 that do not separate, the closed ones — the
``simultaneous`` law (the default) applies Newton's law to all of them at once, one LCP;
the ``sequential`` law applies it to the impacting contact alone, the closed contacts
held, and the next contact's impact follows as its own event. A Newton's cradle of three
balls leaves at (−1/3, 2/3, 2/3) v under the first and at (0, 0, 1) v under the second. The
``lzb`` law takes the contacts of the simultaneous one through the Liu–Zhao–Brogliato impact
process (:mod:`daebench.core.lzb`, the model's ``contact_stiffness``).

The driver's contact bookkeeping is one value, :class:`ContactState` (which contacts are
closed, which penetrate, their episodes); the functions here take it and the phase's
:class:`daebench.core.problem.Problem`, through which they see the system like every
integrator does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np
from scipy.optimize import brentq

from daebench.core import phase as _phase
from daebench.core.contact import Impact
from daebench.core.frictional_impact import failure_message, frictional_impact, law_name
from daebench.core.kernels import friction_coefficients
from daebench.core.linalg import solve_structured
from daebench.core.lzb import NAME as LZB_NAME, failure_message as lzb_failure, lzb_law
from daebench.core.problem import Problem
from daebench.core.resting_contacts import failure_message as resting_failure, resting_lcp
from daebench.core.system import MechanicalSystem, State
from daebench.core.coulomb import cone_margin
from daebench.driver.stickslip import (PAINLEVE_SLIP, SLIP_MIN, phase_friction, slip_velocity, stick_groups,
                                       tangent_row)
from daebench.integrators.base import StepFailure
from daebench.stepping.watch import GAP_BAND, GAP_ROUNDOFF, gap_event, near

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


def find_event(cs: ContactState, prev: State, new: State, problem: Problem,
               dense: Callable[[float], State]) -> Event | None:
    """Earliest event in (prev.t, new.t] on the dense output ``dense``, or None; re-arms
    the gaps that left the band."""
    cands = []
    if cs.watched:
        # the previous step's new state is usually this step's prev: reuse its gaps
        gc = cs.gap_cache
        g0 = gc[2] if gc is not None and gc[0] is prev.q and gc[1] == prev.t else problem.gap(prev.q)
        g1 = problem.gap(new.q)
        cs.gap_cache = (new.q, new.t, g1)
        for i in range(problem.n_contacts):
            if i in cs.active:
                continue
            if cs.continuous and i in cs.penetrating:
                if g1[i] > 0.0:
                    cands.append(Event(_root(lambda t: problem.gap(dense(t).q)[i], prev, new), "separate", i))
                continue
            closes, arms = gap_event(g1[i], cs.armed[i])
            off = 0.0 if cs.armed[i] else GAP_BAND
            if closes and g0[i] >= -off - GAP_ROUNDOFF:
                # the band decides whether the contact closed; where is g = 0 when the
                # step started on or above the plane
                at = 0.0 if g0[i] >= 0.0 else off
                tc = _closing_root(lambda t: problem.gap(dense(t).q)[i] + at, prev, new)
                if tc < new.t and _normal_velocity(problem, dense(tc), i) > REBOUND_MIN:
                    # the dense output's root separates: the step does not resolve where the gap
                    # closed (a motion faster than the step). Take it again, finer (ContactState.halvings)
                    if cs.halvings < MAX_HALVINGS:
                        cands.append(Event(prev.t, "refine", i))
                        continue
                    tc = new.t  # unresolved at the finest step: the closing is the step's end
                cands.append(Event(tc, "close", i))
            elif closes:
                # the step started already (numerically) closed — e.g. a grazing re-contact
                # right after a separation: contact at its start
                cands.append(Event(prev.t, "close", i))
            elif arms:
                cs.armed[i] = True
        if cs.near_h > 0.0 and not cands:
            # proximity changes, at the step's end (only where no event came first)
            rows = problem.gap_rows(new.q, new.v)
            for i in range(problem.n_contacts):
                if i not in cs.active and i not in cs.penetrating and \
                        is_near(problem, new.q, new.v, new.a, i, cs.near_h, rows) != (i in cs.near):
                    cands.append(Event(new.t, "far" if i in cs.near else "near", i))
    if cs.constraint and cs.active:
        fc = cs.force_cache
        lam0 = fc[2] if fc is not None and fc[0] is prev.q and fc[1] == prev.t else consistent_multipliers(problem, prev)
        lam1 = consistent_multipliers(problem, new)
        cs.force_cache = (new.q, new.t, lam1)
        k = problem.n_bilateral
        f0, f1 = lam0[k:], lam1[k:]
        for j, c in enumerate(cs.active):
            if f1[j] < 0.0:
                at = _root(lambda t: contact_forces(problem, dense(t))[j], prev, new) if f0[j] >= 0.0 else prev.t
                cands.append(Event(at, "open", c))
        cands += _friction_events(cs, prev, new, problem, dense, lam0, lam1)
    # a contact's status changes once an instant: an event that would undo at the phase's start
    # what was decided there (the state is degenerate: force and gap acceleration both zero)
    # waits one step, so that every such cycle advances time
    cands = [c for c in cands if not (c.t <= prev.t and cs.changed_t[c.contact] == prev.t
                                      and c.kind in ("close", "open"))]
    return min(cands, key=lambda c: c.t) if cands else None


def is_near(problem: Problem, q: np.ndarray, v: np.ndarray, a: np.ndarray, i: int, near_h: float,
            rows: tuple | None = None) -> bool:
    """:func:`daebench.stepping.watch.near` for contact i at (q, v, a) (a state without an
    acceleration: its gap moving at constant ġ); ``rows``: the gap rows at (q, v), when the
    caller asks about several contacts (each evaluation computes every contact's row)."""
    g, G, gam = problem.gap_rows(q, v) if rows is None else rows
    gdd = float(G[i] @ a - gam[i]) if np.size(a) == q.shape[0] else 0.0
    return bool(near(float(g[i]), float(G[i] @ v), gdd, near_h))


def _normal_velocity(problem: Problem, s: State, i: int) -> float:
    """ġ_i = g_q,i v at the state ``s``."""
    return float(problem.gap_jacobian(s.q)[i] @ s.v)


def contact_forces(problem: Problem, s: State) -> np.ndarray:
    """The consistent normal forces λ_N ≥ 0 (compressive) of the phase's closed contacts at
    the state ``s``: the multipliers of [[M, C_qᵀ], [C_q, 0]] [a; λ] = [Q; γ] at (t, q, v),
    the acceleration-level law of the phase — whatever multiplier the integrator's step made."""
    return consistent_multipliers(problem, s)[problem.n_bilateral:]


def consistent_multipliers(problem: Problem, s: State) -> np.ndarray:
    """Every multiplier λ of the phase's constraints at the state ``s`` (module docstring):
    not counted as the integrator's work."""
    n, m = problem.n, problem.m
    acc, lam = np.empty(n), np.empty(m)
    w = _phase.augmented_work(n, m)
    if _phase.solve_augmented(problem.kernel, float(s.t), np.ascontiguousarray(s.q, float),
                              np.ascontiguousarray(s.v, float), 0.0, 0.0, w, acc, lam):
        raise StepFailure("singular augmented mass matrix at a contact-force evaluation (dependent constraints?)",
                          s.t)
    return lam


def _friction_events(cs: ContactState, prev: State, new: State, problem: Problem,
                     dense: Callable[[float], State], lam0: np.ndarray, lam1: np.ndarray) -> list[Event]:
    """A slipping contact's slip velocity through zero (stop); a stick group's force
    leaving the cone (slide); ``lam0``, ``lam1``: the consistent multipliers at prev and new."""
    out = []
    md = cs.base.kernel.model
    for c, s in cs.slip.items():
        def ut(t: float, c: int = c, s: float = s) -> float:
            st = dense(t)
            return s * slip_velocity(md, c, st.q, st.v)
        u0, u1 = s * slip_velocity(md, c, prev.q, prev.v), s * slip_velocity(md, c, new.q, new.v)
        if u1 < 0.0:
            out.append(Event(_root(ut, prev, new) if u0 > 0.0 else prev.t, "stop", c))
    if cs.groups:
        m0, m1 = cs.cone_margins(problem, lam0), cs.cone_margins(problem, lam1)
        for c in cs.groups:
            if m1[c][0] < 0.0:
                f = (lambda t, c=c: cs.cone_margins(problem, consistent_multipliers(problem, dense(t)))[c][0])
                out.append(Event(_root(f, prev, new) if m0[c][0] >= 0.0 else prev.t, "slide", c))
    return out


def _closing_root(f: Callable[[float], float], prev: State, new: State) -> float:
    """Where f (a gap above its closing threshold) first turns negative in (prev.t, new.t].
    A step that starts on the threshold (f = 0: the contact rebounded there) first rises:
    the return is bracketed by sampling the dense output — at 2⁻ᵏ of the step for a flight
    shorter than a step, then uniformly — so a rebound is never taken for a closing."""
    if abs(f(prev.t)) > GAP_ROUNDOFF:
        return _root(f, prev, new)
    h = new.t - prev.t
    taus = [h * 2.0 ** -k for k in range(FLIGHT_SAMPLES, 0, -1)] + [h * j / 16.0 for j in range(9, 17)]
    last_up = None
    for tau in taus:
        t = prev.t + tau
        if f(t) > 0.0:
            last_up = t
        elif last_up is not None:
            return brentq(f, last_up, t, xtol=EVENT_TOL, rtol=4 * np.finfo(float).eps)
    return prev.t if last_up is None else new.t


def _root(f: Callable[[float], float], prev: State, new: State) -> float:
    fa, fb = f(prev.t), f(new.t)
    if fa == 0.0:
        return prev.t
    if np.sign(fa) == np.sign(fb):
        # the dense output disagrees with the step endpoints in sign: take the step end
        return new.t
    return brentq(f, prev.t, new.t, xtol=EVENT_TOL, rtol=4 * np.finfo(float).eps)


def apply_event(cs: ContactState, event: Event, state: State, problem: Problem, contact_work: float) -> State:
    """Apply ``event`` to the contacts and to the state (on the dense output at the event
    time) of the phase ``problem`` that it ends; ``contact_work``: the continuous laws'
    work booked so far. Which contacts then stay closed is decided at the start of the
    next phase (:func:`settle`)."""
    t, kind, i = event
    # the event state comes from the dense output: put it back on the constraints of
    # the phase it ends (closed contacts: g = 0, ġ = 0) before switching
    q, v = project(problem, t, state.q, state.v)
    system = cs.base.system if cs.base is not None else problem.system
    if kind != "refine":
        cs.halvings = 0  # any other event: the step the phase calls for again
    if kind == "close" and cs.constraint:
        v, lifted = _impact(cs, problem, t, i, q, v)
        if lifted:  # open contacts found below their surface: a position drift, not an impact
            q = lift(cs, system, t, q, lifted)
        if cs.active:
            # the impact was located on g = 0 (or −GAP_BAND): start the closed phase on it
            q, v = project_resting(cs, cs.phase(system), t, q, v)
        cs.armed[i] = False
    elif kind == "stop":
        # the contact and every other slipping one at rest with it stick here
        md = cs.base.kernel.model
        stopped = {c: s for c, s in cs.slip.items() if c == i or abs(slip_velocity(md, c, q, v)) < SLIP_MIN}
        for c in stopped:
            del cs.slip[c]
            cs.stick[c] = q.copy()
        cs.regroup(t, q)
        try:
            phase = cs.phase(system)
            q1, v1 = project(phase, t, q, v)
            phase.acceleration(t, q1, v1)
            q, v = q1, v1
        except np.linalg.LinAlgError:
            # sticking would lock the system (the stick rows singular there, e.g. a slider at
            # its crank's dead centre): the slip velocity passes through zero, the slip reverses
            for c, s in stopped.items():
                del cs.stick[c]
                cs.slip[c] = -s
            cs.regroup(t, q)
    elif kind == "slide":
        lam_t = cs.cone_margins(problem, consistent_multipliers(problem, State(t, q, v)))[i][1]
        for c in cs.groups[i]:
            del cs.stick[c]
            cs.slip[c] = math.copysign(1.0, lam_t)
        cs.regroup(t, q)
    elif kind == "open":
        cs.release([i], t, q)
        cs.force_release_t[i] = t
    elif kind == "refine":
        cs.halvings += 1  # the phase restarts here, at half the step that did not resolve the approach
    elif kind in ("near", "far"):
        cs.near.symmetric_difference_update({i})  # the phase restarts here, at the contact step or the free one
    elif kind == "close":  # continuous law: first touch
        vn = float(problem.gap_jacobian(q)[i] @ v)
        cs.approach_speed[i] = max(-vn, 1e-12)
        cs.penetrating.add(i)
        cs.episode_start_W[i] = contact_work
        cs.impacts.append(Impact(t, i, vn, math.nan, math.nan))
    elif kind == "separate":
        cs.penetrating.discard(i)
        cs.armed[i] = False  # a release like any other: re-closing goes by the band rule
        vn = float(problem.gap_jacobian(q)[i] @ v)
        for imp in reversed(cs.impacts):
            if imp.contact == i and math.isnan(imp.vn_plus):
                imp.vn_plus = vn
                imp.energy_loss = cs.episode_start_W.pop(i, math.nan) - contact_work
                imp.t_end = t
                break
    return State(t, q, v)


def _impact(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray
            ) -> tuple[np.ndarray, list[int]]:
    """Newton's law at the closing of contact i at (t, q, v⁻), with the law's restitution and
    the phase's bilateral constraints kept (module docstring). Books the impacts (contacts
    that receive an impulse), closes the contacts left at rest (ġ⁺ below REBOUND_MIN: the
    acceleration-level law decides at the next phase start whether they stay closed) and
    opens the closed ones that separate. Returns v⁺ and the open contacts of the event that
    lie below their surface by more than the band allows (to be lifted onto it)."""
    base = cs.base if cs.base is not None else problem
    M = base.mass(q)
    g, Gq, _ = base.gap_rows(q)
    B = base.constraint_jacobian(t, q)[:base.n_bilateral]
    e = problem.contact_law.restitution
    # a re-impact within REIMPACT_MIN_DT (Zeno chatter) closes plastically
    zeno = t - cs.last_impact_t[i] < REIMPACT_MIN_DT
    md = base.kernel.model
    T = np.array([tangent_row(md, c, q) for c in range(len(g))]) if cs.mu.any() else np.zeros_like(Gq)
    if cs.impact_law != "sequential":  # simultaneous, lzb: every contact of the event at once
        part = sorted({i, *cs.active} | {c for c in range(len(g)) if g[c] <= GAP_BAND and Gq[c] @ v <= 0.0
                                          and not (cs.continuous and c in cs.penetrating)})
        held = B
    else:
        part = [i]
        held = np.vstack([B] + [Gq[[c]] for c in cs.active])
    mu = cs.mu[part] if cs.mu.size else np.zeros(len(part))
    e_c = np.full(len(part), 0.0 if zeno else e)
    lzb = lzb_law(base.system, part) if cs.impact_law == "lzb" else None
    law = "lzb" if lzb is not None else "newton"
    res = _law(M, Gq[part], T[part], mu, v, e_c, held, t, i, lzb)
    if e_c.any() and lzb is None:
        # a rebound too slow, or whose Zeno accumulation of ever shorter bounces (2ġ⁺/((1 − e)|g̈|)
        # long in all) ends within the step in force, is plastic: taken as instantaneous (not under
        # LZB, where a contact's e shapes the whole wave: its slow rebounds rest, below)
        short = _unresolvable_rebounds(base, t, q, part, res, e, cs.step)
        if short.any():
            e_c[short] = 0.0
            res = _law(M, Gq[part], T[part], mu, v, e_c, held, t, i, lzb)
    resting = [c for r, c in enumerate(part) if res.vn_plus[r] < REBOUND_MIN]
    if lzb is None:   # contacts of the event that the impact lifts off only briefly rest with the others
        resting += _lifted_briefly(base, t, q, res.v_plus, resting,
                                   [c for r, c in enumerate(part) if c not in resting and res.impulse_n[r] <= 0.0
                                    and g[c] <= GAP_BAND], cs.step)
    cs.release([c for c in part if c in cs.active and c not in resting], t)
    cs.d_impacts += res.energy_loss
    loss = res.energy_loss  # booked on the first contact that takes an impulse (the impacting one if it does)
    for r in sorted(range(len(part)), key=lambda r: part[r] != i):
        c = part[r]
        if res.impulse_n[r] > 0.0:
            cs.last_impact_t[c] = t
            cs.impacts.append(Impact(t, c, float(res.vn_minus[r]), float(res.vn_plus[r]), loss,
                                     c in resting, float(res.impulse_n[r]),
                                     restitution=float(e_c[r]) if lzb is None else math.nan, law=law,
                                     q=q.copy(), v_minus=v.copy(), v_plus=res.v_plus.copy()))
            loss = 0.0
    cs.close([c for c in resting if c not in cs.active], t)
    if cs.mu.any():
        cs.set_friction_state(part, t, q, res.v_plus)
    # below the band (where a rebound from −GAP_BAND lives) a gap is the integrator's drift
    return res.v_plus, [c for c in part if c not in resting and g[c] < -GAP_BAND - GAP_ROUNDOFF]


def _unresolvable_rebounds(base: Problem, t: float, q: np.ndarray, part: list[int], res, e: float,
                           step: float) -> np.ndarray:
    """Which of the impacting contacts ``part`` rebound slower than REBOUND_MIN, or whose
    whole Zeno sequence of bounces, 2ġ⁺/((1 − e)|g̈|) long (g̈ the gap acceleration with the
    contacts open), would end within ``step`` (the step in force; at least ZENO_FLIGHT): no
    step resolves it, and it ends at rest."""
    vn_plus = res.vn_plus
    hit = (res.impulse_n > 0.0) & (vn_plus > 0.0)
    if not hit.any():
        return hit
    a, _ = base.acceleration(t, q, res.v_plus)
    _, G, gam = base.gap_rows(q, res.v_plus)
    gdd = G[part] @ a - gam[part]
    zeno_time = max(step, ZENO_FLIGHT) * (1.0 - min(e, 1.0 - 1e-12))
    return hit & ((vn_plus < REBOUND_MIN) | back_within(vn_plus, gdd, zeno_time))


def back_within(vn: np.ndarray, gdd: np.ndarray, span: float) -> np.ndarray:
    """Which contacts leaving their surface at ġ = ``vn`` > 0 under the gap acceleration
    g̈ = ``gdd`` are back on it within ``span`` seconds (2ġ < span |g̈|, g̈ < 0): the rule of
    every Zeno decision (a rebound sequence, a rocking's alternating lift-offs, a contact at
    rest that drifts open)."""
    vn = np.asarray(vn, float)
    return (vn > 0.0) & (2.0 * vn < span * np.maximum(-np.asarray(gdd, float), 0.0))


def _lifted_briefly(base: Problem, t: float, q: np.ndarray, v: np.ndarray, closed: list[int], rows: list[int],
                    step: float) -> list[int]:
    """Which open contacts ``rows`` on their surface (no impulse of their own: an impact of
    another lifts them, or the integrator's drift opens them) leave it so slowly that they
    would be back within the step in force (:func:`back_within`, g̈ with the contacts
    ``closed`` kept): no step resolves the flight — the Zeno accumulation of a rocking body's
    alternating impacts ends within it — so they are at rest."""
    if not rows:
        return []
    _, G, gam = base.gap_rows(q, v)
    try:
        a, _ = Problem(base.system, tuple(sorted(set(closed)))).acceleration(t, q, v)
    except np.linalg.LinAlgError:   # redundant closed contacts: their free acceleration instead
        a, _ = base.acceleration(t, q, v)
    vn, gdd = G[rows] @ v, G[rows] @ a - gam[rows]
    return [c for c, back in zip(rows, back_within(vn, gdd, max(step, ZENO_FLIGHT))) if back]


def project_resting(cs: ContactState, problem: Problem, t: float, q: np.ndarray, v: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`project` onto the closed contacts of ``problem``, the kinetic energy the
    velocity projection removes (a contact brought to rest: the end of its Zeno sequence;
    ≥ 0, a projection in the kinetic metric) booked as impact loss."""
    q1, v1 = project(problem, t, q, v)
    if problem.m:
        M = problem.mass(q1)
        cs.d_impacts += max(0.5 * float(v @ M @ v - v1 @ M @ v1), 0.0)
    return q1, v1


def _law(M: np.ndarray, GN: np.ndarray, GT: np.ndarray, mu: np.ndarray, v: np.ndarray, e: float,
         held: np.ndarray, t: float, i: int, lzb: Callable | None = None):
    """Newton's law (with Coulomb friction where μ > 0) for the contacts GN, as one LCP
    (:func:`daebench.core.frictional_impact.frictional_impact`; impact of contact i at t), or
    the LZB law ``lzb`` of these contacts (:func:`daebench.core.lzb.lzb_law`).
    Its failure ends the run, named."""
    res = frictional_impact(M, GN, GT, mu, v, e, held) if lzb is None else lzb(M, GN, v, e=e, B=held)
    if not res.ok:
        why = failure_message(res.status) if lzb is None else lzb_failure(res.status, res.step_count,
                                                                           float(np.min(e)))
        raise StepFailure(f"{why} (impact of contact {i})", t)
    return res


def settle(cs: ContactState, t: float, q: np.ndarray, v: np.ndarray) -> bool:
    """Decide which contacts are closed at (t, q, v) by the acceleration-level contact law
    (:func:`daebench.core.resting_contacts.resting_lcp`): the closed contacts and the open
    ones at rest on their surface (|g| ≤ GAP_BAND, |ġ| ≤ REBOUND_MIN) are the candidates;
    those with a positive force close (or stay closed), the others open. Returns whether
    the closed set changed. An open contact on its surface that leaves it so slowly that it
    would be back within the step in force is a candidate too (:func:`_lifted_briefly`: an
    index-3 step's drift opened it; a rebound of this instant is the impact law's and the Zeno
    rule's, :func:`_unresolvable_rebounds`). Frictionless contacts only: with friction the stick/slip
    phases decide (:mod:`daebench.driver.stickslip`)."""
    base = cs.base
    nc = base.n_contacts
    if not (cs.constraint and nc):
        return False
    g, G, gam = base.gap_rows(q, v)
    vn = G @ v
    touching = [c for c in range(nc) if c not in cs.active and abs(g[c]) <= GAP_BAND]
    drifting = [c for c in touching if vn[c] > REBOUND_MIN and cs.last_impact_t[c] != t]  # not a rebound
    cand = sorted(set(cs.active) | {c for c in touching if abs(vn[c]) <= REBOUND_MIN}
                  | set(_lifted_briefly(base, t, q, v, cs.active, drifting, cs.step)))
    if not cand:
        return False
    a_free, _ = base.acceleration(t, q, v)
    B = base.constraint_jacobian(t, q)[:base.n_bilateral]
    sol = resting_lcp(base.mass(q), B, G[cand], a_free, gam[cand], cs.force_release_t[cand] == t)
    if not sol.ok:
        raise StepFailure(f"{resting_failure(sol.status)} (contacts {cand})", t)
    closed = [c for c, shut in zip(cand, sol.closed) if shut]
    if sorted(closed) == sorted(cs.active):
        return False
    cs.release([c for c in cs.active if c not in closed], t)
    cs.close([c for c in closed if c not in cs.active], t)
    return True


def lift(cs: ContactState, system: MechanicalSystem, t: float, q: np.ndarray, contacts: list[int]) -> np.ndarray:
    """Positions moved (mass-weighted, the bilateral constraints and the closed contacts
    kept) so that the open ``contacts``, found below their surface while they separate,
    touch it: the integrator's position drift removed, the velocities untouched."""
    return project_positions(Problem(system, tuple(cs.active) + tuple(contacts)), t, q)


def impact_law_name(cs: ContactState) -> str:
    """The impact law of the run record: e.g. ``newton-coulomb (Pfeiffer–Glocker LCP), simultaneous``."""
    if not cs.constraint:
        return ""
    return LZB_NAME if cs.impact_law == "lzb" else f"{law_name(cs.mu)}, {cs.impact_law}"


def project(problem: Problem, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mass-weighted projection of (q, v) onto C(t, q) = 0 and C_q v + C_t = 0 of the
    problem's active constraints (no-op when none are active)."""
    if problem.m == 0:
        return q, v
    M = problem.mass(q)
    q = project_positions(problem, t, q, M)
    Cq = problem.constraint_jacobian(t, q)
    MiCt = solve_structured(M, Cq.T)
    v = v - MiCt @ np.linalg.solve(Cq @ MiCt, Cq @ v + problem.constraint_t(t, q))
    return q, v


def project_positions(problem: Problem, t: float, q: np.ndarray, M: np.ndarray | None = None) -> np.ndarray:
    """Mass-weighted projection of q onto C(t, q) = 0 of the problem's active constraints
    (:data:`PROJECTION_ITERS` Newton iterations; ``M``: the mass matrix to weigh with, M(q)
    by default)."""
    if problem.m == 0:
        return q
    M = problem.mass(q) if M is None else M
    q = q.copy()
    for _ in range(PROJECTION_ITERS):
        C = problem.constraint(t, q)
        if np.max(np.abs(C)) < 1e-15:
            break
        Cq = problem.constraint_jacobian(t, q)
        MiCt = solve_structured(M, Cq.T)
        q -= MiCt @ np.linalg.solve(Cq @ MiCt, C)
    return q
