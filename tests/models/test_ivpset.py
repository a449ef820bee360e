"""The work of rheonomic constraints (daebench.models._ivpset) against the work–energy
theorem: along any motion, dE/dt equals the power of the non-conservative forces. For
crank (the driven crank, no damping) that is the drive's λᵀC_t alone; for caraxis the road
constraint's λᵀC_t plus the road spring's power. dE/dt is taken here by fourth-order central
differences of the model's energy along (q̇, q̈), with q̈ from the test's own index-1 solve — λ
never enters it, so a wrong multiplier, row or sign in the module shows as a mismatch (a
flipped sign of λᵀC_t fails both cases)."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.models import build_system
from daebench.models._ivpset import consistent_multipliers, constraint_power
from daebench.models.scenes import load_scene


def _acceleration(system, t, q, v):
    """q̈ of M q̈ + C_qᵀλ = Q, C_q q̈ = γ, by eliminating λ with a null-space basis of C_q."""
    M, Q = system.mass_force(t, q, v)
    _, Cq, _, gam = system._constraint_rows(t, q, v)
    a_p = np.linalg.lstsq(Cq, gam, rcond=None)[0]            # a particular solution of C_q q̈ = γ
    N = np.linalg.svd(Cq)[2][Cq.shape[0]:].T                  # columns spanning the null space of C_q
    z = np.linalg.solve(N.T @ M @ N, N.T @ (Q - M @ a_p))
    return a_p + N @ z


def _consistent_velocity(system, t, q, v):
    """v moved onto C_q v + C_t = 0 (least change)."""
    _, Cq, Ct, _ = system._constraint_rows(t, q, v)
    return v - np.linalg.lstsq(Cq, Cq @ v + Ct, rcond=None)[0]


def _energy(system, q, v):
    return sum(system.energy(q, v).values())


@pytest.mark.parametrize("case", ["crank", "caraxis"])
def test_energy_rate_equals_the_power_of_the_moving_constraints(case):
    system = build_system(load_scene(case))
    q0, v0 = system.initial_state()
    rng = np.random.default_rng(7)
    for t in (0.0, 0.013, 0.041):
        # a state off the start (the theorem holds at any consistent (q, q̇), not only on the run)
        v = _consistent_velocity(system, t, q0, v0 * (1.0 + 0.2 * rng.standard_normal(v0.size)))
        a = _acceleration(system, t, q0, v)
        eps = 1e-3 / np.abs(v).max()
        E = [_energy(system, q0 + k * eps * v, v + k * eps * a) for k in (-2, -1, 1, 2)]
        dE = (E[0] - 8 * E[1] + 8 * E[2] - E[3]) / (12 * eps)    # fourth-order central difference
        power = sum(system.power(t, q0, v).values())
        # the power is ~1e-6 of the energy on crank (44 J): the floor is the differences' round-off
        assert power == pytest.approx(dE, rel=1e-2, abs=1e-12 * _energy(system, q0, v)), (case, t, power, dE)
        # the drive's share alone: λᵀC_t, and λ the one the constrained dynamics carry
        M, Q = system.mass_force(t, q0, v)
        Cq = system._constraint_rows(t, q0, v)[1]
        lam = consistent_multipliers(system, t, q0, v)
        np.testing.assert_allclose(M @ a + Cq.T @ lam, Q, atol=1e-9 * np.abs(Q).max() + 1e-12)
        assert constraint_power(system, t, q0, v) == pytest.approx(float(lam @ system._constraint_rows(t, q0)[2]))
