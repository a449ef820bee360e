"""Events of the event-driven driver (:mod:`daebench.driver.simulate`): where in a step a gap
closes, a contact force turns tensile or a penetrating contact separates — located on the
integrator's dense output by Brent's method — and what each does to the state: the Newton
impact map with restitution for the ``constraint`` law (closing the contact when the
rebound is too slow to resolve), the start and end of a continuous-law episode, and the
projection back onto the constraints of the phase that ends.

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

from daebench.core.contact import Impact, impact_map
from daebench.core.problem import Problem
from daebench.core.system import MechanicalSystem, State
from daebench.stepping.watch import GAP_BAND, gap_event

EVENT_TOL = 1e-13        # event times located to this (seconds)
REBOUND_MIN = 1e-9       # a rebound slower than this (m/s) is treated as plastic (ends Zeno chatter)
REIMPACT_MIN_DT = 1e-10  # a second impact of a contact within this time closes it (Zeno)
PROJECTION_ITERS = 3     # Newton iterations of the position projection onto C(q) = 0


class Event(NamedTuple):
    """An event located in a step: its time, its kind (close | open | separate) and contact."""

    t: float
    kind: str
    contact: int


@dataclass
class ContactState:
    """The driver's contacts: which are closed or penetrating, and their episodes.

    ``constraint`` / ``continuous``: the driver closes contacts as constraints (the
    ``constraint`` law) / books continuous-law episodes; neither when the integrator
    resolves the contacts itself. ``hold``: contacts re-closed within the first step after
    their release (the free motion went back into the plane faster than the step
    resolves — unresolved chatter); they stay closed for one full step before the sign of
    λ is read again, so every such cycle advances time by at least one step (a documented
    regularization)."""

    constraint: bool
    continuous: bool
    armed: np.ndarray                       # bool per contact: closing detected at g = 0 (else −GAP_BAND)
    last_impact_t: np.ndarray               # per contact
    last_release_t: np.ndarray              # per contact
    approach_speed: np.ndarray              # v₀ of each continuous-law episode
    active: list[int] = field(default_factory=list)        # closed (constraint law), in row order
    penetrating: set[int] = field(default_factory=set)     # continuous law: g < 0
    hold: set[int] = field(default_factory=set)
    episode_start_W: dict[int, float] = field(default_factory=dict)  # contact work at first touch
    impacts: list[Impact] = field(default_factory=list)
    d_impacts: float = 0.0                  # kinetic energy removed by impact maps
    gap_cache: tuple | None = None          # (q, t, g(q)) of the last step's new state

    @classmethod
    def start(cls, problem: Problem, q: np.ndarray, constraint: bool, continuous: bool) -> "ContactState":
        """The contacts at t = 0 (continuous law: those already penetrating are engaged)."""
        nc = problem.n_contacts
        g = problem.gap(q) if nc else np.zeros(0)
        cs = cls(constraint, continuous, g > GAP_BAND if nc else np.zeros(0, bool),
                 np.full(max(nc, 1), -np.inf), np.full(max(nc, 1), -np.inf), np.full(nc, np.nan))
        if continuous:
            cs.penetrating = {int(i) for i in np.flatnonzero(g < 0.0)}
        return cs

    @property
    def watched(self) -> bool:
        """Whether the driver watches the contacts (it does not when the integrator resolves them)."""
        return self.constraint or self.continuous

    @property
    def in_contact(self) -> bool:
        return bool(self.active) or bool(self.penetrating)

    def release(self, contacts: list[int], t: float) -> None:
        """Open closed contacts at t (a closed contact that would pull)."""
        self.active = [c for c in self.active if c not in contacts]
        self.armed[contacts] = False
        self.last_release_t[contacts] = t

    def phase(self, system: MechanicalSystem) -> Problem:
        """The phase these contacts define: closed contacts, engaged continuous contacts, χ."""
        nc = system.n_contacts
        engaged = np.zeros(nc)
        chi = np.zeros(nc)
        if self.continuous:
            engaged[list(self.penetrating)] = 1.0
            chi = system.contact_law.chi(self.approach_speed)
        return Problem(system, tuple(self.active), engaged, chi)


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
            if closes and g0[i] >= -off:
                # the band decides whether the contact closed; where is g = 0 when the
                # step started on or above the plane
                at = 0.0 if g0[i] >= 0.0 else off
                cands.append(Event(_root(lambda t: problem.gap(dense(t).q)[i] + at, prev, new), "close", i))
            elif closes:
                # the step started already (numerically) closed — e.g. a grazing re-contact
                # right after a separation: contact at its start
                cands.append(Event(prev.t, "close", i))
            elif arms:
                cs.armed[i] = True
    if cs.constraint and cs.active:
        k = problem.n_bilateral
        for j, c in enumerate(cs.active):
            if new.lam[k + j] < 0.0 <= prev.lam[k + j]:
                cands.append(Event(_root(lambda t: dense(t).lam[k + j], prev, new), "open", c))
            elif new.lam[k + j] < 0.0 and c in cs.hold:
                cands.append(Event(new.t, "open", c))  # still tensile after the held step
        cs.hold.clear()
    return min(cands, key=lambda c: c.t) if cands else None


def _root(f: Callable[[float], float], prev: State, new: State) -> float:
    fa, fb = f(prev.t), f(new.t)
    if fa == 0.0:
        return prev.t
    if np.sign(fa) == np.sign(fb):
        # the dense output disagrees with the step endpoints in sign: take the step end
        return new.t
    return brentq(f, prev.t, new.t, xtol=EVENT_TOL, rtol=4 * np.finfo(float).eps)


def apply_event(cs: ContactState, event: Event, state: State, problem: Problem, contact_work: float,
                h: float) -> State:
    """Apply ``event`` to the contacts and to the state (on the dense output at the event
    time) of the phase ``problem`` that it ends; ``contact_work``: the continuous laws'
    work booked so far, ``h``: the phase's step size (the hold rule)."""
    t, kind, i = event
    # the event state comes from the dense output: put it back on the constraints of
    # the phase it ends (closed contacts: g = 0, ġ = 0) before switching
    q, v = project(problem, t, state.q, state.v)
    if kind == "close" and cs.constraint:
        v = _impact(cs, problem, t, i, q, v)
        if i in cs.active:
            if t - cs.last_release_t[i] <= h:
                cs.hold.add(i)
            # the impact was located on g = 0 (or −GAP_BAND): start the closed phase on it
            q, v = project(cs.phase(problem.system), t, q, v)
        cs.armed[i] = False
    elif kind == "open":
        cs.active.remove(i)
        cs.armed[i] = False
        cs.last_release_t[i] = t
        for imp in reversed(cs.impacts):  # the closed episode of contact i ends here
            if imp.contact == i:
                if imp.closed and math.isnan(imp.t_end):
                    imp.t_end = t
                break
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


def _impact(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The Newton impact map of contact i at (t, q, v⁻) with the law's restitution, the
    phase's bilateral constraints and closed contacts kept; books the impact, closes the
    contact when the rebound is too slow to resolve; returns v⁺."""
    M = problem.mass(q)
    Gq = problem.gap_jacobian(q)
    bil = np.vstack([problem.constraint_jacobian(t, q)[:problem.n_bilateral]] + [Gq[[c]] for c in cs.active])
    e = problem.contact_law.restitution
    # a re-impact within REIMPACT_MIN_DT (Zeno chatter) or a contact found already
    # penetrating with a separating velocity closes plastically
    zeno = t - cs.last_impact_t[i] < REIMPACT_MIN_DT or float(Gq[i] @ v) >= 0.0
    res = impact_map(M, Gq[[i]], v, 0.0 if zeno else e, bil)
    closed = zeno or e == 0.0 or res.vn_plus[0] < REBOUND_MIN
    if closed and not (zeno or e == 0.0):
        res = impact_map(M, Gq[[i]], v, 0.0, bil)
    cs.last_impact_t[i] = t
    cs.d_impacts += res.energy_loss
    cs.impacts.append(Impact(t, i, float(res.vn_minus[0]), float(res.vn_plus[0]), res.energy_loss, closed,
                             float(res.impulse[0]), q=q.copy(), v_minus=v.copy(), v_plus=res.v_plus.copy()))
    if closed:
        cs.active.append(i)
    return res.v_plus


def project(problem: Problem, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mass-weighted projection of (q, v) onto C(t, q) = 0 and C_q v + C_t = 0 of the
    problem's active constraints (no-op when none are active)."""
    if problem.m == 0:
        return q, v
    M = problem.mass(q)
    q = q.copy()
    for _ in range(PROJECTION_ITERS):
        C = problem.constraint(t, q)
        if np.max(np.abs(C)) < 1e-15:
            break
        Cq = problem.constraint_jacobian(t, q)
        MiCt = np.linalg.solve(M, Cq.T)
        q -= MiCt @ np.linalg.solve(Cq @ MiCt, C)
    Cq = problem.constraint_jacobian(t, q)
    MiCt = np.linalg.solve(M, Cq.T)
    v = v - MiCt @ np.linalg.solve(Cq @ MiCt, Cq @ v + problem.constraint_t(t, q))
    return q, v
