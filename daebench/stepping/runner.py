"""One compiled loop for every stepper: fixed or adaptive steps, many per call.

:func:`run_phase` steps a method (:mod:`daebench.stepping.methods`) on a phase until
the driver must see the step just taken (:func:`daebench.stepping.watch.quiet`), until
``max_steps`` (which keeps the caller responsive), or until a step fails. The step that
stops it is handed back as (prev, cur); every earlier step was quiet. A single step
from Python is the same loop with ``max_steps = 1``. No allocation per step.

Step control (:mod:`daebench.stepping.control`): at fixed step every step is ctl.h
(landing exactly on t_stop); adaptive, a step is accepted when its error estimate is
≤ 1, rejected steps and failed solves retry smaller, counted in ``cnt[C_REJECTED]``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from daebench.core import phase
from daebench.core.borrow import borrow, copy_to
from daebench.stepping import control, dense, methods, watch
from daebench.stepping.methods import N_COUNTERS

C_REJECTED = N_COUNTERS          # counters: the methods' own, then rejected steps
UNDERFLOW_FAIL, UNDERFLOW_ERROR = 100, 101  # statuses beyond the methods' own (1 … 99)


@njit(cache=True, inline="always")
def _copy(dst, src):
    copy_to(dst.q, src.q)
    copy_to(dst.v, src.v)
    copy_to(dst.a, src.a)
    copy_to(dst.lam, src.lam)


@njit(cache=True)
def run_phase(meth, ws, ph, ctl, w, t, t_stop, h_next, cur, new, prev, max_steps, cnt, t_out, out):
    """Advance ``cur`` (at t) in place; ``prev`` receives the state before the last step.

    A step whose only news is an output time is not handed back when ``t_out`` (the output
    times from the watch's next one on) is not empty: the rows of the output times it
    passed go to ``out`` (:func:`daebench.stepping.dense.record_outputs`) and the loop goes on.

    Returns (status, steps taken, t before the last step, t now, next step size, size
    of the failed step, method status behind an underflow, local error behind one, rows
    written to ``out``, output times consumed).
    """
    # the caller holds every argument for the whole call: no reference counting inside
    meth, ws, ph, ctl, w, cur, new, prev, cnt, t_out, out = borrow((meth, ws, ph, ctl, w, cur, new, prev, cnt,
                                                                t_out, out))
    n = cur.q.shape[0]
    m = cur.lam.shape[0]
    C, Ct, gam = np.empty(m), np.empty(m), np.empty(m)
    Cq = np.empty((m, n))
    steps = 0
    t_prev = t
    h = h_next
    nrow = np.int64(0)   # not the literal 0: numba would compile record_outputs for Literal[int](0) too
    oi = np.int64(0)
    t_next = w.t_out_next
    while True:
        h_small = control.h_min(ctl, t)
        while True:  # attempts of one step (one attempt at fixed step)
            h_try = h_next if ctl.adaptive else ctl.h
            h, t_new = control.land(t, t_stop, h_try)
            status, err = methods.step(meth, ws, ph, ctl, t, h, cur, new, cnt)
            if status != 0:
                if not ctl.adaptive:
                    return status, steps, t_prev, t, h_next, h, 0, 0.0, nrow, oi
                cnt[C_REJECTED] += 1
                h_next = control.FAC_FAIL * h
                if h_next < h_small:
                    return UNDERFLOW_FAIL, steps, t_prev, t, h_next, h, status, 0.0, nrow, oi
                continue
            if ctl.adaptive:
                ok, h_next = control.judge(ctl, err, h, h_try)
                if not ok:
                    cnt[C_REJECTED] += 1
                    if h_next < h_small:
                        return UNDERFLOW_ERROR, steps, t_prev, t, h_next, h, 0, err, nrow, oi
                    continue
            break
        _copy(prev, cur)
        _copy(cur, new)
        methods.accept(meth, ws, h, prev, cur)
        t_prev = t
        t = t_new
        steps += 1
        phase.book_friction(ph, t_prev, t, cur.q, cur.v)   # a slipping phase's friction work (core.coulomb)
        # watch.quiet, with the rows of a quiet step's output times written here when t_out is given
        if steps >= max_steps or watch.step_events(ph, w, t, cur):
            break
        if watch.reached(t, t_next, w.t_end):
            if t_out.shape[0] == 0:
                break
            j = dense.record_outputs(t_prev, prev, t, cur, t_out, oi, w.t_end, out, nrow)
            if j < 0 or not phase.book_rows(ph, t_prev, t, t_out, oi, j, nrow):
                break
            nrow += j - oi
            oi = j
            t_next = t_out[oi] if oi < t_out.shape[0] else math.inf
            if watch.reached(t, t_next, w.t_end):
                break
        watch.track(ph, w, t, cur, C, Cq, Ct, gam)
    return 0, steps, t_prev, t, h_next, h, 0, 0.0, nrow, oi
