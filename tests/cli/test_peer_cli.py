"""`daebench peer` (daebench.cli.peers): an unknown code refused with the choices (exit 2); Siconos'
Moreau–Jean on the dropped ball scored through the command, its position error against the ball's
closed form (tests/_closed_forms.py) equal to that of daebench's own Moreau–Jean at the same steps
(two codes, one scheme: 7.775e-3 / 4.153e-3 m at h = 1e-3 / 5e-4; daebench 7.775e-3 / 4.145e-3 m)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import daebench
from daebench.cli.app import app
from _closed_forms import ball_impacts, ball_motion  # noqa: E402
from _peers import needs_siconos  # noqa: E402


def test_an_unknown_code_is_refused_with_the_choices():
    res = CliRunner().invoke(app, ["peer", "ball", "--code", "nope"])
    assert res.exit_code == 2 and "unknown peer 'nope'; choose one of siconos-mj, siconos-ed, exudyn-ga" in res.output


@needs_siconos
def test_siconos_moreau_jean_scores_as_daebench_moreau_jean(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    res = CliRunner().invoke(app, ["peer", "ball", "--code", "siconos-mj", "--steps", "1e-3,5e-4", "--json"])
    assert res.exit_code == 0, res.output
    rows = json.loads(res.stdout)
    assert [r["h"] for r in rows] == [1e-3, 5e-4] and all(r["status"] == "completed" for r in rows)
    for r in rows:
        h = daebench.run("ball", integrator="moreau", h=r["h"]).observables
        x, _ = ball_motion(h["t"].to_numpy(), ball_impacts())
        # measured: equal to 1e-12 at 1e-3, 0.19 % apart at 5e-4
        assert r["err_x_max"] == pytest.approx(float(np.max(np.abs(h["x"].to_numpy() - x))), rel=5e-3)
