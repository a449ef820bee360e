"""Protocols that converge: after the protocol's runs, `daebench compare` extends a
method's series until each target is decided or a stated budget is spent, and says which.

**Decided.** A target is decided for a series when the series *qualifies* for it
(:func:`daebench.harness.analysis.evidence.qualify`: the run and every finer run reach it,
none failed, the order over them positive) with evidence of at least :data:`MIN_EVIDENCE`
runs and the observed order inside the asymptotic rule
(:func:`daebench.harness.analysis.evidence.regime`: within a factor
:data:`daebench.harness.analysis.evidence.FAR` of the declared order).

**Extending.** A fixed-step series is extended by halving its finest h, a tolerance series
by dividing its tightest tolerance by 10. A series is extended only while it could still
win: its predicted cost to reach the target — the error and the CPU time each fitted as a
power of h (or tol) over its last :data:`FIT_RUNS` completed runs — below the current pick's
cost (the current pick's own series is extended until it decides the target). Rounds run
every extended series once (in parallel), until no series is left to
extend or the next round's predicted wall time would overrun the budget.

**The answer** per target is the pick with its cost (:mod:`daebench.harness.analysis.recommend`)
or "not reached within B s; the last series predicts X s" (the cheapest predicted cost).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from daebench.harness.analysis import evidence
from daebench.harness.sweeps import sweep
from daebench.harness.sweeps.plan import plan_sweep

#: compare's default budget for extending series [s of wall time]: a user can wait for it
DEFAULT_BUDGET_S = 600.0
#: the runs a decided target rests on
MIN_EVIDENCE = 3
#: the completed runs the error and cost fits use (the finest ones)
FIT_RUNS = 3
#: how each kind of series is refined
REFINE = {"h": 0.5, "tol": 0.1}
#: a fitted order of the error below this predicts no reachable cost (the errors do not fall)
MIN_ORDER = 0.1
#: the most runs one series may grow by
MAX_EXTENSIONS = 6


def stopping_rule(budget_s: float) -> str:
    """The stopping rule in words (the table's summary, compare.json)."""
    return (f"each series is extended (h/2, or tol/10) until the target is decided — reached with an observed "
            f"order inside the asymptotic rule over ≥ {MIN_EVIDENCE} runs — or the budget of {budget_s:g} s is "
            f"spent; a series is extended only while its predicted cost is below the current pick's")


@dataclass
class Prediction:
    """What a series' fits say about a target: the setting and CPU time that reach it."""

    label: str
    x: float = math.nan          # the step or tolerance that reaches the target
    cost_s: float = math.nan     # its predicted CPU time
    order: float = math.nan      # the fitted order of the error
    why: str = ""                # '' or why there is no prediction


def _completed(s: pd.DataFrame, measure: str) -> list[tuple[float, float, float]]:
    """(x, error, CPU s) of a series' completed runs with a positive finite error, coarse → fine."""
    out = []
    for _, r in s.iterrows():
        kind, x = evidence.step_of(r)
        e = evidence._err(r, measure)
        c = float(pd.to_numeric(r.get(evidence.COST, math.nan), errors="coerce"))
        if kind and math.isfinite(e) and e > 0 and math.isfinite(c) and c > 0:
            out.append((x, e, c))
    return out


def predict(s: pd.DataFrame, measure: str, target: float) -> Prediction:
    """The setting and CPU time at which series ``s`` (coarse → fine) reaches ``target``,
    from power laws in x fitted over its last :data:`FIT_RUNS` completed runs."""
    label = str(s["label"].iloc[0]) if len(s) else "?"
    pts = _completed(s, measure)[-FIT_RUNS:]
    if len(pts) < 2:
        return Prediction(label, why="fewer than two completed runs")
    xs, es, cs = (np.array(v, float) for v in zip(*pts))
    p = evidence.fitted_order(xs, es)
    if not (math.isfinite(p) and p > MIN_ORDER):
        return Prediction(label, order=p, why=f"errors not falling (fitted order {p:.2g})")
    r = evidence.fitted_order(xs, cs)     # cost ∝ x^r (r ≈ −1 for a fixed step)
    x_at = xs[-1] * (target / es[-1]) ** (1.0 / p)
    cost = cs[-1] * (x_at / xs[-1]) ** r if math.isfinite(r) else math.nan
    return Prediction(label, float(x_at), float(cost), float(p))


def decided(v: Mapping[str, Any]) -> bool:
    """A verdict (:func:`daebench.harness.analysis.evidence.qualify`) that decides its target."""
    return bool(v["qualified"]) and int(v["evidence"]) >= MIN_EVIDENCE and not v["regime"]


@dataclass
class Progress:
    """The extension's account: the budget, the wall time spent, the runs added (label,
    setting), and the prediction per target where none decided it."""

    budget_s: float
    spent_s: float = 0.0
    added: list[tuple[str, str]] = field(default_factory=list)
    predictions: dict[tuple[str, float], Prediction] = field(default_factory=dict)
    stopped: str = ""


def _series(df: pd.DataFrame) -> dict[str, pd.DataFrame]:
    return {str(k): evidence.series(g) for k, g in df.groupby("label", sort=False)}


def _next(s: pd.DataFrame) -> tuple[str, float] | None:
    """The next, finer setting of a series (None: a run at its defaults, or its finest failed)."""
    if not len(s):
        return None
    last = s.iloc[-1]
    kind, x = evidence.step_of(last)
    if not kind or str(last.get("status")) != "completed":
        return None
    return kind, x * REFINE[kind]


def plan_round(df: pd.DataFrame, targets: Mapping[str, Sequence[float]], prog: Progress,
               grown: Mapping[str, int]) -> dict[str, tuple[str, float, float]]:
    """The series to extend in the next round: label → (kind, next x, predicted CPU s of that
    run), for every target not decided whose series could still win (module docstring)."""
    out: dict[str, tuple[str, float, float]] = {}
    series = _series(df)
    for m, ts in targets.items():
        for t in ts:
            verdicts = {lab: evidence.qualify(s, m, float(t), evidence.declared_order(
                str(s["integrator"].iloc[0]), evidence.step_of(s.iloc[-1])[0])) for lab, s in series.items() if len(s)}
            picks = [v["reach_cpu_s"] for v in verdicts.values() if v["qualified"]]
            best = min(picks) if picks else math.inf
            pick = next((lab for lab, v in verdicts.items() if v["qualified"] and v["reach_cpu_s"] == best), None)
            if any(decided(v) and v["reach_cpu_s"] <= best for v in verdicts.values()):
                prog.predictions.pop((m, float(t)), None)
                continue
            preds = []
            for lab, s in series.items():
                nxt = _next(s)
                if nxt is None:
                    continue
                pr = predict(s, m, float(t))
                preds.append(pr)
                if decided(verdicts.get(lab, {"qualified": False, "evidence": 0, "regime": ""})) \
                        or grown.get(lab, 0) >= MAX_EXTENSIONS:
                    continue
                could_win = lab == pick or (math.isfinite(pr.cost_s) and pr.cost_s < best)   # the pick: confirmed
                if not could_win:
                    continue
                pts = _completed(s, m)
                r = evidence.fitted_order([p[0] for p in pts[-FIT_RUNS:]], [p[2] for p in pts[-FIT_RUNS:]])
                c_last = pts[-1][2] if pts else math.nan
                c_next = c_last * REFINE[nxt[0]] ** r if math.isfinite(r) else 2 * c_last
                out[lab] = (nxt[0], nxt[1], float(c_next))
            ok = [p for p in preds if math.isfinite(p.cost_s)]
            if not picks and ok:
                prog.predictions[(m, float(t))] = min(ok, key=lambda p: p.cost_s)
    return out


def extend(df: pd.DataFrame, targets: Mapping[str, Sequence[float]], budget_s: float,
           run: Callable[[Mapping[str, tuple[str, float]]], pd.DataFrame], factor: float = 1.0) -> tuple[pd.DataFrame,
                                                                                                        Progress]:
    """``df`` with its series extended until every target is decided or ``budget_s`` is
    spent (module docstring). ``run`` runs one round (label → (kind, x)) and returns its
    rows; ``factor`` converts the rows' CPU time into the wall time a round takes (measured
    on the protocol's runs), so a round that would overrun the budget is not started."""
    prog = Progress(float(budget_s))
    grown: dict[str, int] = {}
    if not (budget_s > 0) or not targets:
        prog.stopped = "no budget for extending" if targets else "no target"
        return df, prog
    while True:
        todo = plan_round(df, targets, prog, grown)
        if not todo:
            prog.stopped = prog.stopped or "every target decided, or no series could still win"
            break
        # the cheapest runs first, as many as the rest of the budget holds
        fits, need = {}, 0.0
        for lab, (kind, x, c) in sorted(todo.items(), key=lambda kv: kv[1][2]):
            if prog.spent_s + need + factor * c <= budget_s:
                fits[lab] = (kind, x)
                need += factor * c
        if not fits:
            prog.stopped = f"the budget of {budget_s:g} s is spent ({prog.spent_s:.3g} s used; the next run would overrun it)"
            break
        t0 = time.perf_counter()
        rows = run(fits)
        took = time.perf_counter() - t0
        prog.spent_s += took
        cpu = float(pd.to_numeric(rows.get(evidence.COST, pd.Series(dtype=float)), errors="coerce").sum())
        if cpu > 0:
            factor = max(factor, took / cpu)
        df = pd.concat([df, rows], ignore_index=True)
        for lab, (kind, x) in fits.items():
            grown[lab] = grown.get(lab, 0) + 1
            prog.added.append((lab, f"{kind}={x:g}"))
    # the predictions of targets still without a pick, for the answer
    plan_round(df, targets, prog, {lab: MAX_EXTENSIONS for lab in _series(df)})
    return df, prog


def answer_text(pred: Prediction | None, budget_s: float) -> str:
    """The answer for a target without a pick."""
    if pred is None:
        return f"not reached within {budget_s:g} s; no series predicts a cost (errors not falling or too few runs)"
    return (f"not reached within {budget_s:g} s; the last series predicts {pred.cost_s:.3g} s CPU "
            f"({pred.label} at {pred.x:.3g}, fitted order {pred.order:.2g})")


def compare_extend(df: pd.DataFrame, scene: Any, entries: Sequence[Any], targets: Mapping[str, Sequence[float]],
                   options: Any, budget_s: float, first_index: int, factor: float) -> tuple[pd.DataFrame, Progress]:
    """:func:`extend` for `daebench compare`: a round's runs planned as the protocol's
    (each integrator's fixed settings from its ``entries``) and run as its sweep."""

    fixed = {e.integrator: dict(e.options) for e in entries}
    integrator_of = {str(r["label"]): str(r["integrator"]) for _, r in df.iterrows()}
    counter = [first_index]

    def run(fits: Mapping[str, tuple[str, float]]) -> pd.DataFrame:
        specs = []
        for lab, (kind, x) in fits.items():
            name = integrator_of[lab]
            for s in plan_sweep(scene, [name], steps=[x] if kind == "h" else None, tols=[x] if kind == "tol" else None,
                                options=fixed.get(name, {})):
                s.index = counter[0]
                counter[0] += 1
                specs.append(s)
        return sweep.run_specs(specs, scene, options, description=f"compare {scene.name}: extending series")

    return extend(df, targets, budget_s, run, factor)
