"""Cost to reach an accuracy: from the work–precision points of one integrator setting
(the rows of one label on one case, across its steps or tolerances), the wall time and
the steps at which its error on a chosen measure falls to a target τ.

**The rule** (:func:`cost_to_reach`), for one setting, one measure and one cost column:

1. Points are the runs with a finite, positive error and a finite, positive cost (a run
   that did not complete has a NaN error and takes no part; an error of exactly 0 has no
   logarithm and is dropped).
2. *Non-monotone points*: sorted by cost, a run is kept only when its error is strictly
   smaller than that of every cheaper run (the lower envelope, "the most accurate run
   for its price"); a dearer run that is not more accurate says nothing about what the
   setting can reach cheaply. Along the kept points the error falls strictly with cost.
3. The first kept point with error ≤ τ is the cheapest run that reaches τ. If it is not
   the first kept point, the cost is interpolated linearly in (log error, log cost)
   between it and the kept point before it: exact for a power law error = C·h^p with
   cost = K/h. ``kind = 'interpolated'`` (``'at a run'`` when τ equals a run's error).
4. If even the cheapest kept run is at least as accurate as τ, τ is reached at that
   run's cost or less; the cost is that run's (an upper bound: never extrapolated below
   it), ``kind = 'bound'``.
5. If no run reaches τ (τ below the smallest error), the cost is NaN,
   ``kind = 'not reached'``; never extrapolated.

:func:`reach_table` applies the rule to every (case, setting, measure, target) of a
scored sweep table and returns one row each: the column set ``reach_<cost>`` (e.g.
``reach_wall_s``, ``reach_steps``: the envelope is that of the first cost column, and the
others are read between the same two runs at the same point, :func:`reach_costs`),
``reach_kind``, ``reached`` and the setting's run summary (runs, completed, best error,
the first failure's reason).
"""

from __future__ import annotations

import math
from typing import Any, Iterable, Mapping, Sequence

import numpy as np
import pandas as pd

from daebench.core.params import ParamError

#: cost columns of a sweep row that a reach table reports by default
COST_COLUMNS = ("wall_s", "steps")
#: columns that name one integrator setting within a case (its steps/tolerances vary)
SETTING_KEYS = ("case", "label")
KINDS = ("interpolated", "at a run", "bound", "not reached", "no points")


def _positive_finite(x: np.ndarray) -> np.ndarray:
    return np.isfinite(x) & (x > 0.0)


def envelope_index(err: Sequence[float], cost: Sequence[float]) -> np.ndarray:
    """Indices (into the runs given) of the points of rule 1–2: finite positive (error,
    cost) pairs, sorted by cost, each strictly more accurate than every cheaper one (ties
    in cost: the smaller error)."""
    e = np.asarray(err, float)
    c = np.asarray(cost, float)
    if e.shape != c.shape:
        raise ParamError(f"errors and costs must have one value per run; got {e.size} errors and {c.size} costs")
    idx = np.nonzero(_positive_finite(e) & _positive_finite(c))[0]
    idx = idx[np.lexsort((e[idx], c[idx]))]
    keep, best = [], math.inf
    for i in idx:
        if e[i] < best:
            keep.append(int(i))
            best = e[i]
    return np.asarray(keep, int)


def envelope(err: Sequence[float], cost: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """The (error, cost) points of rule 1–2 (:func:`envelope_index`)."""
    k = envelope_index(err, cost)
    return np.asarray(err, float)[k], np.asarray(cost, float)[k]


def _check_target(target: float) -> float:
    t = float(target)
    if not (math.isfinite(t) and t > 0.0):
        raise ParamError(f"a target error must be a finite positive number, got {target!r} "
                         f"(e.g. 1e-3, in the measure's units)")
    return t


def cost_to_reach(err: Sequence[float], cost: Sequence[float], target: float) -> tuple[float, str]:
    """The cost at which a setting's error falls to ``target`` (rules in the module
    docstring) and how it was found.

    Parameters
    ----------
    err : the setting's errors on one measure, one per run (NaN for runs without one)
    cost : the same runs' costs (wall time [s], steps, …)
    target : the target error τ, in the measure's units (> 0)

    Returns
    -------
    (cost, kind)
        ``kind`` is 'interpolated', 'at a run', 'bound' (τ is at least the cheapest run's
        error: its cost is an upper bound), 'not reached' (NaN) or 'no points' (NaN).

    Raises
    ------
    ParamError
        For a non-finite or non-positive target, or lengths that differ.
    """
    tau = _check_target(target)
    e, c = envelope(err, cost)
    if e.size == 0:
        return math.nan, "no points"
    hit = np.nonzero(e <= tau)[0]
    if hit.size == 0:
        return math.nan, "not reached"
    j = int(hit[0])
    if j == 0:
        return float(c[0]), "at a run" if e[0] == tau else "bound"
    if e[j] == tau:
        return float(c[j]), "at a run"
    le0, le1 = math.log(e[j - 1]), math.log(e[j])
    s = (math.log(tau) - le0) / (le1 - le0)          # in (0, 1): strictly between the two runs
    return float(math.exp((1.0 - s) * math.log(c[j - 1]) + s * math.log(c[j]))), "interpolated"


def reach_costs(err: Sequence[float], costs: Sequence[Sequence[float]], target: float) -> tuple[list[float], str]:
    """:func:`cost_to_reach` on the first cost column, and every other column read at the
    same point: between the same two runs, at the same fraction of the log error (so that
    the wall time and the steps of one answer come from the same runs)."""
    tau = _check_target(target)
    e = np.asarray(err, float)
    cols = [np.asarray(c, float) for c in costs]
    k = envelope_index(e, cols[0])
    if k.size == 0:
        return [math.nan] * len(cols), "no points"
    hit = np.nonzero(e[k] <= tau)[0]
    if hit.size == 0:
        return [math.nan] * len(cols), "not reached"
    j = int(hit[0])
    if j == 0 or e[k[j]] == tau:
        kind = "at a run" if e[k[j]] == tau else "bound"
        return [float(c[k[j]]) for c in cols], kind
    a, b = k[j - 1], k[j]
    s = (math.log(tau) - math.log(e[a])) / (math.log(e[b]) - math.log(e[a]))
    out = [float(math.exp((1.0 - s) * math.log(c[a]) + s * math.log(c[b])))
           if c[a] > 0 and c[b] > 0 and math.isfinite(c[a]) and math.isfinite(c[b]) else math.nan for c in cols]
    return out, "interpolated"


def _first_failure(rows: pd.DataFrame) -> str:
    bad = rows[rows["status"].astype(str) != "completed"] if "status" in rows else rows.iloc[:0]
    if not len(bad):
        return ""
    real = bad[~bad["status"].astype(str).str.startswith("skipped")]   # a failure before a run not made
    r = (real if len(real) else bad).iloc[0]
    msg = str(r.get("message", "") or "").strip().replace("\n", " ")
    where = _run_setting(r)
    return f"{r['status']}{' at ' + where if where else ''}" + (f": {msg[:160]}" if msg and msg != "nan" else "")


def _run_setting(r: Mapping[str, Any]) -> str:
    """'h=5e-05' or 'tol=1e-06' for a row of a sweep ('' if neither)."""
    for k in ("tol", "h"):
        v = r.get(k)
        if isinstance(v, (int, float)) and math.isfinite(float(v)):
            return f"{k}={float(v):g}"
    return ""


def parse_targets(spec: Iterable[str]) -> dict[str, list[float]]:
    """``["err_x_max=1e-2,1e-3", …]`` → {measure: [targets]}.

    Raises
    ------
    ParamError
        For a malformed entry or a target that is not finite and positive.
    """
    out: dict[str, list[float]] = {}
    for item in spec:
        m, sep, vals = str(item).partition("=")
        if not sep or not m.strip() or not vals.strip():
            raise ParamError(f"--target '{item}' must be MEASURE=v1,v2 (e.g. err_x_max=1e-2,1e-3)")
        try:
            ts = [_check_target(float(v)) for v in vals.split(",") if v.strip()]
        except ValueError:
            raise ParamError(f"--target '{item}': the targets must be numbers, e.g. err_x_max=1e-2,1e-3") from None
        out.setdefault(m.strip(), []).extend(ts)
    return out


def decade_targets(values: Iterable[float], most: int = 3) -> list[float]:
    """Default targets of a measure: the powers of ten between the lower and the upper
    quartile of the finite positive errors given (pooled over the runs that will be
    compared), at most ``most`` of them around the middle; when the quartiles enclose no
    power of ten, the one nearest their geometric mean. [] for no finite error."""
    v = np.asarray([x for x in values if isinstance(x, (int, float)) and math.isfinite(x) and x > 0], float)
    if v.size == 0:
        return []
    lo, hi = np.log10(np.quantile(v, 0.25)), np.log10(np.quantile(v, 0.75))
    ks = list(range(math.ceil(lo - 1e-12), math.floor(hi + 1e-12) + 1))
    if not ks:
        ks = [round(0.5 * (lo + hi))]
    while len(ks) > most:
        ks = ks[1:] if len(ks) % 2 == 0 else ks[1:-1]
    return [float(10.0 ** k) for k in sorted(ks, reverse=True)]


def reach_table(df: pd.DataFrame, targets: Mapping[str, Sequence[float]],
                costs: Sequence[str] = COST_COLUMNS, by: Sequence[str] = SETTING_KEYS) -> pd.DataFrame:
    """Cost to reach each target, per setting: one row per (``by``…, measure, target).

    Parameters
    ----------
    df : a scored sweep table (one row per run: ``status``, the measures, the costs)
    targets : {measure column: [target errors in its units]}; a measure the table lacks
        gives rows with kind 'no points'
    costs : cost columns (default wall time and steps)
    by : columns that name a setting (default case and label: the runs of one label are
        its steps or tolerances)

    Returns
    -------
    pandas.DataFrame
        Columns: ``by``…, ``integrator``, ``measure``, ``target``, ``reach_<cost>`` per
        cost, ``reach_kind`` (of the first cost column), ``reached``, ``runs``,
        ``completed``, ``best_err`` and ``failure`` (the first run that failed, diverged or
        gave no verdict, else the first one skipped, with its reason; '' if none).

    Raises
    ------
    ParamError
        For a table without the ``by`` or cost columns, or a bad target.
    """
    missing = [c for c in list(by) + list(costs) if c not in df.columns]
    if missing:
        raise ParamError(f"the table has no column {', '.join(missing)}; a reach table needs a scored sweep "
                         f"table (daebench.bench or daebench compare)")
    rows = []
    for key, g in df.groupby(list(by), sort=False, dropna=False):
        key = key if isinstance(key, tuple) else (key,)
        done = g[g["status"].astype(str) == "completed"] if "status" in g else g
        base = {**dict(zip(by, key)), "integrator": str(g["integrator"].iloc[0]) if "integrator" in g else "",
                "runs": len(g), "completed": len(done), "failure": _first_failure(g)}
        for m, ts in targets.items():
            err = pd.to_numeric(done[m], errors="coerce").to_numpy(float) if m in done else np.array([])
            best = float(np.nanmin(err)) if err.size and np.isfinite(err).any() else math.nan
            for t in ts:
                row = {**base, "measure": m, "target": _check_target(t), "best_err": best}
                cols = [pd.to_numeric(done[c], errors="coerce").to_numpy(float) for c in costs]
                vals, row["reach_kind"] = reach_costs(err, cols, t) if err.size else \
                    ([math.nan] * len(costs), "no points")
                row.update({f"reach_{c}": v for c, v in zip(costs, vals)})
                row["reached"] = math.isfinite(row[f"reach_{costs[0]}"])
                rows.append(row)
    cols = list(by) + ["integrator", "measure", "target"] + [f"reach_{c}" for c in costs] + \
        ["reach_kind", "reached", "runs", "completed", "best_err", "failure"]
    return pd.DataFrame(rows, columns=cols)
