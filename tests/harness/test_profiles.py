"""Performance profiles (daebench.harness.analysis.profiles) on a hand-computed example.

Costs to reach the target (∞: not reached; '-': setting absent from the case):

    case  A   B   C      ratios A  B  C
    P1    1   2   ∞             1  2  ∞
    P2    3   1   6             3  1  6
    P3    ∞   ∞   ∞             ∞  ∞  ∞      (no setting reaches it: counted, 'unsolved')
    P4    2  10   -             1  5  ∞
    P5    the measure does not exist there (no points): not a case of this profile

ρ_A(1) = 2/4 (P1, P4), ρ_A(4) = 3/4, ρ_A(∞) = 3/4; ρ_B(1) = 1/4, ρ_B(4) = 2/4 (P1, P2),
ρ_B(∞) = 3/4; ρ_C(1) = ρ_C(4) = 0, ρ_C(∞) = 1/4.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from daebench.core.params import ParamError
from daebench.harness.analysis import profiles

INF = math.inf
COSTS = {"P1": {"A": 1.0, "B": 2.0, "C": INF}, "P2": {"A": 3.0, "B": 1.0, "C": 6.0},
         "P3": {"A": INF, "B": INF, "C": INF}, "P4": {"A": 2.0, "B": 10.0}}


def _reach() -> pd.DataFrame:
    rows = []
    for case, cs in COSTS.items():
        for s, c in cs.items():
            rows.append(dict(case=case, label=s, measure="err_x_max", target=1e-3,
                             reach_wall_s=c if math.isfinite(c) else math.nan,
                             reach_kind="interpolated" if math.isfinite(c) else "not reached"))
    for s in "ABC":
        rows.append(dict(case="P5", label=s, measure="err_x_max", target=1e-3, reach_wall_s=math.nan,
                         reach_kind="no points"))
    return pd.DataFrame(rows)


def test_ratios_and_rho_by_hand():
    r = profiles.ratio_matrix(_reach(), "err_x_max", 1e-3)
    assert list(r.index) == ["P1", "P2", "P3", "P4"]
    assert r.loc["P2", "C"] == 6.0 and r.loc["P4", "B"] == 5.0 and np.isinf(r.loc["P4", "C"])
    p = profiles.rho(r, (1.0, 4.0, INF))
    expect = {"A": (0.5, 0.75, 0.75), "B": (0.25, 0.5, 0.75), "C": (0.0, 0.0, 0.25)}
    for s, vals in expect.items():
        assert tuple(p[s]) == pytest.approx(vals)


def test_profile_table_and_curve():
    tab = profiles.profile_table(_reach())
    assert list(tab.setting) == ["A", "B", "C"]          # sorted by ρ(1)
    assert set(tab.cases) == {4} and set(tab.unsolved) == {1}
    a = tab[tab.setting == "A"].iloc[0]
    assert (a.rho_1, a.rho_4, a.rho_inf) == pytest.approx((0.5, 0.75, 0.75))
    r = profiles.ratio_matrix(_reach(), "err_x_max", 1e-3)
    tau, y = profiles.curve(r, "B")                       # jumps at 1 (P2), 2 (P1), 5 (P4)
    assert list(tau) == [1.0, 1.0, 2.0, 5.0] and list(y) == pytest.approx([0.25, 0.25, 0.5, 0.75])


def test_figure_written(tmp_path):
    files = profiles.figure(_reach(), tmp_path / "profile")
    assert [f.suffix for f in files] == [".png", ".svg"] and all(f.stat().st_size > 1000 for f in files)
    svg = files[1].read_text()
    from daebench.harness.scoring import glossary
    assert "fraction of cases" in svg and glossary.target_text("err_x_max", 1e-3) in svg   # axis label, panel title


def test_refusals():
    with pytest.raises(ParamError, match="not a reach table"):
        profiles.ratio_matrix(pd.DataFrame({"case": []}), "err_x_max", 1e-3)
    with pytest.raises(ParamError, match="no rows"):
        profiles.ratio_matrix(_reach(), "err_y_max", 1e-3)
