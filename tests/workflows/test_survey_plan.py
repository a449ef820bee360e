"""daebench.workflows.survey_plan: a resumed survey is the survey that was planned (each
difference named), and a target of a measure no case is scored on is refused."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from daebench.core.params import ParamError
from daebench.harness.sweeps.store import StoreError
from daebench.workflows import survey_plan as sp


def _opts(**kw):
    base = dict(targets={"err_theta_max": [1e-2, 1e-3]}, integrators=["newmark", "hht"], quick=True, budget=150,
                reference="auto")
    return SimpleNamespace(**{**base, **kw})


def test_the_plan_is_what_the_tables_depend_on_in_a_canonical_order():
    plan = sp.plan_of(_opts(), ["pendulum", "ball"])
    assert plan == {"cases": ["pendulum", "ball"], "integrators": ["hht", "newmark"], "quick": True,
                    "budget_s": 150.0, "reference": "auto", "targets": {"err_theta_max": [0.001, 0.01]}}
    assert sp.plan_of(_opts(integrators=["hht", "newmark"]), ["pendulum", "ball"]) == plan   # order of -i: same plan


def test_a_resume_with_the_same_plan_passes_and_another_is_refused_naming_each_difference(tmp_path):
    plan = sp.plan_of(_opts(), ["pendulum", "ball"])
    sp.check_resume(tmp_path, "s1", plan)                 # nothing recorded yet: a resume starts it
    sp.record(tmp_path, plan)
    sp.check_resume(tmp_path, "s1", plan)
    other = sp.plan_of(_opts(budget=300, integrators=[]), ["pendulum"])
    with pytest.raises(StoreError) as exc:
        sp.check_resume(tmp_path, "s1", other)
    msg = str(exc.value)
    assert "cases (--cases): planned pendulum, ball, now pendulum" in msg
    assert "planned hht, newmark, now every registered one" in msg
    assert "planned 150, now 300" in msg and "--resume" in msg and "--overwrite" in msg


def test_a_damaged_plan_says_so(tmp_path):
    (tmp_path / sp.PLAN_FILE).write_text("{not json")
    with pytest.raises(StoreError, match="cannot resume survey 's1'.*--overwrite"):
        sp.check_resume(tmp_path, "s1", sp.plan_of(_opts(), ["ball"]))


def test_targets_of_unknown_measures_are_refused_with_the_closest():
    sp.check_targets({"err_theta_max": [1e-3]}, ["err_theta_max", "err_x_max"])
    sp.check_targets(None, ["err_x_max"])
    with pytest.raises(ParamError, match="no case of this survey is scored on 'err_theta_mx'.*err_theta_max"):
        sp.check_targets({"err_theta_mx": [1e-3]}, ["err_theta_max", "err_x_max"])
