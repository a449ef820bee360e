"""The LZB multiple-impact law (daebench.core.lzb), checked against truth independent of it:

* two bodies: Newton's law with the restitution e (the energetic coefficient of a
  frictionless two-body impact is Newton's), closed form (cradle.two_ball_outcome); e = 1
  and equal masses exchange the velocities;
* momentum conservation (exact: the impulses act in pairs) and the energy book (the
  dissipation booked per contact against the kinetic energy lost);
* a bilateral constraint kept: two balls tied together are one body of twice the mass;
* the law's stated order: halving the step divides the error by about 2⁴;
* the stated accuracy: the default step meets its target on chains of 10 and 100 balls.
"""

from __future__ import annotations

import numpy as np
import pytest

from daebench.core.lzb import ACCURACY, lzb_impact, steps_for
from daebench.models.cradle import hertz_stiffness, masses, radii, two_ball_outcome

STEEL = dict(modulus=203e9, poisson=0.3)


def chain(n: int, ratio: float = 1.0):
    """(M, G, v⁻, K) of n steel balls (R = 1 cm, ρ = 7780 kg/m³) in a row, the first at 1 m/s."""
    r = radii(n, 0.02, ratio)
    G = np.zeros((n - 1, n))
    for i in range(n - 1):
        G[i, i], G[i, i + 1] = -1.0, 1.0
    v = np.zeros(n)
    v[0] = 1.0
    return np.diag(masses(r, 0.0, 7780.0)), G, v, hertz_stiffness(r, STEEL["modulus"], STEEL["poisson"])


@pytest.mark.parametrize("e", [1.0, 0.7, 0.3, 0.0])
@pytest.mark.parametrize("m2", [0.03, 0.05])
def test_two_bodies_follow_newtons_law_with_the_energetic_restitution(e, m2):
    """v⁺ of two balls (m1 = 0.03 kg at 1 m/s on m2 at rest) equals Newton's law with e to the
    default accuracy (1e-8 of the approach speed); the energy lost, (1 − e²) ½ m* u², is the
    dissipation booked at the contact, to the accuracy the velocities' implies (2e-8 of the
    striker's energy)."""
    m1 = 0.03
    M, G, v = np.diag([m1, m2]), np.array([[-1.0, 1.0]]), np.array([1.0, 0.0])
    res = lzb_impact(M, G, v, 1e10, 1.5, e)
    assert res.ok
    assert np.abs(res.v_plus - two_ball_outcome(m1, m2, 1.0, 0.0, e)).max() < ACCURACY
    lost = 0.5 * (1.0 - e * e) * m1 * m2 / (m1 + m2)
    assert res.energy_loss == pytest.approx(lost, abs=2 * ACCURACY * 0.5 * m1)
    assert res.dissipation[0] == pytest.approx(lost, abs=2 * ACCURACY * 0.5 * m1)
    assert res.vn_plus[0] == pytest.approx(e, abs=ACCURACY)  # Newton: ġ⁺ = −e ġ⁻
    assert res.impulse_n[0] > 0.0 and not res.impulse_t.any()


def test_equal_balls_exchange_their_velocities():
    res = lzb_impact(np.eye(2) * 0.03, np.array([[-1.0, 1.0]]), np.array([1.0, 0.0]), 1e10, 1.5, 1.0)
    assert np.abs(res.v_plus - [0.0, 1.0]).max() < ACCURACY


def test_a_bilateral_constraint_is_kept():
    """Balls 2 and 3 tied (v2 = v3): the striker meets one body of mass 2m."""
    M, G = np.eye(3) * 0.03, np.array([[-1.0, 1.0, 0.0]])
    for e in (1.0, 0.6):
        res = lzb_impact(M, G, np.array([1.0, 0.0, 0.0]), 1e10, 1.5, e, np.array([[0.0, 1.0, -1.0]]))
        v1, v2 = two_ball_outcome(0.03, 0.06, 1.0, 0.0, e)
        assert np.abs(res.v_plus - [v1, v2, v2]).max() < ACCURACY


def test_contacts_that_do_not_approach_get_no_impulse():
    res = lzb_impact(np.eye(2), np.array([[-1.0, 1.0]]), np.array([0.0, 1.0]), 1e10, 1.5, 1.0)
    assert res.ok and not res.impulse_n.any() and np.array_equal(res.v_plus, [0.0, 1.0])


def test_refuses_a_contact_without_stiffness():
    with pytest.raises(ValueError, match="positive stiffness"):
        lzb_impact(np.eye(2), np.array([[-1.0, 1.0]]), np.array([1.0, 0.0]), 0.0, 1.5, 1.0)


@pytest.mark.parametrize("ratio, e", [(1.0, 1.0), (0.95, 1.0), (1.0, 0.8)])
def test_the_error_falls_as_the_fourth_power_of_the_step(ratio, e):
    """Ten balls (equal, tapered; e = 1, 0.8): halving the step in impulse (N = 16 → 32)
    divides the error of v⁺ (against N = 128) by 2⁴ (measured 15.7, 16.6, 11.9; at least 2³
    asked: order ≥ 3); the momentum is conserved exactly at every N."""
    M, G, v, K = chain(10, ratio)
    out = {N: lzb_impact(M, G, v, K, 1.5, e, steps=N) for N in (16, 32, 128)}
    err = {N: np.abs(out[N].v_plus - out[128].v_plus).max() for N in (16, 32)}
    assert err[16] / err[32] > 8.0, err
    for r in out.values():
        assert abs(np.diag(M) @ r.v_plus - M[0, 0]) < 1e-15


@pytest.mark.parametrize("n, ratio, e", [(10, 1.0, 1.0), (10, 0.95, 1.0), (10, 1.0, 0.5),
                                         pytest.param(100, 1.0, 1.0, marks=pytest.mark.slow)])
def test_the_default_step_meets_its_accuracy_target(n, ratio, e):
    """The default accuracy (1e-8 of the striker's speed): error of v⁺ against a run at
    N = 4 × steps_for(1e-8) (errors 256 times smaller); energy book: T⁻ − T⁺ equals the
    dissipation booked to the accuracy the velocities' implies (2e-8 of the striker's energy;
    measured 2e-9 … 7e-9)."""
    M, G, v, K = chain(n, ratio)
    res = lzb_impact(M, G, v, K, 1.5, e)
    fine = lzb_impact(M, G, v, K, 1.5, e, steps=4 * steps_for(ACCURACY))
    assert res.step_count == steps_for(ACCURACY)
    assert np.abs(res.v_plus - fine.v_plus).max() < ACCURACY
    assert abs(res.energy_residual) < 2 * ACCURACY * 0.5 * M[0, 0]
    if e == 1.0:
        assert abs(res.energy_loss) < 2 * ACCURACY * 0.5 * M[0, 0]
