"""The GGL residual of :mod:`daebench.integrators.ida` as one compiled call (numba).

IDA calls the residual once per Newton iteration, ~1.2 times per step; in Python it was
a chain of model calls (mass, force, constraint rows, each allocating) costing about as
much as IDA's own step. Here it is one njit call on preallocated arrays, through the
model descriptor of :mod:`daebench.integrators._compiled_models` (the same kernels the
Python path calls, so both paths agree to round-off; tests/test_ida.py).

:func:`daebench.integrators._compiled_watch.quiet` is the per-step watch of
:meth:`daebench.integrators.ida.IDA.advance`:
IDA's steps stay Python-level calls into SUNDIALS, but a step that needs no driver
attention (no gap crossing, no tensile multiplier, no output time) costs one compiled
check instead of the driver's Python event search and bookkeeping.
"""

from __future__ import annotations

from numba import njit

from daebench.integrators import _compiled_models as cm


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
