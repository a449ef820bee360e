"""Checks of an external trajectory against its case: the metadata, the columns, the numbers,
the times (from the case's start t = 0 to its t_end, in seconds), the units and the start
values. Every refusal is an :class:`~.records.ExternalDataError` naming the column, row or
value and the fix."""

from __future__ import annotations

import math
from typing import Any, Iterable, Mapping, Sequence

import numpy as np
import pandas as pd

from daebench.core.observables import Observables
from daebench.core.params import did_you_mean
from daebench.harness.scoring import metrics
from daebench.harness.scoring.external.records import ExternalDataError, clip
from daebench.harness.scoring.graphdist import value_scale

#: times closer than this × max(1, t_end) [s] count as equal (the ends of the case's span)
TIME_TOL = 1e-9
#: columns besides the observables: the energy balance and the constraint residuals
ENERGY_COLUMNS = ("E", "D_impacts")
ENERGY_PREFIXES = ("E_", "W_")
RESIDUAL_COLUMNS = ("C", "Cdot", "Cddot")
#: unit factors told apart (the truth ÷ the file's values), with what they most likely mean
UNIT_FACTORS = ((180.0 / math.pi, "radians where the case declares degrees"),
                (math.pi / 180.0, "degrees where the case declares radians"),
                (1e-3, "a unit 1000× smaller (mm for m, mm/s for m/s, ms for s)"),
                (1e3, "a unit 1000× larger (km for m, kN for N)"),
                (1e-2, "a unit 100× smaller (cm for m)"),
                (-1.0, "the opposite sign convention"))
UNIT_FACTOR_RTOL = 0.02   # the fitted ratio within this of a factor …
UNIT_FIT_RTOL = 0.05      # … and the scaled values within this of the truth (RMS, relative): a unit error
UNIT_RAW_RTOL = 0.5       # … while the values as given are this far from it
#: time units told apart when the times overrun the span: the last time ÷ t_end near one of these
TIME_UNITS = ((1e3, "milliseconds"), (1e6, "microseconds"), (60.0, "a unit 60× smaller (s for min)"))
#: a start value differs from the case's when off by more than this × the column's scale
#: (the larger of |its start value| and the truth's range of it)
START_RTOL = 1e-6


def metadata(meta: Mapping[str, Any], overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The metadata with ``overrides`` (the command line's --label, --cost-s, --steps) applied
    and ``label``, ``cost_s`` (> 0 [s]) and ``steps`` (a positive integer) checked."""
    out = {str(k): v for k, v in meta.items()}
    out.update({k: v for k, v in (overrides or {}).items() if v is not None})
    if "cost_s" in out:
        try:
            c = float(out["cost_s"])
        except (TypeError, ValueError):
            c = math.nan
        if not (math.isfinite(c) and c > 0.0):
            raise ExternalDataError(f"the cost (cost_s) must be a positive number of seconds, got {clip(out['cost_s'])}")
        out["cost_s"] = c
    if "steps" in out:
        try:
            n = float(out["steps"])
        except (TypeError, ValueError):
            n = math.nan
        if not (math.isfinite(n) and n >= 1 and n == int(n)):
            raise ExternalDataError(f"the step count (steps) must be a positive integer, got {clip(out['steps'])}")
        out["steps"] = int(n)
    if "label" in out:
        label = str(out["label"]).strip()
        if not label or len(label) > 80 or any(c in label for c in "/\\\n\r\t") or label.startswith("."):
            raise ExternalDataError(f"the label {clip(out['label'])} cannot name a row: use up to 80 characters "
                                    f"without '/', '\\' or a leading '.', e.g. --label exudyn-genalpha")
        out["label"] = label
    return out


def accepted_columns(system: Any, declared: Observables) -> list[str]:
    """The observable columns of a model: its history's (``system.observables`` at the start)
    and those it declares."""
    q0, v0 = system.initial_state()
    names = list(system.observables(0.0, np.asarray(q0, float), np.asarray(v0, float)))
    return list(dict.fromkeys(names + [o.name for o in declared.declared]))


def is_energy(c: str) -> bool:
    return c in ENERGY_COLUMNS or c.startswith(ENERGY_PREFIXES)


def numeric(df: pd.DataFrame, what: str) -> pd.DataFrame:
    """Every column as float64; a column of non-numbers is refused (its first bad cell named)."""
    out = {}
    for c in df.columns:
        col = df[c]
        if pd.api.types.is_bool_dtype(col) or not pd.api.types.is_numeric_dtype(col):
            num = pd.to_numeric(col, errors="coerce")
            bad = num.isna() & col.notna()
            if bad.any() or pd.api.types.is_bool_dtype(col):
                k = int(np.flatnonzero(bad.to_numpy())[0]) if bad.any() else 0
                raise ExternalDataError(f"{what}: column {clip(str(c))} holds something other than numbers (row "
                                        f"{k + 1}: {clip(col.iloc[k])}); write plain numbers with '.' as the "
                                        f"decimal point")
            col = num
        out[str(c)] = col.to_numpy(dtype=float)
    return pd.DataFrame(out)


def check_finite(df: pd.DataFrame, what: str) -> None:
    for c in df.columns:
        v = df[c].to_numpy(float)
        bad = ~np.isfinite(v)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            where = f" (t = {df['t'].iloc[k]:.9g} s)" if c != "t" and "t" in df.columns else ""
            raise ExternalDataError(f"{what}: column '{c}' is {v[k]} in row {k + 1}{where}"
                                    + (f" and {int(bad.sum()) - 1} more rows" if bad.sum() > 1 else "")
                                    + "; a scored trajectory has finite values only (cut the file where the "
                                      "external run stopped and score a shorter case: --set t_end=…)")


def _unit_hint(t_max: float, t_end: float) -> str:
    ratio = t_max / t_end if t_end > 0 else math.nan
    for factor, unit in TIME_UNITS:
        if 0.5 * factor <= ratio <= 1.05 * factor:
            return f" — the times look like {unit} (the last is {ratio:.4g} × t_end): write t in seconds"
    return ""


def check_times(t: np.ndarray, t_end: float, what: str, trajectory: bool = True) -> None:
    """Times that never decrease, inside [0, t_end]; for a ``trajectory`` also at most two rows
    per time (an impact's two sides), starting at the case's start t = 0 and reaching t_end
    (an impacts table: sorted impact times only)."""
    tol = TIME_TOL * max(1.0, abs(t_end))
    d = np.diff(t)
    if (d < 0).any():
        k = int(np.flatnonzero(d < 0)[0])
        why = ("sort the rows by t (two rows with one time are an impact's two sides)" if trajectory
               else "sort the impacts by t")
        raise ExternalDataError(f"{what}: the times decrease at row {k + 2} (t = {t[k + 1]:.12g} s after "
                                f"{t[k]:.12g} s); {why}")
    same = d == 0
    if trajectory and (same[:-1] & same[1:]).any():
        k = int(np.flatnonzero(same[:-1] & same[1:])[0])
        raise ExternalDataError(f"{what}: three or more rows at t = {t[k]:.12g} s (rows {k + 1}–{k + 3}); at an "
                                f"impact write two rows, before and after, and no more")
    if t[0] < -tol or t[-1] > t_end + tol:
        bad = t[0] if t[0] < -tol else t[-1]
        raise ExternalDataError(f"{what}: t = {bad:.12g} s lies outside the case's span [0, {t_end:g}] s"
                                f"{_unit_hint(float(t[-1]), t_end)}; write times in [0, t_end] only (or score "
                                f"another span: --set t_end=…)")
    if not trajectory:
        return
    if t[0] > tol:
        raise ExternalDataError(f"{what}: the data start at t = {t[0]:.12g} s, after the case's start t = 0; give "
                                f"the rows from t = 0 (the start values are checked against the case's)")
    if t[-1] < t_end - tol:
        raise ExternalDataError(f"{what}: the data end at t = {t[-1]:.12g} s, before the case's t_end = {t_end:g} s; "
                                f"give the whole span, or score the case over what the file covers "
                                f"(--set t_end={t[-1]:.12g})")


def check_history(df: pd.DataFrame, t_end: float, observables: Sequence[str], scored: Sequence[str],
                  what: str = "the data") -> pd.DataFrame:
    """``df`` checked as an external history of a case whose observable columns are
    ``observables`` (``scored``: those its scene scores): returned as float columns, ``E`` added
    as the sum of the ``E_<term>`` columns when only those are given.

    Raises
    ------
    ExternalDataError
    """
    cols = [str(c) for c in df.columns]
    known = set(observables) | set(ENERGY_COLUMNS) | set(RESIDUAL_COLUMNS)
    if "t" not in cols:
        guess = next((c for c in cols if c.strip().lower() in ("t", "time", "time_s", "t_s", "t [s]", "time [s]")),
                     None)
        hint = f"; the column '{guess}' looks like it: name it 't'" if guess else ""
        shown = ", ".join(clip(c, 40) for c in cols[:20]) + (f" and {len(cols) - 20} more" if len(cols) > 20 else "")
        raise ExternalDataError(f"{what} has no time column 't' (columns: {shown or 'none'}){hint}. "
                                f"Write the times in seconds in a column named t")
    unknown = [c for c in cols if c != "t" and c not in known and not is_energy(c)]
    if unknown:
        c = unknown[0]
        raise ExternalDataError(f"{what}: unknown column {clip(c)}{did_you_mean(c[:200], [*observables, 't'])} The "
                                f"case's observables are {', '.join(observables)} (names and units: `daebench show "
                                f"CASE`); energy terms E, E_<term>, W_<effect>, D_impacts; residuals C, Cdot, Cddot")
    if not any(c in observables for c in cols):
        raise ExternalDataError(f"{what} holds no observable of the case (columns: {', '.join(cols)}); give at least "
                                f"one of {', '.join(scored or observables)}")
    if len(df) < 2:
        raise ExternalDataError(f"{what} has {len(df)} row(s); a trajectory needs at least two output times")
    out = numeric(df, what)
    check_finite(out, what)
    check_times(out["t"].to_numpy(float), t_end, what)
    terms = [c for c in out.columns if c.startswith("E_")]
    if "E" not in out.columns and terms:
        out["E"] = out[terms].sum(axis=1)
    return out


def check_units(history: pd.DataFrame, truth: pd.DataFrame, columns: Iterable[str], declared: Observables,
                what: str = "the data") -> None:
    """Refuse a column whose values are the truth's divided by a unit factor
    (:data:`UNIT_FACTORS`): the least-squares ratio s of the truth to the values, at the
    file's times, lies within :data:`UNIT_FACTOR_RTOL` of a factor, the scaled values fit the
    truth to :data:`UNIT_FIT_RTOL` (RMS, relative) and the values as given do not
    (:data:`UNIT_RAW_RTOL`). An integrator's error, however large, is not a constant factor.

    Raises
    ------
    ExternalDataError
    """
    t = history["t"].to_numpy(float)
    for c in columns:
        if c not in history.columns or c not in truth.columns:
            continue
        ref = metrics.interpolate(truth, c, t)
        val = history[c].to_numpy(float)
        ok = np.isfinite(ref) & np.isfinite(val)
        a, b = val[ok], ref[ok]
        nb, aa = float(np.sqrt(np.mean(b * b))) if b.size else 0.0, float(a @ a)
        if not (nb > 0.0 and aa > 0.0):
            continue
        s = float(a @ b) / aa
        fit = float(np.sqrt(np.mean((b - s * a) ** 2))) / nb
        raw = float(np.sqrt(np.mean((b - a) ** 2))) / nb
        for factor, meaning in UNIT_FACTORS:
            if abs(s / factor - 1.0) < UNIT_FACTOR_RTOL and fit < UNIT_FIT_RTOL and raw > UNIT_RAW_RTOL:
                unit = declared.get(c).unit
                raise ExternalDataError(
                    f"{what}: column '{c}' looks like a unit error — the truth is {s:.4g} × its values "
                    f"(≈ {factor:.4g}: likely {meaning}); the case declares {c} in {unit or 'its own unit'} "
                    f"(`daebench show CASE`). Convert the column and score again")


def start_mismatches(history: pd.DataFrame, start: Mapping[str, float], truth: pd.DataFrame,
                     declared: Observables) -> list[str]:
    """The columns whose value in the first row differs from the case's at t = 0 (``start``:
    the model's observables at the initial state) by more than :data:`START_RTOL` × the
    column's scale (the larger of |the start value| and the truth's range), one sentence each."""
    out = []
    for c, want in start.items():
        if c not in history.columns:
            continue
        got = float(history[c].iloc[0])
        rng = value_scale(truth[c].to_numpy(float)) if c in truth.columns else 0.0
        scale = max(abs(float(want)), rng, 1e-300)
        if not abs(got - float(want)) <= START_RTOL * scale:
            unit = declared.get(c).unit
            out.append(f"'{c}' is {got:.10g} {unit} at t = 0, the case's start is {float(want):.10g} {unit} "
                       f"(off by {got - float(want):+.3g} {unit})".replace("  ", " "))
    return out


#: the note of a file coarser than the case's output interval (:mod:`.grid`)
SPACING_NOTE = ("the file is coarser than the case's output interval ({rows} rows, largest spacing {dt:.4g} s > "
                "output.dt {out:.4g} s): scored on the case's {n} output times, the file interpolated between its "
                "rows (cubic Hermite where it holds the observable's derivative column, else linear: "
                "see the docs, score-external)")
