"""daebench.models.caraxis: the road excitation of the car axis (Hairer–Wanner's benchmark):
the point B(t) = (√(L² − y_b²), r sin ω t) stays on the circle of radius L about the origin,
and its velocity and acceleration are its derivatives (checked by central differences)."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.models import build_system
from daebench.models.caraxis import road
from daebench.models.scenes import load_scene


@pytest.fixture(scope="module")
def md():
    return build_system(load_scene("caraxis")).data


@pytest.mark.parametrize("t", [0.0, 0.37, 1.2, 2.9])
def test_the_road_point_and_its_derivatives(md, t):
    xb, yb, xd, yd, xdd, ydd = road(md, t)
    assert xb * xb + yb * yb == pytest.approx(md.L ** 2, rel=1e-14)
    assert yb == pytest.approx(md.r * np.sin(md.w * t), rel=1e-14, abs=1e-300)
    dt = 1e-5

    def pos(s):
        return np.array(road(md, s)[:2])

    def vel(s):
        return np.array(road(md, s)[2:4])

    np.testing.assert_allclose([xd, yd], (pos(t + dt) - pos(t - dt)) / (2 * dt), rtol=1e-7, atol=1e-10)
    np.testing.assert_allclose([xdd, ydd], (vel(t + dt) - vel(t - dt)) / (2 * dt), rtol=1e-6, atol=1e-9)
