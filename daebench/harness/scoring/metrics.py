"""Scores of one run: pure functions on time histories (pandas DataFrames).

Every function here takes histories as written by :mod:`daebench.driver.simulate` (one row
per output time, column ``t`` plus observables, energy terms, work, constraint
residuals) and returns plain numbers in a dict, so that a sweep row is the union of
the dicts. Nothing here runs a simulation, except :func:`time_call`, which only
times a callable.

Accuracy is measured in the spirit of DiffEqDevTools: a run is compared at its own
output times against the reference's dense interpolation (:func:`dense`, within the
reference's smooth segments between impacts), and the final, the max and the L2
(root-mean-square over the output times, i.e. √(∫e² dt / T)) errors are stored for
every observable; a plot later picks one. The impact-aware measures (before the first
impact, per re-synchronised window, energy per impact) are in
:mod:`daebench.harness.scoring.impact_metrics`.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
import pandas as pd

from daebench.core.observables import NONE, STATE_PREFIXES, Observables

GRID_POINTS = 2001             # default size of the uniform comparison grid
ENERGY_RTOL = 1e-6             # energy residual beyond this × energy scale is flagged
#: History columns that are bookkeeping, not observables.
_BOOKKEEPING_PREFIXES = ("E_", "W_", "lambda_", *STATE_PREFIXES)
_BOOKKEEPING = {"t", "E", "D_impacts", "energy_residual", "n_active", "C", "Cdot", "Cddot"}


# -- grids and interpolation --------------------------------------------------------
def uniform_grid(t0: float, t1: float, n: int = GRID_POINTS) -> np.ndarray:
    """``n`` equally spaced times from ``t0`` to ``t1`` (inclusive)."""
    if not t1 > t0:
        raise ValueError(f"empty time span [{t0}, {t1}]")
    return np.linspace(t0, t1, int(n))


def interpolate(hist: pd.DataFrame, column: str, grid: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``hist[column]`` onto ``grid`` (NaN outside the history).

    Duplicate times (an event written twice) keep the last value: the state after
    the event."""
    t = hist["t"].to_numpy(float)
    y = hist[column].to_numpy(float)
    keep = np.append(np.diff(t) > 0.0, True)
    t, y = t[keep], y[keep]
    out = np.interp(grid, t, y)
    out[(grid < t[0] - 1e-12) | (grid > t[-1] + 1e-12)] = np.nan
    return out


def observable_columns(hist: pd.DataFrame) -> list[str]:
    """The observable columns of a history (everything but time and bookkeeping)."""
    return [c for c in hist.columns
            if c not in _BOOKKEEPING and not c.startswith(_BOOKKEEPING_PREFIXES)
            and pd.api.types.is_numeric_dtype(hist[c])]


# -- accuracy ------------------------------------------------------------------------
def error_norms(err: np.ndarray, prefix: str) -> dict[str, float]:
    """Final, max and L2 (RMS over a uniform grid) of an error sample."""
    a = np.abs(np.asarray(err, float))
    if a.size == 0 or not np.all(np.isfinite(a)):
        return {f"{prefix}_final": math.nan, f"{prefix}_max": math.nan, f"{prefix}_l2": math.nan}
    return {f"{prefix}_final": float(a[-1]), f"{prefix}_max": float(a.max()),
            f"{prefix}_l2": float(np.sqrt(np.mean(a * a)))}


def accuracy(hist: pd.DataFrame, ref: pd.DataFrame, observables: Sequence[str] | None = None,
             n_grid: int | None = None, ref_impacts: Sequence[float] = (), declared: Observables = NONE
             ) -> dict[str, float]:
    """Errors of ``hist`` against ``ref`` for every observable both hold.

    By default (as DiffEqDevTools' ``errors``) the run is compared at its own output
    times over the reference's span, the reference interpolated there by :func:`dense`
    within each smooth segment between its ``ref_impacts`` (never across a velocity
    jump). ``declared`` (the model's :class:`daebench.core.observables.Observables`)
    names the error columns, gives each column's derivative for the interpolation and
    the positions scored as one Euclidean error. With ``n_grid`` both are instead linearly interpolated onto one uniform grid
    of that many points. A history that stops before the reference ends (a diverged or
    failed run) gets NaN errors: a partial trajectory has no comparable error.

    Raises
    ------
    ValueError
        If an observable asked for is not in the reference (a silently dropped score
        would read as "not measured").

    Returns
    -------
    dict
        ``err_<short>_{final,max,l2}`` per observable (its declared short name) and
        ``err_<point>_{final,max,l2}`` for the Euclidean error of each declared
        position whose two columns the reference holds. L2 is the RMS over the samples
        (uniform output times: √(∫e² dt / T)).
    """
    if observables:
        absent = [c for c in observables if c not in ref.columns]
        if absent:  # a score silently missing from a row reads as "not measured", not as an error
            raise ValueError(f"the reference has no column {', '.join(absent)}; it cannot score this run")
    cols = list(observables) if observables else observable_columns(ref)
    t0, t1 = float(ref["t"].iloc[0]), float(ref["t"].iloc[-1])
    reaches = len(hist) > 0 and float(hist["t"].iloc[-1]) >= t1 - 1e-9 * max(1.0, abs(t1))
    points = [p for p in declared.positions if p.x in ref.columns and p.y in ref.columns]
    need = list(dict.fromkeys(cols + [c for p in points for c in (p.x, p.y)]))
    if n_grid is not None:
        grid = uniform_grid(t0, t1, n_grid)
        ref_i = {c: interpolate(ref, c, grid) for c in need}
        run_i = {c: interpolate(hist, c, grid) if (reaches and c in hist.columns) else np.full_like(grid, np.nan)
                 for c in need}
    else:
        run_i, ref_i = _at_run_times(hist, ref, need, ref_impacts, reaches, t0, t1, declared)
    out: dict[str, float] = {}
    for c in cols:
        out.update(error_norms(run_i[c] - ref_i[c], f"err_{declared.get(c).score_name}"))
    for p in points:
        e = np.hypot(run_i[p.x] - ref_i[p.x], run_i[p.y] - ref_i[p.y])
        out.update(error_norms(e, f"err_{p.score_name}"))
        if p.angle:
            d = np.degrees(np.arctan2(run_i[p.y], run_i[p.x]) - np.arctan2(ref_i[p.y], ref_i[p.x]))
            out.update(error_norms((d + 180.0) % 360.0 - 180.0, f"err_{p.angle}"))
    return out


def _at_run_times(hist: pd.DataFrame, ref: pd.DataFrame, cols: Sequence[str], ref_impacts: Sequence[float],
                  reaches: bool, t0: float, t1: float, declared: Observables
                  ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The run's samples at its output times in [t0, t1] and the reference there, segment by segment."""
    if not reaches:
        nan = np.full(1, np.nan)
        return {c: nan for c in cols}, {c: nan for c in cols}
    run = hist[~hist["t"].duplicated(keep="last")]
    t = run["t"].to_numpy(float)
    sel = (t >= t0 - 1e-12) & (t <= t1 + 1e-12)
    run, t = run[sel], t[sel]
    ref_i = {c: np.full(t.size, np.nan) for c in cols}
    cuts = [-math.inf, *sorted(float(x) for x in ref_impacts), math.inf]
    for a, b in zip(cuts[:-1], cuts[1:]):
        seg = smooth_rows(ref, a, b)
        k = (t > a) & (t < b)
        for c in cols:
            ref_i[c][k] = dense(seg, c, t[k], declared.derivative(c))
    # samples the reference cannot give (between its last row and an impact) are dropped
    ok = np.all([np.isfinite(v) for v in ref_i.values()], axis=0) if cols else np.ones(t.size, bool)
    run_i = {c: run[c].to_numpy(float)[ok] if c in run.columns else np.full(int(ok.sum()), np.nan) for c in cols}
    return run_i, {c: v[ok] for c, v in ref_i.items()}


def smooth_rows(hist: pd.DataFrame, lo: float, hi: float) -> pd.DataFrame:
    """Rows with lo < t < hi, duplicate times dropped (the last kept: the state after an
    event)."""
    t = hist["t"].to_numpy(float)
    sel = (t > lo) & (t < hi)
    seg = hist[sel]
    return seg[~seg["t"].duplicated(keep="last")]


def dense(seg: pd.DataFrame, column: str, times: np.ndarray, derivative: tuple[str, float] | None = None
          ) -> np.ndarray:
    """``seg[column]`` at ``times``: cubic Hermite when ``derivative`` = (column of
    d(column)/dt, factor) is given and ``seg`` holds that column (error ≈ (ωΔt)⁴/384 of
    a tone's amplitude at output spacing Δt, against (ωΔt)²/8 linearly), else linear;
    NaN outside ``seg``'s span. ``seg`` must be one smooth segment (no velocity jump
    between rows). The model declares the derivative
    (:meth:`daebench.core.observables.Observables.derivative`)."""
    times = np.asarray(times, float)
    out = np.full(times.shape, np.nan)
    if len(seg) < 2 or column not in seg.columns:
        if len(seg) == 1 and column in seg.columns:
            out[np.isclose(times, float(seg["t"].iloc[0]), rtol=0, atol=1e-12)] = float(seg[column].iloc[0])
        return out
    t = seg["t"].to_numpy(float)
    y = seg[column].to_numpy(float)
    inside = (times >= t[0] - 1e-12) & (times <= t[-1] + 1e-12)
    if not inside.any():
        return out
    x = np.clip(times[inside], t[0], t[-1])
    if derivative is None or derivative[0] not in seg.columns:
        out[inside] = np.interp(x, t, y)
        return out
    d = seg[derivative[0]].to_numpy(float) * derivative[1]
    k = np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 2)
    h = t[k + 1] - t[k]
    s = (x - t[k]) / h
    h00, h10 = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2
    h01, h11 = s * s * (3 - 2 * s), s * s * (s - 1)
    out[inside] = h00 * y[k] + h10 * h * d[k] + h01 * y[k + 1] + h11 * h * d[k + 1]
    return out


# -- events ----------------------------------------------------------------------------
def impact_time_errors(times: Sequence[float], ref_times: Sequence[float]) -> dict[str, float]:
    """Impact times matched in order (the k-th impact against the k-th of the reference).

    Returns the count of each, the error of the first and second impact times and
    the max over the matched ones (NaN where an impact is missing)."""
    t = np.asarray(list(times), float)
    r = np.asarray(list(ref_times), float)
    k = min(t.size, r.size)
    d = np.abs(t[:k] - r[:k])
    out = {"impacts": int(t.size), "impacts_ref": int(r.size),
           "err_impact_t_max": float(d.max()) if k else math.nan}
    for j in (0, 1):
        out[f"err_impact{j + 1}_t"] = float(d[j]) if j < k else math.nan
    return out


def rebound_apex(hist: pd.DataFrame, impact_times: Sequence[float], column: str | None) -> tuple[float, float]:
    """(time, height) of the highest point of ``column`` between the first and the
    second impact (or the end), from the history. NaN if there is no rebound or no
    ``column`` (a model's height column: :meth:`daebench.core.observables.Observables.height_column`).
    """
    col = column if column in hist.columns else None
    times = list(impact_times)
    if col is None or not times or len(hist) == 0:
        return math.nan, math.nan
    t = hist["t"].to_numpy(float)
    lo = times[0]
    hi = times[1] if len(times) > 1 else t[-1]
    sel = (t > lo) & (t < hi)
    if not np.any(sel):
        return math.nan, math.nan
    y = hist[col].to_numpy(float)[sel]
    i = int(np.argmax(y))
    y0 = float(np.interp(lo, t, hist[col].to_numpy(float)))
    if not y[i] > y0 + 1e-12:  # never rose above the plane: no rebound
        return math.nan, math.nan
    return float(t[sel][i]), float(y[i])


def event_errors(hist: pd.DataFrame, impacts: Sequence[float], ref: pd.DataFrame,
                 ref_impacts: Sequence[float], declared: Observables = NONE) -> dict[str, float]:
    """Impact-time errors plus rebound-apex time and height errors against the reference
    (the height: the first of ``declared``'s heights the history holds)."""
    out = impact_time_errors(impacts, ref_impacts)
    ta, ya = rebound_apex(hist, impacts, declared.height_column(list(hist.columns)))
    tr, yr = rebound_apex(ref, ref_impacts, declared.height_column(list(ref.columns)))
    out.update({"apex_t": ta, "apex_height": ya,
                "err_apex_t": abs(ta - tr), "err_apex_height": abs(ya - yr)})
    return out


# -- energy -----------------------------------------------------------------------------
def energy_residual_series(hist: pd.DataFrame) -> np.ndarray:
    """E − E0 − ΣW + D_impacts recomputed from the history's columns (so that an
    inconsistent ``energy_residual`` column cannot hide a drift); falls back on the
    ``energy_residual`` column when the components are absent."""
    if "E" not in hist.columns:
        return hist["energy_residual"].to_numpy(float)
    E = hist["E"].to_numpy(float)
    work = sum((hist[c].to_numpy(float) for c in hist.columns if c.startswith("W_")), np.zeros_like(E))
    d_imp = hist["D_impacts"].to_numpy(float) if "D_impacts" in hist.columns else 0.0
    return E - E[0] - work + d_imp


def energy_scale(hist: pd.DataFrame) -> float:
    """A size for energies in this run: the largest |energy term| seen (≥ tiny)."""
    terms = [c for c in hist.columns if c.startswith("E_")] or ["E"]
    vals = np.abs(hist[terms].to_numpy(float))
    return float(max(np.nanmax(vals) if vals.size else 0.0, 1e-300))


def energy_balance(hist: pd.DataFrame, rtol: float = ENERGY_RTOL) -> dict[str, Any]:
    """Energy-balance residual: max and RMS over the output times, the final value,
    the same relative to the energy scale, and a flag ``energy_ok`` (max relative
    residual ≤ ``rtol``)."""
    r = energy_residual_series(hist)
    if r.size == 0 or not np.all(np.isfinite(r)):
        return {"energy_resid_max": math.nan, "energy_resid_rms": math.nan, "energy_resid_final": math.nan,
                "energy_resid_rel": math.nan, "energy_ok": False}
    scale = energy_scale(hist)
    rmax = float(np.max(np.abs(r)))
    return {"energy_resid_max": rmax, "energy_resid_rms": float(np.sqrt(np.mean(r * r))),
            "energy_resid_final": float(r[-1]), "energy_resid_rel": rmax / scale,
            "energy_ok": bool(rmax <= rtol * scale)}


# -- verdict ------------------------------------------------------------------------------
def stability_verdict(status: str, message: str, t_final: float, t_end: float) -> dict[str, Any]:
    """One word (completed, diverged, failed), the time it stopped and why."""
    reason = message or ("reached t_end" if status == "completed" else "")
    return {"verdict": status, "verdict_t": float(t_final) if t_final == t_final else math.nan,
            "verdict_reason": reason, "t_reached": float(t_final) / float(t_end) if t_end else math.nan}


# -- oscillation content -----------------------------------------------------------
TREND_DEGREE = 12   # Chebyshev degree of the slow motion removed before the spectrum
ZERO_PAD = 8        # FFT length / samples: keeps the scalloping loss of an off-bin tone < 1 %


def oscillation_spectrum(t: np.ndarray, x: np.ndarray, trend_degree: int = TREND_DEGREE
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectrum of the oscillation of ``x(t)`` about its slow trend.

    ``x`` is sampled at uniform times ``t``. The trend (e.g. the rigid swing of a beam)
    is a least-squares Chebyshev polynomial of ``trend_degree``; the remainder is
    Hann-windowed, zero-padded ``ZERO_PAD``× and transformed. A sinusoid of amplitude A
    appears as a peak of height A (the window's coherent gain is divided out) to about
    1 %. Returns (ω [rad/s], amplitude); the low end holds what the trend fit left.
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    if t.size < 4 * (trend_degree + 1):
        raise ValueError(f"need at least {4 * (trend_degree + 1)} samples for a spectrum, got {t.size}")
    dt = float(t[1] - t[0])
    if not np.allclose(np.diff(t), dt, rtol=1e-6, atol=0.0):
        raise ValueError("oscillation_spectrum needs uniformly sampled times")
    r = x - np.polynomial.Chebyshev.fit(t, x, trend_degree)(t)
    w = np.hanning(r.size)
    nfft = ZERO_PAD * (1 << int(math.ceil(math.log2(r.size))))
    amp = 2.0 * np.abs(np.fft.rfft(r * w, nfft)) / w.sum()
    return 2.0 * math.pi * np.fft.rfftfreq(nfft, dt), amp


TONE_GUARD_BINS = 16  # a tone is the largest amplitude within this many bins on each side


def highest_frequency_above(omega: np.ndarray, amp: np.ndarray, level: float, span: float
                            ) -> tuple[float, float]:
    """The highest tone of a spectrum from :func:`oscillation_spectrum` with an amplitude
    above ``level``: (its ω, its amplitude), or (0, 0) if none.

    ``span`` is the sampled time span (bin = 2π/span). A tone is a peak that is the
    largest value within ``TONE_GUARD_BINS`` bins on either side, which excludes the Hann
    sidelobes of stronger tones (−31 dB at 2.5 bins, falling 18 dB/octave: below 1e-3 of
    the tone beyond 16 bins). Two tones closer than that count as one (the stronger)."""
    d_omega = float(omega[1] - omega[0])
    guard = max(1, int(round(TONE_GUARD_BINS * 2.0 * math.pi / span / d_omega)))
    padded = np.concatenate([np.full(guard, -np.inf), amp, np.full(guard, -np.inf)])
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * guard + 1)
    tones = np.flatnonzero((amp > level) & (amp >= windows.max(axis=1)))
    if tones.size == 0:
        return 0.0, 0.0
    k = int(tones[-1])
    return float(omega[k]), float(amp[k])


def free_windows(hist: pd.DataFrame, min_length: float, breaks: Sequence[float] = ()
                 ) -> list[tuple[float, float]]:
    """Spans of the history with no closed contact (``n_active == 0`` at every output
    time) and no time of ``breaks`` (impacts: the velocity jumps there) inside, at least
    ``min_length`` long, trimmed by one output interval at each end (an event lies between
    two outputs)."""
    t = hist["t"].to_numpy()
    free = hist["n_active"].to_numpy() == 0 if "n_active" in hist else np.ones(t.size, bool)
    for tb in breaks:
        k = int(np.searchsorted(t, tb))
        free[max(k - 1, 0):k + 1] = False
    out, i = [], 0
    while i < t.size:
        if not free[i]:
            i += 1
            continue
        j = i
        while j + 1 < t.size and free[j + 1]:
            j += 1
        a = i + (1 if i > 0 else 0)
        b = j - (1 if j < t.size - 1 else 0)
        if b > a and t[b] - t[a] >= min_length:
            out.append((float(t[a]), float(t[b])))
        i = j + 1
    return out


def trusted_errors(hist: pd.DataFrame, ref: pd.DataFrame, ref_impacts: Sequence[float], trust_t: float,
                   columns: Sequence[str] | None = None, **kwargs: Any) -> dict[str, float]:
    """The run's errors on the trusted span: :func:`accuracy` on the run's rows at
    t ≤ trust_t against the reference cut at the last of them (the same keys, ``err_<obs>_{final,max,l2}``; NaN when the run stopped before trust_t).
    ``kwargs`` go to :func:`accuracy` (e.g. ``declared``)."""
    tol = 1e-12 * max(1.0, abs(float(trust_t)))
    h = hist[hist["t"] <= trust_t + tol]
    if not len(h) or float(hist["t"].iloc[-1]) < trust_t - tol:
        h = hist.iloc[:0]
    t_cut = float(h["t"].iloc[-1]) if len(h) else float(trust_t)
    r = ref[ref["t"] <= t_cut + tol]
    if len(r) < 2 and len(ref) >= 2:  # a span shorter than two reference rows has no comparable error
        r = ref[ref["t"] <= float(ref["t"].iloc[1]) + tol]
    return accuracy(h if len(h) else hist.iloc[:0], r, columns,
                    ref_impacts=[x for x in ref_impacts if x <= t_cut], **kwargs)
