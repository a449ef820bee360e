"""daebench.workflows.survey_protocol: what a survey runs of an integrator it has no declared
runs for (its default step and halvings, or its default rtol and decades), the quick
scene's span, and the rounds a sweep's runs are grouped into (the k-th run of each setting
in round k)."""

from __future__ import annotations

import pandas as pd
import pytest

from daebench.harness.sweeps.plan import RunSpec
from daebench.integrators.registry import get_integrator
from daebench.workflows import survey_protocol as sp


def _default(name, key):
    return next(float(s.default) for s in get_integrator(name).settings_spec if s.name == key)


def test_fixed_step_methods_halve_their_default_step():
    h0 = _default("hht", "h")
    assert sp.halvings("hht").steps == (h0, h0 / 2, h0 / 4)
    assert sp.halvings("hht", levels=2).steps == (h0, h0 / 2)


def test_an_adaptive_only_method_goes_down_in_decades_of_rtol():
    r0 = _default("ida", "rtol")
    entry = sp.halvings("ida")
    assert entry.steps in ((), None) and entry.tols == pytest.approx((r0, r0 / 10, r0 / 100), rel=1e-15)


def test_the_quick_scene_ends_by_half_a_second_and_keeps_shorter_spans():
    assert sp.case_scene("beam-impact", quick=True).t_end == sp.QUICK_T_END
    assert sp.case_scene("beam-impact").t_end == 1.0
    assert sp.case_scene("crank", quick=True).t_end <= sp.QUICK_T_END


def test_rounds_group_the_kth_run_of_each_setting():
    def spec(i, name, **opts):
        return RunSpec(i, name, opts, {}, {})
    specs = [spec(0, "hht", h=1e-3, alpha=-0.1), spec(1, "hht", h=5e-4, alpha=-0.1), spec(2, "hht", h=1e-3, alpha=0.0),
             spec(3, "ida", rtol=1e-6, atol=1e-8, adaptive=True), spec(4, "ida", rtol=1e-7, atol=1e-9, adaptive=True),
             spec(5, "hht", h=2.5e-4, alpha=-0.1)]
    assert [[s.index for s in r] for r in sp.rounds(specs)] == [[0, 2, 3], [1, 4], [5]]


def test_measures_fall_back_on_the_first_two_whole_run_maxima_with_a_value():
    from types import SimpleNamespace
    df = pd.DataFrame({"err_theta_max": [1e-3, None], "err_x_max": [None, None], "err_y_max": [2e-3, 1e-3],
                       "err_tip_x_max": [1.0, 2.0], "err_z_max": [1.0, 1.0]})
    assert sp.case_measures(df, SimpleNamespace(measures=("err_not_there",))) == ["err_theta_max", "err_y_max"]
