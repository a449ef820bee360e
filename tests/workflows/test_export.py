"""`daebench export CASE`: what another code needs to set a case up.

Independent check: a scene file written only from the exported JSON, every key explicit
(no daebench default can fill a gap), runs to a history equal to the bit to the case's own;
the docs' case pages are the export's Markdown sheets.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from daebench.cli.app import app

runner = CliRunner()
DOCS = Path(__file__).resolve().parents[2] / "docs" / "cases"


@pytest.fixture(autouse=True)
def results(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    return tmp_path / "results"


def toml_value(v) -> str:
    """A JSON value as TOML (what another code's set-up script would write)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    return json.dumps(v)   # strings and lists of strings: JSON's escapes are TOML's


def test_an_exported_case_rebuilt_from_its_values_runs_to_the_same_history(tmp_path, results):
    import daebench
    from daebench.models.scenes import model_schema

    r = runner.invoke(app, ["export", "beam-impact", "--json"])
    assert r.exit_code == 0, r.output
    sheet = json.loads(r.stdout)
    values = {p["key"]: p["value"] for p in sheet["parameters"]}
    assert set(values) == set(model_schema(sheet["model"])), "every key of the model, none left to a default"
    values["t_end"] = 0.05                                       # a short run, before the first impact
    scene = tmp_path / "rebuilt.toml"
    scene.write_text("".join(f"{k} = {toml_value(v)}\n" for k, v in values.items()))
    original = daebench.load_scene("beam-impact", {"t_end": 0.05})
    rebuilt = daebench.load_scene(scene)
    assert rebuilt.values == original.values and rebuilt.hash == original.hash
    a = daebench.run(original, "hht", h=1e-4).observables
    b = daebench.run(rebuilt, "hht", h=1e-4).observables
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    assert len(a) == 51 and sheet["time"]["output_times"] == 1001


def test_the_sheet_states_units_start_contact_and_observables(results):
    import daebench

    res = daebench.export_case("ball")
    s = res.sheet
    assert {p.suffix for p in res.files} == {".json", ".md"} and all(p.is_relative_to(results) for p in res.files)
    assert json.loads(res.files[0].read_text()) == s
    units = {p["key"]: p["unit"] for p in s["parameters"]}
    assert units["start.x"] == "m" and units["gravity.g"] == "m/s²" and units["t_end"] == "s"
    assert s["initial_state"]["coordinates"] == [{"name": "x", "q0": 1.0, "v0": 0.0}]
    assert s["contact"]["law"] == "constraint" and s["contact"]["restitution"] == 0.8
    assert s["contact"]["gaps_at_start"] == [1.0]
    obs = {o["name"]: o for o in s["observables"]}
    assert obs["x"]["unit"] == "m" and obs["x"]["at_start"] == 1.0 and "scored" in obs["x"]["role"]
    assert obs["gap"]["role"] == ["height above the contact surface"]
    assert s["time"] == {"t_end": 2.5, "output_dt": 0.001, "output_times": 2501,
                         "rule": "t_k = k·t_end/2500, k = 0 … 2500 (output.dt = 0.001 s divides t_end)"}
    assert s["energy_at_start"]["E_gravity"] == pytest.approx(9.81)
    assert "daebench score ball FILE.csv [--impacts IMPACTS.csv]" in s["scoring"]["command"]
    pend = daebench.export_case("pendulum", write=False).sheet
    assert pend["scoring"]["truth"] == "the exact solution" and "--impacts" not in pend["scoring"]["command"]


@pytest.mark.parametrize("case", ["pendulum", "ball", "beam-impact"])
def test_the_docs_case_page_is_the_export_sheet(case):
    import daebench
    from daebench.workflows.export import markdown

    assert (DOCS / f"{case}.md").read_text() == markdown(daebench.export_case(case, write=False).sheet), \
        f"docs/cases/{case}.md is stale: rewrite it with `daebench export {case} --out docs/cases` (keep the .md)"


@pytest.mark.slow
def test_every_docs_case_page_is_current():
    import daebench
    from daebench.core.scene import list_scenes
    from daebench.workflows.export import markdown

    stale = [n for n, _ in list_scenes()
             if not (DOCS / f"{n}.md").exists()
             or (DOCS / f"{n}.md").read_text() != markdown(daebench.export_case(n, write=False).sheet)]
    assert stale == []


def test_an_empty_out_is_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = runner.invoke(app, ["export", "ball", "--out", ""])
    assert r.exit_code != 0 and "must be a folder path" in r.output
    assert not list(tmp_path.glob("ball.*"))


def test_the_description_states_the_values_used_after_set(results):
    import daebench

    sheet = daebench.export_case("ball", overrides=["contact.restitution=0.5"], write=False).sheet
    assert "restitution 0.8" in sheet["description"]   # the case file's own words …
    assert "contact.restitution = 0.5 (the case file: 0.8)" in sheet["description"]   # … and the value used
    assert sheet["changed"] == {"contact.restitution": {"value": 0.5, "case_file": 0.8}}
    assert daebench.export_case("ball", write=False).sheet["changed"] == {}


def test_the_score_page_lists_what_each_cases_file_holds():
    from daebench.core.scene import list_scenes
    from daebench.workflows.export import file_table

    page = (Path(__file__).resolve().parents[2] / "docs" / "score-external.md").read_text()
    assert file_table([n for n, _ in list_scenes()]) in page, \
        "docs/score-external.md's per-case table is stale: paste daebench.workflows.export.file_table's output"
