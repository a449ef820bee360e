"""Events of the event-driven driver (:mod:`daebench.driver.simulate`): where in a step a gap
closes, a contact force turns tensile, a penetrating contact separates, a slipping contact
stops or a sticking one's force leaves the friction cone — located on the integrator's
dense output by Brent's method — and what each does to the state: the impact law of the
``constraint`` law (closing the contact when the rebound is too slow to resolve), the
start and end of a continuous-law episode, the switch between stick and slip
(:mod:`daebench.driver.stickslip`), and the projection back onto the constraints of the
phase that ends.

The impact law (scene key ``contact.impact_law``, named in the run record by
:func:`impact_law_name`): where several contacts close at the same instant — the
impacting one, the open contacts at g = 0 that do not separate, the closed ones — the
``simultaneous`` law (the default) applies Newton's law to all of them at once, one LCP
(:func:`daebench.core.frictional_impact.frictional_impact`, with planar Coulomb friction
in the manner of Pfeiffer & Glocker where μ > 0); the ``sequential`` law applies it to
the impacting contact alone, the closed contacts held, and the next contact's impact
follows as its own event. A Newton's cradle of three balls leaves at (−1/3, 2/3, 2/3) v
under the first and at (0, 0, 1) v under the second.

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
from daebench.core.frictional_impact import failure_message, frictional_impact, law_name
from daebench.core.kernels import friction_coefficients
from daebench.core.linalg import solve_structured
from daebench.core.problem import Problem
from daebench.core.system import MechanicalSystem, State
from daebench.driver.stickslip import (CONE_TOL, PAINLEVE_SLIP, SLIP_MIN, FrictionPhase, stick_groups,
                                       tangent_row)
from daebench.integrators.base import StepFailure
from daebench.stepping.watch import GAP_BAND, gap_event

EVENT_TOL = 1e-13        # event times located to this (seconds)
REBOUND_MIN = 1e-9       # a rebound slower than this (m/s) is treated as plastic (ends Zeno chatter)
REIMPACT_MIN_DT = 1e-10  # a second impact of a contact within this time closes it (Zeno)
PROJECTION_ITERS = 3     # Newton iterations of the position projection onto C(q) = 0


class Event(NamedTuple):
    """An event located in a step: its time, its kind (close | open | separate | stop | slide)
    and contact."""

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
                ut = float(tangent_row(md, c, q) @ v)
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
            out[c] = (mu * lam_n * (1.0 + CONE_TOL) + 1e-12 * abs(lam_t) - abs(lam_t), lam_t)
        return out

    @property
    def watched(self) -> bool:
        """Whether the driver watches the contacts (it does not when the integrator resolves them)."""
        return self.constraint or self.continuous

    @property
    def in_contact(self) -> bool:
        return bool(self.active) or bool(self.penetrating)

    def release(self, contacts: list[int], t: float, q: np.ndarray | None = None) -> None:
        """Open closed contacts at t (a closed contact that would pull)."""
        self.active = [c for c in self.active if c not in contacts]
        self.armed[contacts] = False
        self.last_release_t[contacts] = t
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
        if self.groups or self.slip:
            system = FrictionPhase(system, tuple(self.active), {c: self.stick[c] for c in self.groups},
                                   self.slip, self.mu)
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
        cands += _friction_events(cs, prev, new, problem, dense)
    return min(cands, key=lambda c: c.t) if cands else None


def _friction_events(cs: ContactState, prev: State, new: State, problem: Problem,
                     dense: Callable[[float], State]) -> list[Event]:
    """A slipping contact's slip velocity through zero (stop); a stick group's force
    leaving the cone (slide)."""
    out = []
    md = cs.base.kernel.model
    for c, s in cs.slip.items():
        def ut(t: float, c: int = c, s: float = s) -> float:
            st = dense(t)
            return s * float(tangent_row(md, c, st.q) @ st.v)
        u0, u1 = s * float(tangent_row(md, c, prev.q) @ prev.v), s * float(tangent_row(md, c, new.q) @ new.v)
        if u1 < 0.0:
            out.append(Event(_root(ut, prev, new) if u0 > 0.0 else prev.t, "stop", c))
    if cs.groups and new.lam.size == problem.m:
        m0, m1 = cs.cone_margins(problem, prev.lam), cs.cone_margins(problem, new.lam)
        for c in cs.groups:
            if m1[c][0] < 0.0:
                f = (lambda t, c=c: cs.cone_margins(problem, dense(t).lam)[c][0])
                out.append(Event(_root(f, prev, new) if m0[c][0] >= 0.0 else prev.t, "slide", c))
    return out


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
    system = cs.base.system if cs.base is not None else problem.system
    if kind == "close" and cs.constraint:
        v = _impact(cs, problem, t, i, q, v)
        if i in cs.active and t - cs.last_release_t[i] <= h:
            cs.hold.add(i)
        if cs.active:
            # the impact was located on g = 0 (or −GAP_BAND): start the closed phase on it
            q, v = project(cs.phase(system), t, q, v)
        cs.armed[i] = False
    elif kind == "stop":
        # the contact and every other slipping one at rest with it stick here
        md = cs.base.kernel.model
        stopped = {c: s for c, s in cs.slip.items() if c == i or abs(float(tangent_row(md, c, q) @ v)) < SLIP_MIN}
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
        lam_t = cs.cone_margins(problem, state.lam)[i][1]
        for c in cs.groups[i]:
            del cs.stick[c]
            cs.slip[c] = math.copysign(1.0, lam_t)
        cs.regroup(t, q)
    elif kind == "open":
        cs.active.remove(i)
        cs.armed[i] = False
        cs.last_release_t[i] = t
        if cs.stick or cs.slip:
            cs.regroup(t, q)
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
    """The impact law at contact i at (t, q, v⁻) with the law's restitution and the phase's
    bilateral constraints kept (module docstring); books the impacts, closes the contacts
    whose rebound is too slow to resolve and opens the closed ones that separate; returns v⁺."""
    base = cs.base if cs.base is not None else problem
    M = base.mass(q)
    g, Gq, _ = base.gap_rows(q)
    B = base.constraint_jacobian(t, q)[:base.n_bilateral]
    e = problem.contact_law.restitution
    # a re-impact within REIMPACT_MIN_DT (Zeno chatter) or a contact found already
    # penetrating with a separating velocity closes plastically (the contact's own map)
    zeno = t - cs.last_impact_t[i] < REIMPACT_MIN_DT or float(Gq[i] @ v) >= 0.0
    md = base.kernel.model
    T = np.array([tangent_row(md, c, q) for c in range(len(g))]) if cs.mu.any() else np.zeros_like(Gq)
    if cs.impact_law == "simultaneous" and not zeno:
        part = sorted({i, *cs.active} | {c for c in range(len(g)) if g[c] <= GAP_BAND and Gq[c] @ v <= 0.0
                                          and not (cs.continuous and c in cs.penetrating)})
        held = B
    else:
        part = [i]
        held = np.vstack([B] + [Gq[[c]] for c in cs.active])
    mu = cs.mu[part] if cs.mu.size else np.zeros(len(part))
    res = _law(M, Gq[part], T[part], mu, v, 0.0 if zeno else e, held, t, i)
    k = part.index(i)
    closed = zeno or e == 0.0 or res.vn_plus[k] < REBOUND_MIN
    if closed and not (zeno or e == 0.0):
        res = _law(M, Gq[part], T[part], mu, v, 0.0, held, t, i)
    cs.d_impacts += res.energy_loss
    opened = []
    for r, c in enumerate(part):
        shut = closed if c == i else (res.vn_plus[r] < REBOUND_MIN)
        if c == i or res.impulse_n[r] > 0.0:
            cs.last_impact_t[c] = t
            cs.impacts.append(Impact(t, c, float(res.vn_minus[r]), float(res.vn_plus[r]),
                                     res.energy_loss if c == i else 0.0, shut, float(res.impulse_n[r]),
                                     q=q.copy(), v_minus=v.copy(), v_plus=res.v_plus.copy()))
        if shut and c not in cs.active:
            cs.active.append(c)
        elif not shut and c in cs.active:
            opened.append(c)
    if opened:
        cs.release(opened, t)
    if cs.mu.any():
        cs.set_friction_state(part, t, q, res.v_plus)
    return res.v_plus


def _law(M: np.ndarray, GN: np.ndarray, GT: np.ndarray, mu: np.ndarray, v: np.ndarray, e: float,
         held: np.ndarray, t: float, i: int):
    """The impact of the contacts GN (impact of contact i at t): one frictionless contact —
    the equality map of core.contact.impact_map (also a Zeno closing, whatever the
    velocity; the driver's map before the LCP, kept bit for bit); else the LCP of
    core.frictional_impact. Its failure ends the run, named."""
    if GN.shape[0] == 1 and not mu.any():
        r = impact_map(M, GN, v, e, held)
        return _Res(r.v_plus, r.impulse, np.zeros_like(r.impulse), r.vn_minus, r.vn_plus, r.energy_loss)
    res = frictional_impact(M, GN, GT, mu, v, e, held)
    if not res.ok:
        raise StepFailure(f"{failure_message(res.status)} (impact of contact {i})", t)
    return res


@dataclass
class _Res:
    v_plus: np.ndarray
    impulse_n: np.ndarray
    impulse_t: np.ndarray
    vn_minus: np.ndarray
    vn_plus: np.ndarray
    energy_loss: float
    ok: bool = True


def impact_law_name(cs: ContactState) -> str:
    """The impact law of the run record: e.g. ``newton-coulomb (Pfeiffer–Glocker LCP), simultaneous``."""
    return f"{law_name(cs.mu)}, {cs.impact_law}" if cs.constraint else ""


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
        MiCt = solve_structured(M, Cq.T)
        q -= MiCt @ np.linalg.solve(Cq @ MiCt, C)
    Cq = problem.constraint_jacobian(t, q)
    MiCt = solve_structured(M, Cq.T)
    v = v - MiCt @ np.linalg.solve(Cq @ MiCt, Cq @ v + problem.constraint_t(t, q))
    return q, v
