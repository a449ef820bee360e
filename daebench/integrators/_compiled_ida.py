"""The GGL residual of :mod:`daebench.integrators.ida` as one compiled call (numba).

IDA calls the residual once per Newton iteration, ~1.2 times per step; in Python it was
a chain of model calls (mass, force, constraint rows, each allocating) costing about as
much as IDA's own step. Here it is one njit call on preallocated arrays, through the
model descriptor of :mod:`daebench.integrators._compiled_models` (the same kernels the
Python path calls, so both paths agree to round-off; tests/test_ida.py).

:func:`quiet` is the per-step watch of :meth:`daebench.integrators.ida.IDA.advance`:
IDA's steps stay Python-level calls into SUNDIALS, but a step that needs no driver
attention (no gap crossing, no tensile multiplier, no output time) costs one compiled
check instead of the driver's Python event search and bookkeeping.
"""

from __future__ import annotations

import math

from numba import njit

from daebench.integrators import _compiled_models as cm
from daebench.integrators._compiled_newmark import GAP_BAND


@njit(cache=True)
def ggl_residual(md, active, m, t, y, yp, res, M, Q, C, Cq, Ct, gam):
    """F(t, y, ẏ) of the GGL form, y = (q, v, λ, μ) (see ida.py), into ``res``."""
    n = M.shape[0]
    q = y[:n]
    v = y[n:2 * n]
    cm.mass_force(md, t, q, v, M, Q)
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += M[i, j] * yp[n + j]
        res[i] = yp[i] - v[i]
        res[n + i] = acc - Q[i]
    if m == 0:
        return
    cm.constraints(md, t, q, v, active, C, Cq, Ct, gam)
    for r in range(m):
        lam = y[2 * n + r]
        mu = y[2 * n + m + r]
        cv = 0.0
        for i in range(n):
            res[i] += Cq[r, i] * mu
            res[n + i] += Cq[r, i] * lam
            cv += Cq[r, i] * v[i]
        res[2 * n + r] = C[r]
        res[2 * n + m + r] = cv + Ct[r]


@njit(cache=True)
def quiet(md, active, inactive, lam_rows, armed, continuous, track, cmax, t, q, v, a, lam,
          t_out_next, t_end, g, zeros, C, Cq, Ct, gam):
    """Whether the step that ended in (t, q, v, a, λ) needs no driver attention — the rule
    of :class:`daebench.integrators.base.BatchWatch`, as in ``_compiled_newmark.run_fixed``:
    re-arms gaps that left the band and, for a quiet step, raises the constraint maxima."""
    n = q.shape[0]
    m = lam.shape[0]
    stop = False
    for i in range(n):
        if not (math.isfinite(q[i]) and math.isfinite(v[i])):
            stop = True
    if inactive.shape[0]:
        cm.gaps(md, q, zeros, g)
        for i in inactive:
            off = 0.0 if armed[i] else GAP_BAND
            if (continuous and g[i] < 0.0) or g[i] < -off:
                stop = True
            elif g[i] > GAP_BAND:
                armed[i] = True
    for r in lam_rows:
        if lam[r] < 0.0:
            stop = True
    if t_out_next <= t + 1e-12 * max(1.0, t_end) or t >= t_end - 1e-15 * max(1.0, t_end):
        stop = True
    if stop:
        return False
    if track and m:
        cm.constraints(md, t, q, v, active, C, Cq, Ct, gam)
        for k in range(m):
            cv = 0.0
            ca = 0.0
            for j in range(n):
                cv += Cq[k, j] * v[j]
                ca += Cq[k, j] * a[j]
            cmax[0] = max(cmax[0], abs(C[k]))
            cmax[1] = max(cmax[1], abs(cv + Ct[k]))
            cmax[2] = max(cmax[2], abs(ca - gam[k]))
    return True
