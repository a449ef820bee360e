"""Smoke test of `daebench perf` (daebench.cli.perf, daebench.studies.perf.suite with the quick
daebench.studies.perf.settings) with tiny settings: the sections' records — the step rates, the
model-kernel floor (daebench.studies.perf.model_floor), the adaptive step bound
(daebench.studies.perf.adaptive_steps), the peer comparison (daebench.studies.perf.peers) — and the
report (daebench.studies.perf.report). The figures themselves come from a full `daebench perf`
run on a quiet machine, never from timed tests."""

import json

from typer.testing import CliRunner

from daebench.cli.app import app


def test_perf_quick_writes_the_figures(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    res = CliRunner().invoke(app, ["perf", "--quick", "--out", str(tmp_path / "perf")])
    assert res.exit_code == 0, res.output
    data = json.loads((tmp_path / "perf" / "perf.json").read_text())
    for k in ("compile_s", "step_rates", "scaling", "exudyn", "adaptive"):
        assert k in data
    assert {r["integrator"] for r in data["step_rates"]} == {"hht", "baumgarte", "newmark+hertz", "ida"}
    assert all(r["steps"] > 0 for r in data["step_rates"])
    bound = data["adaptive"]["bound"]
    assert bound["available"] and bound["steps_lower_bound"] >= 0.0 and len(bound["windows"]) == 1
    assert "growth / N²" in res.output and "Steps per second" in res.output
    floor = data["floor"]  # the model-kernel floor: a bound no run can beat
    assert [(r["case"], r["integrator"]) for r in floor] == [("beam-impact", "hht"), ("pendulum", "hht"),
                                                             ("pendulum", "genalpha")]
    assert all(r["residual_evals_per_step"] >= 1.0 and 0.0 < r["kernel_share"] < 1.0
               and r["bound_steps_per_s"] > r["steps_per_s"] for r in floor)
    assert "model's own physics" in (tmp_path / "perf" / "perf.md").read_text()
