"""Determinism: a digest of a run's history, and the comparison of two tables' digests.

:func:`history_digest` is the SHA-256 of the history's column names and of its values
as little-endian float64 bytes, column after column — bitwise: nothing rounded. Two runs
of one integrator with the same settings on the same scene must give the same digest,
whether they ran in this process, in a worker process (``--jobs 2``) or on Dask; a
difference means a run depends on something it should not (uninitialised memory, the
order of a parallel reduction, state left by an earlier run in the process).
:func:`mismatches` lists the runs of two tables whose digests differ.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

#: columns that identify a run across tables (its scene variant and its settings)
RUN_KEYS = ("case", "scene_hash", "integrator", "settings")


def history_digest(hist: pd.DataFrame) -> str:
    """SHA-256 (hex) of a history: its column names, then each column's values as
    little-endian float64 bytes (non-numeric columns as their text)."""
    h = hashlib.sha256()
    h.update(("\x1f".join(map(str, hist.columns)) + f"\x1e{len(hist)}").encode())
    for c in hist.columns:
        col = hist[c]
        if pd.api.types.is_numeric_dtype(col) or pd.api.types.is_bool_dtype(col):
            h.update(np.ascontiguousarray(col.to_numpy(dtype="<f8")).tobytes())
        else:
            h.update("\x1f".join(map(str, col.tolist())).encode())
    return h.hexdigest()


def mismatches(a: pd.DataFrame, b: pd.DataFrame, keys: Sequence[str] = RUN_KEYS) -> pd.DataFrame:
    """The runs present in both tables (same ``keys``) whose ``digest`` differs; one row
    each with both digests. Rows without a digest (runs that gave no history) are left
    out. Empty when both tables agree."""
    keys = [k for k in keys if k in a.columns and k in b.columns]
    cols = keys + ["digest"]
    if "digest" not in a.columns or "digest" not in b.columns or not keys:
        return pd.DataFrame(columns=cols + ["digest_other"])
    x = a[cols].dropna(subset=["digest"]).drop_duplicates(keys)
    y = b[cols].dropna(subset=["digest"]).drop_duplicates(keys).rename(columns={"digest": "digest_other"})
    both = x.merge(y, on=keys, how="inner")
    return both[both["digest"] != both["digest_other"]].reset_index(drop=True)


def previous_table(path: Path) -> pd.DataFrame | None:
    """The table a command wrote last time at ``path`` (.parquet), to compare digests with
    the new run's; None when there is none or it cannot be read."""
    try:
        return pd.read_parquet(path) if Path(path).exists() else None
    except Exception:  # a damaged old table only means there is nothing to compare with
        return None


def mismatch_lines(old: pd.DataFrame | None, new: pd.DataFrame) -> list[str]:
    """'DETERMINISM: …' lines for the runs whose digest changed since ``old`` (same scene
    variant, integrator and settings); [] when none did or nothing can be compared."""
    if old is None:
        return []
    bad = mismatches(new, old)
    return [f"DETERMINISM: {r.get('integrator')} {r.get('settings')} on {r.get('case')}: history digest "
            f"{str(r['digest'])[:12]} now, {str(r['digest_other'])[:12]} in the previous run of the same "
            f"settings" for _, r in bad.iterrows()]
