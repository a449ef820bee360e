"""daebench.api.runs: a run through the API's front door (then daebench.workflows.run) — the pendulum under hht against its
exact solution (Jacobi elliptic functions, daebench.models.pendulum.exact_theta), second order
from two steps, nothing written unless asked, settings given as a string refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.api import ParamError
from daebench.api.runs import run
from daebench.models.pendulum import exact_theta


def _theta_error(h: float) -> float:
    r = run("pendulum", "hht", overrides={"t_end": 1.0}, settings={"h": h, "alpha": 0.0}, write=False)
    assert r.record.status == "completed" and not r.history_path          # write=False: no file
    theta = np.arctan2(r.q[:, 0], -r.q[:, 1])                    # x = l sin θ, y = −l cos θ
    return float(np.max(np.abs(theta - exact_theta(r.t, math.radians(30.0)))))


def test_hht_on_the_pendulum_converges_at_second_order_to_the_exact_angle():
    e1, e2 = _theta_error(2e-3), _theta_error(1e-3)
    assert e1 < 1e-3
    assert math.log2(e1 / e2) == pytest.approx(2.0, abs=0.15)


def test_settings_as_the_command_lines_string_are_refused():
    with pytest.raises(ParamError, match="settings must be a dict"):
        run("pendulum", "hht", settings="h=1e-3")
