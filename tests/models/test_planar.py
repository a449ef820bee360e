"""The planar FE bodies (daebench.models.planar: floating frames, node-to-segment contact,
compiled in daebench.models._planar_kernels): kernels against finite differences and
invariances, meshes and lumped masses against geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.models import build_system
from daebench.models._planar_mesh import assemble, rounded_bar
from daebench.models.scenes import load_scene
from daebench.core.system import central_difference


@pytest.fixture(scope="module")
def rod():
    """A 2 × 6 rod with ν = 0.3, deformed and turned: every kernel term is exercised."""
    s = build_system(load_scene("rod-wall", {"rod.elements": 6, "rod.elements_across": 2, "rod.nu": 0.3}))
    q, v = s.initial_state()
    rng = np.random.default_rng(1)
    q = q + 2e-4 * rng.standard_normal(q.size)
    return s, q, v + rng.standard_normal(v.size)


def _turn(q, th, shift=(0.3, -0.2)):
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    return (q.reshape(-1, 2) @ R.T + np.asarray(shift)).ravel(), R


def test_strain_energy_and_force_are_frame_invariant(rod):
    s, q, v = rod
    qr, R = _turn(q, 0.9)
    assert s.strain_energy(qr) == pytest.approx(s.strain_energy(q), rel=1e-12)
    Q = s.applied_force(0.0, q, v)
    Qr = s.applied_force(0.0, qr, v)
    assert np.max(np.abs(Qr - (Q.reshape(-1, 2) @ R.T).ravel())) < 1e-10 * np.max(np.abs(Q))
    # no net force, no net moment: momentum and angular momentum are conserved
    f = Q.reshape(-1, 2)
    x = q.reshape(-1, 2)
    assert np.max(np.abs(f.sum(axis=0))) < 1e-12 * np.max(np.abs(f))
    assert abs(np.sum(x[:, 0] * f[:, 1] - x[:, 1] * f[:, 0])) < 1e-11 * np.max(np.abs(f))


def test_force_is_minus_the_energy_gradient(rod):
    s, q, v = rod
    grad = central_difference(lambda x: np.array([s.strain_energy(x)]), q, 1)[0]
    Q = s.applied_force(0.0, q, v)
    assert np.max(np.abs(Q + grad)) < 1e-6 * np.max(np.abs(Q))


def test_force_jacobian_matches_differences_and_is_symmetric(rod):
    s, q, v = rod
    Kq, Kv = s.force_jacobian(0.0, q, v)
    fd = central_difference(lambda x: s.applied_force(0.0, x, v), q, s.n)
    assert np.max(np.abs(Kq - fd)) < 1e-7 * np.max(np.abs(fd))
    assert np.max(np.abs(Kq - Kq.T)) < 1e-9 * np.max(np.abs(Kq))
    assert not Kv.any()


def test_lumped_mass_is_the_body_mass_and_constant(rod):
    s, q, v = rod
    M = s.mass(q)
    sc = load_scene("rod-wall")
    m = sc["rod.density"] * sc["rod.length"] * sc["rod.height"] * sc["rod.thickness"]
    assert np.trace(M) == pytest.approx(2.0 * m, rel=1e-12)
    assert np.count_nonzero(M - np.diag(np.diag(M))) == 0


def test_node_to_segment_gap_and_jacobian_with_a_flexible_master():
    s = build_system(load_scene("rod-plate", {"mesh.size": 0.02, "mesh.contact_size": 2.5e-3}))
    q, v = s.initial_state()
    rng = np.random.default_rng(2)
    q = q + 1e-6 * rng.standard_normal(q.size)
    g, G, gam = s._gap_rows(q, v + rng.standard_normal(v.size))
    assert g.min() == pytest.approx(load_scene("rod-plate")["start.gap"], abs=1e-5)
    fd = central_difference(s.gap, q, s.n_contacts)
    assert np.max(np.abs(G - fd)) < 1e-7
    # the rate form: γ = −(d/dt g_q) v from differences of g_q v along v
    vv = rng.standard_normal(v.size)
    eps = 1e-7
    rate = lambda x: s.gap_jacobian(x) @ vv
    dG = (rate(q + eps * vv) - rate(q - eps * vv)) / (2 * eps)
    assert np.allclose(s.gap_gamma(q, vv), -dG, atol=1e-5 * np.max(np.abs(dG)) + 1e-12)


def test_rounded_bar_mesh_covers_the_shape():
    m = rounded_bar(12e-3, 3e-3, 0.4e-3)
    exact = 10.5e-3 * 3e-3 + math.pi * 1.5e-3 ** 2 / 2
    assert m.area() == pytest.approx(exact, rel=3e-3)      # polygonal arc: slightly less
    assert m.area() < exact
    bm = assemble(m, 3e9, 0.3, 1800.0, 1e-3)
    assert bm.mass.sum() == pytest.approx(1800.0 * 1e-3 * m.area(), rel=1e-12)
    w = np.linalg.eigvalsh(bm.K.toarray())
    assert np.sum(np.abs(w) < 1e-9 * w.max()) == 3        # exactly the three rigid motions
