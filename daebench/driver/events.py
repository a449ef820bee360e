"""Where in a step an event of the event-driven driver (:mod:`daebench.driver.simulate`)
falls: a gap closes, a contact force turns tensile, a penetrating contact separates, a
slipping contact stops or a sticking one's force leaves the friction cone — located on the
integrator's dense output by Brent's method (to :data:`daebench.driver.contact_state.EVENT_TOL`).
What each event does to the state is :mod:`daebench.driver.transitions`.

A closed contact opens when its *consistent* force (the phase's acceleration-level
multiplier at the step's (t, q, v), :func:`contact_forces`) turns tensile. The multiplier
an index-3 step returns is not used: at small h it is dominated by the step's position
correction (∝ C/(βh²)) and changes sign from step to step.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.optimize import brentq

from daebench.core import phase as _phase
from daebench.core.problem import Problem
from daebench.core.system import State
from daebench.driver.contact_state import (EVENT_TOL, FLIGHT_SAMPLES, MAX_HALVINGS, REBOUND_MIN, ContactState,
                                           Event, EventKind, is_near)
from daebench.driver.stickslip import slip_velocity
from daebench.integrators.base import StepFailure
from daebench.stepping.watch import GAP_BAND, GAP_ROUNDOFF, gap_event


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
                    cands.append(Event(_root(lambda t: problem.gap(dense(t).q)[i], prev, new), EventKind.SEPARATE, i))
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
                    if cs.memory.halvings < MAX_HALVINGS:
                        cands.append(Event(prev.t, EventKind.REFINE, i))
                        continue
                    tc = new.t  # unresolved at the finest step: the closing is the step's end
                cands.append(Event(tc, EventKind.CLOSE, i))
            elif closes:
                # the step started already (numerically) closed — e.g. a grazing re-contact
                # right after a separation: contact at its start
                cands.append(Event(prev.t, EventKind.CLOSE, i))
            elif arms:
                cs.armed[i] = True
        if cs.rules.near_h > 0.0 and not cands:
            # proximity changes, at the step's end (only where no event came first)
            rows = problem.gap_rows(new.q, new.v)
            for i in range(problem.n_contacts):
                if i not in cs.active and i not in cs.penetrating and \
                        is_near(problem, new.q, new.v, new.a, i, cs.rules.near_h, rows) != (i in cs.near):
                    cands.append(Event(new.t, EventKind.FAR if i in cs.near else EventKind.NEAR, i))
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
                cands.append(Event(at, EventKind.OPEN, c))
        cands += _friction_events(cs, prev, new, problem, dense, lam0, lam1)
    # a contact's status changes once an instant: an event that would undo at the phase's start
    # what was decided there (the state is degenerate: force and gap acceleration both zero)
    # waits one step, so that every such cycle advances time
    cands = [c for c in cands if not (c.t <= prev.t and cs.memory.changed_t[c.contact] == prev.t
                                      and c.kind in (EventKind.CLOSE, EventKind.OPEN))]
    return min(cands, key=lambda c: c.t) if cands else None


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
    for c, s in cs.friction.slip.items():
        def ut(t: float, c: int = c, s: float = s) -> float:
            st = dense(t)
            return s * slip_velocity(md, c, st.q, st.v)
        u0, u1 = s * slip_velocity(md, c, prev.q, prev.v), s * slip_velocity(md, c, new.q, new.v)
        if u1 < 0.0:
            out.append(Event(_root(ut, prev, new) if u0 > 0.0 else prev.t, EventKind.STOP, c))
    if cs.friction.groups:
        m0, m1 = cs.cone_margins(problem, lam0), cs.cone_margins(problem, lam1)
        for c in cs.friction.groups:
            if m1[c][0] < 0.0:
                f = (lambda t, c=c: cs.cone_margins(problem, consistent_multipliers(problem, dense(t)))[c][0])
                out.append(Event(_root(f, prev, new) if m0[c][0] >= 0.0 else prev.t, EventKind.SLIDE, c))
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
