"""daebench.core.phase.rows and .forces: the active constraint rows and the phase's mass,
force and Jacobians, against closed forms — the pendulum's rod C = ½(x² + y² − l²)
(C_q = [x, y], γ = −v·v, ∂(C_qᵀλ)/∂q = λ I, ∂(C_q v)/∂q = vᵀ, M = m I, Q = (0, −m g)) and the
ball's closed contact (the row C = −(x − x_w), C_q = −1)."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.core.phase import forces, rows
from daebench.core.problem import Problem
from daebench.models import build_system
from daebench.models.scenes import load_scene

Q_AT = np.array([0.6, -0.8])       # on the unit circle
V_AT = np.array([0.8, 0.6])        # tangent to it


@pytest.fixture(scope="module")
def pendulum():
    return Problem(build_system(load_scene("pendulum", {"pendulum.mass": 2.0})))


def test_the_rod_row(pendulum):
    ph = pendulum.kernel
    C, Ct, gam, Cq = np.empty(1), np.empty(1), np.empty(1), np.empty((1, 2))
    q = Q_AT * 1.1                                        # off the circle: C ≠ 0
    rows.constraints(ph, 0.0, q, V_AT, C, Cq, Ct, gam)
    assert C[0] == pytest.approx(0.5 * (q @ q - 1.0), rel=1e-15)
    np.testing.assert_allclose(Cq[0], q, rtol=1e-15)
    assert Ct[0] == 0.0 and gam[0] == pytest.approx(-(V_AT @ V_AT), rel=1e-15)


def test_the_rods_second_derivatives_by_differences_are_the_closed_forms(pendulum):
    ph = pendulum.kernel
    K = np.empty((2, 2))
    rows.constraint_force_jacobian(ph, 0.0, Q_AT, np.array([3.0]), K)      # ∂(C_qᵀλ)/∂q = λ I
    np.testing.assert_allclose(K, 3.0 * np.eye(2), atol=1e-8)
    Kv = np.empty((1, 2))
    rows.velocity_constraint_jacobian(ph, 0.0, Q_AT, V_AT, Kv)             # ∂(C_q v)/∂q = vᵀ
    np.testing.assert_allclose(Kv[0], V_AT, atol=1e-8)


def test_the_pendulums_mass_force_and_jacobians(pendulum):
    ph = pendulum.kernel
    M, Q = np.empty((2, 2)), np.empty(2)
    forces.mass_force(ph, 0.0, Q_AT, V_AT, M, Q)
    np.testing.assert_array_equal(M, 2.0 * np.eye(2))
    np.testing.assert_allclose(Q, [0.0, -2.0 * 9.81], rtol=1e-15)
    Kq, Kv = np.full((2, 2), np.nan), np.full((2, 2), np.nan)
    forces.force_jacobian(ph, 0.0, Q_AT, V_AT, Kq, Kv)                   # gravity: no state dependence
    np.testing.assert_array_equal(Kq, 0.0)
    np.testing.assert_array_equal(Kv, 0.0)


def test_a_closed_contact_is_a_row_after_the_bilateral_ones():
    system = build_system(load_scene("ball"))
    p = Problem(system, active=(0,))
    wall = 0.0                                             # cases/ball.toml: the ground at x = 0
    C, Ct, gam, Cq = np.empty(1), np.empty(1), np.empty(1), np.empty((1, 1))
    q, v = np.array([0.25]), np.array([-1.5])
    rows.constraints(p.kernel, 0.0, q, v, C, Cq, Ct, gam)
    assert C[0] == pytest.approx(-(0.25 - wall), rel=1e-15) and Cq[0, 0] == -1.0
    assert Ct[0] == 0.0 and gam[0] == 0.0                  # a flat wall: no curvature term
