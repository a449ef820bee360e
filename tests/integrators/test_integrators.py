"""The built-in integrators hht, newmark and baumgarte against independent truth.

Truth: the exact pendulum solution (Jacobi elliptic functions, itself checked
against solve_ivp in test_pendulum.py), a periodic Kepler orbit (returns exactly
to its start after one period) and a linear oscillator.
"""

import numpy as np
import pytest

from daebench.integrators.base import IntegratorError, StepFailure
from daebench.integrators.registry import get_integrator
from daebench.integrators.baumgarte import BaumgarteABM4
from daebench.integrators.hht import HHT
from daebench.integrators.newmark import Newmark
from daebench.models.pendulum import Pendulum, exact_theta
from daebench.core.problem import Problem
from daebench.core.system import MechanicalSystem, State

G = 9.81
T_ORDER = 1.5  # mid-swing: at a turning point (t ≈ 1.02) phase errors barely show in x, y


# -- small systems with exact solutions ----------------------------------------------------
class AnglePendulum(MechanicalSystem):
    """The pendulum in its angle θ: an ODE (m = 0), θ̈ = −(g/l) sin θ."""

    n = 1

    def mass(self, q):
        return np.eye(1)

    def applied_force(self, t, q, v):
        return -G * np.sin(q)

    def force_jacobian(self, t, q, v):
        return np.array([[-G * np.cos(q[0])]]), np.zeros((1, 1))

    def mass_jacobian_product(self, q, a):
        return np.zeros((1, 1))

    def energy(self, q, v):
        return {"kinetic": 0.5 * float(v @ v), "gravity": -G * float(np.cos(q[0]))}


class Kepler(MechanicalSystem):
    """A point in a central 1/r² field (GM = 1): eccentric orbits need adaptive steps."""

    n = 2

    def mass(self, q):
        return np.eye(2)

    def applied_force(self, t, q, v):
        return -q / np.hypot(q[0], q[1]) ** 3

    def energy(self, q, v):
        return {"kinetic": 0.5 * float(v @ v), "gravity": -1.0 / float(np.hypot(q[0], q[1]))}


class Spring(MechanicalSystem):
    """A stiff linear oscillator: k/m = ω²."""

    n = 1

    def __init__(self, omega):
        self.k = omega**2

    def mass(self, q):
        return np.eye(1)

    def applied_force(self, t, q, v):
        return -self.k * q

    def energy(self, q, v):
        return {"kinetic": 0.5 * float(v @ v), "elastic": 0.5 * self.k * float(q @ q)}


def integrate(integ, system, q0, v0, h, t_end, every=None):
    """Drive an integrator like the driver does; return the final state, the problem
    and (optionally) the states visited."""
    prob = Problem(system)
    q0, v0 = np.asarray(q0, float), np.asarray(v0, float)
    state = State(0.0, q0, v0, *prob.acceleration(0.0, q0, v0))
    integ.start(prob, state, h)
    states = [state]
    while state.t < t_end:
        state = integ.step(t_end)
        if every is not None:
            states.append(state)
    return state, prob, states


def pendulum_error(integ, h, t_end=T_ORDER, theta0=30.0):
    p = Pendulum(theta0_deg=theta0)
    q0, v0 = p.initial_state()
    s, _, _ = integrate(integ, p, q0, v0, h, t_end)
    return float(np.max(np.abs(s.q - p.exact_position(t_end))))


def slope(hs, errs):
    return float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


H2 = [1e-2, 5e-3, 2.5e-3, 1.25e-3]

CASES = [
    ("hht", dict(alpha=0.0), H2, 2),
    ("hht", dict(alpha=-0.15), H2, 2),
    ("hht", dict(alpha=-1.0 / 3.0, reuse_jacobian=False), H2, 2),
    ("newmark", dict(), H2, 2),
    ("baumgarte", dict(), H2, 4),
    ("baumgarte", dict(delta=1.0, epsilon=1.0), H2, 4),
    ("genalpha", dict(rho_inf=0.5), H2, 2),
    ("genalpha", dict(rho_inf=0.74, ggl=True), H2, 2),
]


# -- order on the index-3 pendulum --------------------------------------------------------------
@pytest.mark.parametrize("name, settings, hs, order", CASES)
def test_order_on_constrained_pendulum(name, settings, hs, order):
    cls = get_integrator(name)
    assert cls.capabilities.order == order
    errs = [pendulum_error(cls(**settings), h) for h in hs]
    assert abs(slope(hs, errs) - order) < 0.2, errs


# -- order on an ODE (m = 0) ----------------------------------------------------------------------
@pytest.mark.parametrize("name, settings, hs, order", CASES)
def test_order_on_ode(name, settings, hs, order):
    cls = get_integrator(name)
    th0 = np.deg2rad(30.0)
    exact = exact_theta(T_ORDER, th0, 0.0, G, 1.0)
    errs = []
    for h in hs:
        s, prob, _ = integrate(cls(**settings), AnglePendulum(), [th0], [0.0], h, T_ORDER)
        assert prob.m == 0 and s.lam.size == 0
        errs.append(abs(s.q[0] - exact))
    assert abs(slope(hs, errs) - order) < 0.2, errs
    assert errs[-1] < (1e-5 if order == 2 else 1e-10)


# -- constraints -----------------------------------------------------------------------------------
def constraint_history(integ, h, t_end, theta0=30.0):
    p = Pendulum(theta0_deg=theta0)
    q0, v0 = p.initial_state()
    _, prob, states = integrate(integ, p, q0, v0, h, t_end, every=True)
    C = np.array([abs(prob.constraint(s.t, s.q)[0]) for s in states])
    Cd = np.array([abs(prob.constraint_jacobian(s.t, s.q) @ s.v)[0] for s in states])
    return C, Cd, states


@pytest.mark.parametrize("alpha", [0.0, -0.15, -1.0 / 3.0])
def test_hht_keeps_position_and_velocity_constraints(alpha):
    C, Cd, states = constraint_history(HHT(alpha=alpha), 2e-3, 2.0, theta0=60.0)
    assert C.max() <= 1e-10 and Cd.max() <= 1e-8
    assert all(s.lam.shape == (1,) and s.lam[0] > 0.0 for s in states)  # the rod pulls


def test_newmark_keeps_position_constraint():
    C, Cd, _ = constraint_history(Newmark(), 2e-3, 2.0, theta0=60.0)
    assert C.max() <= 1e-10
    assert Cd.max() > 1e-8  # not enforced by plain index 3: an honest difference to GGL


def test_baumgarte_stabilization_bounds_drift():
    # h ε = 0.5 keeps the violation dynamics (eigenvalues −10 ± 49i) inside ABM4's region
    C0, Cd0, _ = constraint_history(BaumgarteABM4(), 1e-2, 10.0, theta0=60.0)
    C1, Cd1, _ = constraint_history(BaumgarteABM4(delta=10.0, epsilon=50.0), 1e-2, 10.0, theta0=60.0)
    tenth = len(C0) // 10
    assert C0[-tenth:].max() > 1.5 * C0[:tenth].max()  # unstabilized: C drifts away
    assert C1[-tenth:].max() < 1.1 * C1[:tenth].max()  # stabilized: bounded ...
    assert C1.max() < 0.2 * C0.max()                    # ... and smaller
    assert Cd1[-tenth:].max() < 1.1 * Cd1[:tenth].max()


# -- energy ------------------------------------------------------------------------------------------
def energy_history(integ, h, t_end):
    p = Pendulum(theta0_deg=60.0)
    q0, v0 = p.initial_state()
    _, _, states = integrate(integ, p, q0, v0, h, t_end, every=True)
    E = np.array([p.total_energy(s.q, s.v) for s in states])
    return E - E[0]


def test_hht_trapezoidal_energy_bounded():
    dE = energy_history(HHT(alpha=0.0), 1e-2, 20.0)  # ≈ 9 periods
    n = len(dE)
    assert np.abs(dE).max() < 1e-3 * G  # small, and no drift: the last period is like the first
    assert np.abs(dE[-n // 9:]).max() < 2.0 * np.abs(dE[: n // 9]).max() + 1e-12


def test_newmark_trapezoidal_energy_bounded_on_ode():
    th0 = np.deg2rad(60.0)
    sysa = AnglePendulum()
    _, _, states = integrate(Newmark(), sysa, [th0], [0.0], 1e-2, 20.0, every=True)
    E = np.array([sysa.total_energy(s.q, s.v) for s in states])
    dE = E - E[0]
    n = len(dE)
    assert np.abs(dE).max() < 1e-3 * G
    assert np.abs(dE[-n // 9:]).max() < 2.0 * np.abs(dE[: n // 9]).max() + 1e-12


def test_newmark_trapezoidal_index3_multiplier_instability():
    """A known property, kept visible: γ = ½ Newmark on the index-3 form has no damping of the
    spurious multiplier oscillation, which grows (Cardona & Géradin 1989); GGL-stabilized HHT
    with α = 0 does not show it, and γ > ½ damps it."""
    p = Pendulum(theta0_deg=60.0)
    q0, v0 = p.initial_state()

    def lam_dev(integ, t_end):
        _, prob, states = integrate(integ, p, q0, v0, 1e-2, t_end, every=True)
        return max(abs(s.lam[0] - prob.acceleration(s.t, s.q, s.v)[1][0]) for s in states[1:])

    assert lam_dev(Newmark(), 4.0) > 10.0 * lam_dev(Newmark(), 1.0)
    assert lam_dev(Newmark(gamma=0.6, beta=0.3025), 4.0) < 0.1
    assert lam_dev(HHT(alpha=0.0), 4.0) < 0.1


def test_hht_alpha_dissipates():
    """α < 0 drains energy period after period; α = 0 only oscillates around a constant mean."""
    means = {}
    for alpha in (0.0, -0.15):
        dE = energy_history(HHT(alpha=alpha), 1e-2, 20.0)
        period = len(dE) // 9
        means[alpha] = (dE[:period].mean(), dE[-period:].mean())
    loss0 = means[0.0][0] - means[0.0][1]
    loss = means[-0.15][0] - means[-0.15][1]
    assert loss > 3.0 * abs(loss0) and loss > 0.0
    assert loss < 0.01 * G  # "a little": < 1 % of m g l over 8 periods at h = 0.01


# -- adaptive HHT ------------------------------------------------------------------------------------
def kepler_error(integ, h, e=0.8):
    q0 = [1.0 - e, 0.0]
    v0 = [0.0, np.sqrt((1.0 + e) / (1.0 - e))]
    s, _, _ = integrate(integ, Kepler(), q0, v0, h, 2.0 * np.pi)
    return float(np.max(np.abs(s.q - q0))), integ.counters


def test_adaptive_hht_beats_fixed_step_on_eccentric_orbit():
    err_a, c = kepler_error(HHT(alpha=0.0, adaptive=True, rtol=1e-7, atol=1e-7), 0.1)
    assert c.rejected > 0  # h = 0.1 at the pericentre is far too large
    assert err_a < 0.05
    err_f, _ = kepler_error(HHT(alpha=0.0), 2.0 * np.pi / c.steps)  # the same number of steps
    assert err_f > 5.0 * err_a


def test_adaptive_error_decreases_with_tolerance():
    errs = [kepler_error(HHT(adaptive=True, rtol=tol, atol=tol), 1e-3)[0] for tol in (1e-5, 1e-7)]
    assert errs[1] < 0.2 * errs[0]


# -- Baumgarte divergence ------------------------------------------------------------------------------
def test_baumgarte_diverges_with_step_failure():
    with pytest.raises(StepFailure, match="diverged"):
        integrate(BaumgarteABM4(), Spring(1e3), [1e-3], [0.0], 1e-2, 10.0)


def test_baumgarte_stable_on_same_spring_with_small_step():
    s, _, _ = integrate(BaumgarteABM4(), Spring(1e3), [1e-3], [0.0], 1e-4, 0.05)
    assert abs(s.q[0] - 1e-3 * np.cos(1e3 * 0.05)) < 1e-6  # h ω = 0.1: amplitude error ~1e-4


# -- Newton failure -------------------------------------------------------------------------------------
def test_newton_failure_is_step_failure():
    p = Pendulum(theta0_deg=60.0)
    q0, v0 = p.initial_state()
    with pytest.raises(StepFailure, match="Newton"):
        integrate(HHT(newton_maxiter=1, reuse_jacobian=False), p, q0, v0, 0.05, 1.0)


# -- restart, partial steps, dense output ------------------------------------------------------------------
@pytest.mark.parametrize("name", ["hht", "newmark", "baumgarte"])
def test_restart_and_partial_steps(name):
    """Stopping at odd times and restarting from the returned state keeps the accuracy."""
    cls = get_integrator(name)
    p = Pendulum(theta0_deg=30.0)
    q0, v0 = p.initial_state()
    prob = Problem(p)
    integ = cls()
    state = State(0.0, q0, v0, *prob.acceleration(0.0, q0, v0))
    for t_stop in (0.3337, 0.71, 1.0):
        integ.start(prob, state, 1e-3)
        while state.t < t_stop:
            state = integ.step(t_stop)
            assert state.t <= t_stop
        assert state.t == t_stop
    assert np.max(np.abs(state.q - p.exact_position(1.0))) < 1e-5
    mid = integ.dense(state.t - 0.5e-3)
    assert np.max(np.abs(mid.q - p.exact_position(mid.t))) < 1e-5


# -- settings, config, counters ----------------------------------------------------------------------------------
def test_settings_validation():
    with pytest.raises(IntegratorError, match="did you mean 'alpha'"):
        HHT(alpah=-0.1)
    with pytest.raises(IntegratorError, match="out of range"):
        HHT(alpha=-0.5)
    with pytest.raises(IntegratorError, match="out of range"):
        HHT(alpha=0.1)
    with pytest.raises(IntegratorError, match="out of range"):
        Newmark(gamma=0.4)
    with pytest.raises(IntegratorError, match="beta > 0"):
        Newmark(beta=0.0)
    with pytest.raises(IntegratorError, match="did you mean 'epsilon'"):
        BaumgarteABM4(epsilo=3.0)
    with pytest.raises(IntegratorError, match="out of range"):
        BaumgarteABM4(delta=-1.0)
    assert HHT(alpha="-0.1").settings["alpha"] == -0.1  # command-line strings are coerced


@pytest.mark.parametrize("cls, settings", [(HHT, dict(alpha=-0.2, adaptive=True, rtol=1e-5, ggl=False)),
                                           (Newmark, dict(beta=0.3, gamma=0.6, h=1e-3)),
                                           (BaumgarteABM4, dict(delta=10.0, epsilon=50.0))])
def test_config_round_trip(cls, settings):
    integ = cls(**settings)
    cfg = integ.to_config()
    assert cfg["integrator"] == cls.name
    again = cls.from_config(cfg)
    assert again.settings == integ.settings
    for k, v in settings.items():
        assert again.settings[k] == v


@pytest.mark.parametrize("name", ["hht", "newmark", "baumgarte"])
def test_counters_sensible(name):
    integ = get_integrator(name)()
    p = Pendulum(theta0_deg=30.0)
    q0, v0 = p.initial_state()
    integrate(integ, p, q0, v0, 1e-2, 1.0)
    c = integ.counters_snapshot()
    assert c["steps"] == 100 and c["rejected"] == 0
    assert c["residual_evals"] >= c["steps"]
    if name == "baumgarte":
        assert c["newton_iterations"] == 0
        assert c["residual_evals"] == 2 * 97 + 4 * 3 + 1  # PECE, 3 RK4 start steps, the start state
    else:
        assert 0 < c["lu_factorizations"] <= c["newton_iterations"]
        assert c["steps"] <= c["newton_iterations"] <= 6 * c["steps"]
        assert c["lu_factorizations"] < c["steps"] // 2  # the iteration matrix is reused
        assert c["jacobian_evals"] == c["lu_factorizations"]


def test_jacobian_reuse_off_factors_every_iteration():
    integ = HHT(reuse_jacobian=False)
    p = Pendulum(theta0_deg=30.0)
    q0, v0 = p.initial_state()
    integrate(integ, p, q0, v0, 1e-2, 1.0)
    c = integ.counters
    assert c.lu_factorizations == c.newton_iterations


def test_capabilities():
    assert HHT.capabilities.index == 3 and HHT.capabilities.adaptive and HHT.capabilities.constraints
    assert Newmark.capabilities.index == 3 and Newmark.capabilities.order == 2
    assert BaumgarteABM4.capabilities.index == 1 and not BaumgarteABM4.capabilities.adaptive
    assert BaumgarteABM4.capabilities.order == 4
