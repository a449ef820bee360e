"""Error measures that survive impacts: scores of a run against its reference that do
not mix the integrator's error with the event sequence.

A whole-run error (:func:`daebench.harness.scoring.metrics.accuracy`) after the first impact measures
the impact-time error and the sequence of contact episodes as much as the integrator:
a run whose impact comes 1 µs early carries the velocity jump 1 µs early, and every
later window inherits the phase. The measures here separate the parts:

* **before the first impact** (:func:`pre_impact_errors`): the observables and
  positions the model declares with ``impact_windows``
  (:mod:`daebench.core.observables`) over [0, t₁_ref), the smooth part of the run —
  its error falls with the method's order;
* **the first impact time** (``err_impact1_t``, :func:`daebench.harness.scoring.metrics.impact_time_errors`);
* **each window after re-synchronising at its impact** (:func:`window_errors`): the
  run's window [t_k, t_k+1) is shifted onto the reference's matching window, so that the
  window error is the error of the flight that follows the k-th impact, not the
  accumulated phase;
* **energy lost per impact** against the exact Newton impact-map value at the run's own
  pre-impact state (:func:`impact_energy_scores`), and against the reference's loss.

Sampling (as DiffEqDevTools' ``errors``: the solution's saved points against the
reference's dense interpolation): a run is compared at its own output times, the
reference is interpolated there — by cubic Hermite where the history holds the
derivative the model declares for the column, linearly otherwise, and only
from reference rows inside the same smooth segment (never across an impact, where the
velocity jumps). References are stored oversampled (:data:`daebench.harness.references.reference.
REF_OVERSAMPLE`) so that the interpolation error is far below the errors scored.
"""

from __future__ import annotations

import json
import math
from typing import Any, Sequence

import numpy as np
import pandas as pd

from daebench.core.observables import NONE, Observable, Observables, Position
from daebench.harness.scoring.metrics import dense, error_norms, smooth_rows

#: an impact of the run is matched to the reference's k-th when it lies closer than this
#: fraction of the distance from the reference's k-th impact to its nearest neighbour
MATCH_FRACTION = 0.5


# -- sampling ---------------------------------------------------------------------------
def _columns(run: pd.DataFrame, ref: pd.DataFrame, observables: Sequence[Observable | str],
             pairs: Sequence[Position]) -> tuple[list[Observable], list[Position]]:
    both = set(run.columns) & set(ref.columns)
    cols = [o if isinstance(o, Observable) else Observable(o) for o in observables]
    return [o for o in cols if o.name in both], [p for p in pairs if p.x in both and p.y in both]


def segment_errors(run_seg: pd.DataFrame, ref_seg: pd.DataFrame, shift: float, cols: Sequence[Observable],
                   pairs: Sequence[Position]) -> dict[str, np.ndarray]:
    """Error samples of one smooth segment: the run at its own output times t, the
    reference at t − ``shift``; samples the reference segment does not cover are dropped
    (consistently for every column). Keys: the score names."""
    t = run_seg["t"].to_numpy(float)
    tr = t - shift
    ref_i = {o.name: dense(ref_seg, o.name, tr, (o.derivative, float(o.derivative_factor)) if o.derivative else None)
             for o in cols}
    for p in pairs:
        for c in (p.x, p.y):
            ref_i.setdefault(c, dense(ref_seg, c, tr))
    ok = np.ones(t.size, bool)
    for v in ref_i.values():
        ok &= np.isfinite(v)
    out = {o.score_name: (run_seg[o.name].to_numpy(float) - ref_i[o.name])[ok] for o in cols}
    for p in pairs:
        out[p.score_name] = np.hypot(run_seg[p.x].to_numpy(float) - ref_i[p.x],
                                     run_seg[p.y].to_numpy(float) - ref_i[p.y])[ok]
    return out


# -- before the first impact ---------------------------------------------------------------
def pre_impact_errors(run: pd.DataFrame, ref: pd.DataFrame, t_first_ref: float,
                      observables: Sequence[Observable | str] = (), pairs: Sequence[Position] = ()
                      ) -> dict[str, float]:
    """Final, max and L2 error over [0, t₁_ref) (``err_pre_<obs>_{final,max,l2}``): the
    run at its output times before the reference's first impact (a run that strikes
    earlier carries its jump into the last samples: that is its error), the reference
    from its rows before t₁_ref. Without reference impacts the span is the whole run.
    ``observables`` (declarations, or plain column names) and ``pairs`` are those the
    model scores around impacts (:meth:`daebench.core.observables.Observables.windowed`)."""
    t1 = t_first_ref if math.isfinite(t_first_ref) else math.inf
    cols, prs = _columns(run, ref, observables, pairs)
    e = segment_errors(smooth_rows(run, -math.inf, t1), smooth_rows(ref, -math.inf, t1), 0.0, cols, prs)
    out: dict[str, float] = {}
    for name, err in e.items():
        out.update(error_norms(err, f"err_pre_{name}"))
    return out


# -- impact matching and windows -----------------------------------------------------------
def match_impacts(times: Sequence[float], ref_times: Sequence[float], fraction: float = MATCH_FRACTION) -> int:
    """How many impacts match, in order: the run's k-th impact matches the reference's
    k-th when it lies within ``fraction`` × the distance from the reference's k-th impact
    to its nearest neighbour (to t = 0 for the first). Matching stops at the first pair
    that does not match — after it the two event sequences differ, and windows cannot be
    paired by their order any more."""
    r = np.asarray(list(ref_times), float)
    t = np.asarray(list(times), float)
    k = 0
    while k < min(t.size, r.size):
        left = r[k] - (r[k - 1] if k else 0.0)
        right = (r[k + 1] - r[k]) if k + 1 < r.size else math.inf
        if not abs(t[k] - r[k]) < fraction * min(left, right):
            break
        k += 1
    return k


def window_errors(run: pd.DataFrame, impacts: Sequence[float], ref: pd.DataFrame, ref_impacts: Sequence[float],
                  observables: Sequence[Observable | str] = (), pairs: Sequence[Position] = ()
                  ) -> dict[str, Any]:
    """Errors of the windows that follow each matched impact, re-synchronised.

    Window k of the reference is (t_k_ref, t_k+1_ref) (the last ends at the end of the
    run), the run's is (t_k, t_k+1); both start with the k-th impact and hold its
    contact episode and the flight to the next impact. The run's window is shifted by
    Δ_k = t_k − t_k_ref onto the reference's and compared over the shorter of the two
    lengths. Impacts are matched by :func:`match_impacts`; windows after the first
    unmatched impact are not scored. ``observables`` and ``pairs`` as for
    :func:`pre_impact_errors`.

    Returns
    -------
    dict
        ``windows_matched`` (scored windows), ``windows_ref`` (the reference's),
        ``err_win_<obs>_max`` (max over the scored windows) and ``_l2`` (RMS over all
        their samples), NaN unless every reference window was matched (a run with a
        different event sequence has no comparable window error), the same over the
        matched windows only as ``err_winm_<obs>_{max,l2}``, and per-window max errors as
        a JSON list ``win_<obs>_max``.
    """
    t_run, t_ref = list(map(float, impacts)), list(map(float, ref_impacts))
    k_match = match_impacts(t_run, t_ref)
    cols, prs = _columns(run, ref, observables, pairs)
    names = [o.score_name for o in cols] + [p.score_name for p in prs]
    end_run = float(run["t"].iloc[-1]) if len(run) else math.nan
    end_ref = float(ref["t"].iloc[-1])
    samples: dict[str, list[np.ndarray]] = {n: [] for n in names}
    for k in range(k_match):
        a_ref, a_run = t_ref[k], t_run[k]
        b_ref = t_ref[k + 1] if k + 1 < len(t_ref) else end_ref + 1e-12
        b_run = t_run[k + 1] if k + 1 < len(t_run) else end_run + 1e-12
        length = min(b_ref - a_ref, b_run - a_run)
        e = segment_errors(smooth_rows(run, a_run, a_run + length), smooth_rows(ref, a_ref, b_ref),
                           a_run - a_ref, cols, prs)
        for n in names:
            samples[n].append(e[n])
    out: dict[str, Any] = {"windows_matched": k_match, "windows_ref": len(t_ref)}
    complete = k_match == len(t_ref) and len(t_run) == len(t_ref)
    for n in names:
        per = [float(np.max(np.abs(s))) if s.size else math.nan for s in samples[n]]
        allv = np.concatenate(samples[n]) if samples[n] else np.zeros(0)
        mx = float(np.nanmax(per)) if any(math.isfinite(x) for x in per) else math.nan
        l2 = float(np.sqrt(np.mean(allv * allv))) if allv.size else math.nan
        out[f"err_winm_{n}_max"], out[f"err_winm_{n}_l2"] = mx, l2
        out[f"err_win_{n}_max"], out[f"err_win_{n}_l2"] = (mx, l2) if complete else (math.nan, math.nan)
        out[f"win_{n}_max"] = json.dumps([None if not math.isfinite(x) else x for x in per])
    return out


# -- energy lost per impact ----------------------------------------------------------------
def exact_impact_loss(system: Any, q: np.ndarray, v_minus: np.ndarray, contact: int, restitution: float,
                      t: float = 0.0) -> float:
    """Kinetic energy a Newton impact of restitution e removes at (q, v⁻):
    ½ (1 − e²) (g_q v⁻)² / (g_q P g_qᵀ), where P = M⁻¹ restricted to the bilateral
    constraints B (P = M⁻¹ − M⁻¹Bᵀ(BM⁻¹Bᵀ)⁻¹BM⁻¹; P = M⁻¹ without them, which gives the
    textbook ½(1−e²)(g_q v⁻)²/(g_q M⁻¹ g_qᵀ)). Other closed contacts are not included."""
    M = np.atleast_2d(system.mass(q))
    g = np.atleast_2d(system.gap_jacobian(q))[contact]
    Minv_g = np.linalg.solve(M, g)
    w = float(g @ Minv_g)
    B = np.atleast_2d(system.constraint_jacobian(t, q)).reshape(-1, M.shape[0])
    if B.shape[0]:
        MinvB = np.linalg.solve(M, B.T)
        c = B @ Minv_g
        w -= float(c @ np.linalg.solve(B @ MinvB, c))
    vn = float(g @ v_minus)
    return 0.5 * (1.0 - restitution ** 2) * vn * vn / w


def reference_impact_losses(ref: pd.DataFrame, ref_impacts: Sequence[float]) -> list[float]:
    """The reference's energy lost at each impact: the jump of its cumulative
    ``D_impacts`` between the rows that bracket the impact (NaN when another impact lies
    in the same bracket or the column is absent)."""
    if "D_impacts" not in ref.columns:
        return [math.nan] * len(ref_impacts)
    t = ref["t"].to_numpy(float)
    d = ref["D_impacts"].to_numpy(float)
    r = np.asarray(list(ref_impacts), float)
    out = []
    for ti in r:
        i0 = int(np.searchsorted(t, ti, side="left")) - 1    # last row before
        i1 = int(np.searchsorted(t, ti, side="right"))       # first row after
        if i0 < 0 or i1 >= t.size or np.sum((r > t[i0]) & (r < t[i1])) != 1:
            out.append(math.nan)
        else:
            out.append(float(d[i1] - d[i0]))
    return out


def impact_energy_scores(system: Any, impacts: Sequence[Any], restitution: float,
                         ref_losses: Sequence[float] = ()) -> dict[str, Any]:
    """Energy lost per impact against the exact impact-map value and the reference.

    ``impacts`` are the run's Impact records (:class:`daebench.core.contact.Impact`). For each
    record with a configuration and pre-impact velocities, the exact loss is
    :func:`exact_impact_loss` at that state with the contact law's e; the run's loss is the
    record's ``energy_loss`` (what the driver's impact map removed, or what a contact
    law dissipated over the episode). Returns ``impact_loss_dev_max`` [J] and
    ``impact_loss_dev_rel`` (÷ the largest exact loss; NaN where no record can be
    checked), the first impact's loss ``impact1_loss`` [J] and its error against the
    reference's first-impact loss ``err_impact1_loss`` [J], and both lists as JSON.
    """
    losses, exact = [], []
    for imp in impacts:
        losses.append(float(imp.energy_loss))
        if getattr(imp, "q", None) is None or getattr(imp, "v_minus", None) is None \
                or getattr(imp, "law", "") == "lzb":  # no state, or not Newton's law
            exact.append(math.nan)
        else:
            exact.append(exact_impact_loss(system, imp.q, imp.v_minus, int(imp.contact), restitution, float(imp.t)))
    ls, ex = np.asarray(losses, float), np.asarray(exact, float)
    ok = np.isfinite(ls) & np.isfinite(ex)
    dev = float(np.max(np.abs(ls[ok] - ex[ok]))) if ok.any() else math.nan
    scale = float(np.max(np.abs(ex[ok]))) if ok.any() else math.nan
    first = float(ls[0]) if ls.size else math.nan
    ref1 = float(ref_losses[0]) if len(ref_losses) else math.nan
    return {"impact_loss_dev_max": dev, "impact_loss_dev_rel": dev / scale if scale and scale > 0 else math.nan,
            "impact1_loss": first, "err_impact1_loss": abs(first - ref1),
            "impact_losses": json.dumps([x if math.isfinite(x) else None for x in losses]),
            "impact_losses_exact": json.dumps([x if math.isfinite(x) else None for x in exact])}


def impact_scores(run: pd.DataFrame, impacts: Sequence[Any], ref: pd.DataFrame, ref_impacts: Sequence[float],
                  system: Any = None, restitution: float = math.nan, declared: Observables = NONE) -> dict[str, Any]:
    """Every impact-aware score of one run (the union of the functions above), for the
    observables and positions ``declared`` with ``impact_windows``."""
    t_run = [float(i.t) for i in impacts]
    obs, pairs = declared.windowed([c for c in run.columns if c in ref.columns])
    out: dict[str, Any] = {}
    out.update(pre_impact_errors(run, ref, ref_impacts[0] if len(ref_impacts) else math.nan, obs, pairs))
    out.update(window_errors(run, t_run, ref, ref_impacts, obs, pairs))
    if system is not None and math.isfinite(restitution):
        out.update(impact_energy_scores(system, impacts, restitution, reference_impact_losses(ref, ref_impacts)))
    return out
