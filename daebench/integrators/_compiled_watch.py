"""The driver's watch over a quiet step, compiled once for every phase runner (numba).

Every compiled phase runner — HHT/Newmark (:mod:`._compiled_newmark`), Baumgarte
(:mod:`._compiled_abm`), IDA's :meth:`advance` — takes many steps per call and must hand
back the first step the event-driven driver has to see (the rule of
:class:`daebench.integrators.base.BatchWatch`). For every earlier ("quiet") step it does
the only bookkeeping the driver would have done: re-arming gaps that left the
``GAP_BAND`` and the running maxima of |C|, |Ċ|, |C̈|. One function, so the rule cannot
drift apart between integrators.
"""

from __future__ import annotations

import math

from numba import njit

from daebench.integrators import _compiled_models as cm

GAP_BAND = 1e-9  # = daebench.simulate.GAP_BAND (kept equal by tests/test_compiled.py)


@njit(cache=True)
def quiet(md, active, inactive, lam_rows, armed, continuous, track, cmax, t, q, v, a, lam,
          t_out_next, t_end, g, zeros, C, Cq, Ct, gam):
    """Whether the step that ended in (t, q, v, a, λ) needs no driver attention — the rule
    of :class:`daebench.integrators.base.BatchWatch`, as in ``_compiled_newmark.run_phase``:
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
