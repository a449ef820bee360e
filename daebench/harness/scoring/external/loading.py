"""The whole input: a file (or DataFrame) read, checked against its case, with its event
sequence, its spacing and its notes (:func:`load`)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from daebench.core.observables import Observables
from daebench.harness.scoring.eventseq import ANY
from daebench.harness.scoring.external import events as ev
from daebench.harness.scoring.external.checks import SPACING_NOTE, accepted_columns, check_history, metadata
from daebench.harness.scoring.external.grid import SPACING_RTOL, output_times, resample, spacing
from daebench.harness.scoring.external.reading import read_table
from daebench.harness.scoring.external.records import ExternalData
from daebench.harness.sweeps.digest import history_digest


def _events(hist: Any, data: Any, impacts: Any, t_end: float, n_contacts: int) -> tuple[list, str, list[str]]:
    """(impacts, where they came from, notes) — the module docstring of
    :mod:`daebench.harness.scoring.external.events`."""
    t = hist["t"].to_numpy(float)
    found = ev.beside(data) if impacts is None else None
    if impacts is not None or found is not None:
        src = impacts if impacts is not None else found
        what = "the impacts file" + ("" if impacts is not None else " found beside the data")
        return ev.read_impacts(src, t_end, n_contacts, what), "impacts file", []
    if "gap" in hist.columns:
        one = 0 if n_contacts == 1 else ANY   # one gap column of several contacts: which is not known
        return ev.gap_events(t, hist["gap"].to_numpy(float), one), "gap column", []
    if n_contacts and (np.diff(t) == 0).any():
        return ev.repeated_time_events(t), "repeated times", []
    notes = ["no event sequence given (no impacts file, no gap column, no repeated time): the trajectory counts "
             "as one without impacts"] if n_contacts else []
    return [], "none", notes


def load(data: Any, t_end: float, system: Any, declared: Observables, scored: Sequence[str],
         impacts: Any = None, overrides: Mapping[str, Any] | None = None, what: str = "the data file",
         output_dt: float | None = None, allow_start_mismatch: bool = False) -> ExternalData:
    """An external trajectory checked against its case (end time ``t_end``, the built
    ``system``, the model's ``declared`` observables, the scene's ``scored`` ones, its
    ``output_dt``), with its event sequence (:mod:`.events`), its metadata (``overrides``:
    label, cost_s, steps) and, when coarser than ``output_dt``, resampled on the case's output
    times (:mod:`.grid`).

    Raises
    ------
    ExternalDataError
    """
    df, meta, source = read_table(data, what)
    if source != "DataFrame":
        what = f"{what} '{Path(source).name}'"
    meta = metadata(meta, overrides)
    if "label" not in meta and source != "DataFrame":
        meta["label"] = Path(source).stem
    hist = check_history(df, t_end, accepted_columns(system, declared), scored, what)
    n_contacts = int(system.n_contacts)
    events, events_from, notes = _events(hist, data, impacts, t_end, n_contacts)
    if events and "E" in hist.columns and "D_impacts" not in hist.columns and n_contacts:
        notes.append(f"{len(events)} impact(s) and energy terms but no D_impacts column: the energy the impacts "
                     f"took counts as energy-balance residual: write D_impacts, the energy lost at impacts so far "
                     f"(cumulative) [J]")
    missing = [c for c in scored if c not in hist.columns]
    if missing:
        notes.append(f"not in the file, not scored: {', '.join(missing)}")
    digest = history_digest(hist)
    dt = spacing(hist["t"].to_numpy(float))
    rows, resampled = len(hist), False
    if output_dt is not None and math.isfinite(dt) and dt > float(output_dt) * (1.0 + SPACING_RTOL):
        hist = resample(hist, output_times(t_end, float(output_dt)), declared)
        resampled = True
        notes.append(SPACING_NOTE.format(rows=rows, dt=dt, out=float(output_dt), n=len(hist)))
    src = source if source == "DataFrame" else Path(source).name
    return ExternalData(hist, tuple(events), events_from, meta, src, tuple(notes), dt, rows, resampled,
                        allow_start_mismatch, digest)
