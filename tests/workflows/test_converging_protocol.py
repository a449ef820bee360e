"""Protocols that converge (daebench.workflows.converge): series extended until a target is
decided or the budget is spent, on synthetic series whose error and cost laws are known."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from daebench.workflows import converge


def _row(label: str, integrator: str, h: float, err_c: float, order: float, cost_c: float) -> dict:
    return {"label": label, "integrator": integrator, "h": h, "tol": math.nan, "status": "completed",
            "err_x_max": err_c * h ** order, "cpu_s": cost_c / h, "steps": 1.0 / h, "cpu_spread": 0.0}


LAWS = {"hht": (1e3, 2.0, 1e-4), "newmark": (1e3, 2.0, 3e-4)}   # e = C h², CPU = c / h


def _table(steps: tuple[float, ...]) -> pd.DataFrame:
    return pd.DataFrame([_row(n, n, h, *LAWS[n]) for n in LAWS for h in steps])


def _runner(calls: list):
    def run(fits):
        calls.append(dict(fits))
        return pd.DataFrame([_row(lab, lab, x, *LAWS[lab]) for lab, (kind, x) in fits.items()])
    return run


def test_a_series_is_extended_until_the_target_is_decided_and_a_loser_is_not():
    """e = 1e3 h²: the target 1e-5 is reached at h = 1e-4. From h = 1e-3, 5e-4 hht is halved
    until three runs decide it: the last not reaching it (1.25e-4) and two that do (6.25e-5,
    3.125e-5). newmark costs 3× hht at every h: once hht's pick stands it is not extended."""
    calls: list = []
    df, prog = converge.extend(_table((1e-3, 5e-4)), {"err_x_max": (1e-5,)}, 1e6, _runner(calls))
    hht = df[df["label"] == "hht"].sort_values("h", ascending=False)
    reached = hht[hht["err_x_max"] <= 1e-5]
    assert len(reached) == 2 and hht["h"].min() == pytest.approx(3.125e-5)
    assert converge.decided(converge.evidence.qualify(converge.evidence.series(hht), "err_x_max", 1e-5, 2.0))
    nm = df[df["label"] == "newmark"]
    assert len(nm) < len(hht)          # extended only while it could still win
    assert prog.spent_s >= 0 and prog.added and "decided" in prog.stopped


def test_the_budget_stops_the_extension_and_the_answer_predicts_the_cost():
    """A budget too small for the next run: nothing runs, and the answer is the fitted
    prediction, c / h* with h* = (τ / C)^(1/2)."""
    calls: list = []
    df, prog = converge.extend(_table((1e-3, 5e-4)), {"err_x_max": (1e-6,)}, 1e-9, _runner(calls))
    assert not calls and "budget" in prog.stopped
    pred = prog.predictions[("err_x_max", 1e-6)]
    h_star = (1e-6 / 1e3) ** 0.5
    assert pred.label == "hht" and pred.x == pytest.approx(h_star, rel=1e-9)
    assert pred.cost_s == pytest.approx(1e-4 / h_star, rel=1e-9) and pred.order == pytest.approx(2.0)
    text = converge.answer_text(pred, 1e-9)
    assert text.startswith("not reached within 1e-09 s; the last series predicts 3.16 s CPU (hht at 3.16e-05")
    assert "budget of 1e-09 s" in converge.stopping_rule(1e-9)


def test_errors_that_do_not_fall_give_no_prediction():
    df = pd.DataFrame([_row("hht", "hht", h, 1e3, 0.0, 1e-4) for h in (1e-3, 5e-4)])
    p = converge.predict(converge.evidence.series(df), "err_x_max", 1e-6)
    assert math.isnan(p.cost_s) and "not falling" in p.why
    df2, prog = converge.extend(df, {"err_x_max": (1e-6,)}, 1e6, _runner([]))
    assert len(df2) == len(df) and "no series predicts" in converge.answer_text(prog.predictions.get(
        ("err_x_max", 1e-6)), 1e6)


def test_compare_extends_a_series_until_its_target_is_decided(tmp_path, monkeypatch):
    """The pendulum against its exact solution: hht (α = 0, order 2) from h = 1e-2, 5e-3 is
    halved until three runs decide θ ≤ 1e-3 deg; compare.json names the budget and the rule."""
    import json

    from daebench.harness.sweeps.options import Execution, SweepOptions
    from daebench.models.scenes import load_scene
    from daebench.workflows import compare as C

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    sc = load_scene("pendulum", {"t_end": 0.5})
    proto = C.Protocol((C.Entry("hht", (1e-2, 5e-3), options={"alpha": 0.0}),), measures=("err_theta_max",),
                       targets={"err_theta_max": (1e-3,)})
    res = C.run_compare(sc, SweepOptions(reference="none", execution=Execution(jobs=1, progress=False)),
                        out=tmp_path / "cmp", protocol=proto, budget_s=300.0)
    df = res.table.sort_values("h", ascending=False)
    e = df["err_theta_max"].to_numpy()
    assert len(df) >= 4 and (e[1:] < e[:-1]).all()                      # halved, errors falling
    assert (e <= 1e-3).sum() >= 2 and e[-3] > 1e-3 or (e <= 1e-3).sum() >= 3
    rec = res.recommendations[0]
    assert rec["pick"].startswith("hht") and res.convergence["added"]
    side = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    assert side["convergence"]["budget_s"] == 300.0 and "≥ 3 runs" in side["convergence"]["stopping_rule"]
    assert any("stopping rule" in line for line in res.summary_lines())
