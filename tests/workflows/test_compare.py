"""`daebench compare`: the protocol's plan, every row scored, the shipped reference fingerprint.

Independent truths: the pendulum's exact solution (every compared run is scored against
it, as `daebench.run` scores the same run: one scoring pipeline), the
integrators' declared capabilities (which ones may run a constraint-contact scene), and —
slow — a reference recomputed from scratch reproducing the fingerprint shipped with the
repository.
"""

from __future__ import annotations

import json

from pathlib import Path

import numpy as np
import pytest

from daebench.harness.sweeps.options import Execution, SweepOptions
from daebench.workflows import compare as C
from daebench.harness.references import fingerprints
from daebench.models.scenes import load_scene


def test_beam_impact_protocol_plans_every_applicable_integrator():
    sc = load_scene("beam-impact")
    specs, refused = C.plan(sc, C.protocol_for(sc))
    planned = {s.integrator for s in specs}
    # constraint contact with an impact law: ODE-only and complementarity-only methods cannot run it
    assert set(refused) == {"central", "lcp", "lcp-avg"}
    assert {"hht", "newmark", "genalpha", "baumgarte", "ida", "moreau", "nsgenalpha"} <= planned
    hht = sorted(s.options["h"] for s in specs if s.integrator == "hht")
    assert hht == [2.5e-5, 5e-5, 1e-4] and all(s.options["h_contact"] == 1e-6 for s in specs if s.integrator == "hht")
    assert [s.index for s in specs] == list(range(len(specs)))


def test_compare_scores_every_row_and_writes_table_and_figure(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    sc = load_scene("pendulum", {"t_end": 0.5})
    proto = C.Protocol((C.Entry("hht", (1e-2, 5e-3), options={"alpha": 0.0}), C.Entry("central")),
                       measures=("err_theta_max", "err_pos_max"))
    options = SweepOptions(reference="compute", execution=Execution(jobs=1, progress=False))
    res = C.run_compare(sc, options, out=tmp_path / "cmp", protocol=proto)
    df = res.table
    assert list(df["status"]) == ["completed", "completed"] and "central" in res.not_applicable
    assert np.all(np.isfinite(df["err_theta_max"])) and np.all(df["repeats"] >= 1)
    # one scoring pipeline: the row is scored against the exact solution, as the API scores the run
    from daebench import api
    assert (df["against"] == "exact solution").all()
    for _, r in df.iterrows():
        run = api.run(sc, "hht", h=float(r["h"]), alpha=0.0)
        assert run.error["against"] == "exact solution"
        assert r["err_theta_max"] == pytest.approx(run.error["err_theta_max"], rel=1e-12)
        assert r["err_pos_max"] == pytest.approx(run.error["err_pos_max"], rel=1e-12)
    assert (tmp_path / "cmp" / "table.csv").exists() and (tmp_path / "cmp" / "wp-pendulum.png").exists()
    cols, rows = res.table_rows()
    assert len(rows) == 2 and cols[:5] == ["integrator", "settings", "status", "steps", "CPU\n[s]"]
    assert cols[5] == "θ max\nwhole run\n[deg]" and rows[1][1] == "h=0.005" and rows[1][4] == df["cpu_s"].iloc[1]
    # the observed order of the second run: log(e1/e2)/log(2), against the first
    e = df["err_theta_max"].to_numpy()
    assert df["order"].iloc[1] == pytest.approx(np.log(e[0] / e[1]) / np.log(2.0), rel=1e-12)
    side = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    for r in side["recommendations"]:
        assert {"target", "pick", "cost_cpu_s", "runner_up", "ratio", "reasons"} <= set(r)
    assert res.heading("pendulum") == "pendulum: 2 runs (runs given to compare) — hht: h = 0.01, 0.005 s with alpha = 0"


def test_protocols_are_the_cases_declarations():
    """compare reads the case's [compare] table (the methods it names at its steps, the
    contact step only for the event-driven ones) and runs every other integrator once at its
    defaults; the heading says what ran, grouped."""
    from daebench.integrators.registry import get_integrator

    sc = load_scene("rocking-block")
    assert sc.comparison.steps == (2e-3, 1e-3, 5e-4) and get_integrator("hht").protocol("rocking-block") is None
    proto = C.protocol_for(sc)
    by = {e.integrator: e for e in proto.entries}
    assert by["hht"].declared and by["hht"].steps == (2e-3, 1e-3, 5e-4) and not by["central"].declared
    assert by["moreau"].steps == (2e-3, 1e-3, 5e-4) and not by["ida"].declared
    beams = {e.integrator: e for e in C.protocol_for(load_scene("beam-impact")).entries}
    assert beams["hht"].options == {"h_contact": 1e-6} and beams["moreau"].options == {}   # capturing: no contact step
    assert beams["ida"].tols == (1e-4, 1e-5, 1e-6) and not beams["ida"].steps
    assert list(beams)[0] == "ida"   # tolerance runs first
    import pandas as pd
    df = pd.DataFrame({"integrator": ["moreau", "moreau", "nsgenalpha", "nsgenalpha", "central"],
                       "h": [2e-3, 1e-3, 2e-3, 1e-3, 1e-4], "tol": [float("nan")] * 5})
    res = C.CompareResult(df, {}, [], proto)
    assert res.heading("rocking-block") == (
        "rocking-block: 5 runs (the runs declared for this case; the others once at their defaults: "
        "nothing declared for this case) — moreau, nsgenalpha: h = 0.002, 0.001 s; central: one run at its defaults")
    df = pd.DataFrame({"integrator": ["hht", "ida"], "h": [1e-4, float("nan")], "tol": [float("nan")] * 2})
    assert C.CompareResult(df, {}, [], C.default_protocol(sc)).heading("pendulum") == (
        "pendulum: 2 runs (every integrator once at its defaults: no runs declared for this case) — hht, ida: "
        "one run each at their defaults")


def test_fingerprint_refuses_a_reference_that_disagrees(monkeypatch):
    import pandas as pd

    from daebench.harness.references.reference import Reference, ReferenceDamaged

    sc = load_scene("beam-impact")
    t = np.linspace(0.0, sc.t_end, 20001)
    hist = pd.DataFrame({"t": t, "theta_deg": 45.0 * np.cos(3 * t), "tip_y": 0.7 * np.cos(3 * t)})
    good = Reference(hist, [0.37, 0.79], {"settings": {"rtol": 1e-11}}, Path("ref.parquet"))
    monkeypatch.setattr(fingerprints, "_load", lambda: {sc.hash: fingerprints.make(sc, good)})
    fingerprints.check(sc, good)
    late = Reference(hist, [0.37, 0.79 + 1e-7], good.meta, good.path)
    assert "impact times" in " ".join(fingerprints.differences(sc, late))
    bent = Reference(hist.assign(theta_deg=hist["theta_deg"] + 1e-3), [0.37, 0.79], good.meta, good.path)
    with pytest.raises(ReferenceDamaged, match="theta_deg differs"):
        fingerprints.check(sc, bent)


@pytest.mark.slow
def test_shipped_beam_impact_reference_is_reproduced_from_scratch(tmp_path, monkeypatch):
    """The reference `daebench compare beam-impact` scores against (IDA rtol 1e-11, computed
    when missing) reproduces the fingerprint shipped in cases/reference-fingerprints.json."""
    from daebench.harness.references.reference import compute_reference

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    sc = load_scene("beam-impact")
    ref = compute_reference(sc)
    assert sc.hash in fingerprints._load(), "no fingerprint shipped for the default beam-impact scene"
    assert fingerprints.differences(sc, ref) == []
    assert ref.meta["agreement"]["err_impact_t_max"] < 1e-8


def test_an_error_at_the_start_is_a_row_not_a_refusal():
    """Only the integrator's own refusal before its first step (an IntegratorError raised by
    its start, flagged by the driver) means 'not applicable'; any other failure before the
    first step (e.g. a compilation that broke) stays in the table as an error row, whatever
    its message says."""
    import pandas as pd

    from daebench.harness.running.runner import make_integrator, run_scene
    from daebench.integrators.hht import HHT
    from daebench.models.scenes import load_scene

    class Broken(HHT):
        name = "broken-start"

        def start(self, *args, **kwargs):
            raise RuntimeError("IntegratorError: a message that only looks like a refusal")

    _, refused = run_scene(load_scene("ball"), make_integrator("imm", {}), write=False, force=True)
    _, broken = run_scene(load_scene("ball"), Broken(), write=False, force=True)
    assert refused.refused and refused.t_final == 0.0 and "runs the planar FE models" in refused.message
    assert not broken.refused and broken.status == "failed"
    rows = [pd.Series({"status": r.status, "t_final": 0.0, "steps": 0, "message": r.message, "refused": r.refused})
            for r in (refused, broken)]
    assert C._refused_at_start(rows[0]) and not C._refused_at_start(rows[1])
    assert not C._refused_at_start(pd.Series({"status": "failed", "refused": float("nan")}))   # an older row


def test_the_figure_title_states_what_the_answer_depends_on():
    """beam-impact's file sets N = 5 and e = 0 over 1 s (read with tomllib); the pendulum has
    neither key, so only its span is stated."""
    import tomllib

    from daebench.core.scene import cases_dir

    raw = tomllib.loads((cases_dir() / "beam-impact.toml").read_text())
    n, e, t = raw["discretization"]["n"], raw["contact"]["restitution"], raw["t_end"]
    assert C.scene_label(load_scene("beam-impact")) == f"beam-impact (N = {n:g}, e = {e:g}, {t:g} s)"
    assert C.scene_label(load_scene("beam-impact", ["discretization.n=7"])).startswith("beam-impact (N = 7,")
    assert C.scene_label(load_scene("pendulum")).endswith(" s)") and "N =" not in C.scene_label(
        load_scene("pendulum"))
