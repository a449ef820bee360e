"""The start of another code's file is the case's: a column whose value at t = 0 differs is
refused with both values named (unless allowed), and energy terms without D_impacts on a case
with impacts are said to count the impacts' loss as residual.

Independent truth: the ball's closed form (tests/_closed_forms.py) and its start x = 1 m."""

from __future__ import annotations

import pandas as pd
import pytest
from typer.testing import CliRunner

import daebench
from _closed_forms import G
from _external_files import ball_event_driven, csv
from daebench.cli.app import app

runner = CliRunner()


@pytest.fixture(autouse=True)
def results(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    return tmp_path / "results"


def _shifted(radius=0.1) -> pd.DataFrame:
    df = ball_event_driven()
    return df.assign(x=df["x"] + radius).drop(columns="gap")   # the centre written, not the contact point


def test_a_start_shifted_by_the_radius_is_refused_with_both_values(tmp_path, results):
    r = runner.invoke(app, ["score", "ball", csv(tmp_path / "r.csv", _shifted())])
    msg = " ".join(r.output.split())
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert "'x' is 1.1 m at t = 0, the case's start is 1 m" in msg and "--allow-start-mismatch" in msg
    assert not results.exists() or not any(results.rglob("*.json"))


def test_an_allowed_start_mismatch_is_scored_with_a_note(tmp_path):
    r = runner.invoke(app, ["score", "ball", csv(tmp_path / "r.csv", _shifted()), "--allow-start-mismatch",
                            "--json"])
    assert r.exit_code == 0, r.output
    import json

    row = json.loads(r.stdout.strip().splitlines()[-1])
    assert "the start differs from the case's (allowed)" in row["message"]
    assert row["err_x_max"] == pytest.approx(0.1, rel=1e-9)


def test_energy_terms_without_d_impacts_are_named():
    df = ball_event_driven()
    df = df.assign(E=G * df["x"] + 0.5 * df["v"] ** 2)
    res = daebench.score("ball", df, write=False)
    assert "no D_impacts column" in res.row["message"] and res.row["status"] == "completed"
    lost = (1 - 0.8 ** 8) * G   # E0 = m g h0 (m = 1, h0 = 1); four impacts keep e⁸ of it
    assert res.row["energy_resid_max"] == pytest.approx(lost, rel=1e-9)
