"""Measures for nonsmooth runs that converge where the max norm cannot: velocities in L¹
and the distance between the cumulative contact impulses.

**Velocity in L¹.** A velocity that jumps at impacts has a max error of the jump's size
whenever a run's impact lies a step away from the truth's, however fine the step; its
time average (1/T)∫|v_run − v_truth| dt falls with the impact-time error instead
(``err_<v>_l1`` for every scored observable that is another's declared derivative, on the
truth's span, the truth interpolated within its smooth segments).

**Impulse measure.** The contact impulse is a measure, dΛ = λ dt + Σ_k Λ_k δ(t − t_k)
(Moreau 1988): the contact force while a contact is closed plus the impulses of the impacts.
Its cumulative distribution Λ(t) = ∫₀ᵗ dΛ is compared in L¹ over the span T:
``err_impulse_measure`` = (1/T)∫₀ᵀ |Λ_run(t) − Λ_truth(t)| dt [N s] (for equal totals the
Wasserstein-1 distance of the two measures: an impulse moved by δt costs Λ_k δt / T, a
1 % error in one impulse 0.01 Λ_k (T − t_k) / T), and ``err_impulse_measure_rel`` that
over the truth's total Λ_truth(T). The force part is read from the history's ``lambda_*``
and ``contact_force_*`` columns; an episode the driver's impact law did not make (event
capturing) carries its whole impulse unless the history has its force. The integral is
exact for the piecewise-constant and trapezoidal parts.

References: J. J. Moreau, *Unilateral contact and dry friction in finite freedom
dynamics* (1988); V. Acary & B. Brogliato, *Numerical Methods for Nonsmooth Dynamical
Systems* (2008), §1.2 and ch. 10 (convergence in L¹ and of the impulse measure).
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
import pandas as pd

#: the prefixes of the history's contact-force columns: a closed contact's multiplier (the
#: driver's constraint law), a continuous law's force
FORCE_PREFIXES = ("lambda_", "contact_force_")


def cumulative(times: Sequence[float], impulses: Sequence[float], t: np.ndarray, force_t: np.ndarray | None = None,
               force: np.ndarray | None = None, left: bool = False) -> np.ndarray:
    """Λ(t) at times ``t``: the impulses of the impacts at ``times`` up to t (before t when
    ``left``) plus ∫₀ᵗ force (trapezoidal over ``force_t``, linear between)."""
    tk = np.asarray(list(times), float)
    lk = np.asarray(list(impulses), float)
    order = np.argsort(tk, kind="stable")
    tk, lk = tk[order], np.concatenate([[0.0], np.cumsum(lk[order])])
    out = lk[np.searchsorted(tk, t, side="left" if left else "right")]
    if force_t is not None and force is not None and len(force_t) > 1:
        f = np.nan_to_num(np.asarray(force, float))
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(force_t))])
        out = out + np.interp(t, force_t, cum, left=0.0)
    return out


def impulse_distance(run: tuple, truth: tuple, T: float) -> float:
    """(1/T)∫₀ᵀ |Λ_run − Λ_truth| dt; ``run`` and ``truth`` are (impact times, impulses,
    force times or None, force or None) (module docstring)."""
    if not (math.isfinite(T) and T > 0):
        return math.nan
    pts = [0.0, T, *run[0], *truth[0]]
    for part in (run, truth):
        if part[2] is not None:
            pts += list(np.asarray(part[2], float))
    g = np.unique(np.clip(np.asarray(pts, float), 0.0, T))
    d_right = cumulative(*run[:2], g, *run[2:]) - cumulative(*truth[:2], g, *truth[2:])
    d_left = cumulative(*run[:2], g, *run[2:], left=True) - cumulative(*truth[:2], g, *truth[2:], left=True)
    return float(np.sum(0.5 * (np.abs(d_right[:-1]) + np.abs(d_left[1:])) * np.diff(g)) / T)


def _force(hist: pd.DataFrame) -> tuple[np.ndarray | None, np.ndarray | None]:
    cols = [c for c in hist.columns if c.startswith(FORCE_PREFIXES)]
    if not cols or not len(hist):
        return None, None
    h = hist[~hist["t"].duplicated(keep="last")]
    return h["t"].to_numpy(float), h[cols].to_numpy(float).sum(axis=1)


def velocity_l1(run: Any, tr: Any) -> dict[str, float]:
    """``err_<v>_l1`` of every scored velocity observable (module docstring)."""
    from daebench.harness.scoring import metrics   # lazy: metrics imports this module; the truth's interpolation within its smooth segments

    d = run.declared
    vel = {o.derivative for o in d.declared if o.derivative}
    cols = [c for c in run.scored_columns() if c in vel and c in tr.history.columns]
    if not cols:
        return {}
    t0, t1 = float(tr.history["t"].iloc[0]), float(tr.history["t"].iloc[-1])
    reaches = len(run.history) > 0 and float(run.history["t"].iloc[-1]) >= t1 - 1e-9 * max(1.0, abs(t1))
    r, ref = metrics._at_run_times(run.history, tr.history, cols, tr.impacts, reaches, t0, t1, d)
    out = {}
    for c in cols:
        e = np.abs(r[c] - ref[c])
        out[f"err_{d.get(c).score_name}_l1"] = float(e.mean()) if e.size and np.all(np.isfinite(e)) else math.nan
    return out


def impulse_measure(run: Any, tr: Any) -> dict[str, float]:
    """``err_impulse_measure`` and ``err_impulse_measure_rel`` over the truth's trusted
    span (NaN when the truth records no impulses or a run impulse is unknown)."""
    nan = {"err_impulse_measure": math.nan, "err_impulse_measure_rel": math.nan}
    if len(tr.impulses) != len(tr.impacts) or (tr.impacts and not tr.impulses):
        return nan
    T = min(tr.trust_t if math.isfinite(tr.trust_t) else math.inf, float(tr.history["t"].iloc[-1]))
    ft, f = _force(run.history)
    # an episode without the driver's law carries its whole impulse, unless the history has its force
    lam = [float(i.impulse) if getattr(i, "law", "") or f is None else 0.0 for i in run.impacts]
    if not all(math.isfinite(x) for x in lam):
        return nan
    tt, tf = _force(tr.history)
    dist = impulse_distance((run.impact_times, lam, ft, f), (tr.impacts, tr.impulses, tt, tf), T)
    total = float(cumulative(tr.impacts, tr.impulses, np.array([T]), tt, tf)[0])
    return {"err_impulse_measure": dist, "err_impulse_measure_rel": dist / total if total > 0 else math.nan}


def measure(run: Any, tr: Any) -> dict[str, Any]:
    """The scoring pipeline's measure (:data:`daebench.harness.scoring.pipeline.MEASURES`):
    for a run of a system with contacts, the velocities in L¹ and the impulse measure."""
    if not getattr(run.system, "n_contacts", 0):
        return {}
    return {**velocity_l1(run, tr), **impulse_measure(run, tr)}
