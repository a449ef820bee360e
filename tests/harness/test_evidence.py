"""The evidence behind a recommendation: a lucky isolated point and a run after coarser
divergence are never picked; a tie is called a tie; the observed order and the asymptotic
flag come out of known power laws."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from daebench.harness.analysis import evidence, recommend

STEPS = (4e-3, 2e-3, 1e-3, 5e-4)


def _rows(label, errs, cpu, status=None, spread=0.02, integrator=None):
    status = status or ["completed"] * len(errs)
    return [dict(case="c", label=label, integrator=integrator or label, h=h, status=st, cpu_s=c, cpu_spread=spread,
                 steps=round(1 / h), err_x_max=e if st == "completed" else np.nan)
            for h, e, c, st in zip(STEPS, errs, cpu, status)]


def _order2(h):
    return 1e3 * h ** 2                       # e = 1e3 h², declared order 2: 16e-3 … 2.5e-4


def test_neither_a_lucky_isolated_point_nor_a_run_after_divergence_is_picked():
    """'lucky' reaches τ = 1e-3 at its coarsest step only (its finer runs sit at 2e-3:
    converged to something else), and is the cheapest there; 'fragile' diverged at the two
    coarser steps and reaches τ at its third run, one run with no order; 'steady' is
    e = 1e3 h² (reaches 1e-3 exactly at its run h = 1e-3) at 10× the cost. 'lucky' never
    qualifies; 'fragile' is picked only with its stability limit, and not at all once its
    finest run is gone (one run shows no order)."""
    tau = 1e-3
    lucky = _rows("lucky", [0.9e-3, 2e-3, 2.1e-3, 2.0e-3], [0.01, 0.02, 0.04, 0.08])
    fragile = _rows("fragile", [np.nan, np.nan, 0.5e-3, 0.2e-3], [0.005, 0.01, 0.02, 0.04],
                    status=["diverged", "diverged", "completed", "completed"])
    steady = _rows("steady", [_order2(h) for h in STEPS], [0.1, 0.2, 0.4, 0.8], integrator="hht")
    df = pd.DataFrame(lucky + fragile + steady)
    order_of = {"lucky": 2.0, "fragile": 4.0, "hht": 2.0}
    v = evidence.verdict_table(df, {"err_x_max": [tau]}, order_of=lambda name, kind: order_of[name])
    by = v.set_index("label")
    assert not by.loc["lucky", "qualified"] and "errors do not fall" not in by.loc["lucky", "missing"]
    assert by.loc["lucky", "missing"].startswith("run finer steps of lucky")
    # fragile: e falls 0.5e-3 → 0.2e-3 between h = 1e-3 and 5e-4: order log(2.5)/log(2) = 1.32, positive —
    # it qualifies, but only with its stability limit stated
    assert by.loc["fragile", "qualified"] and by.loc["fragile", "limit"] == "diverged at h=0.002"
    assert by.loc["fragile", "order"] == pytest.approx(math.log(2.5) / math.log(2), rel=1e-12)
    assert by.loc["fragile", "regime"] == "order 1.3 far from 4"
    assert by.loc["steady", "qualified"] and by.loc["steady", "reach_kind"] == "at a run"
    assert by.loc["steady", "order"] == pytest.approx(2.0, rel=1e-9)
    # e = 1e3 h², cost = 4e-4 / h: τ at h* = 1e-3 exactly → the cost of the run at 1e-3
    assert by.loc["steady", "reach_cpu_s"] == pytest.approx(0.4, rel=1e-9)
    recs = recommend.recommend_case(v)
    assert recs[0]["pick"].startswith("fragile") and recs[0]["runner_up"].startswith("steady")
    assert any(r.startswith("stability limit: diverged at h=0.002") for r in recs[0]["reasons"])
    # without the run after divergence's finer confirmation (its finest run missing): nothing qualifies
    # from fragile, and lucky is never the pick
    df2 = df[~((df["label"] == "fragile") & (df["h"] == 5e-4))]
    v2 = evidence.verdict_table(df2, {"err_x_max": [tau]}, order_of=lambda name, kind: order_of[name])
    r2 = recommend.recommend_case(v2)[0]
    assert r2["pick"].startswith("steady") and r2["runner_up"] == ""
    assert "run finer steps of fragile" in v2.set_index("label").loc["fragile", "missing"]


def test_a_failed_finer_run_disqualifies_and_nothing_qualifying_says_what_is_missing():
    """A setting reaches τ at its coarse runs but its finest run failed: not trusted. With
    no other setting the recommendation says what is missing."""
    df = pd.DataFrame(_rows("a", [8e-4, 2e-4, 5e-5, np.nan], [1, 2, 4, 8],
                            status=["completed", "completed", "completed", "failed"]))
    v = evidence.verdict_table(df, {"err_x_max": [1e-3]}, order_of=lambda n, k: 2.0)
    rec = recommend.recommend_case(v)[0]
    assert rec["pick"] == "" and rec["missing"] == "a at its finest h=0.0005 failed"
    assert "no setting qualifies yet — a at its finest h=0.0005 failed" in recommend.sentence(rec)


def test_a_tie_within_the_repeats_spread_is_called_a_tie():
    """Two settings with e = 1e3 h² whose CPU times differ by 5 %: a tie when the
    repeats' spread is 10 %, not when it is 1 %."""
    a = _rows("a", [_order2(h) for h in STEPS], [1.0, 2.0, 4.0, 8.0], spread=0.10)
    b = _rows("b", [_order2(h) for h in STEPS], [1.05, 2.1, 4.2, 8.4], spread=0.10)
    v = evidence.verdict_table(pd.DataFrame(a + b), {"err_x_max": [1e-3]}, order_of=lambda n, k: 2.0)
    rec = recommend.recommend_case(v)[0]
    assert rec["pick"].startswith("a") and rec["ratio"] == pytest.approx(1.05) and rec["tie"]
    assert any("a tie with b" in r for r in rec["reasons"])
    b = _rows("b", [_order2(h) for h in STEPS], [1.05, 2.1, 4.2, 8.4], spread=0.01)
    a = _rows("a", [_order2(h) for h in STEPS], [1.0, 2.0, 4.0, 8.0], spread=0.01)
    v = evidence.verdict_table(pd.DataFrame(a + b), {"err_x_max": [1e-3]}, order_of=lambda n, k: 2.0)
    assert not recommend.recommend_case(v)[0]["tie"]


def test_observed_order_per_run_and_the_asymptotic_flag():
    """e = 1e3 h² then a floor: orders 2, 2, then 0 (errors not falling) at the finest."""
    errs = [_order2(4e-3), _order2(2e-3), _order2(1e-3), _order2(1e-3)]
    df = pd.DataFrame(_rows("a", errs, [1, 2, 4, 8]))
    o = evidence.observed_orders(df, "err_x_max", order_of=lambda n, k: 2.0)
    assert math.isnan(o["order"].iloc[0])
    np.testing.assert_allclose(o["order"].iloc[1:3], [2.0, 2.0], rtol=1e-12)
    assert o["order"].iloc[3] == 0.0 and o["regime"].iloc[3] == "errors not falling"
    assert list(o["regime"].iloc[:3]) == ["", "", ""]


def test_what_is_missing_groups_the_settings_that_need_the_same():
    items = ["run finer steps of a (one run reaching it shows no order)",
             "run finer steps of b (one run reaching it shows no order)",
             "run finer steps of c (its finest, h=2.5e-05, reaches 1.22)",
             "run finer steps of d (its finest, h=2.5e-05, reaches 1.21)",
             "e at its finest h=0.001 diverged"]
    assert recommend.missing_text(items) == (
        "run finer steps of a, b (one run reaching it shows no order); run finer steps of c, d (their finest, "
        "h=2.5e-05, reach 1.22, 1.21); e at its finest h=0.001 diverged")
