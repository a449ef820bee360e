"""Cost to reach an accuracy (daebench.harness.analysis.costs) on synthetic work–precision data
with known answers: a power law error = C·h^p with cost = K/h lies on a straight line in
log–log, so the interpolated cost at any τ inside the range is exact."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from daebench.core.params import ParamError
from daebench.harness.analysis import costs

C, P, K = 3.0, 2.0, 0.01          # error = C h^p, cost = K / h


def _power_law(hs):
    h = np.asarray(hs, float)
    return C * h ** P, K / h


def test_power_law_interpolation_is_exact():
    err, cost = _power_law([1e-2, 5e-3, 2.5e-3, 1.25e-3])
    for tau in (1e-4, 3e-5, 7.5e-5 * 0.9, 5e-6):
        h_star = (tau / C) ** (1.0 / P)            # C h^p = τ
        got, kind = costs.cost_to_reach(err, cost, tau)
        assert kind == "interpolated"
        assert got == pytest.approx(K / h_star, rel=1e-12)


def test_exact_hit_and_out_of_range():
    err, cost = _power_law([1e-2, 5e-3, 2.5e-3])
    got, kind = costs.cost_to_reach(err, cost, err[1])
    assert kind == "at a run" and got == pytest.approx(cost[1], rel=1e-15)
    # below the smallest error: not reached, never extrapolated
    got, kind = costs.cost_to_reach(err, cost, 0.5 * err.min())
    assert math.isnan(got) and kind == "not reached"
    # looser than the cheapest run: reached at that run's cost at most (an upper bound)
    got, kind = costs.cost_to_reach(err, cost, 10.0 * err.max())
    assert kind == "bound" and got == cost[0]


def test_non_monotone_points_use_the_lower_envelope():
    # costs 1, 2, 4, 8; errors 1e-2, 2e-2 (dearer and worse: dropped), 1e-3, 1e-4
    err = [1e-2, 2e-2, 1e-3, 1e-4]
    cost = [1.0, 2.0, 4.0, 8.0]
    e, c = costs.envelope(err, cost)
    assert list(c) == [1.0, 4.0, 8.0] and list(e) == [1e-2, 1e-3, 1e-4]
    # τ = 10^-2.5: half way in log error between (1e-2, 1) and (1e-3, 4) → cost 2
    got, kind = costs.cost_to_reach(err, cost, 10 ** -2.5)
    assert kind == "interpolated" and got == pytest.approx(2.0, rel=1e-12)
    # an unsorted input and NaN / zero errors (failed runs) change nothing
    got2, _ = costs.cost_to_reach([np.nan, 1e-4, 0.0, 1e-3, 2e-2, 1e-2], [0.5, 8.0, 9.0, 4.0, 2.0, 1.0], 10 ** -2.5)
    assert got2 == pytest.approx(2.0, rel=1e-12)


def test_no_points_and_bad_target():
    assert costs.cost_to_reach([np.nan], [1.0], 1e-3)[1] == "no points"
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ParamError, match="target"):
            costs.cost_to_reach([1e-3], [1.0], bad)
    with pytest.raises(ParamError, match="one value per run"):
        costs.cost_to_reach([1e-3, 1e-4], [1.0], 1e-3)


def test_reach_table_columns_and_failures():
    hs = [1e-2, 5e-3, 2.5e-3]
    err, wall = _power_law(hs)
    steps = 1.0 / np.asarray(hs)
    rows = []
    for i, h in enumerate(hs):
        rows.append(dict(case="a", label="good", integrator="good", h=h, status="completed",
                         err_x_max=err[i], wall_s=wall[i], steps=steps[i], message=""))
        st = "completed" if i == 0 else "diverged"
        rows.append(dict(case="a", label="bad", integrator="bad", h=h, status=st,
                         err_x_max=err[i] if st == "completed" else np.nan, wall_s=wall[i], steps=steps[i],
                         message="" if st == "completed" else "NaN in the state at t = 0.1"))
    df = pd.DataFrame(rows)
    tau = 5e-5   # between the errors at h = 5e-3 (7.5e-5) and 2.5e-3 (1.9e-5)
    tab = costs.reach_table(df, {"err_x_max": [tau, 1e-9]})
    g = tab[(tab.label == "good") & (tab.target == tau)].iloc[0]
    h_star = (tau / C) ** 0.5
    assert g.reach_wall_s == pytest.approx(K / h_star, rel=1e-12)
    assert g.reach_steps == pytest.approx(1.0 / h_star, rel=1e-12)
    assert g.reached and g.reach_kind == "interpolated" and g.completed == 3
    b = tab[(tab.label == "bad") & (tab.target == tau)].iloc[0]
    # one completed point (h = 1e-2, error 3e-4 > τ): not reached; the failure named
    assert not b.reached and b.reach_kind == "not reached"
    assert b.failure.startswith("diverged at h=0.005") and "NaN in the state" in b.failure
    assert not tab[tab.target == 1e-9].reached.any()
    with pytest.raises(ParamError, match="no column"):
        costs.reach_table(df.drop(columns="steps"), {"err_x_max": [tau]})


def test_targets_parsing_and_decades():
    assert costs.parse_targets(["err_a_max=1e-2,1e-3", "err_b_l2=5"]) == {"err_a_max": [1e-2, 1e-3],
                                                                          "err_b_l2": [5.0]}
    for bad in ("err_a_max", "err_a_max=x", "err_a_max=-1"):
        with pytest.raises(ParamError):
            costs.parse_targets([bad])
    # quartiles of 1e-1 … 1e-7 (7 decades): 1e-5.5 … 1e-2.5 → 1e-3, 1e-4, 1e-5
    assert costs.decade_targets([10.0 ** -k for k in range(1, 8)]) == [1e-3, 1e-4, 1e-5]
    assert costs.decade_targets([2e-3, 3e-3]) == [pytest.approx(1e-3)]   # no decade inside: the nearest
    assert costs.decade_targets([np.nan]) == []


def test_recommendation_names_cheapest_runner_up_and_failures():
    """Two power laws on one case: 'fast' reaches τ at K_f/h*, 'slow' at twice the CPU
    time (K_s = 2 K_f); 'broken' diverges at every step. Known answers: best 'fast' with its
    cost interpolated between h = 1e-2 and 5e-3, observed order 2, runner-up 'slow', ratio
    2, and 'broken' said to have diverged (where), never with its exception's text."""
    from daebench.harness.analysis import recommend

    rows = []
    for h in (1e-2, 5e-3, 2.5e-3):
        for lab, k, st in (("fast", K, "completed"), ("slow", 2 * K, "completed"), ("broken", K, "diverged")):
            rows.append(dict(case="c", label=lab, integrator=lab, h=h, status=st, cpu_s=k / h, cpu_spread=0.05,
                             steps=1 / h, err_x_max=C * h ** P if st == "completed" else np.nan,
                             message="" if st == "completed" else "step size underflow at t = 0.2"))
    df = pd.DataFrame(rows)
    tau = 5e-5
    verdicts, recs, text = recommend.for_table(df, ["err_x_max"], {"err_x_max": [tau]})
    rec = recs["c"][0]
    h_star = (tau / C) ** 0.5                       # 4.08e-3: between the runs at 5e-3 and 2.5e-3
    assert rec["pick"] == "fast (between h=0.005 and h=0.0025)"
    assert rec["cost_cpu_s"] == pytest.approx(K / h_star, rel=1e-12)
    assert rec["runner_up"].startswith("slow") and rec["ratio"] == pytest.approx(2.0, rel=1e-12)
    assert not rec["tie"]
    fast = verdicts[verdicts["label"] == "fast"].iloc[0]
    assert fast["order"] == pytest.approx(P, rel=1e-9) and fast["regime"] == ""
    para = text["c"]
    assert "take fast (between h=0.005 and h=0.0025): 2.45 s CPU; runner-up slow" in para
    assert "broken (diverged at h=0.01)" in para and "underflow" not in para
    # default targets: decades inside the pooled errors' quartiles
    assert recommend.default_targets(df, ["err_x_max"]) == {"err_x_max": [1e-4]}


def test_steps_read_at_the_wall_time_point():
    """Wall times out of step order (a loaded machine): the envelope is the wall time's,
    and the steps come from the same two runs at the same point — not from an envelope of
    their own."""
    err = [1e-2, 1e-3, 1e-4]
    wall = [2.0, 1.0, 4.0]           # the middle run timed fastest: the first run is dominated
    steps = [100.0, 200.0, 400.0]
    vals, kind = costs.reach_costs(err, [wall, steps], 10 ** -3.5)   # half way between runs 2 and 3
    assert kind == "interpolated"
    assert vals[0] == pytest.approx(2.0, rel=1e-12) and vals[1] == pytest.approx(math.sqrt(200 * 400), rel=1e-12)
    vals, kind = costs.reach_costs(err, [wall, steps], 5e-3)          # the cheapest (by wall) run reaches it
    assert kind == "bound" and vals == [1.0, 200.0]
