"""A recommendation that survives a second look: per case and target error, the cheapest
setting whose evidence holds, its cost, the runner-up, the ratio between them and why.

Everything is read from a verdict table (:func:`daebench.harness.analysis.evidence.verdict_table`):
a setting is a candidate for a target only where it *qualifies* — its run and every finer
run of the same method reach the target (or the cost is interpolated between two runs
that bracket it), none of those finer runs failed, and the observed order over them is
positive. Candidates are ranked by CPU time (the minimum of each run's timed repeats,
interpolated like the error); two whose costs differ by less than the spread of their
repeats are a **tie**, and said to be one. A setting that did not complete at coarser
steps is recommended with its stability limit. When no setting qualifies, the
recommendation says what is missing ("run finer steps of hht"). Measures are named in
words (:mod:`daebench.harness.scoring.glossary`).
"""

from __future__ import annotations

import math
import re
from typing import Any, Callable, Mapping, Sequence

import pandas as pd

from daebench.harness.analysis import costs, evidence
from daebench.harness.scoring import glossary

#: the fields of one recommendation record (compare.json, the survey's recommendations.json)
RECORD = ("case", "measure", "target", "pick", "cost_cpu_s", "steps", "runner_up", "runner_cost_cpu_s", "ratio",
          "tie", "reasons")


def _unit(measure: str, model: str | None) -> str:
    u = glossary.describe(measure, model).unit
    return f" {u}" if u else ""


def _reasons(v: Mapping[str, Any], model: str | None) -> list[str]:
    """Why a qualified setting is trusted at its cost, in words."""
    out = []
    if v["reach_kind"] == "interpolated":
        out.append(f"cost interpolated {v['at']}; every finer run reaches it")
    elif v["reach_kind"] == "bound":
        out.append(f"its coarsest run ({v['at']}) and every finer one reach it: the cost is an upper bound")
    else:
        out.append(f"the run at {v['at']} and every finer run reach it")
    p, dec = v["order"], v["declared"]
    order = f"observed order {p:.2g} over {int(v['evidence'])} runs" + (f" (declared {dec:g})"
                                                                         if math.isfinite(dec) else "")
    out.append(order + (f"; outside the asymptotic regime: {v['regime']}" if v["regime"] else ""))
    if v["limit"]:
        out.append(f"stability limit: {v['limit']}")
    return out


def recommend_case(verdicts: pd.DataFrame, model: str | None = None) -> list[dict[str, Any]]:
    """One record per (measure, target) of one case's verdict table (:data:`RECORD` plus
    ``missing``: what would make a recommendation when none qualifies)."""
    recs = []
    for (m, t), g in verdicts.groupby(["measure", "target"], sort=False):
        ok = g[g["qualified"].astype(bool)].sort_values(["reach_cpu_s", "label"], kind="stable")
        rec: dict[str, Any] = {"case": str(g["case"].iloc[0]) if "case" in g else "", "measure": m,
                               "target": float(t), "pick": "", "cost_cpu_s": math.nan, "steps": math.nan,
                               "runner_up": "", "runner_cost_cpu_s": math.nan, "ratio": math.nan, "tie": False,
                               "reasons": [], "missing": ""}
        if not len(ok):
            rec["missing"] = missing_text([str(x) for x in g["missing"] if str(x)])
            recs.append(rec)
            continue
        b = ok.iloc[0]
        rec.update(pick=f"{b['label']} ({b['at']})", cost_cpu_s=float(b["reach_cpu_s"]),
                   steps=float(b["reach_steps"]), reasons=_reasons(b, model))
        if len(ok) > 1:
            r = ok.iloc[1]
            ratio = float(r["reach_cpu_s"]) / rec["cost_cpu_s"]
            spread = max(float(b["spread"]), float(r["spread"]))
            tie = math.isfinite(spread) and ratio - 1.0 <= spread
            rec.update(runner_up=f"{r['label']} ({r['at']})", runner_cost_cpu_s=float(r["reach_cpu_s"]), ratio=ratio,
                       tie=bool(tie))
            if tie:
                rec["reasons"].append(f"a tie with {r['label']}: the costs differ by {100 * (ratio - 1):.0f} %, "
                                      f"within the repeats' CPU-time spread ({100 * spread:.0f} %)")
        else:
            rec["reasons"].append("no other setting qualifies")
        recs.append(rec)
    return recs


def missing_text(items: Sequence[str]) -> str:
    """What would make a recommendation, the settings that need the same thing in one
    clause ('run finer steps of a, b (one run reaching it shows no order)')."""
    if not items:
        return "no setting was scored on this measure"
    groups: dict[tuple[str, str], list[str]] = {}
    rest = []
    for it in items:
        head, sep, tail = it.partition(" of ")
        name, _, why = tail.partition(" (")
        if it.startswith("run finer") and sep and why.endswith("shows no order)"):
            groups.setdefault((head, why), []).append(name)
        else:
            rest.append(it)
    out = [f"{head} of {', '.join(names)} ({why}" for (head, why), names in groups.items()]
    finest: dict[tuple[str, str], list[tuple[str, str]]] = {}   # 'run finer steps of X (its finest, h=…, reaches e)'
    other = []
    for it in rest:
        m = re.fullmatch(r"(run finer \w+) of (.+) \(its finest, (\S+), reaches (\S+)\)", it)
        if m:
            finest.setdefault((m.group(1), m.group(3)), []).append((m.group(2), m.group(4)))
        else:
            other.append(it)
    for (head, at), pairs in finest.items():
        names, errs = ", ".join(n for n, _ in pairs), ", ".join(e for _, e in pairs)
        out.append(f"{head} of {names} (their finest, {at}, reach {errs})" if len(pairs) > 1
                   else f"{head} of {names} (its finest, {at}, reaches {errs})")
    return "; ".join(out + other)


def _cost(v: float) -> str:
    return f"{v:.3g} s CPU" if math.isfinite(v) else "-"


def sentence(r: Mapping[str, Any], model: str | None = None) -> str:
    """One target of one case, in words (display names, never column names)."""
    head = f"To reach {glossary.target_text(r['measure'], r['target'], model)}"
    if not r["pick"]:
        return f"{head}: no setting qualifies yet — {r['missing']}."
    tie = " (a tie)" if r["tie"] else ""
    s = f"{head}, take {r['pick']}{tie}: {_cost(r['cost_cpu_s'])}"
    if r["runner_up"]:
        s += f"; runner-up {r['runner_up']}, {r['ratio']:.2g}× the cost"
    why = "; ".join(r["reasons"])
    return f"{s}. {why[:1].upper()}{why[1:]}." if why else s + "."


def failures(table: pd.DataFrame, setting: str = "label") -> list[tuple[str, str]]:
    """(setting, its first run that did not complete, with the status and where) for one
    case's runs; a run skipped for the budget is said as such. Never an exception's text:
    that stays in the table's message column."""
    out = []
    if "status" not in table:
        return out
    for name, g in table.groupby(setting, sort=False):
        bad = g[g["status"].astype(str) != "completed"]
        if len(bad):
            real = bad[~bad["status"].astype(str).str.startswith("skipped")]
            r = (real if len(real) else bad).iloc[0]
            out.append((str(name), f"{r['status']} at {evidence.setting_text(r)}"))
    return out


def paragraph(case: str, recs: Sequence[Mapping[str, Any]], fails: Sequence[tuple[str, str]] = (),
              model: str | None = None) -> str:
    """The recommendation for one case in words: a sentence per target, then the settings
    that did not complete (where), then those whose finer steps were not run."""
    parts = [f"{case}:"] + [sentence(r, model) for r in recs]
    real = [(s, why) for s, why in fails if not why.startswith("skipped")]
    skipped = [s for s, why in fails if why.startswith("skipped")]
    if real:
        parts.append("Did not complete: " + "; ".join(f"{s} ({why})" for s, why in real) + ".")
    if skipped:
        parts.append(f"Not run within the budget: the finer steps of {', '.join(skipped)}.")
    return " ".join(parts)


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
              most: int = 2, model_of: Callable[[str], str | None] = lambda case: None
              ) -> tuple[pd.DataFrame, dict[str, list[dict[str, Any]]], dict[str, str]]:
    """A scored table (one case or several) → its verdict table, the recommendation
    records per case and the paragraph per case: what `daebench compare` and `daebench
    survey` end with. ``targets`` default to :func:`default_targets` of ``measures``;
    ``model_of`` names a case's model (the labels and units of its observables)."""
    tg = dict(targets) if targets else default_targets(df, measures, most)
    if not tg or not len(df):
        return pd.DataFrame(), {}, {}
    verdicts = evidence.verdict_table(df, tg)
    return (verdicts, *by_case(verdicts, df, model_of))


def by_case(verdicts: pd.DataFrame, table: pd.DataFrame,
            model_of: Callable[[str], str | None] = lambda case: None
            ) -> tuple[dict[str, list[dict[str, Any]]], dict[str, str]]:
    """The records and the paragraph of every case of a verdict table (``table``: the runs,
    for the settings that did not complete)."""
    recs: dict[str, list[dict[str, Any]]] = {}
    paras: dict[str, str] = {}
    if not len(verdicts):
        return recs, paras
    for case, g in verdicts.groupby("case", sort=False):
        model = model_of(str(case))
        recs[str(case)] = recommend_case(g, model)
        runs = table[table["case"] == case] if "case" in table else table
        paras[str(case)] = paragraph(str(case), recs[str(case)], failures(runs), model)
    return recs, paras


def table_rows(recs: Sequence[Mapping[str, Any]], model: str | None = None) -> tuple[list[str], list[list[Any]]]:
    """The recommendation as a small table: target → pick, cost, runner-up, ratio, why."""
    cols = ["target", "pick", "CPU s", "runner-up", "ratio", "why"]
    rows = []
    for r in recs:
        m = glossary.describe(r["measure"], model)
        target = f"{m.short} ≤ {r['target']:g}{_unit(r['measure'], model)}"
        if not r["pick"]:
            rows.append([target, "none qualifies", math.nan, "", math.nan, r["missing"]])
            continue
        rows.append([target, r["pick"] + (" (tie)" if r["tie"] else ""), r["cost_cpu_s"], r["runner_up"] or "-",
                     r["ratio"], "; ".join(r["reasons"])])
    return cols, rows
