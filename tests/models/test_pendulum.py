"""The rigid pendulum model: exact solution, constraint derivatives, scene."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from daebench.models import build_system
from daebench.models.pendulum import Pendulum, exact_theta
from daebench.core.scene import SceneError
from daebench.models.scenes import load_scene
from daebench.core.problem import Problem
from daebench.core.system import central_difference

G, L = 9.81, 1.0


@pytest.mark.parametrize("theta0_deg, omega0", [(30.0, 0.0), (-45.0, 0.0), (60.0, 2.0), (60.0, -2.0),
                                                (170.0, 0.0), (0.0, 1.5)])
def test_exact_theta_matches_solve_ivp(theta0_deg, omega0):
    th0 = np.deg2rad(theta0_deg)
    t = np.linspace(0.0, 3.0, 61)
    sol = solve_ivp(lambda _, y: [y[1], -G / L * np.sin(y[0])], (0.0, 3.0), [th0, omega0],
                    method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
    assert np.max(np.abs(sol.y[0] - exact_theta(t, th0, omega0, G, L))) < 1e-9


def test_exact_theta_refuses_revolving_pendulum():
    with pytest.raises(ValueError, match="revolves"):
        exact_theta(1.0, 0.0, omega0=10.0, g=G, length=L)


def test_constraint_derivatives_and_gamma_sign():
    p = Pendulum(mass=2.0, length=1.5, theta0_deg=40.0, omega0=1.3)
    q, v = p.initial_state()
    assert abs(p.constraint(0.0, q)[0]) < 1e-15
    # C_q by central differences
    Cq_fd = central_difference(lambda x: p.constraint(0.0, x), q, 1)
    assert np.allclose(p.constraint_jacobian(0.0, q), Cq_fd, atol=1e-8)
    # C̈ = C_q q̈ − γ must vanish along the exact motion: check d²C/dt² of C(q(t)) with q(t) from θ(t)
    prob = Problem(p)
    a, lam = prob.acceleration(0.0, q, v)
    Cq = p.constraint_jacobian(0.0, q)
    assert np.allclose(Cq @ a, p.constraint_gamma(0.0, q, v))
    hh = 1e-4
    C = [p.constraint(0.0, q + s * hh * v + 0.5 * (s * hh) ** 2 * a)[0] for s in (-1, 0, 1)]
    assert abs((C[0] - 2 * C[1] + C[2]) / hh**2) < 1e-6
    # λ is the rod tension / l: m(g cos θ + l ω²)/l
    th = np.deg2rad(40.0)
    assert lam[0] == pytest.approx(2.0 * (G * np.cos(th) + 1.5 * 1.3**2) / 1.5, rel=1e-12)


def test_energy_and_observables():
    p = Pendulum(mass=2.0, length=1.0, theta0_deg=30.0)
    q, v = p.initial_state()
    e = p.energy(q, v)
    assert set(e) == {"kinetic", "gravity"}
    assert e["gravity"] == pytest.approx(-2.0 * G * np.cos(np.deg2rad(30.0)))
    obs = p.observables(0.0, q, v)
    assert obs["theta_deg"] == pytest.approx(30.0)
    assert (obs["x"], obs["y"]) == pytest.approx((0.5, -np.cos(np.deg2rad(30.0))))


def test_scene_builds_the_case():
    scene = load_scene("pendulum")
    p = build_system(scene)
    assert isinstance(p, Pendulum) and p.n == 2 and p.n_bilateral == 1
    assert scene.t_end == 1.0
    assert np.allclose(p.exact_position(0.0), p.initial_state()[0])
    with pytest.raises(SceneError, match="did you mean 'pendulum.length'"):
        load_scene("pendulum", ["pendulum.lenght=2"])
    with pytest.raises(SceneError, match="unstable equilibrium"):
        load_scene("pendulum", ["start.theta_deg=180"])
