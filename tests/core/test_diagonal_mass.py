"""A lumped model's mass as an operator (daebench.core.linalg.DiagonalMass): the contact
transitions' solves against the dense augmented system written here, and a run of a lumped
FE model through impacts, settling and projection that never builds the dense n × n mass."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.core.frictional_impact import constrained_inverse, frictional_impact
from daebench.core.linalg import DiagonalMass, solve_structured
from daebench.core.problem import Problem
from _rod_wall import acm_ten_elements, assert_semidiscrete_rod  # noqa: E402  (tests/ is on sys.path under pytest)

rng = np.random.default_rng(7)


def _augmented(d: np.ndarray, B: np.ndarray, G: np.ndarray) -> np.ndarray:
    """M_B⁻¹ Gᵀ from [[M, Bᵀ], [B, 0]] [X; Y] = [Gᵀ; 0], dense, by LAPACK."""
    n, mb = d.size, B.shape[0]
    A = np.zeros((n + mb, n + mb))
    A[:n, :n], A[:n, n:], A[n:, :n] = np.diag(d), B.T, B
    return np.linalg.solve(A, np.vstack([G.T, np.zeros((mb, G.shape[0]))]))[:n]


@pytest.mark.parametrize("mb", [0, 2])
def test_constrained_inverse_of_a_diagonal_mass_is_the_augmented_systems(mb):
    n, k = 40, 3
    d = rng.uniform(0.5, 2.0, n)
    B, G = rng.normal(size=(mb, n)), rng.normal(size=(k, n))
    X = constrained_inverse(DiagonalMass(d), B, G)
    np.testing.assert_allclose(X, _augmented(d, B, G), rtol=1e-11, atol=1e-13)
    if mb:
        np.testing.assert_allclose(B @ X, 0.0, atol=1e-12)       # the bilateral rows kept


def test_products_and_solves_of_a_diagonal_mass():
    d, v = rng.uniform(0.5, 2.0, 6), rng.normal(size=6)
    M = DiagonalMass(d)
    assert v @ M @ v == pytest.approx(float(np.sum(d * v * v)), rel=1e-14)
    np.testing.assert_array_equal(M @ v, d * v)
    np.testing.assert_allclose(solve_structured(M, np.eye(6)), np.diag(1.0 / d), rtol=1e-15)
    with pytest.raises(ValueError, match="positive"):
        DiagonalMass(np.array([1.0, 0.0]))
    with pytest.raises(ValueError, match="finite"):
        DiagonalMass(np.array([1.0, np.nan]))


def test_frictional_impact_with_a_diagonal_mass_is_the_dense_ones():
    """Two contacts, one with friction, one bilateral row: Newton–Coulomb with the operator
    and with the dense matrix give the same velocities and impulses."""
    n = 12
    d = rng.uniform(0.5, 2.0, n)
    GN, GT, B = rng.normal(size=(2, n)), rng.normal(size=(2, n)), rng.normal(size=(1, n))
    v = -(GN.T @ np.array([1.0, 0.5])) * 0.3
    dense = frictional_impact(np.diag(d), GN, GT, np.array([0.3, 0.0]), v, 0.5, B)
    op = frictional_impact(DiagonalMass(d), GN, GT, np.array([0.3, 0.0]), v, 0.5, B)
    assert dense.status >= 0 and op.status >= 0          # solved (the status counts pivots)
    np.testing.assert_allclose(op.v_plus, dense.v_plus, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(op.impulse_n, dense.impulse_n, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(op.impulse_t, dense.impulse_t, rtol=1e-10, atol=1e-12)
    assert op.energy_loss == pytest.approx(dense.energy_loss, rel=1e-10)


def test_a_lumped_fe_run_through_impacts_never_builds_the_dense_mass(monkeypatch):
    """rod-wall, 10 lumped elements, constraint law: the two end nodes' impact, the
    settling that holds them and the projections run on the diagonal — the dense mass is
    refused — and the run is still the semi-discrete rod of docs/sources.md §A.3
    (v/v0 = 0.928, energy after 0.950)."""
    def refuse(self, q):
        raise AssertionError("the dense n × n mass was built for a lumped model")

    monkeypatch.setattr(Problem, "mass", refuse)
    assert_semidiscrete_rod(*acm_ten_elements())
