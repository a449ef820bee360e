"""Dense output of the one-step methods, compiled: the one cubic Hermite rule.

The driver asks an integrator for the state at an output time inside its last step
(:meth:`daebench.integrators.base.Integrator.dense`); the compiled runner writes the rows
of the output times its quiet steps pass itself (:func:`record_outputs`) instead of
handing every such step back to Python. Both use :func:`hermite`, so a history does not
depend on which of the two wrote a row.

Which state serves an output time is one rule, :func:`outputs_due` and :func:`source`:
the driver (for any integrator's own dense output), this runner's rows and native IDA's
(:mod:`daebench.stepping.ida_advance`) all call it.
"""

from __future__ import annotations

from numba import njit

from daebench.core.borrow import copy_to, uncounted
from daebench.stepping.watch import output_due

#: :func:`source` of an output time in a step: its end state, its start state, dense output inside
END, START, INSIDE = 0, 1, 2

#: output rows a compiled call of an integrator's ``advance`` writes at most (its buffer)
MAX_OUTPUT_ROWS = 4096


@njit(cache=True, inline="always")
def outputs_due(t_out, oi, t1, t_end):
    """The index past the output times from ``t_out[oi]`` on that are due at t1
    (:func:`daebench.stepping.watch.output_due`): those a step ending at t1 writes."""
    j = oi
    while j < t_out.shape[0] and output_due(t_out[j], t1, t_end):
        j += 1
    return j


@njit(cache=True, inline="always")
def source(to, t0, t1):
    """Which state of the step t0 → t1 serves output time ``to``: the end state at or after
    the step's end (and for a step of no length), the start state at or before its start,
    the dense output strictly inside."""
    if to >= t1 or t1 <= t0:
        return END
    if to <= t0:
        return START
    return INSIDE


@uncounted
def hermite(t0, q0, v0, a0, l0, t1, q1, v1, a1, l1, t, q, v, a, lam):
    """The state at t in the step (t0, …) → (t1, …) into (q, v, a, lam): cubic Hermite in
    q (with v), in v (with a, when both ends have it; else the derivative of the
    q-interpolant), linear in a and λ (the end's values where the sizes differ)."""
    n = q0.shape[0]
    h = t1 - t0
    if h <= 0.0:
        copy_to(q, q1)
        copy_to(v, v1)
        copy_to(a, a1)
        copy_to(lam, l1)
        return
    th = (t - t0) / h
    th2 = th * th
    th3 = th2 * th
    h00 = 2.0 * th3 - 3.0 * th2 + 1.0
    h10 = th3 - 2.0 * th2 + th
    h01 = -2.0 * th3 + 3.0 * th2
    h11 = th3 - th2
    for i in range(n):
        q[i] = h00 * q0[i] + (h10 * h) * v0[i] + h01 * q1[i] + (h11 * h) * v1[i]
    if a0.shape[0] == n and a1.shape[0] == n:
        for i in range(n):
            v[i] = h00 * v0[i] + (h10 * h) * a0[i] + h01 * v1[i] + (h11 * h) * a1[i]
    else:
        d00 = (6.0 * th2 - 6.0 * th) / h
        d10 = 3.0 * th2 - 4.0 * th + 1.0
        d01 = (-6.0 * th2 + 6.0 * th) / h
        d11 = 3.0 * th2 - 2.0 * th
        for i in range(n):
            v[i] = d00 * q0[i] + d10 * v0[i] + d01 * q1[i] + d11 * v1[i]
    if a0.shape[0] == a1.shape[0]:
        for i in range(a1.shape[0]):
            a[i] = (1.0 - th) * a0[i] + th * a1[i]
    else:
        copy_to(a, a1)
    if l0.shape[0] == l1.shape[0]:
        for i in range(l1.shape[0]):
            lam[i] = (1.0 - th) * l0[i] + th * l1[i]
    else:
        copy_to(lam, l1)


@uncounted
def record_outputs(t0, s0, t1, s1, t_out, oi, t_end, out, nrow):
    """The driver's rows of the output times in the step (t0, s0) → (t1, s1)
    (:meth:`daebench.driver.simulate.Driver._record_until` with the Hermite
    :meth:`~daebench.integrators.base.Integrator.dense`): the state :func:`source` names,
    :func:`hermite` inside. Rows (t_out, t of the state, q, v, a, λ) go to ``out`` from
    row ``nrow``. Returns the next output index, or −1 (nothing kept) when ``out`` has no
    room for them all."""
    n = s1.q.shape[0]
    m = s1.lam.shape[0]
    j = outputs_due(t_out, oi, t1, t_end)
    if nrow + (j - oi) > out.shape[0]:
        return -1
    for r, i in enumerate(range(oi, j)):
        to = t_out[i]
        row = out[nrow + r]
        row[0] = to
        q, v, a, lam = row[2:2 + n], row[2 + n:2 + 2 * n], row[2 + 2 * n:2 + 3 * n], row[2 + 3 * n:2 + 3 * n + m]
        src = source(to, t0, t1)
        if src == INSIDE:
            row[1] = to
            hermite(t0, s0.q, s0.v, s0.a, s0.lam, t1, s1.q, s1.v, s1.a, s1.lam, to, q, v, a, lam)
        else:
            s = s1 if src == END else s0
            row[1] = t1 if src == END else t0
            copy_to(q, s.q)
            copy_to(v, s.v)
            copy_to(a, s.a)
            copy_to(lam, s.lam)
    return j
