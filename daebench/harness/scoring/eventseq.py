"""Event sequences, classified: a run's impacts (event-capturing runs: contact episodes)
against the reference's, in order, per contact.

Whole-run errors after an impact mix the integrator with the event sequence: a run that
strikes twice where the reference strikes once is wrong in a way no trajectory norm
names. This module names it, with pure functions on impact records.

Matching rule
-------------
Impacts are grouped by contact (when either side does not say which contact struck — a
reference sidecar that stores times only — all impacts form one group). Within a group,
both sequences are sorted by time and paired **in order, one to one**, a run impact
r and a reference impact s being pairable when |r − s| ≤ ``tol`` (the row's
``impact_tol``). The pairing is the greedy two-pointer sweep: the earliest unpaired impacts
of both sides are paired when within ``tol``, otherwise the earlier of the two is left
unpaired. For points on a line with a distance threshold this gives a maximum one-to-one
order-preserving pairing (an exchange argument; tests check it against a general
bipartite maximum matching). Then:

* ``impacts_matched``: the pairs;
* ``impacts_merged``: matched run impacts that stand for several reference impacts: an
  unpaired reference impact of the same contact inside a matched run impact's *span*
  [t − tol, t_end + tol] is *absorbed* by it (the earliest such run impact). The span ends
  at the episode's end ``t_end`` (a persistent contact: an event-driven closed phase, an
  event-capturing episode of several steps; an episode still open at the end of the run
  spans to the end), at t for an instantaneous bounce. ``impacts_absorbed`` counts the
  absorbed reference impacts;
* ``impacts_missed``: reference impacts neither paired nor absorbed;
* ``impacts_spurious``: run impacts not paired.

So impacts_matched + impacts_absorbed + impacts_missed = the reference's count and
impacts_matched + impacts_spurious = the run's.

Chatter: within one contact, the impacts are scanned in time order; a window of length
``window`` (the row's ``chatter_window``) opened at an impact holds it and every later
impact up to ``window`` after it; a window with at least :data:`CHATTER_MIN` impacts is a
cluster (``chatter_clusters``), and the scan resumes after its last impact, otherwise at the
next impact.

Penetration: ``max_penetration`` [m] = the largest −gap of the run (≥ 0): from the records'
smallest gap over their episode (``min_gap``) and from a ``gap`` column of the history
when given; NaN when neither is known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Iterable, Sequence

import numpy as np

from daebench.core.params import ParamError

ANY = -1            #: contact index of an impact whose contact is not known
CHATTER_MIN = 3     #: impacts of one contact within the chatter window that make a cluster
#: defaults for a sweep row (:func:`default_windows`): the time tolerance is this fraction of
#: the horizon but at least TOL_STEPS steps; the chatter window CHATTER_FRACTION of the
#: horizon but at least CHATTER_STEPS steps
TOL_FRACTION, TOL_STEPS = 1e-3, 2.0
CHATTER_FRACTION, CHATTER_STEPS = 1e-2, 10.0


@dataclass(frozen=True)
class Event:
    """One impact (or contact episode): start time, contact (:data:`ANY` if unknown), end of
    its episode (NaN: instantaneous unless ``closed``), smallest gap over it (NaN: unknown)."""

    t: float
    contact: int = ANY
    t_end: float = math.nan
    closed: bool = False
    min_gap: float = math.nan

    def span_end(self) -> float:
        """Where the episode ends: t_end; +inf for a closed contact never released; t for a bounce."""
        if math.isfinite(self.t_end):
            return max(self.t, self.t_end)
        return math.inf if self.closed else self.t


@dataclass
class Classification:
    """Indices into the run's and the reference's event lists (as given, not sorted)."""

    matched: list[tuple[int, int]] = field(default_factory=list)     # (run, reference)
    absorbed: dict[int, list[int]] = field(default_factory=dict)     # run → reference impacts it absorbed
    missed: list[int] = field(default_factory=list)
    spurious: list[int] = field(default_factory=list)

    @property
    def merged(self) -> list[int]:
        """Run impacts that stand for several reference impacts."""
        return sorted(i for i, js in self.absorbed.items() if js)


def as_events(records: Iterable[Any]) -> list[Event]:
    """Events from impact records (:class:`daebench.core.contact.Impact` or anything with
    ``t`` and optionally ``contact``, ``t_end``, ``closed``, ``min_gap``), (t, contact) pairs
    or bare times (contact unknown). Non-finite times are refused."""
    out = []
    for r in records:
        if isinstance(r, Event):
            ev = r
        elif isinstance(r, (int, float, np.floating, np.integer)):
            ev = Event(float(r))
        elif isinstance(r, (tuple, list)):
            ev = Event(float(r[0]), int(r[1]) if len(r) > 1 else ANY)
        else:
            ev = Event(float(r.t), int(getattr(r, "contact", ANY)), float(getattr(r, "t_end", math.nan)),
                       bool(getattr(r, "closed", False)), float(getattr(r, "min_gap", math.nan)))
        if not math.isfinite(ev.t):
            raise ParamError(f"an impact at t = {ev.t} cannot be classified; impact times must be finite")
        out.append(ev)
    return out


def _check_positive(value: float, name: str) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ParamError(f"{name} must be a positive finite time in seconds, got {value!r}")
    return v


def _groups(run: Sequence[Event], ref: Sequence[Event]) -> list[tuple[list[int], list[int]]]:
    """Index lists (run, reference) per contact, each sorted by time; one group when a
    contact is unknown on either side."""
    def by_time(evs, idx):
        return sorted(idx, key=lambda k: (evs[k].t, k))
    if any(e.contact == ANY for e in (*run, *ref)):
        return [(by_time(run, range(len(run))), by_time(ref, range(len(ref))))]
    contacts = sorted({e.contact for e in (*run, *ref)})
    return [(by_time(run, [k for k, e in enumerate(run) if e.contact == c]),
             by_time(ref, [k for k, e in enumerate(ref) if e.contact == c])) for c in contacts]


def classify(run: Iterable[Any], ref: Iterable[Any], tol: float) -> Classification:
    """Pair, absorb and count the run's impacts against the reference's (module docstring).

    Parameters
    ----------
    run, ref
        Impact records, (t, contact) pairs or times (:func:`as_events`).
    tol
        Time tolerance [s] within which a run impact and a reference impact pair.
    """
    tol = _check_positive(tol, "the impact time tolerance")
    rv, fv = as_events(run), as_events(ref)
    out = Classification()
    for ri, fi in _groups(rv, fv):
        i = j = 0
        paired_ref: set[int] = set()
        matched_run: list[int] = []
        while i < len(ri) and j < len(fi):
            d = rv[ri[i]].t - fv[fi[j]].t
            if abs(d) <= tol:
                out.matched.append((ri[i], fi[j]))
                matched_run.append(ri[i])
                paired_ref.add(fi[j])
                i, j = i + 1, j + 1
            elif d < 0.0:
                i += 1
            else:
                j += 1
        paired_run = set(matched_run)
        out.spurious += [k for k in ri if k not in paired_run]
        for k in matched_run:
            out.absorbed.setdefault(k, [])
        for j in fi:
            if j in paired_ref:
                continue
            s = fv[j].t
            host = next((k for k in matched_run if rv[k].t - tol <= s <= rv[k].span_end() + tol), None)
            if host is None:
                out.missed.append(j)
            else:
                out.absorbed[host].append(j)
    out.matched.sort()
    out.spurious.sort()
    out.missed.sort()
    return out


def chatter_clusters(records: Iterable[Any], window: float, minimum: int = CHATTER_MIN) -> int:
    """Clusters of at least ``minimum`` impacts of one contact within ``window`` seconds
    (module docstring; impacts with unknown contact count as one contact)."""
    window = _check_positive(window, "the chatter window")
    evs = as_events(records)
    by_contact: dict[int, list[float]] = {}
    for e in evs:
        by_contact.setdefault(e.contact, []).append(e.t)
    n = 0
    for times in by_contact.values():
        t = np.sort(np.asarray(times, float))
        k = 0
        while k < t.size:
            last = int(np.searchsorted(t, t[k] + window, side="right"))  # impacts k … last−1 in the window
            if last - k >= minimum:
                n += 1
                k = last
            else:
                k += 1
    return n


def max_penetration(records: Iterable[Any], gap: Sequence[float] | np.ndarray | None = None) -> float:
    """Largest penetration −gap ≥ 0 [m] of a run, from its records' ``min_gap`` and a gap
    series; NaN when neither holds a finite value."""
    vals = [-e.min_gap for e in as_events(records) if math.isfinite(e.min_gap)]
    if gap is not None:
        g = np.asarray(gap, float)
        g = g[np.isfinite(g)]
        if g.size:
            vals.append(-float(g.min()))
    return max(0.0, max(vals)) if vals else math.nan


def default_windows(t_end: float, h: float = 0.0) -> tuple[float, float]:
    """(time tolerance, chatter window) of a sweep row: :data:`TOL_FRACTION` of the horizon
    but ≥ :data:`TOL_STEPS` steps h, and :data:`CHATTER_FRACTION` of it but ≥
    :data:`CHATTER_STEPS` steps (h = 0: an adaptive run, the fractions alone)."""
    t_end = _check_positive(t_end, "the horizon t_end")
    h = float(h) if h and math.isfinite(float(h)) else 0.0
    return max(TOL_FRACTION * t_end, TOL_STEPS * h), max(CHATTER_FRACTION * t_end, CHATTER_STEPS * h)


def sequence_scores(run: Iterable[Any], ref: Iterable[Any], tol: float, window: float,
                    gap: Sequence[float] | np.ndarray | None = None) -> dict[str, Any]:
    """The row's event-sequence columns: ``impacts_matched``, ``impacts_missed``,
    ``impacts_spurious``, ``impacts_merged``, ``impacts_absorbed``, ``chatter_clusters``
    (the run's) and ``chatter_clusters_ref``, ``max_penetration`` [m], the largest
    time error over the pairs ``err_impact_t_matched_max`` [s] (NaN without a pair), and
    the rule's parameters ``impact_tol`` and ``chatter_window`` [s]."""
    rv, fv = as_events(run), as_events(ref)
    c = classify(rv, fv, tol)
    dts = [abs(rv[i].t - fv[j].t) for i, j in c.matched]
    return {"impacts_matched": len(c.matched), "impacts_missed": len(c.missed),
            "impacts_spurious": len(c.spurious), "impacts_merged": len(c.merged),
            "impacts_absorbed": sum(len(v) for v in c.absorbed.values()),
            "chatter_clusters": chatter_clusters(rv, window), "chatter_clusters_ref": chatter_clusters(fv, window),
            "max_penetration": max_penetration(rv, gap),
            "err_impact_t_matched_max": max(dts) if dts else math.nan,
            "impact_tol": float(tol), "chatter_window": float(window)}


def measure(run: Any, truth: Any) -> dict[str, Any]:
    """The scoring pipeline's measure (:data:`daebench.harness.scoring.pipeline.MEASURES`): a run
    (its Impact records, the scene's horizon, a ``gap`` column if the history holds one)
    against its truth's impact times, with :func:`default_windows` of the horizon."""
    tol, window = default_windows(float(run.scene.t_end))
    gap = run.history["gap"].to_numpy(float) if "gap" in run.history.columns else None
    return sequence_scores(run.impacts, truth.impacts, tol, window, gap)
