"""`daebench effects` (daebench.workflows.effects) against closed forms.

The ball (cases/ball.toml, dropped from x0 = 1 m, restitution e = 0.8) with contact on
bounces at t1 = √(2 x0/g) with v1 = g t1; with contact off it falls freely. After t1 the
two velocities differ by the constant (1 + e)·v1, so max |Δv| = (1 + e) v1 and
max |Δx| = (1 + e) v1 (T − t1) at the end T; before t1 the runs are identical."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from daebench.core.params import ParamError
from daebench.workflows import effects
from daebench.models.scenes import load_scene

G, X0, E, T = 9.81, 1.0, 0.8, 0.6


def test_max_differences_synthetic():
    t = np.linspace(0.0, 1.0, 101)
    on = pd.DataFrame({"t": t, "a": t ** 2, "b": np.zeros_like(t)})
    off = pd.DataFrame({"t": t[::2], "a": t[::2] ** 2 + 0.5 * t[::2], "c": t[::2]})
    d = effects.max_differences(on, off, ["a", "b"])
    assert d["a"] == pytest.approx(0.5, rel=1e-12) and math.isnan(d["b"])   # 'b' missing in the off run


def test_ball_contact_off_closed_form(tmp_path):
    sc = load_scene("ball", [f"t_end={T}"])
    assert effects.switchable(sc) == ["effects.contact"]
    res = effects.run_effects(sc, "hht", {"h": 1e-4}, tmp_path)
    tab = res.table.set_index("effect")
    assert list(tab.index) == [effects.ALL_ON, "contact"] and set(tab.status) == {"completed"}
    t1 = math.sqrt(2 * X0 / G)
    v1 = G * t1
    off = tab.loc["contact"]
    assert off["max_abs_d_v"] == pytest.approx((1 + E) * v1, rel=1e-3)
    assert off["max_abs_d_x"] == pytest.approx((1 + E) * v1 * (T - t1), rel=1e-3)
    # fixed steps: the same number of steps within the impact's restart
    assert abs(off["steps"] - tab.loc[effects.ALL_ON, "steps"]) <= 3
    assert (tmp_path / "effects.csv").exists() and (tmp_path / "effects.json").exists()
    cols, rows = effects.table_rows(res.table)
    assert cols[0] == "effect off" and len(rows) == 2


def test_no_switchable_effect_refused():
    with pytest.raises(ParamError, match="no effect switched on"):
        effects.run_effects(load_scene("pendulum"), "hht")
