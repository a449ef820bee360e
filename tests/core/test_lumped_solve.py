"""The lumped-mass solve of a phase (daebench.core.phase: a model with a constant diagonal M
goes through the Schur complement): the same q̈ and λ as the dense augmented system, and
both satisfy M q̈ + C_qᵀλ = Q and C_q q̈ = γ − 2δ(C_q v + C_t) − ε²C with M, Q, C_q, γ
assembled by the model's own kernels."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.core import phase
from daebench.core.problem import Problem
from daebench.models import build_system
from daebench.models.scenes import load_scene


@pytest.fixture(scope="module")
def slider():
    """slider-slot on a coarse mesh (n = 42, 16 node-to-surface contacts)."""
    return build_system(load_scene("slider-slot").with_overrides({"slider.mesh_size": 0.002}))


def _solve(kernel, n, m, t, q, v, delta, eps):
    acc, lam = np.empty(n), np.empty(m)
    w = phase.augmented_work(n, m)
    assert phase.solve_augmented(kernel, t, q, v, delta, eps, w, acc, lam) == 0
    return acc, lam


@pytest.mark.parametrize("active", [(), (0,), (0, 5, 9)])
@pytest.mark.parametrize("delta, eps", [(0.0, 0.0), (30.0, 400.0)])
def test_lumped_solve_equals_dense(slider, active, delta, eps):
    assert slider.lumped_mass.shape == (slider.n,)
    pr = Problem(slider, active=active)
    n, m = pr.n, pr.m
    rng = np.random.default_rng(7)
    q0, v0 = slider.initial_state()
    q = np.ascontiguousarray(q0 + 1e-5 * rng.standard_normal(n))
    v = np.ascontiguousarray(v0 + 1e-2 * rng.standard_normal(n))
    acc, lam = _solve(pr.kernel, n, m, 0.0, q, v, delta, eps)
    dense = pr.kernel._replace(lumped=None)          # the same phase through the dense LU
    acc_d, lam_d = _solve(dense, n, m, 0.0, q, v, delta, eps)
    scale = np.max(np.abs(acc_d))
    np.testing.assert_allclose(acc, acc_d, rtol=0, atol=1e-9 * scale)
    if m:
        np.testing.assert_allclose(lam, lam_d, rtol=1e-9, atol=1e-12 * np.max(np.abs(lam_d)))
    # the equations themselves, from the model's M (dense kernel) and the phase's rows
    w = phase.augmented_work(n, m)
    phase.mass_force(dense, 0.0, q, v, w.M, w.Q)
    np.testing.assert_allclose(np.diag(w.M), slider.lumped_mass, rtol=1e-15)
    res = w.Q - w.M @ acc
    if m:
        phase.constraints(dense, 0.0, q, v, w.C, w.Cq, w.Ct, w.gam)
        Cq = w.Cq[:m]
        res -= Cq.T @ lam
        rhs = w.gam[:m] - 2 * delta * (Cq @ v + w.Ct[:m]) - eps ** 2 * w.C[:m]
        np.testing.assert_allclose(Cq @ acc, rhs, rtol=1e-9, atol=1e-9 * np.max(np.abs(rhs)) + 1e-12)
    assert np.max(np.abs(res)) <= 1e-9 * np.max(np.abs(w.Q))
