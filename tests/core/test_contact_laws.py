"""daebench.core.phase.laws: the continuous contact laws against their formulas written
here — Hertz F = K δⁿ (1 + χ δ̇), penalty F = K δ + c δ̇, no adhesion, the potential the
integral of the elastic force (by quadrature), regularised Coulomb F_T = −μ F_N tanh(v_T/v_ε)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from daebench.core.phase.laws import (LAW_HERTZ, LAW_NONE, LAW_PENALTY, friction_force, law_elastic, law_force,
                                      law_potential)

HERTZ = np.array([LAW_HERTZ, 2.0e9, 1.5, 0.0, 1e-4])
PENALTY = np.array([LAW_PENALTY, 1.0e6, 1.0, 50.0, 1e-4])


@pytest.mark.parametrize("g, gdot", [(-1e-4, -0.3), (-2e-5, 0.1), (-1e-6, 0.0)])
def test_hertz_with_hunt_crossley_damping(g, gdot):
    chi = 0.4
    delta = -g
    want = max(2.0e9 * delta ** 1.5 * (1.0 + chi * (-gdot)), 0.0)
    assert law_force(HERTZ, True, chi, g, gdot) == pytest.approx(want, rel=1e-14)
    assert law_elastic(HERTZ, True, g) == pytest.approx(2.0e9 * delta ** 1.5, rel=1e-14)


def test_penalty_and_no_adhesion():
    assert law_force(PENALTY, True, 0.0, -1e-3, -0.2) == pytest.approx(1e6 * 1e-3 + 50.0 * 0.2, rel=1e-14)
    assert law_force(PENALTY, True, 0.0, -1e-6, 10.0) == 0.0     # separating fast: clipped, never pulls
    assert law_force(HERTZ, True, 1.0, -1e-6, 5.0) == 0.0
    assert law_force(PENALTY, True, 0.0, 1e-3, -0.2) == 0.0      # open gap
    assert law_force(HERTZ, False, 0.4, -1e-4, -0.3) == 0.0      # not engaged
    assert law_force(np.array([LAW_NONE, 1.0, 1.0, 0.0, 1e-4]), True, 0.0, -1.0, -1.0) == 0.0


@pytest.mark.parametrize("law", [HERTZ, PENALTY], ids=["hertz", "penalty"])
def test_the_potential_is_the_work_of_the_elastic_force(law):
    for g in (-1e-6, -3e-5, -1e-3):
        work, err = quad(lambda x: law_elastic(law, True, -x), 0.0, -g, epsabs=0.0, epsrel=1e-12)
        assert law_potential(law, g) == pytest.approx(work, rel=1e-10)
    assert law_potential(law, 1e-3) == 0.0


def test_regularised_coulomb():
    for vt in (-1e-3, -1e-5, 0.0, 2e-5, 1.0):
        assert friction_force(HERTZ, 0.3, 10.0, vt) == pytest.approx(-0.3 * 10.0 * math.tanh(vt / 1e-4), abs=1e-15)
    assert friction_force(HERTZ, 0.3, 10.0, 1.0) == pytest.approx(-3.0, rel=1e-12)   # full slip: μ F_N
    assert friction_force(HERTZ, 0.0, 10.0, 1.0) == 0.0 and friction_force(HERTZ, 0.3, 0.0, 1.0) == 0.0


def test_the_tables_of_forces_and_potentials_follow_the_formulas():
    """law_forces / law_potentials (rows × contacts, the output rows' columns) against
    Hertz's formula written here, contact by contact; an unengaged contact carries no force."""
    from daebench.core.phase.laws import law_forces, law_potentials

    g = np.array([[-1e-4, 2e-3, -3e-6], [-2e-5, -1e-6, 0.0]])
    gdot = np.array([[-0.3, 0.1, 0.0], [0.2, -1.0, 0.5]])
    engaged, chi = np.array([True, True, False]), np.array([0.4, 0.0, 0.4])
    F, U = np.empty(g.shape), np.empty(2)
    law_forces(HERTZ, engaged, chi, g, gdot, F)
    law_potentials(HERTZ, g, U)
    delta = np.maximum(-g, 0.0)
    want = np.where(engaged, np.maximum(2.0e9 * delta ** 1.5 * (1.0 + chi * (-gdot)), 0.0), 0.0)
    np.testing.assert_allclose(F, want, rtol=1e-14, atol=0.0)
    np.testing.assert_allclose(U, (2.0e9 * delta ** 2.5 / 2.5).sum(axis=1), rtol=1e-14, atol=0.0)
