"""Files read as other codes write them (daebench.harness.scoring.external.loading, through
daebench.api.external and daebench.cli.external), bounded before anything is allocated, and every
refusal a message that names the problem and the fix (exit 2, nothing written)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import daebench
from _closed_forms import T_BALL, ball_impacts, ball_motion
from _external_files import csv, pendulum
from daebench.cli.app import app

runner = CliRunner()


@pytest.fixture(autouse=True)
def results(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    return tmp_path / "results"


def _refused(*args) -> str:
    r = runner.invoke(app, ["score", *args])
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    return " ".join(r.output.split())


def test_a_column_written_twice_is_named_as_such(tmp_path):
    f = tmp_path / "a.csv"
    f.write_text("t,theta_deg,theta_deg\n0,30,30\n1,-29.9,-29.9\n")
    msg = _refused("pendulum", str(f))
    assert "has the column 'theta_deg' twice" in msg and "x.1" not in msg and "theta_deg.1" not in msg


def test_a_utf16_file_with_its_byte_order_mark_is_read(tmp_path):
    f = tmp_path / "u16.csv"
    f.write_bytes(pendulum().to_csv(index=False).encode("utf-16"))
    row = daebench.score("pendulum", str(f), write=False).row
    assert row["status"] == "completed" and row["err_theta_max"] < 1e-12


def test_a_semicolon_separated_file_is_told_to_use_commas(tmp_path):
    f = tmp_path / "semi.csv"
    f.write_text("t;theta_deg\n0;30\n1;-29,94\n")
    msg = _refused("pendulum", str(f))
    assert "separated by semicolons" in msg and "no time column" not in msg


def test_times_in_milliseconds_get_a_unit_hint(tmp_path):
    df = pendulum().assign(t=lambda d: d["t"] * 1e3)
    msg = _refused("pendulum", csv(tmp_path / "ms.csv", df))
    assert "outside the case's span" in msg and "look like milliseconds" in msg


def test_a_file_starting_after_the_case_is_refused(tmp_path):
    df = pendulum()
    msg = _refused("pendulum", csv(tmp_path / "late.csv", df[df["t"] >= 0.2]))
    assert "the data start at t = 0.2 s, after the case's start t = 0" in msg


def test_impacts_file_errors_speak_of_impacts(tmp_path):
    t = np.linspace(0.0, T_BALL, 2501)
    x, v = ball_motion(t, ball_impacts())
    f = csv(tmp_path / "ball.csv", pd.DataFrame({"t": t, "x": x, "v": v}))
    imp = csv(tmp_path / "imp.csv", pd.DataFrame({"t": [0.9, 0.45]}))
    msg = _refused("ball", f, "--impacts", imp)
    assert "sort the impacts by t" in msg and "two sides" not in msg


def test_many_columns_are_refused_from_the_header(tmp_path):
    f = tmp_path / "wide.csv"
    f.write_text("t," + ",".join(f"c{i}" for i in range(5000)) + "\n" + ",".join(["0"] * 5001) + "\n")
    assert "has 5001 columns, more than the 2000 read" in _refused("pendulum", str(f))


def test_parquet_rows_are_counted_from_its_metadata(tmp_path, monkeypatch):
    from daebench.harness.scoring.external import reading

    f = tmp_path / "big.parquet"
    pendulum().to_parquet(f, index=False)
    monkeypatch.setattr(reading, "MAX_CELLS", 1000)
    read = []
    monkeypatch.setattr(reading.pd, "read_parquet", lambda *a, **k: read.append(a))
    assert "holds 1001 rows × 2 columns, more than the" in _refused("pendulum", str(f))
    assert not read


def test_a_long_label_is_clipped_in_the_message(tmp_path):
    f = csv(tmp_path / "lab.csv", pendulum(), ["# label: " + "a/" * 50_000])
    msg = _refused("pendulum", f)
    assert "cannot name a row" in msg and "(100000 characters)" in msg and len(msg) < 600


def test_the_summary_never_speaks_of_the_none(tmp_path):
    t = np.linspace(0.0, T_BALL, 2501)
    x, v = ball_motion(t, ball_impacts())
    r = runner.invoke(app, ["score", "ball", csv(tmp_path / "b.csv", pd.DataFrame({"t": t, "x": x, "v": v}))])
    assert r.exit_code == 0, r.output
    out = " ".join(r.output.split())
    assert "from the none" not in out and "none in the data (no impacts file, gap column or repeated time)" in out


def test_a_missed_first_impact_prints_no_first_impact_time(tmp_path):
    imp = ball_impacts()
    t = np.linspace(0.0, T_BALL, 2501)
    x, v = ball_motion(t, imp)
    f = csv(tmp_path / "b.csv", pd.DataFrame({"t": t, "x": x, "v": v}))
    fi = csv(tmp_path / "i.csv", pd.DataFrame({"t": imp[1:]}))
    r = runner.invoke(app, ["score", "ball", f, "--impacts", fi])
    assert r.exit_code == 0, r.output
    out = " ".join(r.output.split())
    assert "impact times: max over the matched" in out and "first 2.2" not in out and "first " not in \
        out.split("impact times:")[1].split("graph")[0]


def test_impacts_beside_the_file_are_read(tmp_path):
    imp = ball_impacts()
    t = np.linspace(0.0, T_BALL, 2501)
    x, v = ball_motion(t, imp)
    f = csv(tmp_path / "run.csv", pd.DataFrame({"t": t, "x": x, "v": v}))
    csv(tmp_path / "run-impacts.csv", pd.DataFrame({"t": imp, "contact": 0}))
    row = daebench.score("ball", f, write=False).row
    assert row["impacts_matched"] == len(imp) and math.isclose(row["err_impact_t_max"], 0.0, abs_tol=1e-12)
    assert '"events": "impacts file"' in row["settings"]


def test_a_moreau_jean_bounce_with_a_positive_gap_is_found(tmp_path):
    """A capturing code bounces before the gap closes (its velocity-level law acts when the gap
    is about to close): the gap written at its steps turns back up short of zero, as the exact
    ball's gap does at output times that straddle each impact. Its impacts are the rows where
    it turns, within one output interval of the truth's."""
    imp = ball_impacts()
    t = np.linspace(0.0, T_BALL, 2501)
    x, v = ball_motion(t, imp)
    gap = x
    assert gap.min() > 0.0                          # closed at no output time
    row = daebench.score("ball", pd.DataFrame({"t": t, "x": x, "v": v, "gap": gap}), write=False).row
    assert row["impacts"] == len(imp) and row["impacts_matched"] == len(imp)
    assert row["err_impact_t_matched_max"] <= 1e-3
