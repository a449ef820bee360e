"""A resumed survey is the survey that was planned (other cases, budget, targets or
integrators refused, naming the difference; its tables never narrowed), a survey in which
no run completed fails, and a target of a measure no case is scored on is refused with
the measures there are."""

from __future__ import annotations

import pandas as pd
import pytest
from typer.testing import CliRunner

from daebench.cli.app import app
from daebench.core.params import ParamError
from daebench.harness.sweeps.store import StoreError
from daebench.workflows import survey as S

TINY = dict(integrators=("hht",), quick=True, jobs=1, reference="none", repeat_check=False, progress=False,
            budget_s=1e6)


def test_resume_with_another_plan_is_refused_naming_the_difference(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    first = S.run_survey(S.SurveyOptions(cases=("pendulum",), name="s1", **TINY))
    assert list(first.table.status) == ["completed", "completed"]
    table = pd.read_csv(first.folder / "table.csv")
    for change, said in (
            (dict(cases=("pendulum", "ball")), "cases (--cases): planned pendulum, now pendulum, ball"),
            (dict(budget_s=10.0), "budget per case (--budget, s): planned 1e+06, now 10"),
            (dict(targets={"err_theta_max": [1e-3]}),
             "targets (--target): planned the default decades, now err_theta_max=0.001"),
            (dict(integrators=("hht", "newmark")), "integrators (-i): planned hht, now hht, newmark")):
        o = {**TINY, "cases": ("pendulum",), **change}
        with pytest.raises(StoreError, match="cannot resume survey 's1'") as e:
            S.run_survey(S.SurveyOptions(name="s1", resume=True, **o))
        assert said in str(e.value)
        pd.testing.assert_frame_equal(pd.read_csv(first.folder / "table.csv"), table)   # never narrowed
    # the plan it was made with resumes (nothing left to run), and a new name is a new survey
    again = S.run_survey(S.SurveyOptions(cases=("pendulum",), name="s1", resume=True, **TINY))
    assert list(again.table.status) == ["completed", "completed"]


def test_running_an_interrupted_survey_again_without_resume_is_refused(tmp_path, monkeypatch):
    """Its plan is on disk from before the first run: the name is taken until --resume or --overwrite."""
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    folder = tmp_path / "survey" / "s2"
    folder.mkdir(parents=True)
    (folder / "plan.json").write_text('{"cases": ["pendulum"]}')
    with pytest.raises(StoreError, match="survey 's2' exists.*--resume"):
        S.run_survey(S.SurveyOptions(cases=("ball",), name="s2", **TINY))
    assert (folder / "plan.json").read_text() == '{"cases": ["pendulum"]}'     # not replaced


def test_an_unknown_target_is_refused_listing_the_measures(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    r = CliRunner().invoke(app, ["survey", "--quick", "--cases", "pendulum", "-i", "hht", "--reference", "none",
                                 "--target", "foo=1", "--name", "t"])
    assert r.exit_code == 2, r.output
    assert "--target foo: no case of this survey is scored on 'foo'" in r.output
    assert "err_theta_max_trusted" in r.output and "err_theta_max" in r.output and "Traceback" not in r.output
    assert not (tmp_path / "survey" / "t").exists()                       # refused before anything ran
    with pytest.raises(ParamError, match="did you mean 'err_theta_max'"):
        S.run_survey(S.SurveyOptions(cases=("pendulum",), name="t", targets={"err_theta_mx": [1e-3]}, **TINY))


def test_a_survey_where_no_run_completed_exits_1(tmp_path, monkeypatch):
    """Every run over its cap (timeout rows): nothing was judged, so the survey fails as
    `bench` does for the same runs."""
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    r = CliRunner().invoke(app, ["survey", "--quick", "--cases", "pendulum", "-i", "hht", "--reference", "none",
                                 "--run-cap", "0.001", "-j", "1", "--name", "to"])
    assert "2 runs (2 timeout)" in r.output
    assert r.exit_code == 1, r.output
    assert "no run of the survey completed (2 runs): nothing was judged" in r.output
