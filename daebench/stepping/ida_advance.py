"""The compiled entries of :mod:`daebench.stepping.ida_native`: one ``IDASolve`` with
the callbacks' ``user_data`` set (:func:`solve`), and the driver's quiet steps in one
compiled loop around it (:func:`advance_loop`), which also writes the rows of the output
times a step passes (:func:`record_outputs`) instead of handing such a step back to the
Python driver: the same states the driver would get from :meth:`daebench.integrators.ida.IDA.dense`
(IDA's own interpolating polynomial, ``IDAGetSolution``, the call ``IDASolve`` makes for an
output time behind IDA's time), computed without a Python call per output time.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from daebench.stepping import watch as _watch
from daebench.stepping.dense import END, INSIDE, START, outputs_due, source
from daebench.stepping.methods import StateArrays
from daebench.stepping.sundials_c import A_CLEAR, A_GETSOL, A_SOLVE, A_STOP, address_of, ccall

IDA_NORMAL, IDA_ONE_STEP = 1, 2


# -- the compiled entries (they set user_data, then call IDA) ----------------------------------------
@njit(cache=True)
def solve(cx, mem, yy, yp, tout, tstop, itask, tret, slot):
    """One ``IDASolve`` (with ``IDASetStopTime(tstop)`` / ``IDAClearStopTime`` around it
    when tstop is finite), as scikit-sundae's ``step`` does it. Returns IDA's flag."""
    a = cx.addr
    slot[0] = address_of(cx)
    stop = math.isfinite(tstop)
    if stop:
        flag = ccall(types.int32, a[A_STOP], (mem, tstop))
        if flag < 0:
            return flag
    flag = ccall(types.int32, a[A_SOLVE], (mem, tout, tret.ctypes.data, yy, yp, np.int32(itask)))
    if stop:
        ccall(types.int32, a[A_CLEAR], (mem,))
    return flag


ADV_STOP, ADV_MAX, ADV_PYTHON, ADV_FAIL, ADV_STUCK, ADV_NONFINITE = range(6)
DENSE_EDGE = 1e-10  # relative distance to a step's end within which an output time is the Python path's


@njit(cache=True)
def record_outputs(cx, mem, prev, cur, t_out, oi, t_end, out, nrow, yd, ypd_d, nvd, nvpd):
    """The driver's rows of the output times in the step prev → cur
    (:meth:`daebench.driver.simulate.Driver._record_until` with :meth:`daebench.integrators.ida.IDA.dense`):
    the step's end state at an output time at or after its end, IDA's interpolating
    polynomial (``IDAGetSolution``, what ``dense`` gets from IDA) strictly inside it. Rows
    (t_out, t of the state, y, ẏ) go to ``out`` from row ``nrow``. Returns the next output
    index, or −1 when a row is the Python path's (an output time at or before the step's
    start or within DENSE_EDGE of its end: Hermite there; no room; IDA refuses): nothing is
    written then that the caller keeps."""
    N = yd.shape[0]
    t0, t1 = prev[0], cur[0]
    edge = t1 - DENSE_EDGE * (t1 - t0)
    j = outputs_due(t_out, oi, t1, t_end)
    for i in range(oi, j):
        src = source(t_out[i], t0, t1)
        if src == START or (src == INSIDE and t_out[i] >= edge):
            return -1
    if nrow + (j - oi) > out.shape[0]:
        return -1
    r = nrow
    for i in range(oi, j):
        to = t_out[i]
        out[r, 0] = to
        if source(to, t0, t1) == END:
            out[r, 1] = t1
            out[r, 2:] = cur[1:]
        else:
            if ccall(types.int32, cx.addr[A_GETSOL], (mem, to, nvd, nvpd)) < 0:
                return -1
            out[r, 1] = to
            out[r, 2:2 + N] = yd
            out[r, 2 + N:] = ypd_d
        r += 1
    return j


@njit(cache=True)
def interpolate(cx, mem, ts, out, yd, ypd_d, nvd, nvpd):
    """IDA's interpolating polynomial over its last step (``IDAGetSolution``, what
    :meth:`daebench.integrators.ida.IDA.dense` gets from IDA) at the times ``ts``: rows
    (y, ẏ) into ``out``. Returns how many rows were written before IDA refused a time."""
    N = yd.shape[0]
    for r in range(ts.shape[0]):
        if ccall(types.int32, cx.addr[A_GETSOL], (mem, ts[r], nvd, nvpd)) < 0:
            return r
        out[r, :N] = yd
        out[r, N:] = ypd_d
    return ts.shape[0]


@njit(cache=True)
def advance_loop(cx, mem, yy, yp, y, ypd, t_cur, ida_t, t_stop, max_steps, w, prev, cur, tret, slot, C, Cq, Ct,
                 gam, t_out, out, yd, ypd_d, nvd, nvpd):
    """IDA one-step calls toward ``t_stop`` until a step the driver must see
    (:func:`daebench.stepping.watch.quiet`), the step budget, or a step the Python path
    must take (a step too close to IDA's time: ``code`` ADV_PYTHON). ``cur``/``prev``
    hold (t, y, ẏ) of the last step's end and start. A step whose only news is an output
    time is not handed back when ``t_out`` (the output times from the watch's next one on)
    is given: its rows go to ``out`` (:func:`record_outputs`) and the loop goes on.
    Returns (steps, code, flag, ida_t, rows written, output times consumed)."""
    n = cx.M.shape[0]
    m = cx.m
    N = y.shape[0]
    scale = max(1.0, abs(t_stop))
    t_end_tol = 1e-15 * max(1.0, t_stop)
    k = 0
    code = ADV_MAX
    flag = 0
    nrow = np.int64(0)   # int64, not literals: the callees compile once (Python passes int64 too)
    oi = np.int64(0)
    one_step = np.int64(IDA_ONE_STEP)
    t_next = w.t_out_next
    while k < max_steps:
        if t_stop - ida_t <= 1e-13 * scale:
            code = ADV_PYTHON
            break
        moved = False
        for _ in range(3):
            flag = solve(cx, mem, yy, yp, t_stop, t_stop, one_step, tret, slot)
            if flag < 0:
                return k, ADV_FAIL, flag, ida_t, nrow, oi
            if tret[0] > t_cur:
                moved = True
                break
        if not moved:
            return k, ADV_STUCK, flag, ida_t, nrow, oi
        t_new = tret[0]
        for i in range(N):
            if not (math.isfinite(y[i]) and math.isfinite(ypd[i])):
                return k, ADV_NONFINITE, flag, ida_t, nrow, oi
        for i in range(cur.shape[0]):
            prev[i] = cur[i]
        cur[0] = t_new
        for i in range(N):
            cur[1 + i] = y[i]
            cur[1 + N + i] = ypd[i]
        ida_t = t_new
        t_cur = t_new
        k += 1
        if t_new >= t_stop - t_end_tol:
            code = ADV_STOP
            break
        st = StateArrays(y[:n], y[n:2 * n], ypd[n:2 * n], y[2 * n:2 * n + m])
        if _watch.events(cx.ph, w, t_new, st):
            code = ADV_STOP
            break
        if _watch.reached(t_new, t_next, w.t_end):
            j = record_outputs(cx, mem, prev, cur, t_out, oi, w.t_end, out, nrow, yd, ypd_d, nvd, nvpd)
            if j < 0:
                code = ADV_STOP
                break
            nrow += j - oi
            oi = j
            t_next = t_out[oi] if oi < t_out.shape[0] else math.inf
            if _watch.reached(t_new, t_next, w.t_end):
                code = ADV_STOP
                break
        _watch.track(cx.ph, w, t_new, st, C, Cq, Ct, gam)
    return k, code, flag, ida_t, nrow, oi
