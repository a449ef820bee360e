"""Which step the event-driven driver must see — the one rule, for every integrator.

The driver (:mod:`daebench.driver.simulate`) watches, after every accepted step, for a contact
closing, a closed contact turning tensile, a stick/slip switch of a frictional one, an
output time, the end time and a non-finite state. A closed contact's force is its consistent multiplier at the step's
(t, q, v) — the acceleration-level law of the phase (:func:`daebench.core.phase.solve_augmented`),
as the driver reads it (:func:`daebench.driver.events.contact_forces`) — never the
multiplier the integrator's step produced. A compiled runner that takes many steps per call stops after the
first step with any of these and hands it back; for every earlier ("quiet") step it
does the only bookkeeping the driver would have done: re-arming gaps and the running
maxima of |C|, |Ċ|, |C̈|. The driver itself decides with :func:`gap_event` too.

Gap rule: after a release or a rebound a contact re-arms its closing event only once
its gap exceeds ``GAP_BAND``; until then closing is detected at g = −GAP_BAND. Without
the band, solver noise (|g| ~ 1e-12 at a release) re-closes the contact at once, over
and over (chatter).

Proximity rule (:func:`near`): an open contact is *near* when, on the quadratic
prediction of its gap from its current velocity and acceleration, it comes within
GAP_BAND of its surface in ``NEAR_STEPS`` free steps. The driver runs the contact step while a contact is near, as while one is
closed: the approach to an impact, and the flights between the impacts of a chatter,
are resolved at the contact step rather than at the free step, which would cross them
(and so the event times and the post-impact state converge with the contact step).
A runner stops when a contact's proximity changes.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from daebench.core.borrow import uncounted
from daebench.core import kernels, phase

GAP_BAND = 1e-9  # m
GAP_ROUNDOFF = 1e-6 * GAP_BAND  # a gap this close to its closing threshold is on it (a rebound located there)
NEAR_STEPS = 2.0  # an open contact within this many free steps of its surface is near


class Watch(NamedTuple):
    """What a runner watches (arrays ``armed`` and ``cmax`` are its own copies, updated
    in place and handed back to the driver as values: :func:`own_copy`)."""

    inactive: np.ndarray   # int64: open contacts whose closing is watched
    lam_rows: np.ndarray   # int64: rows of λ of closed contacts (opening when their consistent λ < 0)
    armed: np.ndarray      # bool per contact
    track: bool            # keep constraint maxima
    cmax: np.ndarray       # float64[3]: max |C|, |Ċ|, |C̈|
    t_out_next: float
    t_end: float
    near_h: float          # NEAR_STEPS × the free step (0: no proximity rule)
    near: np.ndarray       # bool per contact: run at the contact step (near)
    aug: tuple             # phase.AugmentedWork of the phase: the consistent multipliers
    acc: np.ndarray        # float64[n] scratch: the consistent acceleration
    lam: np.ndarray        # float64[m] scratch: the consistent multipliers


def make(n: int, m: int, inactive: np.ndarray, lam_rows: np.ndarray, armed: np.ndarray, track: bool,
         cmax: np.ndarray, t_out_next: float, t_end: float, near_h: float = 0.0,
         near_now: np.ndarray | None = None) -> Watch:
    """A watch over a phase with n coordinates and m constraints (its scratch allocated)."""
    near_now = np.zeros(armed.shape[0], np.bool_) if near_now is None else near_now
    return Watch(inactive, lam_rows, armed, track, cmax, t_out_next, t_end, float(near_h), near_now,
                 phase.augmented_work(n, m), np.zeros(n), np.zeros(max(m, 1)))


def own_copy(w: Watch) -> Watch:
    """The watch with its own ``armed`` and ``cmax`` (what a runner updates in place)."""
    return w._replace(armed=w.armed.copy(), cmax=w.cmax.copy())


def blind(n_contacts: int) -> Watch:
    """A watch that never stops a runner (single steps)."""
    return make(1, 0, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(max(n_contacts, 1), np.bool_), False,
                np.zeros(3), math.inf, math.inf)


@njit(cache=True, inline="always")
def gap_event(g, armed):
    """(closes, arms) for an open contact at gap g: it crossed its closing threshold (0
    once armed, −GAP_BAND before; by more than the round-off GAP_ROUNDOFF, so that a contact
    that rebounded on its threshold does not close again at once), or it left the band and
    re-arms."""
    off = 0.0 if armed else GAP_BAND
    if g < -off - GAP_ROUNDOFF:
        return True, False
    return False, g > GAP_BAND


@njit(cache=True, inline="always")
def near(g, gdot, gddot, near_h):
    """Whether an open contact at gap g, moving at ġ with acceleration g̈, comes within
    GAP_BAND of its surface in the proximity time ``near_h`` (NEAR_STEPS free steps; 0:
    never near) on its quadratic prediction g + ġs + ½g̈s², s ∈ [0, near_h]."""
    if near_h <= 0.0:
        return False
    low = min(g, g + gdot * near_h + 0.5 * gddot * near_h * near_h)
    if gddot > 0.0 and 0.0 < -gdot / gddot < near_h:
        low = min(low, g - 0.5 * gdot * gdot / gddot)
    return low < GAP_BAND


@njit(cache=True, inline="always")
def output_due(t_next, t, t_end):
    """Whether the output time ``t_next`` is due at t: reached within 1e-12·max(1, t_end)."""
    return t_next <= t + 1e-12 * max(1.0, t_end)


@njit(cache=True, inline="always")
def end_reached(t, t_end):
    """Whether t is the end time (within 1e-15·max(1, t_end))."""
    return t >= t_end - 1e-15 * max(1.0, t_end)


@njit(cache=True, inline="always")
def reached(t, t_next, t_end):
    """Whether an output time or the end was reached at t (the driver's tolerances)."""
    return output_due(t_next, t, t_end) or end_reached(t, t_end)


@njit(cache=True, inline="always")
def finite(cur):
    """Whether the state ``cur`` is finite (q and v)."""
    q, v = cur.q, cur.v
    ok = True
    for i in range(q.shape[0]):
        if not (math.isfinite(q[i]) and math.isfinite(v[i])):
            ok = False
    return ok


@njit(cache=True, inline="always")
def step_events(ph, w, t, cur):
    """:func:`events`, compiled into the stepping loop: a phase that watches no contact (none
    open, none closed) pays the finiteness test only, not a call of :func:`events` (which
    passes every array of the phase and of the watch through the stack: a tenth of a
    pendulum step)."""
    if w.inactive.shape[0] == 0 and w.lam_rows.shape[0] == 0:
        return not finite(cur)
    return events(ph, w, t, cur)


@uncounted
def events(ph, w, t, cur):
    """Whether the step that ended in ``cur`` (at t) has an event the driver must handle:
    a non-finite state, an open contact closing or changing its proximity (:func:`near`), a
    closed one whose consistent force turns tensile. Re-arms gaps that left the band (every
    step: the driver's rule)."""
    q, v = cur.q, cur.v
    n = q.shape[0]
    stop = not finite(cur)
    for i in w.inactive:
        g, gam = kernels.gap(ph.model, i, q, v, ph.gq)
        closes, arms = gap_event(g, w.armed[i])
        if closes:
            stop = True
        elif arms:
            w.armed[i] = True
        if w.near_h > 0.0:
            gdot = 0.0
            gddot = -gam
            for j in range(n):
                gdot += ph.gq[j] * v[j]
                gddot += ph.gq[j] * cur.a[j]
            if near(g, gdot, gddot, w.near_h) != w.near[i]:
                stop = True
    if w.lam_rows.shape[0] and not stop:
        if phase.solve_augmented(ph, t, q, v, 0.0, 0.0, w.aug, w.acc, w.lam) != 0:
            return True
        for r in w.lam_rows:
            if w.lam[r] < 0.0:
                stop = True
        if phase.friction_switches(ph, q, v, w.lam):   # stick/slip (daebench.core.coulomb: the driver's rule)
            stop = True
    return stop


@uncounted
def track(ph, w, t, cur, C, Cq, Ct, gam):
    """Raise the running maxima of |C|, |Ċ|, |C̈| by the step that ended in ``cur``."""
    if w.track and C.shape[0]:
        c0, c1, c2 = phase.constraint_residuals(ph, t, cur.q, cur.v, cur.a, C, Cq, Ct, gam)
        w.cmax[0] = max(w.cmax[0], c0)
        w.cmax[1] = max(w.cmax[1], c1)
        w.cmax[2] = max(w.cmax[2], c2)


@uncounted
def quiet(ph, w, t, cur, C, Cq, Ct, gam):
    """Whether the step that ended in ``cur`` (at t) needs no driver attention (no
    :func:`events`, no output or end time reached); re-arms gaps that left the band and,
    for a quiet step, raises the constraint maxima (:func:`track`)."""
    if events(ph, w, t, cur) or reached(t, w.t_out_next, w.t_end):
        return False
    track(ph, w, t, cur, C, Cq, Ct, gam)
    return True
