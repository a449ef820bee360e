"""A scored row is never replaced by another: result files are keyed on everything scored (the
data, the impacts, the cost and steps, the options)."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from typer.testing import CliRunner

from _closed_forms import T_BALL, ball_impacts, ball_motion
from _external_files import csv
from daebench.cli.app import app

runner = CliRunner()


def _json(*args):
    r = runner.invoke(app, ["score", *args, "--json"])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_other_impacts_or_cost_make_another_file(tmp_path):
    import numpy as np

    imp = ball_impacts()
    t = np.linspace(0.0, T_BALL, 2501)
    x, v = ball_motion(t, imp)
    f = csv(tmp_path / "ball.csv", pd.DataFrame({"t": t, "x": x, "v": v}))
    all_ = csv(tmp_path / "all.csv", pd.DataFrame({"t": imp}))
    three = csv(tmp_path / "three.csv", pd.DataFrame({"t": imp[1:]}))
    out = tmp_path / "out"
    rows = [_json("ball", f, "--impacts", all_, "--out", str(out)),
            _json("ball", f, "--impacts", three, "--out", str(out)),
            _json("ball", f, "--impacts", all_, "--cost-s", "0.5", "--out", str(out)),
            _json("ball", f, "--impacts", all_, "--cost-s", "0.5", "--out", str(out))]   # the same again
    files = sorted(out.glob("*.json"))
    assert len(files) == 3
    kept = sorted((json.loads(p.read_text())["impacts_missed"], json.loads(p.read_text())["wall_s"] or 0.0)
                  for p in files)
    assert kept == [(0, 0.0), (0, 0.5), (1, 0.0)] and rows[1]["impacts_missed"] == 1


def test_an_empty_out_is_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    f = csv(tmp_path / "p.csv", pd.DataFrame({"t": [0.0, 1.0], "theta_deg": [30.0, -29.94099]}))
    r = runner.invoke(app, ["score", "pendulum", f, "--out", ""])
    assert r.exit_code != 0 and "must be a folder path" in r.output
    assert not list(tmp_path.glob("*.json"))
