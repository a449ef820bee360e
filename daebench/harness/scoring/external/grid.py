"""Where an external trajectory is compared: its output times, made fit for the measures.

**Sparse files.** A run is compared at its own output times (:mod:`daebench.harness.scoring.metrics`);
a file written more coarsely than the case's output interval would then be judged at a few
times only — two rows of the pendulum, at t = 0 and t_end, scored better than the full
1 001 rows. A file whose largest output spacing exceeds the case's ``output.dt`` is therefore
scored on the case's output times (:func:`output_times`), its values there given by the
file's own interpolation rule (:func:`resample`): within each smooth stretch of the file
(between the two rows an event-driven code writes at an impact), cubic Hermite where the
file also holds the column of the observable's derivative as the model declares it
(θ with ω), linear otherwise — the same rule that interpolates a reference
(:func:`daebench.harness.scoring.metrics.dense`). The row states the file's spacing
(``file_dt_max``), its rows (``file_rows``) and that it was resampled.

**Rows at an impact, one-sided.** An event-driven code writes two rows at an impact, before
and after. When its impact time lies within the event tolerance of the truth's (1e-16 s
before it, for an exact code), the post-impact row would meet the truth's pre-impact branch
and score the whole jump as error. :func:`one_sided` moves such a pair to the two sides of
the truth's impact — the pre-impact row to its left limit, the post-impact row to its right
limit (one unit in the last place either side) — and the truth's own pair at that time
likewise, so that each side is compared with its own branch. The impact-time error is scored
apart (``err_impact_t_*``), from the file's own time.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import pandas as pd

from daebench.core.observables import Observables
from daebench.harness.scoring import metrics

#: a spacing above this × output.dt is coarser than the case's output interval
SPACING_RTOL = 1e-6


def output_times(t_end: float, dt: float) -> np.ndarray:
    """The case's output times, as the driver writes them: k·t_end/n when output.dt divides
    t_end (n = t_end/dt), else k·dt below t_end, then t_end."""
    n = int(round(t_end / dt))
    if abs(n * dt - t_end) < 1e-9 * t_end:
        return np.linspace(0.0, t_end, n + 1)
    return np.append(np.arange(0.0, t_end, dt), t_end)


def spacing(t: np.ndarray) -> float:
    """The largest interval between two distinct output times [s]."""
    d = np.diff(np.asarray(t, float))
    d = d[d > 0]
    return float(d.max()) if d.size else math.nan


def _pairs(t: np.ndarray) -> np.ndarray:
    """Indices i of the rows written twice (t[i] == t[i + 1])."""
    return np.flatnonzero(np.diff(t) == 0)


def resample(hist: pd.DataFrame, grid: np.ndarray, declared: Observables) -> pd.DataFrame:
    """``hist`` on ``grid`` (module docstring): each stretch between two impact pairs
    interpolated on its own, the pairs kept as they are."""
    t = hist["t"].to_numpy(float)
    pairs = _pairs(t)
    bounds = [0, *[int(i) + 1 for i in pairs]]          # first row of each stretch
    ends = [*[int(i) for i in pairs], t.size - 1]        # last row of each stretch
    tol = 1e-12 * max(1.0, float(t[-1]))
    parts = []
    for a, b in zip(bounds, ends):
        seg = hist.iloc[a:b + 1]
        lo, hi = float(t[a]), float(t[b])
        inner = grid[(grid > lo + tol) & (grid < hi - tol)]
        rows = {"t": np.concatenate([[lo], inner, [hi]]) if b > a else np.array([lo])}
        for c in hist.columns:
            if c == "t":
                continue
            mid = metrics.dense(seg, c, inner, declared.derivative(c)) if inner.size else np.zeros(0)
            ends_v = seg[c].to_numpy(float)[[0, -1]] if b > a else seg[c].to_numpy(float)[:1]
            rows[c] = np.concatenate([ends_v[:1], mid, ends_v[1:]])
        parts.append(pd.DataFrame(rows))
    return pd.concat(parts, ignore_index=True)[list(hist.columns)]


def one_sided(hist: pd.DataFrame, impacts: Sequence[float], tol: float) -> tuple[pd.DataFrame, int, float]:
    """``hist`` with each pair of rows written at one time within ``tol`` of an impact time
    of ``impacts`` moved to that impact's two sides (module docstring) — unless another row
    of the file lies between the two times (the file then says the impact came earlier or
    later, and its rows stand as written); (history, pairs moved, the largest shift [s])."""
    t = hist["t"].to_numpy(float).copy()
    imp = np.sort(np.asarray(list(impacts), float))
    moved, shift = 0, 0.0
    for i in _pairs(t) if imp.size else ():
        tau = float(imp[int(np.argmin(np.abs(imp - t[i])))])
        lo, hi = np.nextafter(tau, -np.inf), np.nextafter(tau, np.inf)
        clear = (i == 0 or t[i - 1] < min(lo, t[i])) and (i + 2 >= t.size or t[i + 2] > max(hi, t[i]))
        if abs(tau - t[i]) <= tol and clear:
            shift = max(shift, abs(tau - t[i]))
            t[i], t[i + 1] = lo, hi
            moved += 1
    return (hist.assign(t=t) if moved else hist), moved, shift


def split_truth_pairs(truth: pd.DataFrame, impacts: Sequence[float]) -> pd.DataFrame:
    """The truth's own pairs of rows at its ``impacts`` moved one unit in the last place to
    either side, so that its branches hold their limits at the impact."""
    t = truth["t"].to_numpy(float).copy()
    at = set(float(x) for x in impacts)
    for i in _pairs(t):
        if float(t[i]) in at:
            t[i], t[i + 1] = np.nextafter(t[i], -np.inf), np.nextafter(t[i], np.inf)
    return truth.assign(t=t)
