"""The energy scale a run's residual is measured against (daebench.core.energyscale),
against closed forms of small systems written here."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.core.energyscale import ABSOLUTE_FLOOR, FLOOR_TIME, energy_scale, force_floor


class Point:
    """A point mass m under a constant force Q with the energy terms given."""

    def __init__(self, m: float, Q: float, terms: dict[str, float]):
        self.m, self.Q, self.terms = m, Q, terms

    def energy(self, q, v):
        return dict(self.terms)

    def mass(self, q):
        return np.array([[self.m]])

    def applied_force(self, t, q, v):
        return np.array([self.Q])


Z = np.zeros(1)


def test_a_spring_started_from_rest_is_measured_by_its_energy():
    k, x0 = 100.0, 0.1
    assert energy_scale(Point(1.0, -k * x0, {"elastic": 0.5 * k * x0**2, "kinetic": 0.0}), Z, Z) == \
        pytest.approx(0.5, rel=1e-15)


def test_opposite_terms_that_cancel_still_give_a_scale():
    assert energy_scale(Point(1.0, 0.0, {"kinetic": 3.0, "gravity": -3.0}), Z, Z) == pytest.approx(6.0)


def test_a_start_with_no_energy_gets_what_its_force_gives_in_the_floor_time():
    """½ (τQ)²/m: a 2 kg mass at rest under its weight, τ = FLOOR_TIME."""
    m, g = 2.0, 9.81
    want = 0.5 * (FLOOR_TIME * m * g) ** 2 / m
    assert energy_scale(Point(m, m * g, {"kinetic": 0.0, "gravity": 0.0}), Z, Z) == pytest.approx(want, rel=1e-12)
    assert want == pytest.approx(9.62361e-5, rel=1e-5)


def test_neither_energy_nor_force_nor_a_usable_mass_gives_the_absolute_floor():
    assert energy_scale(Point(1.0, 0.0, {"kinetic": 0.0}), Z, Z) == ABSOLUTE_FLOOR
    singular = Point(0.0, 5.0, {"kinetic": 0.0})
    assert force_floor(singular, Z, Z) == 0.0
    assert energy_scale(singular, Z, Z) == ABSOLUTE_FLOOR
