"""The `ida` integrator against problems with known solutions.

Problems are defined here (not imported from daebench.models) so these tests
depend only on the protocol in daebench.core.system:

* a harmonic oscillator (m = 0), exact solution q = q0 cos ωt;
* a Cartesian pendulum (index 3), truth = the angle ODE by DOP853 at rtol 1e-13;
* a particle sliding on a floor as a closed contact (λ = m g ≥ 0), then flying
  free (a parabola) — one integrator instance across two phase sizes.
"""

from __future__ import annotations

from importlib.metadata import entry_points

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

from daebench.integrators.base import IntegratorError, StepFailure
from daebench.integrators.ida import IDA
from daebench.core.problem import Problem
from daebench.core.system import MechanicalSystem, State

G = 9.81
TH0 = np.pi / 3  # pendulum release angle from the downward vertical


class Oscillator(MechanicalSystem):
    """m q̈ = −k q."""

    n = 1

    def __init__(self, k: float = 4.0, mass: float = 1.0) -> None:
        self.k, self.m_ = k, mass

    def mass(self, q):
        return np.array([[self.m_]])

    def applied_force(self, t, q, v):
        return -self.k * q

    def force_jacobian(self, t, q, v):
        return np.array([[-self.k]]), np.zeros((1, 1))

    def energy(self, q, v):
        return {"kinetic": 0.5 * self.m_ * v[0] ** 2, "elastic": 0.5 * self.k * q[0] ** 2}

    def initial_state(self):
        return np.array([1.0]), np.array([0.0])


class Pendulum(MechanicalSystem):
    """Point mass on a massless rod, Cartesian (x, y), C = (x² + y² − L²)/2."""

    n = 2
    n_bilateral = 1

    def __init__(self, length: float = 1.0, mass: float = 1.0, broken_after: float | None = None) -> None:
        self.L, self.m_ = length, mass
        self.broken_after = broken_after  # force is NaN after this time (failure test)

    def mass(self, q):
        return self.m_ * np.eye(2)

    def applied_force(self, t, q, v):
        if self.broken_after is not None and t > self.broken_after:
            return np.array([np.nan, np.nan])
        return np.array([0.0, -self.m_ * G])

    def force_jacobian(self, t, q, v):
        return np.zeros((2, 2)), np.zeros((2, 2))

    def mass_jacobian_product(self, q, a):
        return np.zeros((2, 2))

    def constraint(self, t, q):
        return np.array([0.5 * (q @ q - self.L**2)])

    def constraint_jacobian(self, t, q):
        return q.reshape(1, 2).copy()

    def constraint_gamma(self, t, q, v):
        return np.array([-(v @ v)])

    def energy(self, q, v):
        return {"kinetic": 0.5 * self.m_ * (v @ v), "gravity": self.m_ * G * q[1]}

    def initial_state(self):
        return np.array([self.L * np.sin(TH0), -self.L * np.cos(TH0)]), np.zeros(2)


class Slider(MechanicalSystem):
    """Point mass above a floor y = 0 with one contact point (gap g = y)."""

    n = 2
    n_contacts = 1

    def mass(self, q):
        return np.eye(2)

    def applied_force(self, t, q, v):
        return np.array([0.0, -G])

    def force_jacobian(self, t, q, v):
        return np.zeros((2, 2)), np.zeros((2, 2))

    def mass_jacobian_product(self, q, a):
        return np.zeros((2, 2))

    def gap(self, q):
        return np.array([q[1]])

    def gap_jacobian(self, q):
        return np.array([[0.0, 1.0]])

    def gap_gamma(self, q, v):
        return np.zeros(1)

    def energy(self, q, v):
        return {"kinetic": 0.5 * (v @ v), "gravity": G * q[1]}


def run(integ: IDA, problem: Problem, state: State, t_end: float) -> list[State]:
    integ.start(problem, state, 1e-3)
    out = [integ.state.copy()]
    while out[-1].t < t_end:
        out.append(integ.step(t_end))
    return out


@pytest.fixture(scope="module")
def pendulum_truth():
    """θ(t) of the pendulum, the angle ODE by DOP853 at rtol 1e-13."""
    sol = solve_ivp(lambda t, y: [y[1], -G * np.sin(y[0])], (0.0, 1.0), [TH0, 0.0],
                    method="DOP853", rtol=1e-13, atol=1e-14, dense_output=True)
    return sol.sol


def exact_pendulum(truth, t):
    th, om = truth(t)
    q = np.array([np.sin(th), -np.cos(th)])
    v = om * np.array([np.cos(th), np.sin(th)])
    lam = v @ v - G * q[1]  # from C̈ = 0 with L = m = 1
    return q, v, lam


# -- settings and registration ----------------------------------------------------------
def test_registered_as_entry_point():
    eps = [ep for ep in entry_points(group="daebench.integrators") if ep.name == "ida"]
    assert eps and eps[0].load() is IDA


def test_settings_validation():
    assert IDA().settings["rtol"] == 1e-8 and IDA().settings["atol"] == 1e-10
    with pytest.raises(IntegratorError, match="adaptive"):
        IDA(adaptive=False)
    with pytest.raises(IntegratorError, match="max_order"):
        IDA(max_ordr=3)
    with pytest.raises(IntegratorError):
        IDA(max_order=6)
    assert IDA.capabilities.constraints and IDA.capabilities.order == 5
    assert IDA.from_config(IDA(rtol=1e-9).to_config()).settings["rtol"] == 1e-9


# -- unconstrained ------------------------------------------------------------------------
@pytest.mark.parametrize("rtol", [1e-6, 1e-8, 1e-10])
@pytest.mark.parametrize("jacobian", ["analytic", "fd"])
def test_oscillator_exact(rtol, jacobian):
    sysm = Oscillator()
    q0, v0 = sysm.initial_state()
    integ = IDA(rtol=rtol, atol=rtol * 1e-2, jacobian=jacobian)
    states = run(integ, Problem(sysm), State(0.0, q0, v0), 2.0)
    w = 2.0
    for s in states:
        scale = 1e-2 * rtol + rtol * 1.0
        assert abs(s.q[0] - np.cos(w * s.t)) < 200 * scale
        assert abs(s.v[0] + w * np.sin(w * s.t)) < 200 * w * scale
        assert abs(s.a[0] + w * w * np.cos(w * s.t)) < 1e4 * w * w * scale  # BDF derivative
    assert states[-1].t == 2.0
    c = integ.counters_snapshot()
    assert 0 < c["steps"] < 2000 and c["lu_factorizations"] > 0 and c["residual_evals"] >= c["steps"]
    assert c["newton_iterations"] >= c["steps"]


def test_order_limit_costs_steps():
    """max_order = 2 must need more steps than order 5 at a tight tolerance."""
    sysm = Oscillator()
    q0, v0 = sysm.initial_state()
    steps = {}
    for k in (2, 5):
        integ = IDA(rtol=1e-9, atol=1e-11, max_order=k)
        run(integ, Problem(sysm), State(0.0, q0, v0), 2.0)
        steps[k] = integ.counters.steps
    assert steps[2] > 3 * steps[5]


def test_max_step_respected():
    sysm = Oscillator()
    q0, v0 = sysm.initial_state()
    states = run(IDA(rtol=1e-6, max_step=0.01), Problem(sysm), State(0.0, q0, v0), 1.0)
    assert max(np.diff([s.t for s in states])) <= 0.01 * (1 + 1e-12)


# -- constrained: pendulum -------------------------------------------------------------------
def test_pendulum_constraints_energy_and_exact_solution(pendulum_truth):
    sysm = Pendulum()
    p = Problem(sysm)
    q0, v0 = sysm.initial_state()
    states = run(IDA(rtol=1e-12, atol=1e-14), p, State(0.0, q0, v0), 1.0)
    E0 = sysm.total_energy(q0, v0)
    worst = dict(C=0.0, Cv=0.0, dE=0.0, q=0.0, v=0.0, lam=0.0)
    for s in states[1:]:
        qe, ve, lame = exact_pendulum(pendulum_truth, s.t)
        worst["C"] = max(worst["C"], abs(p.constraint(s.t, s.q)[0]))
        worst["Cv"] = max(worst["Cv"], abs(p.constraint_jacobian(s.t, s.q)[0] @ s.v))
        worst["dE"] = max(worst["dE"], abs(sysm.total_energy(s.q, s.v) - E0) / abs(E0))
        worst["q"] = max(worst["q"], np.abs(s.q - qe).max())
        worst["v"] = max(worst["v"], np.abs(s.v - ve).max())
        worst["lam"] = max(worst["lam"], abs(s.lam[0] - lame))
    print("pendulum rtol 1e-12, worst over 1 s:", {k: f"{x:.1e}" for k, x in worst.items()})
    assert worst["C"] <= 1e-10
    assert worst["Cv"] <= 1e-8
    assert worst["dE"] < 1e-9
    assert worst["q"] < 1e-9 and worst["v"] < 1e-8
    assert worst["lam"] < 1e-5  # index-2 variable: one order less accurate
    assert states[-1].t == 1.0


def test_pendulum_moderate_tolerance_tracks_truth(pendulum_truth):
    sysm = Pendulum()
    p = Problem(sysm)
    q0, v0 = sysm.initial_state()
    s = run(IDA(rtol=1e-6, atol=1e-8), p, State(0.0, q0, v0), 1.0)[-1]
    qe, ve, _ = exact_pendulum(pendulum_truth, 1.0)
    assert np.abs(s.q - qe).max() < 1e-4
    # the GGL form keeps both constraint levels at the Newton tolerance, with no drift
    assert abs(p.constraint(s.t, s.q)[0]) < 1e-8
    assert abs(p.constraint_jacobian(s.t, s.q)[0] @ s.v) < 1e-7


def test_dense_matches_direct_solve():
    sysm = Pendulum()
    p = Problem(sysm)
    q0, v0 = sysm.initial_state()
    integ = IDA(rtol=1e-10, atol=1e-12)
    integ.start(p, State(0.0, q0, v0), 1e-3)
    s = integ.state
    while s.t < 0.5:
        s = integ.step(1.0)
    s0 = integ.prev
    for frac in (0.25, 0.5, 0.9):
        tm = s0.t + frac * (s.t - s0.t)
        d = integ.dense(tm)
        assert d.t == tm
        direct = run(IDA(rtol=1e-10, atol=1e-12), p, State(0.0, q0, v0), tm)[-1]
        assert direct.t == tm
        assert np.abs(d.q - direct.q).max() < 1e-9
        assert np.abs(d.v - direct.v).max() < 1e-8
        assert abs(d.lam[0] - direct.lam[0]) < 1e-5
    assert integ.dense(s.t).t == s.t and np.array_equal(integ.dense(s.t).q, s.q)
    # dense() must not disturb stepping: the next step still advances
    nxt = integ.step(1.0)
    assert nxt.t > s.t


@pytest.mark.parametrize("native", [False, True], ids=["python-model", "kernel-model"])
def test_dense_many_is_dense_at_each_time(native):
    """The dense states of many output times at once (one compiled call for those inside the
    step, natively) are dense()'s, to the bit: inside, at both ends, a rounding from the end."""
    from daebench.models import build_system
    from daebench.models.scenes import load_scene
    from daebench.stepping.ida_native import NativeIDA

    sysm = build_system(load_scene("pendulum")) if native else Pendulum()
    q0, v0 = sysm.initial_state()
    integ = IDA(rtol=1e-10, atol=1e-12)
    integ.start(Problem(sysm), State(0.0, q0, v0), 1e-3)
    s = integ.state
    while s.t < 0.3:
        s = integ.step(1.0)
    assert isinstance(integ._solver, NativeIDA) == native
    s0 = integ.prev
    ts = [s0.t, *(s0.t + f * (s.t - s0.t) for f in (1e-9, 0.3, 0.5, 0.97, 1.0 - 1e-12)), s.t]
    for one, many in zip((integ.dense(t) for t in ts), integ.dense_many(ts), strict=True):
        assert one.t == many.t
        for a, b in ((one.q, many.q), (one.v, many.v), (one.a, many.a), (one.lam, many.lam)):
            np.testing.assert_array_equal(a, b)
    assert integ.dense_many([]) == []


def test_restart_mid_run_gives_same_answer(pendulum_truth):
    sysm = Pendulum()
    p = Problem(sysm)
    q0, v0 = sysm.initial_state()
    kw = dict(rtol=1e-10, atol=1e-12)
    straight = run(IDA(**kw), p, State(0.0, q0, v0), 1.0)[-1]
    integ = IDA(**kw)
    mid = run(integ, p, State(0.0, q0, v0), 0.4)[-1]
    assert mid.t == 0.4
    integ.start(p, State(mid.t, mid.q, mid.v), 1e-3)  # a driver restart (IDAReInit)
    s = integ.state
    while s.t < 1.0:
        s = integ.step(1.0)
    qe, _, _ = exact_pendulum(pendulum_truth, 1.0)
    assert np.abs(s.q - straight.q).max() < 1e-8
    assert np.abs(s.q - qe).max() < 1e-8


def test_contact_phase_then_free_flight_same_instance():
    """A closed contact gives λ = m g ≥ 0; then a phase of a different size."""
    sysm = Slider()
    integ = IDA(rtol=1e-10, atol=1e-12)
    on_floor = run(integ, Problem(sysm, active=(0,)), State(0.0, np.array([0.0, 0.0]), np.array([2.0, 0.0])), 0.5)
    s = on_floor[-1]
    assert abs(s.q[1]) < 1e-12 and abs(s.v[1]) < 1e-10
    assert abs(s.q[0] - 1.0) < 1e-9
    assert abs(s.lam[0] - G) < 1e-6  # compressive contact force, admissible sign
    # lift off with an upward velocity: a parabola
    integ.start(Problem(sysm), State(s.t, s.q, np.array([2.0, 3.0])), 1e-3)
    f = integ.state
    while f.t < 1.0:
        f = integ.step(1.0)
    dt = 0.5
    assert abs(f.q[0] - (1.0 + 2.0 * dt)) < 1e-8
    assert abs(f.q[1] - (3.0 * dt - 0.5 * G * dt * dt)) < 1e-8
    assert f.lam.size == 0


def test_step_failure_on_nan_force():
    sysm = Pendulum(broken_after=0.1)
    q0, v0 = sysm.initial_state()
    integ = IDA(rtol=1e-8)
    integ.start(Problem(sysm), State(0.0, q0, v0), 1e-3)
    with pytest.raises(StepFailure, match="IDA"):
        s = integ.state
        while s.t < 1.0:
            s = integ.step(1.0)
    assert s.t <= 0.1 + 1e-12


def test_never_steps_past_t_stop():
    sysm = Pendulum()
    q0, v0 = sysm.initial_state()
    integ = IDA(rtol=1e-8)
    integ.start(Problem(sysm), State(0.0, q0, v0), 1e-3)
    s = integ.state
    for t_stop in (0.013, 0.0130000000000001, 0.2, 0.2 + 1e-9, 0.35):
        while s.t < t_stop:
            s = integ.step(t_stop)
            assert s.t <= t_stop
        assert s.t == t_stop


@pytest.mark.parametrize("case, active", [("beam-impact", ()), ("beam-impact", (0,)), ("pendulum", ())])
def test_residual_vanishes_on_a_consistent_state(case, active):
    """The GGL residual F(t, y, ẏ) (one compiled call on the phase) is zero in its dynamic
    rows at y = (q, v, λ, 0), ẏ = (v, q̈, …) with (q̈, λ) the consistent acceleration, and
    its constraint rows are C(q) and C_q v — free and with a closed contact."""
    from daebench.models import build_system
    from daebench.models.scenes import load_scene

    system = build_system(load_scene(case))
    problem = Problem(system, active)
    rng = np.random.default_rng(7)
    q0, v0 = system.initial_state()
    n, m = problem.n, problem.m
    integ = IDA()
    a0, lam0 = problem.acceleration(0.0, q0, v0)
    integ.start(problem, State(0.0, q0, v0, a0, lam0), 1e-4)
    for _ in range(5):
        q = q0 + 1e-2 * rng.standard_normal(n)
        v = rng.standard_normal(n)
        t = float(rng.uniform(0.0, 1.0))
        a, lam = problem.acceleration(t, q, v)
        y = np.concatenate([q, v, lam, np.zeros(m)])
        yp = np.concatenate([v, a, np.zeros(2 * m)])
        res = np.empty_like(y)
        integ._res(t, y, yp, res)
        M, Q = problem.mass_force(t, q, v)
        scale = np.abs(Q).max() + np.abs(M @ a).max()
        np.testing.assert_allclose(res[:2 * n], 0.0, atol=1e-11 * scale)
        C, Cq, Ct, _ = problem.constraint_rows(t, q, v)
        np.testing.assert_allclose(res[2 * n:2 * n + m], C, rtol=1e-14, atol=0)
        np.testing.assert_allclose(res[2 * n + m:], Cq @ v + Ct, rtol=1e-13, atol=1e-14)


def test_batch_advance_equals_stepping_through_the_driver(monkeypatch):
    """IDA.advance (many steps per driver call, compiled quiet-step checks) takes the same
    steps as the driver's one-step loop: identical histories, impacts, counters and
    constraint maxima, through impacts, a closed phase and its release."""
    from daebench.harness.running.runner import run_scene
    from daebench.models.scenes import load_scene

    scene = load_scene("beam-impact", ["t_end=0.3815", "discretization.n=3", "output.dt=2e-4"])
    calls, rows, real_advance = [], [], IDA.advance

    def spy(self, t_stop, watch=None, outputs=None):
        calls.append(watch is not None)
        adv = real_advance(self, t_stop, watch, outputs)
        rows.append(len(getattr(adv, "outputs", ())))
        return adv

    monkeypatch.setattr(IDA, "advance", spy)
    fast_rec, fast = run_scene(scene, "ida", {}, write=False)
    assert sum(calls) > 0 and fast_rec.counters["steps"] > 10 * len(calls)  # many steps per call
    assert sum(rows) > 0.9 * len(fast.history)  # the output rows written by the compiled loop
    from daebench.driver.simulate import Driver

    monkeypatch.setattr(Driver, "_batch_ok", lambda self, problem: False)
    slow_rec, slow = run_scene(scene, "ida", {}, write=False)
    assert len(fast.impacts) == len(slow.impacts) >= 3
    assert [i.t for i in fast.impacts] == [i.t for i in slow.impacts]
    assert fast_rec.counters == slow_rec.counters
    pd.testing.assert_frame_equal(fast.history, slow.history, check_exact=True)
    for k, x in slow.constraint_max.items():
        assert fast.constraint_max[k] == pytest.approx(x, rel=1e-12, abs=1e-18)
