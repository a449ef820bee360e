"""The event sequence of an external trajectory: from an impacts table (given, or the file
``<stem>-impacts.csv`` beside the data file), else from the ``gap`` column — where it closes
(an event-driven code writes 0 at the impact, a capturing one a small penetration) and where
it turns back up short of closing (an event-capturing code such as Moreau–Jean's bounces with
a positive gap: its velocity-level law acts when the gap is about to close) —, else from the
repeated times of an event-driven file (contact unknown).

**Time stamps.** An event-driven code's impact is the time it writes twice; an
event-capturing code's is the end of the step in which its impulse acts (the first row whose
gap has turned back, or is closed). Either is matched to the truth's impact within the
event tolerance of :mod:`daebench.harness.scoring.eventseq`.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from daebench.core.params import did_you_mean
from daebench.harness.scoring.eventseq import ANY
from daebench.harness.scoring.external.checks import check_finite, check_times, numeric
from daebench.harness.scoring.external.reading import read_table
from daebench.harness.scoring.external.records import ExternalDataError, ExternalImpact, clip

#: a gap at or below this × the file's largest |gap| is closed
GAP_CLOSED = 1e-9
#: a gap that turns back up at a row whose gap is at most this × its change over the interval
#: before or after is a bounce short of closing (at the speed either side, the contact closes
#: within about one output interval; a smooth minimum changes by O(Δt²) only)
REVERSAL_REACH = 2.0
#: the impacts file found beside a data file FILE.csv
BESIDE = "{stem}-impacts.csv"


def gap_events(t: np.ndarray, gap: np.ndarray, contact: int = 0) -> list[ExternalImpact]:
    """Impacts from a gap series: closing episodes and bounces short of closing.

    An episode is a run of rows whose gap is closed (≤ :data:`GAP_CLOSED` × max |gap|) after
    an open row; it starts where the gap crosses zero (linear between the open row and the
    first closed one; at that row when its gap is 0, as an event-driven code writes it) and
    ends at its last closed row (an instantaneous bounce: t_end = t). A file that starts
    closed starts with no impact. A bounce short of closing is an open row k where the gap
    stops falling (g[k−1] > g[k] ≤ g[k+1]) with g[k] ≤ :data:`REVERSAL_REACH` × the larger of
    g[k−1] − g[k] and g[k+1] − g[k]: the impact is at t[k]."""
    t, g = np.asarray(t, float), np.asarray(gap, float)
    if not g.size:
        return []
    tol = GAP_CLOSED * max(float(np.max(np.abs(g))), 1e-300)
    closed = g <= tol
    out = []
    k = 1
    while k < g.size:
        if closed[k] and not closed[k - 1]:
            j = k
            while j + 1 < g.size and closed[j + 1]:
                j += 1
            g0, g1 = g[k - 1], g[k]
            t_hit = t[k] if g1 >= -tol else t[k - 1] + (t[k] - t[k - 1]) * g0 / (g0 - g1)
            still = j == g.size - 1
            out.append(ExternalImpact(float(t_hit), contact, float(t[j]), bool(still and t[j] > t[k]),
                                      float(np.min(g[k:j + 1]))))
            k = j + 1
        elif (not closed[k] and k + 1 < g.size and t[k] > t[k - 1] and g[k - 1] > g[k] <= g[k + 1]
              and g[k] <= REVERSAL_REACH * max(g[k - 1] - g[k], g[k + 1] - g[k])):
            out.append(ExternalImpact(float(t[k]), contact, float(t[k]), False, float(g[k])))
            k += 1
        else:
            k += 1
    return out


def repeated_time_events(t: np.ndarray) -> list[ExternalImpact]:
    """Impacts at the times an event-driven file writes twice (contact unknown)."""
    t = np.asarray(t, float)
    k = np.flatnonzero(np.diff(t) == 0)
    return [ExternalImpact(float(t[i])) for i in k]


def beside(path: Any) -> Path | None:
    """The impacts file beside a data file (:data:`BESIDE`), or None."""
    if not isinstance(path, (str, os.PathLike)):
        return None
    p = Path(path)
    cand = p.with_name(BESIDE.format(stem=p.stem))
    return cand if cand.is_file() else None


def read_impacts(data: Any, t_end: float, n_contacts: int, what: str = "the impacts file"
                 ) -> list[ExternalImpact]:
    """Impact records from a table with a column ``t`` [s] and optionally ``contact`` (an index
    0 … n_contacts − 1): a path to a CSV/Parquet file, a DataFrame, or a sequence of times or
    (t, contact) pairs. Several impacts may share a time (contacts striking together).

    Raises
    ------
    ExternalDataError
    """
    if not isinstance(data, (str, os.PathLike, pd.DataFrame)):
        try:
            rows = [(float(x), math.nan) if np.ndim(x) == 0 else (float(x[0]), float(x[1])) for x in data]
        except (TypeError, ValueError, IndexError):
            raise ExternalDataError(f"{what} must be a file, a DataFrame with columns t and contact, or a list of "
                                    f"times or (t, contact) pairs; got {clip(data)}") from None
        data = pd.DataFrame(rows, columns=["t", "contact"])
    df, _, source = read_table(data, what)
    if source != "DataFrame":
        what = f"{what} '{Path(source).name}'"
    cols = [str(c) for c in df.columns]
    if "t" not in cols:
        raise ExternalDataError(f"{what} has no column 't' (columns: {', '.join(cols) or 'none'}); give the impact "
                                f"times in a column t [s] and the contact index in a column contact")
    unknown = [c for c in cols if c not in ("t", "contact")]
    if unknown:
        raise ExternalDataError(f"{what}: unknown column {clip(unknown[0])}"
                                f"{did_you_mean(unknown[0][:200], ['t', 'contact'])} "
                                f"(an impacts table has the columns t and contact)")
    num = numeric(df, what)
    t = num["t"].to_numpy(float)
    check_finite(num[["t"]], what)
    if t.size:
        check_times(t, t_end, what, trajectory=False)
    contact = np.full(t.size, ANY)
    if "contact" in num.columns:
        c = num["contact"].to_numpy(float)
        known = np.isfinite(c)
        bad = known & ((c != np.round(c)) | (c < 0) | (c >= max(n_contacts, 1)))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ExternalDataError(f"{what}: contact {c[k]:g} in row {k + 1} is not a contact of the case (it has "
                                    f"{n_contacts} contact point(s), numbered 0 … {max(n_contacts - 1, 0)}); leave "
                                    f"the cell empty when the contact is not known")
        contact = np.where(known, c, ANY).astype(int)
    return [ExternalImpact(float(ti), int(ci)) for ti, ci in zip(t, contact)]
