"""Other codes' rows beside daebench's: `daebench compare CASE --include FILE` and the report
page, and the worked example of the documentation — the pendulum run by Exudyn's
generalized-α (docs/examples/exudyn_pendulum.py), written to CSV and scored.

Independent truths: the pendulum's closed form (tests/_closed_forms.py) for the included file
whose error is known; for Exudyn, its own generalized-α, whose error must fall as h² (the
method's order) when scored against the exact solution.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from _closed_forms import pendulum_theta_deg
from daebench.cli.app import app
from daebench.workflows import compare as C

runner = CliRunner()
EXAMPLE = Path(__file__).resolve().parents[2] / "docs" / "examples" / "exudyn_pendulum.py"
#: a small protocol for the pendulum: the comparison's own runs are not what is tested here
SMALL = C.Protocol((C.Entry("hht", (1e-2, 5e-3), options={"alpha": 0.0}),), measures=("err_theta_max_trusted",),
                   why="two hht runs beside the included files")
SMALL_BALL = C.Protocol((C.Entry("hht", (1e-3,)),), measures=("err_x_max_trusted",),
                        why="one hht run beside the included file")


def example():
    spec = importlib.util.spec_from_file_location("exudyn_pendulum", EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(autouse=True)
def results(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    real = C.protocol_for
    small = {"pendulum": SMALL, "ball": SMALL_BALL}
    monkeypatch.setattr(C, "protocol_for", lambda sc: small.get(sc.name) or real(sc))
    return tmp_path / "results"


def _closed_form(path: Path, offset: float, meta: tuple[str, ...]) -> Path:
    t = np.linspace(0.0, 1.0, 1001)
    with open(path, "w") as fh:
        fh.write("".join(line + "\n" for line in meta))
        pd.DataFrame({"t": t, "theta_deg": pendulum_theta_deg(t) + offset * t}).to_csv(fh, index=False)
    return path


def _plotted(monkeypatch) -> list:
    """The figures compare draws (the work–precision figure's lines are read from them)."""
    figs = []
    real = C.plots.work_precision

    def keep(*a, **k):
        out = real(*a, **k)
        figs.append(out[0])
        return out

    monkeypatch.setattr(C.plots, "work_precision", keep)
    return figs


def test_compare_shows_included_rows_marked_external(tmp_path, monkeypatch):
    figs = _plotted(monkeypatch)
    a = _closed_form(tmp_path / "a.csv", 1e-4, ("# label: closed-form", "# cost_s: 0.01", "# steps: 100"))
    b = _closed_form(tmp_path / "b.csv", 1e-5, ("# label: closed-form", "# cost_s: 0.02", "# steps: 200"))
    out = tmp_path / "cmp"
    r = runner.invoke(app, ["compare", "pendulum", "--budget", "0", "--include", str(a), "--include", str(b), "--jobs", "1",
                            "--out", str(out), "--report"])
    assert r.exit_code == 0, r.output
    assert "closed-form [external] h=0.01" in r.output and "external: closed-form (a.csv)" in r.output
    table = pd.read_parquet(out / "table.parquet")
    ext = table[table["integrator"] == "external"]
    assert list(ext["label"]) == ["closed-form", "closed-form"] and list(ext["wall_s"]) == [0.01, 0.02]
    assert list(ext["cpu_s"]) == [0.01, 0.02] and list(ext["h"]) == [0.01, 0.005]
    assert ext["order"].iloc[1] == pytest.approx(np.log2(10.0), rel=1e-6)   # 1e-4 → 1e-5 as h halves
    assert ext["err_theta_max_trusted"].to_numpy() == pytest.approx([1e-4, 1e-5], rel=1e-6)
    assert (table["integrator"] == "hht").sum() == 2 and (table["against"] == "exact solution").all()
    assert list(table["run"]) == list(range(len(table)))
    page = (out / "report.html").read_text()
    assert "closed-form [external]" in page and "Other codes" in page
    side = json.loads((out / "compare.json").read_text())
    assert [e["cost_s"] for e in side["external"]] == [0.01, 0.02]
    assert (out / "wp-pendulum.png").exists()
    lines = [ln for ax in figs[-1].axes for ln in ax.get_lines() if str(ln.get_label()).startswith("closed-form")]
    assert len(lines) == 1 and "not shown" not in lines[0].get_label()
    assert list(lines[0].get_xdata()) == [0.01, 0.02]   # the files' costs, on the CPU axis
    assert lines[0].get_ydata() == pytest.approx([1e-4, 1e-5], rel=1e-6)


def test_an_included_file_takes_its_impacts_from_beside_it(tmp_path):
    from _closed_forms import T_BALL, ball_impacts, ball_motion

    imp = ball_impacts()
    t = np.linspace(0.0, T_BALL, 2501)
    x, v = ball_motion(t, imp)
    f = tmp_path / "code.csv"
    pd.DataFrame({"t": t, "x": x, "v": v}).to_csv(f, index=False)
    pd.DataFrame({"t": imp[1:], "contact": 0}).to_csv(tmp_path / "code-impacts.csv", index=False)
    out = tmp_path / "cmp"
    r = runner.invoke(app, ["compare", "ball", "--include", str(f), "--jobs", "1", "--out", str(out)])
    assert r.exit_code == 0, r.output
    ext = pd.read_parquet(out / "table.parquet").query("integrator == 'external'").iloc[0]
    assert json.loads(ext["settings"])["events"] == "impacts file"
    assert (ext["impacts_matched"], ext["impacts_missed"]) == (len(imp) - 1, 1)


def test_an_included_file_with_a_unit_error_refuses_before_any_run(tmp_path):
    t = np.linspace(0.0, 1.0, 1001)
    f = tmp_path / "rad.csv"
    pd.DataFrame({"t": t, "theta_deg": np.radians(pendulum_theta_deg(t))}).to_csv(f, index=False)
    out = tmp_path / "cmp"
    r = runner.invoke(app, ["compare", "pendulum", "--budget", "0", "--include", str(f), "--jobs", "1", "--out", str(out)])
    assert r.exit_code == 2 and "looks like a unit error" in r.output and "Traceback" not in r.output
    assert not (out / "table.csv").exists()


def test_exudyn_generalized_alpha_is_scored_and_compared(tmp_path):
    pytest.importorskip("exudyn")
    ex = example()
    import daebench

    sheet = daebench.export_case("pendulum", write=False).sheet
    files = []
    for h in (1e-3, 5e-4):   # at most the case's output.dt: each file scored at its own rows
        df, meta = ex.simulate(sheet, h)
        files.append(ex.write_csv(df, meta, tmp_path / f"exudyn-h{h:g}.csv"))
    rows = [daebench.score("pendulum", f, write=False).row for f in files]
    for r in rows:
        assert r["against"] == "exact solution" and r["label"] == "exudyn-genalpha" and r["wall_s"] > 0
        assert 0 < r["err_theta_max"] < 1e-3 and r["energy_resid_max"] < 1e-4
    ratio = rows[0]["err_theta_max"] / rows[1]["err_theta_max"]
    assert 3.5 < ratio < 4.5, f"generalized-α is second order: halving h should quarter the error, got {ratio:.2f}"
    out = tmp_path / "cmp"
    r = runner.invoke(app, ["compare", "pendulum", "--budget", "0", *sum((["--include", str(f)] for f in files), []),
                            "--jobs", "1", "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert r.output.count("exudyn-genalpha [external]") == 2
    table = pd.read_parquet(out / "table.parquet")
    ext = table[table["integrator"] == "external"]
    assert ext["err_theta_max"].to_numpy() == pytest.approx([x["err_theta_max"] for x in rows], rel=1e-12)
