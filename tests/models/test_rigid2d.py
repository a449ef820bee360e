"""The planar rigid-body model (daebench.models.rigid2d): its kernels against finite
differences of its own geometry, its scenes, and the closed forms of rigid2d_exact
against independent derivations (momentum balance, energy)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core import kernels
from daebench.core.scene import SceneError
from daebench.models import build_system
from daebench.models.rigid2d import Rigid2d
from daebench.models.rigid2d_exact import housner_ratio, incline_motion, rocking_impact_omegas, rod_impact
from daebench.models.scenes import load_scene


def _point(system: Rigid2d, i: int, q: np.ndarray) -> np.ndarray:
    """World position (along, normal to the ground) of contact point i."""
    p, r = system.points[i]
    s, c = math.sin(q[2]), math.cos(q[2])
    return np.array([q[0] + p * c - r * s, q[1] + p * s + r * c])


@pytest.mark.parametrize("shape", ["box", "rod"])
def test_gap_tangent_and_gamma_are_the_contact_point_kinematics(shape):
    """g = normal coordinate of the point, g_q and the tangent row its Jacobians (central
    differences), γ from g̈ = g_q q̈ − γ along a trajectory with q̈ = 0 (second difference)."""
    system = Rigid2d(shape=shape, width=0.3, height=0.8, friction=0.4, incline_deg=20.0)
    md = system.kernel_data()
    rng = np.random.default_rng(1)
    for _ in range(5):
        q, v = rng.normal(size=3), rng.normal(size=3)
        for i in range(system.n_contacts):
            gq, tq = np.zeros(3), np.zeros(3)
            g, gam = kernels.gap(md, i, q, v, gq)
            mu = kernels.tangent(md, i, q, v, tq)
            assert mu == 0.4 and g == pytest.approx(_point(system, i, q)[1], abs=1e-14)
            d = 1e-6
            J = np.array([(_point(system, i, q + d * e) - _point(system, i, q - d * e)) / (2 * d) for e in np.eye(3)]).T
            assert np.allclose(gq, J[1], atol=1e-8) and np.allclose(tq, J[0], atol=1e-8)
            dt = 1e-4
            gdd = (_point(system, i, q + dt * v)[1] - 2 * g + _point(system, i, q - dt * v)[1]) / dt**2
            assert gdd == pytest.approx(-gam, rel=1e-5, abs=1e-6)


def test_mass_gravity_energy_and_start_on_the_ground():
    """M = diag(m, m, m(w² + h²)/12); gravity along the incline; the lowest corner starts at
    the requested gap; friction coefficients reach the kernels only with contacts on."""
    sc = load_scene("rocking-block")
    system = build_system(sc)
    q, v = system.initial_state()
    M, Q = system.mass_force(0.0, q, v)
    assert np.allclose(np.diag(M), [1.0, 1.0, (0.04 + 1.0) / 12]) and np.allclose(Q, [0.0, -9.81, 0.0])
    assert system.gaps(q).min() == pytest.approx(0.0, abs=1e-15)
    assert np.allclose(kernels.friction_coefficients(system.kernel_data(), system.n_contacts, q, v), 1.0)
    inc = build_system(load_scene("block-incline"))
    _, Q = inc.mass_force(0.0, *inc.initial_state())
    assert np.allclose(Q, [-9.81 * 0.5, -9.81 * math.cos(math.radians(30)), 0.0])
    off = build_system(load_scene("block-incline", ["effects.contact=false"]))
    assert off.n_contacts == 0
    with pytest.raises(SceneError, match="width"):
        load_scene("rocking-block", ["body.width=0"])


def test_closed_forms_against_independent_derivations():
    """Housner's ratio equals the impact solved with the Delassus matrix (sticking new
    corner, e = 0, the old pivot lifting); the first impact's ω from energy about the
    pivot; the incline motion loses μ m g cos φ × the distance slid; the rod's impulse
    in closed form, on the cone's edge when it slips, U_N⁺ = −e U_N⁻."""
    b, h, m = 0.1, 0.5, 1.0
    J = m * (4 * b * b + 4 * h * h) / 12
    # corner (b, −h) strikes, the old pivot (−b, −h) lifts: impulse with stick at the new corner
    G = np.array([[0.0, 1.0, b], [1.0, 0.0, h]])
    Minv = np.diag([1 / m, 1 / m, 1 / J])
    w_minus = -1.0
    vm = np.array([-h * w_minus, b * w_minus, w_minus])       # rotation about (−b, −h): v = ω ẑ × (b, h)
    P = np.linalg.solve(G @ Minv @ G.T, -G @ vm)              # e = 0, stick
    vp = vm + Minv @ G.T @ P
    assert vp[2] / w_minus == pytest.approx(housner_ratio(2 * b, 2 * h), rel=1e-12)
    # energy: ½ I_O ω₁² = m g R (cos(α/2) − cos α) at the first impact
    w1 = rocking_impact_omegas(2 * b, 2 * h, math.atan(b / h) / 2, 9.81, 1)[0]
    R, alpha = math.hypot(b, h), math.atan(b / h)
    assert 0.5 * (4 / 3) * m * R * R * w1**2 == pytest.approx(m * 9.81 * R * (math.cos(alpha / 2) - math.cos(alpha)))
    # incline: kinetic + potential lost = friction work (μ N × distance) at every instant
    phi, mu = math.radians(30), 0.3
    t = np.sort(np.append(np.linspace(0, 1, 101), 3.0 / (9.81 * (math.sin(phi) + mu * math.cos(phi)))))  # + t_s
    x, v = incline_motion(3.0, phi, mu, 9.81, t)
    E = 0.5 * v * v + 9.81 * math.sin(phi) * x
    dist = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(x)))])
    assert np.allclose(E[0] - E, mu * 9.81 * math.cos(phi) * dist, atol=1e-9)
    # rod: frictionless impulse in closed form; slipping impulse on the cone's edge
    pn, pt, _ = rod_impact(1.0, math.radians(30), -2.0, 0.0, 0.5, 0.0)
    assert pn == pytest.approx(1.5 * 2.0 / (1 + 12 * 0.25**2)) and pt == 0.0
    pn, pt, vp = rod_impact(1.0, math.radians(30), -2.0, 0.0, 0.5, 0.2)
    assert pt == pytest.approx(-0.2 * pn) and vp[1] + 0.25 * vp[2] == pytest.approx(1.0)   # U_N⁺ = −e U_N⁻
