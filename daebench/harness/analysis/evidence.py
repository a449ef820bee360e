"""Whether a setting's error can be trusted: the observed order of each setting series,
the runs outside the asymptotic regime, and the cost at which a setting *qualifies* for
a target error.

A **series** is the runs of one setting (one ``label`` of one case) at its steps h (or
tolerances tol), ordered coarse → fine. Runs that were not made (``skipped-…``) are not in
it; a run that did not complete (failed, diverged, error, timeout) is, with no error.

**Observed order** of a run: p = log(e_coarser / e) / log(x_coarser / x) against the next
coarser completed run of its series (x = h, or tol for an adaptive series: the declared
order of a tolerance series is 1, error ∝ tol). A run is **outside the asymptotic regime**
when its errors do not fall (p ≤ 0) or p is more than a factor :data:`FAR` from the
declared order (the integrator's ``capabilities.order``).

**Qualifying** (:func:`qualify`) for a target τ: let k be the coarsest run from which on
every run of the series completed and reaches τ (so none of its finer runs failed). The
setting qualifies at run k when the observed order over the evidence — run k, its finer
runs and, when the run just coarser than k completed without reaching τ, that run too —
is positive, which needs at least two completed runs. The cost is the CPU time (minimum
of the timed repeats) interpolated in (log error, log cost) between the bracketing runs
k − 1 and k ('interpolated'), else run k's own ('at a run'; 'bound' when k is the
series' cheapest run: the target may be reached cheaper still). A run coarser than k that
did not complete is the setting's **stability limit**, stated with it. When a setting does
not qualify, ``missing`` says what would make it ("run finer steps of hht").
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import pandas as pd

#: an observed order outside [declared / FAR, declared · FAR] is outside the asymptotic regime
FAR = 2.0
#: the cost column recommendations and profiles rank by, and the steps read at the same point
COST = "cpu_s"
SPREAD = "cpu_spread"


def step_of(row: Mapping[str, Any]) -> tuple[str, float]:
    """('tol', value) for a tolerance run, ('h', value) for a fixed-step one, ('', NaN)
    for a run at its defaults."""
    for k in ("tol", "h"):
        v = row.get(k)
        if isinstance(v, (int, float)) and math.isfinite(float(v)) and float(v) > 0:
            return k, float(v)
    return "", math.nan


def setting_text(row: Mapping[str, Any]) -> str:
    """'h=5e-05', 'tol=1e-06' or 'defaults'."""
    k, x = step_of(row)
    return f"{k}={x:g}" if k else "defaults"


def declared_order(integrator: str, kind: str) -> float:
    """The order a series should show: 1 for a tolerance series, the integrator's declared
    order for a step series (NaN for an integrator not registered here)."""
    if kind == "tol":
        return 1.0
    from daebench.integrators import registry as integrator_registry  # lazy: it loads every integrator plugin

    try:
        return float(integrator_registry.get_integrator(integrator).capabilities.order)
    except Exception:  # noqa: BLE001 - an unknown or broken plugin: no declared order to compare with
        return math.nan


def series(g: pd.DataFrame) -> pd.DataFrame:
    """The runs of one setting that were made, ordered coarse → fine (a run at its
    defaults first)."""
    made = g[~g["status"].astype(str).str.startswith("skipped")] if "status" in g else g
    x = made.apply(lambda r: step_of(r)[1], axis=1) if len(made) else pd.Series([], dtype=float)
    return made.assign(_x=x).sort_values("_x", ascending=False, kind="stable", na_position="first")


def _err(r: Mapping[str, Any], measure: str) -> float:
    if str(r.get("status", "completed")) != "completed":
        return math.nan
    v = pd.to_numeric(r.get(measure, math.nan), errors="coerce")
    return float(v) if v is not None and math.isfinite(float(v)) else math.nan


def regime(p: float, declared: float) -> str:
    """'' inside the asymptotic regime, else why not (errors not falling, order far from
    the declared one); '' for an unknown order."""
    if not math.isfinite(p):
        return ""
    if p <= 0.0:
        return "errors not falling"
    if math.isfinite(declared) and not (declared / FAR <= p <= declared * FAR):
        return f"order {p:.2g} far from {declared:g}"
    return ""


def observed_orders(df: pd.DataFrame, measure: str, order_of: Callable[[str, str], float] = declared_order,
                    by: Sequence[str] = ("case", "label")) -> pd.DataFrame:
    """Per run of ``df`` (same index): ``order`` (observed, against the next coarser
    completed run of its series; NaN for the coarsest or a run without an error),
    ``declared`` and ``regime`` ('' or why the run is outside the asymptotic regime)."""
    out = pd.DataFrame({"order": math.nan, "declared": math.nan, "regime": ""}, index=df.index)
    if measure not in df.columns or not len(df):
        return out
    keys = [k for k in by if k in df.columns]
    for _, g in df.groupby(keys, sort=False, dropna=False) if keys else [((), df)]:
        s = series(g)
        prev: tuple[float, float] | None = None
        for i, r in s.iterrows():
            kind, x = step_of(r)
            e = _err(r, measure)
            dec = order_of(str(r.get("integrator", "")), kind)
            out.at[i, "declared"] = dec
            if not (math.isfinite(e) and e > 0 and kind):
                continue
            if prev is not None and prev[0] != x:
                p = math.log(prev[1] / e) / math.log(prev[0] / x)
                out.at[i, "order"] = p
                out.at[i, "regime"] = regime(p, dec)
            prev = (x, e)
    return out


def fitted_order(xs: Sequence[float], es: Sequence[float]) -> float:
    """Least-squares slope of log e against log x (NaN for fewer than two distinct x)."""
    x = np.log(np.asarray(xs, float))
    e = np.log(np.asarray(es, float))
    if x.size < 2 or np.ptp(x) == 0:
        return math.nan
    return float(np.polyfit(x, e, 1)[0])


def _interp(a: float, b: float, s: float) -> float:
    return math.exp((1 - s) * math.log(a) + s * math.log(b)) if a > 0 and b > 0 else math.nan


def qualify(s: pd.DataFrame, measure: str, target: float, declared: float = math.nan) -> dict[str, Any]:
    """Whether one series (:func:`series`, coarse → fine) qualifies for ``target`` on
    ``measure``, and at what cost (module docstring).

    Returns
    -------
    dict
        ``qualified``, ``reach_cpu_s``, ``reach_steps``, ``reach_kind``, ``at`` (the run or the
        bracket, in words), ``order`` (fitted over the evidence), ``declared``, ``regime``,
        ``evidence`` (runs), ``limit`` (the stability limit, '' if none), ``spread`` (the
        CPU spread of the runs the cost comes from), ``best_err``, ``missing`` ('' when
        it qualifies).
    """
    rows = [r for _, r in s.iterrows()]
    errs = [_err(r, measure) for r in rows]
    name = str(rows[0].get("label", rows[0].get("integrator", "?"))) if rows else "?"
    kind0 = step_of(rows[-1])[0] if rows else ""
    word = "tolerances" if kind0 == "tol" else "steps"
    fin = [e for e in errs if math.isfinite(e)]
    out: dict[str, Any] = {"qualified": False, "reach_cpu_s": math.nan, "reach_steps": math.nan, "reach_kind": "not qualified",
                           "at": "", "order": math.nan, "declared": declared, "regime": "", "evidence": 0,
                           "limit": "", "spread": math.nan, "best_err": min(fin) if fin else math.nan,
                           "missing": ""}
    if not fin:
        out["reach_kind"] = "no points"
    if not rows:
        out["missing"] = f"run {name}"
        return out
    k = len(rows)
    while k > 0 and math.isfinite(errs[k - 1]) and errs[k - 1] <= target:
        k -= 1
    if k == len(rows):
        last = rows[-1]
        out["missing"] = (f"{name} at its finest {setting_text(last)} {last['status']}" if not math.isfinite(errs[-1])
                          else f"run finer {word} of {name} (its finest, {setting_text(last)}, reaches "
                               f"{errs[-1]:.3g})")
        return out
    bracket = k > 0 and math.isfinite(errs[k - 1])
    ev = list(range(k - 1 if bracket else k, len(rows)))
    xs = [step_of(rows[i])[1] for i in ev]
    pos = [i for i, x in zip(ev, xs) if math.isfinite(x) and errs[i] > 0]
    p = fitted_order([step_of(rows[i])[1] for i in pos], [errs[i] for i in pos])
    failed = [i for i in range(k) if not math.isfinite(errs[i])]
    if failed:
        j = failed[-1]
        out["limit"] = f"{rows[j]['status']} at {setting_text(rows[j])}"
    out.update(order=p, evidence=len(ev), regime=regime(p, declared))
    if not math.isfinite(p):
        out["missing"] = f"run finer {word} of {name} (one run reaching it shows no order)"
        return out
    if p <= 0:
        out["missing"] = (f"{name}'s errors do not fall from {setting_text(rows[ev[0]])} to "
                          f"{setting_text(rows[ev[-1]])} (observed order {p:.2g}): run finer {word} of {name}")
        return out
    cost = [float(pd.to_numeric(r.get(COST, math.nan), errors="coerce")) for r in rows]
    steps = [float(pd.to_numeric(r.get("steps", math.nan), errors="coerce")) for r in rows]
    spread = [float(pd.to_numeric(r.get(SPREAD, math.nan), errors="coerce")) for r in rows]
    if bracket and errs[k] < target:
        a = k - 1
        t = (math.log(target) - math.log(errs[a])) / (math.log(errs[k]) - math.log(errs[a]))
        out.update(reach_cpu_s=_interp(cost[a], cost[k], t), reach_steps=_interp(steps[a], steps[k], t),
                   reach_kind="interpolated", at=f"between {setting_text(rows[a])} and {setting_text(rows[k])}",
                   spread=max(spread[a], spread[k]))
    else:
        out.update(reach_cpu_s=cost[k], reach_steps=steps[k], reach_kind="bound" if k == 0 else "at a run",
                   at=setting_text(rows[k]), spread=spread[k])
    out["qualified"] = math.isfinite(out["reach_cpu_s"])
    if not out["qualified"]:
        out["missing"] = f"{name} has no CPU time recorded"
    return out


def verdict_table(df: pd.DataFrame, targets: Mapping[str, Sequence[float]], setting: str = "label",
                  order_of: Callable[[str, str], float] = declared_order) -> pd.DataFrame:
    """:func:`qualify` for every (case, setting, measure, target) of a scored table: one
    row each, with ``case``, ``label``, ``integrator``, ``measure``, ``target`` and the keys
    of :func:`qualify`."""
    rows = []
    keys = ["case", setting] if "case" in df.columns else [setting]
    for key, g in df.groupby(keys, sort=False, dropna=False):
        key = key if isinstance(key, tuple) else (key,)
        s = series(g)
        if not len(s):
            continue
        integ = str(s["integrator"].iloc[0]) if "integrator" in s else ""
        dec = order_of(integ, step_of(s.iloc[-1])[0])
        for m, ts in targets.items():
            for t in ts:
                rows.append({**dict(zip(keys, key)), "integrator": integ, "measure": m, "target": float(t),
                             **qualify(s, m, float(t), dec)})
    return pd.DataFrame(rows)
