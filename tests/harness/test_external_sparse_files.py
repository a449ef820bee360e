"""A file coarser than the case's output interval is scored on the case's output times, its
values there by its own interpolation rule (linear without a derivative column): two rows
never score better than the full file.

Independent truth: the pendulum's closed form (tests/_closed_forms.py); the expected error of
the two-row file is the largest distance between the closed form and the straight line
through its two rows, at the case's 1 001 output times."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import daebench
from _closed_forms import pendulum_theta_deg
from _external_files import pendulum


def test_two_rows_are_scored_on_the_cases_output_times():
    ends = pendulum_theta_deg(np.array([0.0, 1.0]))
    two = pd.DataFrame({"t": [0.0, 1.0], "theta_deg": ends})
    row = daebench.score("pendulum", two, write=False).row
    full = daebench.score("pendulum", pendulum().assign(theta_deg=lambda d: d["theta_deg"] + 1e-4 * d["t"]),
                          write=False).row
    t = np.linspace(0.0, 1.0, 1001)
    expected = float(np.max(np.abs(np.interp(t, [0.0, 1.0], ends) - pendulum_theta_deg(t))))
    assert expected > 1.0
    assert row["err_theta_max"] == pytest.approx(expected, rel=1e-9)
    assert row["err_theta_max"] > full["err_theta_max"]
    assert (row["file_dt_max"], row["file_rows"], row["file_resampled"]) == (1.0, 2, True)
    assert "coarser than the case's output interval" in row["message"]


def test_a_file_at_the_output_interval_is_scored_at_its_own_rows():
    row = daebench.score("pendulum", pendulum(), write=False).row
    assert row["file_resampled"] is False and row["file_rows"] == 1001
    assert row["file_dt_max"] == pytest.approx(1e-3) and "coarser" not in row["message"]


def test_impact_rows_stay_when_a_coarse_event_driven_file_is_resampled():
    from _external_files import ball_event_driven

    coarse = ball_event_driven(0, n=251)   # 10 ms rows: ten times the case's output.dt
    row = daebench.score("ball", coarse, write=False).row
    assert row["file_resampled"] and row["impacts_matched"] == 4 and row["err_impact_t_max"] < 1e-12
    # cubic Hermite on x with its declared derivative v reproduces each parabolic flight
    # (linear interpolation would be off by up to g Δt²/8 = 1.2e-4 m between 10 ms rows)
    assert row["err_x_max"] <= 1e-12
