"""What an event of the event-driven driver (:mod:`daebench.driver.simulate`; located by
:mod:`daebench.driver.events`) does to the state: the impact law of the
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

The impact law (scene key ``contact.impact_law``; an object of
:mod:`daebench.driver.impact_laws`, named in the run record by :func:`impact_law_name`):
where several contacts close at the same instant — the impacting one, the open contacts at
g = 0 that do not separate, the closed ones — ``simultaneous`` (the default) applies Newton's
law to all of them at once, one LCP; ``sequential`` to the impacting contact alone, the
closed contacts held, the next contact's impact following as its own event (a Newton's
cradle of three balls leaves at (−1/3, 2/3, 2/3) v under the first and at (0, 0, 1) v under
the second); ``lzb`` takes the simultaneous law's contacts through the Liu–Zhao–Brogliato
impact process.

The functions here take the driver's :class:`daebench.driver.contact_state.ContactState`
and the phase's :class:`daebench.core.problem.Problem`.
"""

from __future__ import annotations

import math

import numpy as np

from daebench.core.contact import Impact
from daebench.core.linalg import solve_structured
from daebench.core.problem import Problem
from daebench.core.resting_contacts import failure_message as resting_failure, resting_lcp
from daebench.core.system import MechanicalSystem, State
from daebench.driver.contact_state import (PROJECTION_ITERS, REBOUND_MIN, REIMPACT_MIN_DT, ZENO_FLIGHT,
                                           ContactState, Event, EventKind)
from daebench.driver.events import consistent_multipliers
from daebench.driver.stickslip import SLIP_MIN, slip_velocity, tangent_row
from daebench.integrators.base import StepFailure
from daebench.stepping.watch import GAP_BAND, GAP_ROUNDOFF


def apply_event(cs: ContactState, event: Event, state: State, problem: Problem, contact_work: float) -> State:
    """Apply ``event`` to the contacts and to the state (on the dense output at the event
    time) of the phase ``problem`` that it ends; ``contact_work``: the continuous laws'
    work booked so far. Which contacts then stay closed is decided at the start of the
    next phase (:func:`settle`). Each kind of event has its transition (:data:`TRANSITIONS`)."""
    t, kind, i = event
    # the event state comes from the dense output: put it back on the constraints of
    # the phase it ends (closed contacts: g = 0, ġ = 0) before switching
    q, v = project(problem, t, state.q, state.v)
    if kind is not EventKind.REFINE:
        cs.memory.halvings = 0  # any other event: the step the phase calls for again
    q, v = TRANSITIONS[kind](cs, problem, t, i, q, v, contact_work)
    return State(t, q, v)


def _close(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray,
           contact_work: float) -> tuple[np.ndarray, np.ndarray]:
    """A contact closes: an impact under the constraint law, the first touch of a
    continuous-law episode otherwise."""
    if not cs.constraint:
        vn = float(problem.gap_jacobian(q)[i] @ v)
        cs.memory.approach_speed[i] = max(-vn, 1e-12)
        cs.penetrating.add(i)
        cs.memory.episode_start_W[i] = contact_work
        cs.impacts.append(Impact(t, i, vn, math.nan, math.nan))
        return q, v
    system = cs.base.system
    v, lifted = _impact(cs, problem, t, i, q, v)
    if lifted:  # open contacts found below their surface: a position drift, not an impact
        q = lift(cs, system, t, q, lifted)
    if cs.active:
        # the impact was located on g = 0 (or −GAP_BAND): start the closed phase on it
        q, v = project_resting(cs, cs.phase(system), t, q, v)
    cs.armed[i] = False
    return q, v


def _stop(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray,
          contact_work: float) -> tuple[np.ndarray, np.ndarray]:
    """A slipping contact comes to rest: it and every other slipping one at rest with it stick."""
    system = cs.base.system
    md = cs.base.kernel.model
    stopped = {c: s for c, s in cs.friction.slip.items() if c == i or abs(slip_velocity(md, c, q, v)) < SLIP_MIN}
    for c in stopped:
        del cs.friction.slip[c]
        cs.friction.stick[c] = q.copy()
    cs.regroup(t, q)
    try:
        phase = cs.phase(system)
        q1, v1 = project(phase, t, q, v)
        phase.acceleration(t, q1, v1)
        return q1, v1
    except np.linalg.LinAlgError:
        # sticking would lock the system (the stick rows singular there, e.g. a slider at
        # its crank's dead centre): the slip velocity passes through zero, the slip reverses
        for c, s in stopped.items():
            del cs.friction.stick[c]
            cs.friction.slip[c] = -s
        cs.regroup(t, q)
        return q, v


def _slide(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray,
           contact_work: float) -> tuple[np.ndarray, np.ndarray]:
    """A sticking group leaves its friction cone: it slips along its tangential force."""
    lam_t = cs.cone_margins(problem, consistent_multipliers(problem, State(t, q, v)))[i][1]
    for c in cs.friction.groups[i]:
        del cs.friction.stick[c]
        cs.friction.slip[c] = math.copysign(1.0, lam_t)
    cs.regroup(t, q)
    return q, v


def _open(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray,
          contact_work: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed contact's force crosses zero: it opens there."""
    cs.release([i], t, q)
    cs.memory.force_release_t[i] = t
    return q, v


def _refine(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray,
            contact_work: float) -> tuple[np.ndarray, np.ndarray]:
    """An approach the step did not resolve: the phase restarts here at half that step."""
    cs.memory.halvings += 1
    return q, v


def _near_or_far(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray,
                 contact_work: float) -> tuple[np.ndarray, np.ndarray]:
    """An open contact comes near its surface or leaves it: the phase restarts here at the
    contact step or the free one."""
    cs.near.symmetric_difference_update({i})
    return q, v


def _separate(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray,
              contact_work: float) -> tuple[np.ndarray, np.ndarray]:
    """A continuous-law contact stops penetrating: its episode ends, booked as one impact."""
    cs.penetrating.discard(i)
    cs.armed[i] = False  # a release like any other: re-closing goes by the band rule
    vn = float(problem.gap_jacobian(q)[i] @ v)
    for imp in reversed(cs.impacts):
        if imp.contact == i and math.isnan(imp.vn_plus):
            imp.vn_plus = vn
            imp.energy_loss = cs.memory.episode_start_W.pop(i, math.nan) - contact_work
            imp.t_end = t
            break
    return q, v


#: the transition of each kind of event
TRANSITIONS = {EventKind.CLOSE: _close, EventKind.STOP: _stop, EventKind.SLIDE: _slide, EventKind.OPEN: _open,
               EventKind.REFINE: _refine, EventKind.NEAR: _near_or_far, EventKind.FAR: _near_or_far,
               EventKind.SEPARATE: _separate}


def _impact(cs: ContactState, problem: Problem, t: float, i: int, q: np.ndarray, v: np.ndarray
            ) -> tuple[np.ndarray, list[int]]:
    """Newton's law at the closing of contact i at (t, q, v⁻), with the law's restitution and
    the phase's bilateral constraints kept (module docstring). Books the impacts (contacts
    that receive an impulse), closes the contacts left at rest (ġ⁺ below REBOUND_MIN: the
    acceleration-level law decides at the next phase start whether they stay closed) and
    opens the closed ones that separate. Returns v⁺ and the open contacts of the event that
    lie below their surface by more than the band allows (to be lifted onto it)."""
    base = cs.base if cs.base is not None else problem
    M = base.mass_operator(q)
    g, Gq, _ = base.gap_rows(q)
    B = base.constraint_jacobian(t, q)[:base.n_bilateral]
    e = problem.contact_law.restitution
    # a re-impact within REIMPACT_MIN_DT (Zeno chatter) closes plastically
    zeno = t - cs.memory.last_impact_t[i] < REIMPACT_MIN_DT
    md = base.kernel.model
    T = np.array([tangent_row(md, c, q) for c in range(len(g))]) if cs.friction.mu.any() else np.zeros_like(Gq)
    law = cs.rules.impact_law
    part, held = law.participants(i, g, Gq, v, cs.active, cs.penetrating, cs.continuous, B)
    mu = cs.friction.mu[part] if cs.friction.mu.size else np.zeros(len(part))
    e_c = np.full(len(part), 0.0 if zeno else e)
    res = law.solve(base.system, part, M, Gq[part], T[part], mu, v, e_c, held, t, i)
    if e_c.any() and law.zeno_rules:
        # a rebound too slow, or whose Zeno accumulation of ever shorter bounces (2ġ⁺/((1 − e)|g̈|)
        # long in all) ends within the step in force, is plastic: taken as instantaneous
        short = _unresolvable_rebounds(base, t, q, part, res, e, cs.rules.step)
        if short.any():
            e_c[short] = 0.0
            res = law.solve(base.system, part, M, Gq[part], T[part], mu, v, e_c, held, t, i)
    resting = [c for r, c in enumerate(part) if res.vn_plus[r] < REBOUND_MIN]
    if law.zeno_rules:   # contacts of the event that the impact lifts off only briefly rest with the others
        resting += _lifted_briefly(base, t, q, res.v_plus, resting,
                                   [c for r, c in enumerate(part) if c not in resting and res.impulse_n[r] <= 0.0
                                    and g[c] <= GAP_BAND], cs.rules.step)
    cs.release([c for c in part if c in cs.active and c not in resting], t)
    cs.d_impacts += res.energy_loss
    loss = res.energy_loss  # booked on the first contact that takes an impulse (the impacting one if it does)
    for r in sorted(range(len(part)), key=lambda r: part[r] != i):
        c = part[r]
        if res.impulse_n[r] > 0.0:
            cs.memory.last_impact_t[c] = t
            cs.impacts.append(Impact(t, c, float(res.vn_minus[r]), float(res.vn_plus[r]), loss,
                                     c in resting, float(res.impulse_n[r]),
                                     restitution=law.restitution(float(e_c[r])), law=law.record,
                                     q=q.copy(), v_minus=v.copy(), v_plus=res.v_plus.copy()))
            loss = 0.0
    cs.close([c for c in resting if c not in cs.active], t)
    if cs.friction.mu.any():
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
        M = problem.mass_operator(q1)
        cs.d_impacts += max(0.5 * float(v @ M @ v - v1 @ M @ v1), 0.0)
    return q1, v1


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
    drifting = [c for c in touching if vn[c] > REBOUND_MIN and cs.memory.last_impact_t[c] != t]  # not a rebound
    cand = sorted(set(cs.active) | {c for c in touching if abs(vn[c]) <= REBOUND_MIN}
                  | set(_lifted_briefly(base, t, q, v, cs.active, drifting, cs.rules.step)))
    if not cand:
        return False
    a_free, _ = base.acceleration(t, q, v)
    B = base.constraint_jacobian(t, q)[:base.n_bilateral]
    sol = resting_lcp(base.mass_operator(q), B, G[cand], a_free, gam[cand], cs.memory.force_release_t[cand] == t)
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
    return cs.rules.impact_law.name(cs.friction.mu)


def project(problem: Problem, t: float, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mass-weighted projection of (q, v) onto C(t, q) = 0 and C_q v + C_t = 0 of the
    problem's active constraints (no-op when none are active)."""
    if problem.m == 0:
        return q, v
    M = problem.mass_operator(q)
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
    M = problem.mass_operator(q) if M is None else M
    q = q.copy()
    for _ in range(PROJECTION_ITERS):
        C = problem.constraint(t, q)
        if np.max(np.abs(C)) < 1e-15:
            break
        Cq = problem.constraint_jacobian(t, q)
        MiCt = solve_structured(M, Cq.T)
        q -= MiCt @ np.linalg.solve(Cq @ MiCt, C)
    return q
