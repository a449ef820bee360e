"""`daebench survey` (daebench.workflows.survey): protocols, rounds within the budget,
resume, scoring across cases; determinism of history digests across executors."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from daebench.core.params import ParamError
from daebench.harness.sweeps import digest, sweep as bench
from daebench.workflows import compare, survey as S
from daebench.harness.sweeps.options import Execution, Storage, SweepOptions, Timing
from daebench.harness.sweeps.plan import plan_sweep


def test_halvings_and_protocols():
    e = S.halvings("hht")
    assert e.steps == (1e-4, 5e-5, 2.5e-5) and not e.tols            # its default h and two halvings
    e = S.halvings("ida", 2)
    assert e.tols == (1e-8, 1e-9) and not e.steps                     # adaptive only: decades of its rtol
    sc = S.case_scene("beam-impact")
    p = S.survey_protocol(sc)
    declared = list(compare.declared_entries(sc).values())
    assert p.entries[: len(declared)] == tuple(declared)             # what each integrator declares, as compare has it
    assert declared[0].integrator == "ida" and declared[0].tols == (1e-4, 1e-5, 1e-6)   # the case's [compare] table
    assert {x.integrator for x in p.entries} >= {"lcp", "imm", "central"}
    q = S.case_scene("ball", quick=True)
    assert q.t_end == S.QUICK_T_END and S.survey_protocol(q, quick=True).entries[0].steps == (1e-4, 5e-5)


def test_rounds_group_by_refinement_level():
    sc = S.case_scene("pendulum", quick=True)
    specs, _ = compare.plan(sc, compare.Protocol((S.halvings("hht"), S.halvings("newmark", 2))))
    r = S.rounds(specs)
    assert [[(s.integrator, s.options["h"]) for s in g] for g in r] == [
        [("hht", 1e-4), ("newmark", 1e-4)], [("hht", 5e-5), ("newmark", 5e-5)], [("hht", 2.5e-5)]]


def test_refusals_before_running():
    with pytest.raises(ParamError, match="unknown case"):
        S.run_survey(S.SurveyOptions(cases=("no-such-case",)))
    with pytest.raises(ParamError, match="budget"):
        S.run_survey(S.SurveyOptions(cases=("pendulum",), budget_s=-1.0))
    with pytest.raises(ParamError, match="did you mean 'hht'"):
        S.run_survey(S.SurveyOptions(cases=("pendulum",), integrators=("hhtx",)))


def test_score_across_cases_known_answers():
    """Two synthetic cases, error = C h², cost ∝ 1/h: 'a' is twice as cheap as 'b' on both,
    so ρ_a(1) = 1, ρ_b(1) = 0, ρ_b(2) = 1 and the recommendation names 'a' with ratio 2."""
    results = []
    for case in ("c1", "c2"):
        rows = [dict(run=i, case=case, label=lab, integrator=lab, h=h, status="completed", cpu_s=k / h,
                     cpu_spread=0.01, steps=1 / h, err_y_max=3.0 * h * h)
                for i, (lab, k, h) in enumerate((lab, k, h) for lab, k in (("a", 1e-3), ("b", 2e-3))
                                                for h in (1e-2, 5e-3, 2.5e-3))]
        results.append(S.CaseResult(case, pd.DataFrame(rows), {}, ["err_y_max"], 1.0, 1, 1))
    res = S.score(results, {"err_y_max": [1e-4]})
    assert len(res.reach) == 4 and res.reach.qualified.all()
    prof = res.profile.set_index("setting")
    assert prof.loc["a", "rho_1"] == 1.0 and prof.loc["b", "rho_1"] == 0.0 and prof.loc["b", "rho_4"] == 1.0
    assert "take a (between h=0.01 and h=0.005)" in res.paragraphs["c1"] and "2× the cost" in res.paragraphs["c1"]
    assert res.records["c1"][0]["ratio"] == pytest.approx(2.0, rel=1e-12)


def test_a_case_that_declares_targets_is_judged_on_them_without_target():
    """beam-impact's case file declares err_impact1_t = [1e-8] ([compare.targets], read here
    with tomllib); a case that declares none ('c2', not a library case) gets the powers of
    ten between the quartiles of the errors pooled over the cases: beam-impact's 1e-6 h and
    c2's 1e-4 h at h = 1e-2, 5e-3, 2.5e-3 pool to 2.5e-9 … 1e-6, quartiles 6.25e-9 and
    4.375e-7, so 1e-8 and 1e-7."""
    import tomllib

    from daebench.core.scene import cases_dir

    declared = tomllib.loads((cases_dir() / "beam-impact.toml").read_text())["compare"]["targets"]
    results = []
    for case, k in (("beam-impact", 1e-6), ("c2", 1e-4)):
        rows = [dict(run=i, case=case, label="a", integrator="a", h=h, status="completed", cpu_s=1e-3 / h,
                     cpu_spread=0.01, steps=1 / h, err_impact1_t=k * h) for i, h in enumerate((1e-2, 5e-3, 2.5e-3))]
        results.append(S.CaseResult(case, pd.DataFrame(rows), {}, ["err_impact1_t"], 1.0, 1, 1))
    reach = S.score(results).reach
    assert sorted(reach[reach.case == "beam-impact"].target) == declared["err_impact1_t"] == [1e-8]
    assert sorted(reach[reach.case == "c2"].target) == pytest.approx([1e-8, 1e-7], rel=1e-12)
    # a --target given replaces the declared ones for every case
    assert set(S.score(results, {"err_impact1_t": [5e-9]}).reach.target) == {5e-9}


@pytest.mark.slow
def test_quick_case_budget_skip_then_resume(tmp_path, monkeypatch):
    """A budget too small for the second round: its runs are 'skipped-budget' rows; resumed
    with the same budget nothing runs (the rounds' time already spent counts); a larger
    budget is another survey (refused on resume), and a new name runs it."""
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    o = dict(cases=("pendulum",), integrators=("hht", "newmark"), quick=True, jobs=1, name="t",
             reference="none", repeat_check=False, progress=False)
    # the budget only gates later rounds: round 1 always runs, round 2 is predicted at 2 × round 1 > 1e-6 s
    res = S.run_survey(S.SurveyOptions(budget_s=1e-6, **o))
    tab = res.table
    assert list(zip(tab.integrator, tab.h, tab.status)) == [      # rows in plan order
        ("hht", 1e-4, "completed"), ("hht", 5e-5, S.SKIPPED), ("newmark", 1e-4, "completed"), ("newmark", 5e-5, S.SKIPPED)]
    assert "over the case budget" in tab.message.iloc[1]
    meta = json.loads((res.folder / "survey.json").read_text())
    assert meta["cases"][0]["skipped_budget"] == 2 and meta["cases"][0]["rounds_run"] == 1
    assert meta["workers_started"] == 1                               # --jobs 1: one worker for the survey
    with pytest.raises(ParamError, match="exists"):
        S.run_survey(S.SurveyOptions(budget_s=100.0, **o))
    same = S.run_survey(S.SurveyOptions(budget_s=1e-6, resume=True, **o)).table   # the same budget: the time
    assert list(same.status) == list(tab.status)                   # already spent still counts, nothing runs
    with pytest.raises(ParamError, match=r"budget per case \(--budget, s\): planned 1e-06, now 1e\+06"):
        S.run_survey(S.SurveyOptions(budget_s=1e6, resume=True, **o))
    again = S.run_survey(S.SurveyOptions(budget_s=1e6, **{**o, "name": "t2"})).table
    assert list(again.status) == ["completed"] * 4
    keep = ["run", "label", "h", "steps"]
    first = [0, 2]
    pd.testing.assert_frame_equal(again[keep].iloc[first], tab[keep].iloc[first], check_dtype=False)


def test_digest_is_bitwise():
    """A one-ulp change of one value changes the digest; so does a column name; the
    mismatch listing pairs runs by case, scene, integrator and settings."""
    h = pd.DataFrame({"t": np.linspace(0.0, 1.0, 11), "x": np.sin(np.arange(11.0))})
    h2 = h.copy()
    h2.loc[3, "x"] = np.nextafter(h2.loc[3, "x"], np.inf)
    assert digest.history_digest(h.copy()) == digest.history_digest(h)
    assert digest.history_digest(h2) != digest.history_digest(h)
    assert digest.history_digest(h.rename(columns={"x": "y"})) != digest.history_digest(h)
    a = pd.DataFrame({"case": ["x"], "integrator": ["hht"], "settings": ["{}"], "scene_hash": ["s"], "digest": ["1"]})
    assert len(digest.mismatches(a, a)) == 0 and len(digest.mismatches(a, a.assign(digest="2"))) == 1


@pytest.mark.slow
def test_digest_is_equal_across_executors(tmp_path):
    """The same runs inline, on 2 worker processes and on a local Dask cluster give
    histories with identical digests."""
    sc = S.case_scene("pendulum", quick=True).with_overrides({"t_end": 0.05})
    specs = plan_sweep(sc, ["hht", "newmark"], steps=[1e-3])
    digests = {}
    for how, kw in (("inline", dict(executor="inline")), ("jobs2", dict(jobs=2)),
                    ("dask", dict(executor="dask", jobs=1))):
        options = SweepOptions(reference="none", timing=Timing(repeats=1, warmup=False),
                               execution=Execution(progress=False, **kw),
                               storage=Storage(write=False, history_dir=tmp_path / how))
        df = bench.run_specs(specs, sc, options)
        digests[how] = [digest.history_digest(pd.read_parquet(p)) for p in df["history"]]
    assert digests["inline"] == digests["jobs2"] == digests["dask"]
    assert len(set(digests["inline"])) == 2                       # two different runs, two digests


@pytest.mark.slow
def test_one_worker_serves_every_case_and_round(tmp_path, monkeypatch):
    """Two cases × two rounds (four sweeps) on --jobs 1: one worker process in all (it
    keeps its kernels), every run completed, the pendulum's scored against its exact solution."""
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    res = S.run_survey(S.SurveyOptions(cases=("pendulum", "ball"), integrators=("hht",), quick=True, jobs=1,
                                       name="w", reference="none", repeat_check=False, progress=False,
                                       budget_s=1e6))   # every round runs, however slow the machine
    assert res.workers_started == 1
    assert [c.rounds_run for c in res.cases] == [2, 2]
    assert list(res.table.status) == ["completed"] * 4
    pend = res.table[res.table.case == "pendulum"]
    assert len(pend) == 2 and pend.filter(like="err_").notna().any(axis=1).all()
