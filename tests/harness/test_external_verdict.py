"""An external trajectory is judged (daebench.harness.scoring.external.judge) by the rules a daebench run is held to — penetration,
divergence with the case's own energy scale, no energy made at an impact, values beyond the
case, a trajectory that does not move — and a file that breaks one is never "completed".

Independent truths: the closed forms of tests/_closed_forms.py, the pendulum's start energy
−m g l cos θ0 = −9.81 cos 30° J (m = l = 1) and free fall x = h0 − g t²/2."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

import daebench
from _closed_forms import G, H0, T_BALL, pendulum_theta_deg
from _external_files import ball_event_driven, pendulum

E0_PENDULUM = -G * math.cos(math.radians(30.0))   # m = l = 1


def _row(case, df, **kw):
    return daebench.score(case, df, write=False, **kw).row


def _not_completed(row, status, words):
    assert row["status"] == status and words in row["verdict_reason"], row["verdict_reason"]
    assert all(not (v == v) for k, v in row.items() if k.startswith("err_")), "a broken file keeps no error"


def test_a_ball_through_the_floor_diverged():
    t = np.linspace(0.0, T_BALL, 2501)
    x = H0 - 0.5 * G * t * t                       # never bounces: 29.6 m below the floor at t_end
    row = _row("ball", pd.DataFrame({"t": t, "x": x, "v": -G * t, "gap": x}))
    _not_completed(row, "diverged", "inside its rigid obstacle")


def test_energy_from_nowhere_diverged_against_the_cases_scale():
    df = pendulum().assign(E=lambda d: E0_PENDULUM + 1e4 * d["t"])   # 10⁴ J made in an 8.5 J pendulum
    row = _row("pendulum", df)
    _not_completed(row, "diverged", "energy residual")
    assert row["energy_resid_max"] == pytest.approx(1e4, rel=1e-9)
    assert row["energy_resid_rel"] == pytest.approx(1e4 / abs(E0_PENDULUM), rel=1e-9)


def test_a_small_drift_completes_and_is_relative_to_the_cases_scale():
    df = pendulum().assign(E=lambda d: E0_PENDULUM + 1e-3 * d["t"])
    row = _row("pendulum", df)
    assert row["status"] == "completed" and row["err_theta_max"] < 1e-12
    assert row["energy_resid_rel"] == pytest.approx(1e-3 / abs(E0_PENDULUM), rel=1e-9)


def test_impacts_that_make_energy_fail_with_restitution_at_most_one():
    df = ball_event_driven()
    E = G * df["x"] + 0.5 * df["v"] ** 2
    df = df.assign(E=E, D_impacts=-(E.iloc[0] - E))   # D_impacts falls at each impact: energy made there
    _not_completed(_row("ball", df), "failed", "D_impacts")
    gain = df.drop(columns="D_impacts")
    t = gain["t"].to_numpy()
    k = np.flatnonzero(np.diff(t) == 0)
    gain.loc[k + 1, "E"] = gain.loc[k, "E"].to_numpy() + 1.0   # each impact makes 1 J
    _not_completed(_row("ball", gain), "failed", "made 1.000e+00 J")


def test_noise_is_refused_at_its_start_and_diverged_when_allowed():
    rng = np.random.default_rng(1)
    df = pendulum().assign(x=lambda d: rng.normal(0.0, 1e3, len(d)))   # |x| of kilometres on a 1 m pendulum
    with pytest.raises(daebench.ParamError, match="the start is not the case's"):
        _row("pendulum", df)
    _not_completed(_row("pendulum", df, allow_start_mismatch=True), "diverged", "'x' reaches")


def test_a_constant_or_zero_file_is_no_trajectory():
    t = np.linspace(0.0, 1.0, 1001)
    _not_completed(_row("pendulum", pd.DataFrame({"t": t, "theta_deg": 30.0})), "failed", "at every row")
    zero = pd.DataFrame({"t": t, "theta_deg": 0.0})
    with pytest.raises(daebench.ParamError, match=r"'theta_deg' is 0 deg at t = 0, the case's start is 30 deg"):
        _row("pendulum", zero)
    _not_completed(_row("pendulum", zero, allow_start_mismatch=True), "failed", "at every row")


def test_the_exact_pendulum_with_its_energy_completes():
    t = np.linspace(0.0, 1.0, 1001)
    th = np.radians(pendulum_theta_deg(t))
    df = pd.DataFrame({"t": t, "theta_deg": np.degrees(th), "E": E0_PENDULUM})
    row = _row("pendulum", df)
    assert row["status"] == "completed" and row["energy_resid_max"] == 0.0 and row["energy_ok"]


def test_the_command_exits_1_for_a_file_whose_physics_broke(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from _external_files import csv
    from daebench.cli.app import app

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    t = np.linspace(0.0, T_BALL, 2501)
    x = H0 - 0.5 * G * t * t
    f = csv(tmp_path / "floor.csv", pd.DataFrame({"t": t, "x": x, "v": -G * t, "gap": x}))
    r = CliRunner().invoke(app, ["score", "ball", f])
    out = " ".join(r.output.split())
    assert r.exit_code == 1 and "status: diverged: contact 0 is" in out and "inside its rigid obstacle" in out


@pytest.mark.slow   # block-incline's capturing reference: a fine Moreau–Jean run (cached after the first)
def test_a_block_resting_on_its_ground_holds_its_gap_at_zero_and_completes():
    """The closed form of block-incline (daebench.models.rigid2d_exact): the corners on the
    ground, gap 0 at every row exactly, while the reference holds it to round-off (±3e-17 m);
    its impacts (the two corners closing at the start) carry no impulse, so the impulse
    measure is unknown (NaN), not zero."""
    from daebench.models.rigid2d_exact import incline_motion

    t = np.linspace(0.0, 1.0, 1001)
    x, vx = incline_motion(3.0, math.radians(30.0), 0.3, G, t)
    df = pd.DataFrame({"t": t, "x": x, "vx": vx, "y": 0.1, "theta": 0.0, "gap": 0.0})
    row = _row("block-incline", df, impacts=pd.DataFrame({"t": [0.0, 0.0], "contact": [0, 1]}))
    assert row["status"] == "completed", row["verdict_reason"]
    assert row["err_x_max_trusted"] < 1e-5 and row["err_gap_max_trusted"] < 1e-15
    assert math.isnan(row["err_impulse_measure"])
    # the rule still holds where the truth moves: x held at its start is no trajectory
    _not_completed(_row("block-incline", df.assign(x=0.0)), "failed", "'x' is 0 at every row")
