"""Contact episodes of an event-capturing stepper, kept in compiled code.

A contact *episode* is a run of consecutive steps in which a contact carries a positive
impulse. The stepper proposes, for every step and contact, whether it was in contact,
its impulse, the gap at the step's start and end and ġ at the start
(:func:`propose`); when the step is accepted, :func:`commit` opens, extends or closes
the episodes and writes a *start* record (time and state at the start of the first
step with a positive impulse, ġ⁻ there) or an *end* record (the state at the end of the
last such step, ġ⁺ there, the episode's impulse, smallest gap and number of steps) to a
log, each with the work of that contact's impulses in the step it was written at; a start
record also keeps the state after the first step (the impact step). The integrator drains the log after each compiled call
(:class:`daebench.integrators.capturing.CapturingIntegrator`) into
:class:`daebench.core.contact.Impact` records — the same columns as the driver's impacts:
impact time = start of the first step with a positive impulse, ġ⁻, ġ⁺, energy change
over the episode, total impulse, end time, smallest gap (< 0: penetration).

The book also keeps the cumulative work of the contact impulses (:func:`propose_work`),
which the driver books as ``W_contact`` in the energy balance.

The log holds ``capacity`` records; a compiled call may take at most
``capacity // n_contacts − 1`` steps (each step writes at most one record per contact).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

START, END = 1.0, 2.0
# log columns
L_KIND, L_CONTACT, L_T, L_GDOT, L_IMPULSE, L_GMIN, L_STEPS, L_WORK, L_ULAW = range(9)
N_LOG = 9
# per-contact columns of the proposed step and of the open episode
S_IN, S_IMPULSE, S_G0, S_G1, S_GDOT0 = range(5)
O_OPEN, O_IMPULSE, O_GMIN, O_STEPS = range(4)


class Episodes(NamedTuple):
    step: np.ndarray    # float[nc, 5]: the proposed step, per contact (S_* columns)
    t: np.ndarray       # float[1]: start time of the proposed step
    open: np.ndarray    # float[nc, 4]: the open episode of each contact (O_* columns)
    log: np.ndarray     # float[capacity, N_LOG]
    logx: np.ndarray    # float[capacity, 4n]: q, v of each record; start records: then q, v after the step
    nlog: np.ndarray    # int64[1]
    work: np.ndarray    # float[3]: cumulative contact work before and after the last step, the proposed step's
    cwork: np.ndarray   # float[nc, 2]: the proposed step's work of each contact's impulses (normal and
                        # tangential) and the normal velocity U⁻ its impact law used; NaN where the stepper
                        # books no impact-alone work (nonsmooth generalized-α: its impulse carries λ's share)


def episodes(n: int, nc: int, steps_per_call: int) -> Episodes:
    cap = max(nc, 1) * (steps_per_call + 1)
    return Episodes(np.zeros((max(nc, 1), 5)), np.zeros(1), np.zeros((max(nc, 1), 4)), np.zeros((cap, N_LOG)),
                    np.zeros((cap, 4 * n)), np.zeros(1, np.int64), np.zeros(3), np.full((max(nc, 1), 2), np.nan))


@njit(cache=True)
def propose(ep, i, t, in_contact, impulse, g0, g1, gdot0):
    """Contact i in the step starting at t: in contact?, its impulse, gaps at the start and
    end of the step, ġ at the start."""
    ep.t[0] = t
    s = ep.step[i]
    s[S_IN] = 1.0 if in_contact else 0.0
    s[S_IMPULSE] = impulse
    s[S_G0] = g0
    s[S_G1] = g1
    s[S_GDOT0] = gdot0


@njit(cache=True)
def propose_work(ep, w):
    """The work of the contact impulses in the proposed step (the impulse times the mean of
    the normal velocities before and after, Σ P (U⁻ + U⁺)/2: the impact's energy change by
    Kelvin's theorem); each contact's share is in ``ep.cwork``, which the stepper fills."""
    ep.work[2] = w


@njit(cache=True)
def _record(ep, kind, i, t, gdot, impulse, gmin, steps, work, prev, cur):
    k = ep.nlog[0]
    if k >= ep.log.shape[0]:
        return  # cannot happen within the documented steps per call; never write out of bounds
    row = ep.log[k]
    row[L_KIND] = kind
    row[L_CONTACT] = i
    row[L_T] = t
    row[L_GDOT] = gdot
    row[L_IMPULSE] = impulse
    row[L_GMIN] = gmin
    row[L_STEPS] = steps
    row[L_WORK] = work[0]
    row[L_ULAW] = work[1]
    n = prev.q.shape[0]
    for j in range(n):
        ep.logx[k, j] = prev.q[j]
        ep.logx[k, n + j] = prev.v[j]
        ep.logx[k, 2 * n + j] = cur.q[j]
        ep.logx[k, 3 * n + j] = cur.v[j]
    ep.nlog[0] = k + 1


@njit(cache=True)
def commit(ep, nc, prev, cur):
    """The proposed step from ``prev`` to ``cur`` was accepted: update the episodes."""
    t = ep.t[0]
    ep.work[0] = ep.work[1]
    ep.work[1] += ep.work[2]
    for i in range(nc):
        s = ep.step[i]
        o = ep.open[i]
        if s[S_IN] != 0.0:
            if o[O_OPEN] == 0.0:
                o[O_OPEN] = 1.0
                o[O_IMPULSE] = 0.0
                o[O_GMIN] = s[S_G0]
                o[O_STEPS] = 0.0
                _record(ep, START, i, t, s[S_GDOT0], s[S_IMPULSE], s[S_G0], 1.0, ep.cwork[i], prev, cur)
            o[O_IMPULSE] += s[S_IMPULSE]
            o[O_GMIN] = min(o[O_GMIN], s[S_G1])
            o[O_STEPS] += 1.0
        elif o[O_OPEN] != 0.0:
            # the episode ended with the previous step: its end state is this step's start
            o[O_OPEN] = 0.0
            _record(ep, END, i, t, s[S_GDOT0], o[O_IMPULSE], min(o[O_GMIN], s[S_G0]), o[O_STEPS], ep.cwork[i],
                    prev, cur)


@njit(cache=True)
def reset(ep):
    """Forget open episodes and the log (a restart; the cumulative work goes on)."""
    ep.open[:, :] = 0.0
    ep.nlog[0] = 0
    ep.work[0] = ep.work[1]
    ep.work[2] = 0.0
