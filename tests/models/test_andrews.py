"""Andrews' squeezing mechanism against the published reference and an independent solver.

Reference: F. Mazzia, C. Magherini, *Test Set for IVP Solvers*, problem
"Andrews' squeezing mechanism", source file andrews.f, subroutine ``solut``/
``andsoln``: the solution at t = 0.03 computed with PSIDE at rtol = atol = 1e-14
on a Cray C90 (quoted below to the 16 digits published). The same file gives
the consistent initial values (q̈0, λ0) checked in test_initial_values.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from daebench.integrators.ida import IDA
from daebench.models import andrews
from daebench.models.andrews import NAMES, Andrews
from daebench.models.scenes import load_scene
from daebench.core.problem import Problem
from daebench.core.system import MechanicalSystem, State, central_difference

T_END = 0.03
# andrews.f, andsoln: y(1..7) angles, y(8..14) angular velocities at t = 0.03
REF_Q = np.array([
    0.1581077119629904e+2, -0.1575637105984298e+2, 0.4082224013073101e-1,
    -0.5347301163226948e+0, 0.5244099658805304e+0, 0.5347301163226948e+0,
    0.1048080741042263e+1,
])
REF_V = np.array([
    0.1139920302151208e+4, -0.1424379294994111e+4, 0.1103291221937134e+2,
    0.1929337464421385e+2, 0.5735699284790808e+0, -0.1929337464421385e+2,
    0.3231791658026955e+0,
])
# andrews.f initial values: y(15), y(16) = q̈0 (β, Θ), y(22), y(23) = λ0 (others 0)
REF_A0 = np.array([14222.4439199541138705911625887, -10666.8329399655854029433719415, 0, 0, 0, 0, 0])
REF_LAM0 = np.array([98.5668703962410896057654982170, -6.12268834425566265503114393122, 0, 0, 0, 0])


def digits(x: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Correct digits: −log10 of the relative error (capped at 16)."""
    rel = np.abs(x - ref) / np.abs(ref)
    return -np.log10(np.maximum(rel, 1e-16))


def ida_run(rtol: float) -> tuple[list[State], Problem, IDA]:
    sysm = Andrews()
    p = Problem(sysm)
    q0, v0 = sysm.initial_state()
    integ = IDA(rtol=rtol, atol=rtol)
    integ.start(p, State(0.0, q0, v0), 1e-4)
    states = [integ.state.copy()]
    while states[-1].t < T_END:
        states.append(integ.step(T_END))
    return states, p, integ


@pytest.fixture(scope="module")
def tight():
    return ida_run(1e-12)


@pytest.fixture(scope="module")
def ode_solution():
    """Independent truth: the index-1 ODE q̈ = q̈(q, q̇) from the augmented system
    [[M, Gᵀ], [G, 0]] [q̈; λ] = [f; γ], by DOP853 at rtol 1e-13 (no stabilization,
    no projection: over 0.03 s the drift stays at roundoff level, checked below)."""
    p = Problem(Andrews())
    q0, v0 = p.system.initial_state()

    def rhs(t, y):
        a, _ = p.acceleration(t, y[:7], y[7:])
        return np.concatenate([y[7:], a])

    sol = solve_ivp(rhs, (0.0, T_END), np.concatenate([q0, v0]), method="DOP853",
                    rtol=1e-13, atol=1e-15)
    assert sol.success
    return sol.y[:7, -1], sol.y[7:, -1]


# -- the model ---------------------------------------------------------------------------
def test_initial_values():
    sysm = Andrews()
    q0, v0 = sysm.initial_state()
    p = Problem(sysm)
    assert np.abs(sysm.constraint(0.0, q0)).max() < 1e-15
    a, lam = p.acceleration(0.0, q0, v0)
    assert np.allclose(a, REF_A0, rtol=1e-13, atol=1e-9)
    assert np.allclose(lam, REF_LAM0, rtol=1e-13, atol=1e-11)


def test_derivatives_by_finite_differences():
    sysm = Andrews()
    rng = np.random.default_rng(1)
    q = andrews.Q0 + 0.3 * rng.standard_normal(7)
    v = 50.0 * rng.standard_normal(7)
    a = 1e3 * rng.standard_normal(7)
    G = sysm.constraint_jacobian(0.0, q)
    assert np.allclose(G, central_difference(lambda x: sysm.constraint(0.0, x), q, 6), atol=1e-9)
    # γ = −(G v)_q v
    H = central_difference(lambda x: sysm.constraint_jacobian(0.0, x) @ v, q, 6)
    assert np.allclose(sysm.constraint_gamma(0.0, q, v), -H @ v, rtol=1e-7, atol=1e-5)
    Kq, Kv = sysm.force_jacobian(0.0, q, v)
    Kq_fd, Kv_fd = MechanicalSystem.force_jacobian(sysm, 0.0, q, v)
    assert np.allclose(Kq, Kq_fd, rtol=1e-6, atol=1e-7)
    assert np.allclose(Kv, Kv_fd, rtol=1e-6, atol=1e-10)
    assert np.allclose(sysm.mass_jacobian_product(q, a),
                       MechanicalSystem.mass_jacobian_product(sysm, q, a), atol=1e-10)
    M = sysm.mass(q)
    assert np.allclose(M, M.T) and np.all(np.linalg.eigvalsh(M) > 0)
    # the spring force is −∂V/∂γ
    f = sysm.applied_force(0.0, q, np.zeros(7))
    f[0] -= sysm.mom
    gradV = central_difference(lambda x: np.array([sysm.energy(x, np.zeros(7))["elastic"]]), q, 1)[0]
    assert np.allclose(f, -gradV, atol=1e-8)


def test_scene_builds_with_observables():
    scene = load_scene("andrews")
    assert scene.t_end == T_END and scene["output.dt"] == 1e-4
    sysm = andrews.build(scene)
    assert sysm.mom == 0.033
    assert list(sysm.observables(0.0, *sysm.initial_state())) == list(NAMES) == scene["output.observables"]
    assert andrews.build(scene.with_overrides(["andrews.mom=0.05"])).mom == 0.05


# -- IDA on the mechanism -------------------------------------------------------------------
def test_ida_agrees_with_published_reference(tight):
    states, p, integ = tight
    s = states[-1]
    assert s.t == T_END
    dq, dv = digits(s.q, REF_Q), digits(s.v, REF_V)
    print("\nAndrews, IDA rtol = atol = 1e-12 vs test set at t = 0.03; correct digits")
    for name, a, b in zip(NAMES, dq, dv):
        print(f"  {name:8s} angle {a:5.1f}   velocity {b:5.1f}")
    print("  counters:", integ.counters_snapshot())
    assert dq.min() >= 9.0
    # the published velocities agree with every solver here (IDA, DOP853, Radau) to 7.3–10 digits only
    assert dv.min() >= 7.0


def test_ida_constraints_every_step(tight):
    states, p, _ = tight
    worst_c = max(np.abs(p.constraint(s.t, s.q)).max() for s in states)
    worst_cv = max(np.abs(p.constraint_jacobian(s.t, s.q) @ s.v).max() for s in states)
    print(f"\nAndrews IDA 1e-12: max |g| = {worst_c:.1e}, max |G v| = {worst_cv:.1e} over {len(states)} states")
    assert worst_c <= 1e-10
    assert worst_cv <= 1e-8


def test_energy_balance_with_torque_work(tight):
    """dE/dt = mom β̇ with constant mom: E(t) − E(0) = mom (β(t) − β(0)) exactly."""
    states, p, _ = tight
    sysm = p.system
    E0 = sysm.total_energy(states[0].q, states[0].v)
    worst = 0.0
    for s in states[:: max(1, len(states) // 50)] + [states[-1]]:
        work = sysm.mom * (s.q[0] - states[0].q[0])
        worst = max(worst, abs(sysm.total_energy(s.q, s.v) - E0 - work))
    assert sysm.power(0.0, states[-1].q, states[-1].v)["torque"] == pytest.approx(sysm.mom * states[-1].v[0])
    total_work = sysm.mom * (states[-1].q[0] - states[0].q[0])  # ≈ 0.52 J
    print(f"\nAndrews energy balance residual {worst:.1e} J (torque work {total_work:.3f} J)")
    assert worst < 1e-9


def test_ida_agrees_with_independent_ode_solution(tight, ode_solution):
    q_ode, v_ode = ode_solution
    s = tight[0][-1]
    # the ODE form drifts off the constraints only at roundoff level over 0.03 s
    assert np.abs(Andrews().constraint(0.0, q_ode)).max() < 1e-12
    dq, dv = digits(s.q, q_ode), digits(s.v, v_ode)
    print("\nAndrews, IDA 1e-12 vs DOP853 1e-13 (index-1 ODE): digits q", np.round(dq, 1),
          "v", np.round(dv, 1))
    assert dq.min() >= 9.0 and dv.min() >= 8.0
    assert digits(q_ode, REF_Q).min() >= 9.0


def test_ida_moderate_tolerance_and_fd_jacobian_agree():
    s_an = ida_run(1e-8)[0][-1]
    sysm = Andrews()
    p = Problem(sysm)
    integ = IDA(rtol=1e-8, atol=1e-8, jacobian="fd")
    integ.start(p, State(0.0, *sysm.initial_state()), 1e-4)
    s = integ.state
    while s.t < T_END:
        s = integ.step(T_END)
    assert digits(s_an.q, REF_Q).min() >= 5.5
    assert digits(s.q, REF_Q).min() >= 5.5
