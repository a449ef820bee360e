"""daebench.core.phase.compliant: a continuous law's contact force in the phase's force,
against the ball on a penalty wall written out — Q = −m g + (k δ + c δ̇) for δ = −x > 0, only
−m g while the gap is open, and ∂Q/∂x = −k, ∂Q/∂v = −c inside (central differences of it)."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.core.phase import forces
from daebench.core.problem import Problem
from daebench.models import build_system
from daebench.models.scenes import load_scene

K, C, M, G = 1.0e5, 45.0, 1.0, 9.81        # cases/ball.toml with contact.law = penalty


@pytest.fixture(scope="module")
def ph():
    return Problem(build_system(load_scene("ball", {"contact.law": "penalty"}))).kernel


@pytest.mark.parametrize("x, v, pushing", [(-1e-3, -0.5, True), (-2e-4, 0.1, True), (1e-3, -0.5, False),
                                            (-1e-5, 5.0, False)])     # the last: separating fast, clipped at 0
def test_the_penalty_force_in_the_phases_force(ph, x, v, pushing):
    Mm, Q = np.empty((1, 1)), np.empty(1)
    forces.mass_force(ph, 0.0, np.array([x]), np.array([v]), Mm, Q)
    F = K * (-x) + C * (-v) if pushing else 0.0
    assert Mm[0, 0] == M
    assert Q[0] == pytest.approx(-M * G + max(F, 0.0), rel=1e-14, abs=1e-12)


def test_inside_the_wall_the_force_jacobian_is_minus_k_and_minus_c(ph):
    Kq, Kv = np.empty((1, 1)), np.empty((1, 1))
    forces.force_jacobian(ph, 0.0, np.array([-1e-3]), np.array([-0.5]), Kq, Kv)
    assert Kq[0, 0] == pytest.approx(-K, rel=1e-6) and Kv[0, 0] == pytest.approx(-C, rel=1e-6)
