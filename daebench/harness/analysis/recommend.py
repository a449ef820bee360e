"""A recommendation a user can act on: per case and target, the cheapest setting that
reaches the target error, its cost, the runner-up and the ratio between them, and the
settings that failed or diverged with their reason — one short paragraph per case.

Everything is read from a reach table (:func:`daebench.harness.analysis.costs.reach_table`): the
cost of a setting at a target is the rule stated there (log–log interpolation between
its runs, never extrapolated; an upper bound when its cheapest run already reaches it).
"Cheapest" is by wall time (the minimum of the timed repeats of each run); the steps at
the same target are given beside it.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import pandas as pd

from daebench.harness.analysis import costs


def recommendations(reach: pd.DataFrame, cost: str = "wall_s", setting: str = "label") -> pd.DataFrame:
    """One row per (case, measure, target): ``best`` and ``runner_up`` settings with their
    costs (``best_cost``, ``best_steps``, ``best_kind``, ``runner_cost``), ``ratio`` =
    runner_cost / best_cost, and ``not_reached``: the settings with scored runs that do
    not reach the target, with their smallest error ('name (best e)', '; '-joined)."""
    col = f"reach_{cost}"
    rows = []
    for (case, m, t), g in reach.groupby(["case", "measure", "target"], sort=False):
        ok = g[g[col].notna()].sort_values([col, setting], kind="stable")
        miss = g[g[col].isna() & (g["reach_kind"] == "not reached")]
        row: dict[str, Any] = {"case": case, "measure": m, "target": float(t), "best": "", "best_cost": math.nan,
                               "best_steps": math.nan, "best_kind": "", "runner_up": "", "runner_cost": math.nan,
                               "ratio": math.nan,
                               "not_reached": "; ".join(f"{r[setting]} (best {r['best_err']:.3g})"
                                                        for _, r in miss.iterrows())}
        if len(ok):
            b = ok.iloc[0]
            row.update(best=b[setting], best_cost=float(b[col]), best_kind=b["reach_kind"],
                       best_steps=float(b["reach_steps"]) if "reach_steps" in b else math.nan)
        if len(ok) > 1:
            r = ok.iloc[1]
            row.update(runner_up=r[setting], runner_cost=float(r[col]), ratio=float(r[col]) / row["best_cost"])
        rows.append(row)
    return pd.DataFrame(rows)


def failures(reach: pd.DataFrame, setting: str = "label") -> dict[str, list[tuple[str, str]]]:
    """Per case: (setting, the first run that did not complete with its reason), for the
    settings with such a run."""
    out: dict[str, list[tuple[str, str]]] = {}
    seen = reach.drop_duplicates(["case", setting])
    for _, r in seen.iterrows():
        f = r.get("failure", "")
        if isinstance(f, str) and f:
            out.setdefault(str(r["case"]), []).append((str(r[setting]), f))
    return out


def _cost(v: float, kind: str, unit: str = "s") -> str:
    return ("≤ " if kind == "bound" else "") + f"{v:.3g} {unit}"


def _steps(v: float) -> str:
    return f", {v:,.0f} steps" if isinstance(v, float) and math.isfinite(v) else ""


def sentence(r: Mapping[str, Any]) -> str:
    """One target of one case, in words."""
    head = f"To reach {r['measure']} ≤ {r['target']:g}"
    if not r["best"]:
        tail = f" not one setting suffices" + (f" (closest: {r['not_reached']})" if r["not_reached"] else "") + "."
        return head + ":" + tail
    s = f"{head}, take {r['best']} ({_cost(r['best_cost'], r['best_kind'])}{_steps(r['best_steps'])}"
    s += "; its cheapest run already reaches it)" if r["best_kind"] == "bound" else ")"
    if r["runner_up"]:
        s += f"; runner-up {r['runner_up']} at {r['runner_cost']:.3g} s, {r['ratio']:.2g}× the cost"
    else:
        s += "; no other setting reaches it"
    return s + "."


_SAME = ("measure", "best", "best_cost", "best_kind", "runner_up", "runner_cost")


def _merged(recs: pd.DataFrame) -> list[dict[str, Any]]:
    """Consecutive targets of one measure with the same answer (same settings and costs:
    typically bounds) as one record whose ``target`` lists them."""
    out: list[dict[str, Any]] = []
    for _, r in recs.iterrows():
        r = dict(r)
        if out and all(_eq(out[-1][k], r[k]) for k in _SAME):
            out[-1]["targets"].append(r["target"])
        else:
            r["targets"] = [r["target"]]
            out.append(r)
    return out


def _eq(a: Any, b: Any) -> bool:
    return (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b)) or a == b


def paragraph(case: str, recs: pd.DataFrame, fails: Sequence[tuple[str, str]] = ()) -> str:
    """The recommendation for one case: a sentence per target (targets with the same
    answer in one), then the settings that failed or diverged (the first such run and its
    reason), then how many were not run within the budget."""
    parts = [f"{case}:"]
    for r in _merged(recs):
        s = sentence(r)
        if len(r["targets"]) > 1:
            s = s.replace(f"≤ {r['target']:g}", "≤ " + " / ".join(f"{t:g}" for t in r["targets"]), 1)
        parts.append(s)
    real = [(s, why) for s, why in fails if not why.startswith("skipped")]
    skipped = [s for s, why in fails if why.startswith("skipped")]
    if real:
        parts.append("Failed or diverged: " + "; ".join(f"{s} — {why}" for s, why in real) + ".")
    if skipped:
        parts.append(f"Not run within the budget: the finer steps of {', '.join(skipped)} "
                     f"(--budget, or --resume with a larger one).")
    return " ".join(parts)


def paragraphs(reach: pd.DataFrame, cost: str = "wall_s", setting: str = "label") -> dict[str, str]:
    """{case: its paragraph} for every case of a reach table."""
    recs = recommendations(reach, cost, setting)
    fails = failures(reach, setting)
    return {str(c): paragraph(str(c), g, fails.get(str(c), ())) for c, g in recs.groupby("case", sort=False)}


def default_targets(df: pd.DataFrame, measures: Sequence[str], most: int = 2) -> dict[str, list[float]]:
    """Round targets per measure (:func:`daebench.harness.analysis.costs.decade_targets` over the
    completed runs' errors); measures without a finite error are left out."""
    done = df[df["status"].astype(str) == "completed"] if "status" in df else df
    out = {}
    for m in measures:
        if m in done:
            ts = costs.decade_targets(pd.to_numeric(done[m], errors="coerce"), most)
            if ts:
                out[m] = ts
    return out


def for_table(df: pd.DataFrame, measures: Sequence[str], targets: Mapping[str, Sequence[float]] | None = None,
              most: int = 2) -> tuple[pd.DataFrame, dict[str, str]]:
    """A scored table (one case or several) → its reach table and the paragraph per case:
    what `daebench compare` and `daebench survey` end with. ``targets`` default to
    :func:`default_targets` of ``measures``."""
    tg = dict(targets) if targets else default_targets(df, measures, most)
    if not tg or not len(df):
        return pd.DataFrame(), {}
    reach = costs.reach_table(df, tg)
    return reach, paragraphs(reach)


def compare_lines(df: pd.DataFrame, measures: Sequence[str]) -> list[str]:
    """What `daebench compare` ends with: the recommendation paragraph of the case over
    the protocol's measures (default targets), or why there is none."""
    if not len(df) or not measures:
        return ["recommendation: none (no run was scored on the protocol's measures)"]
    _, paras = for_table(df, measures)
    return [f"recommendation — {p}" for p in paras.values()] or ["recommendation: none (no completed run)"]
