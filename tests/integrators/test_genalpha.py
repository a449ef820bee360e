"""generalized-α (a Newmark-family coefficient set) against independent truth: the exact
pendulum (order 2 measured from a step-size sweep, fixed and adaptive) and the
definition of ρ∞ (the amplification of an undamped oscillator as h ω → ∞)."""

import inspect

import numpy as np
import pytest

from daebench.integrators import genalpha
from daebench.integrators.family import chung_hulbert
from daebench.integrators.genalpha import GeneralizedAlpha
from daebench.models.pendulum import Pendulum
from test_integrators import T_ORDER, Spring, integrate, pendulum_error, slope  # tests/ on sys.path

HS = [1e-2, 5e-3, 2.5e-3, 1.25e-3]


@pytest.mark.parametrize("rho_inf", [0.0, 0.5, 0.74, 1.0])
def test_fixed_step_order_two_on_the_index3_pendulum(rho_inf):
    errs = [pendulum_error(GeneralizedAlpha(rho_inf=rho_inf), h) for h in HS]
    assert abs(slope(HS, errs) - 2.0) < 0.05, errs
    assert errs[-1] < 5e-5


def test_adaptive_order_two_in_steps():
    """Error per step controlled to tol: global error ∝ (steps)^−2 for a second-order method."""
    steps, errs = [], []
    p = Pendulum(theta0_deg=30.0)
    q0, v0 = p.initial_state()
    for tol in (1e-5, 1e-6, 1e-7, 1e-8):
        integ = GeneralizedAlpha(rho_inf=0.74, adaptive=True, rtol=tol, atol=tol)
        s, _, _ = integrate(integ, p, q0, v0, 1e-3, T_ORDER)
        steps.append(integ.counters.steps)
        errs.append(float(np.max(np.abs(s.q - p.exact_position(T_ORDER)))))
    assert abs(slope(steps, errs) + 2.0) < 0.05, (steps, errs)


@pytest.mark.parametrize("rho_inf", [0.3, 0.5, 0.74, 0.9])
def test_high_frequency_amplification_is_rho_inf(rho_inf):
    """Undamped oscillator at h ω = 1e4: the spectral radius of the step is ρ∞ (the
    defining property of the Chung–Hulbert coefficients). Their eigenvalues coalesce at
    −ρ∞ (a Jordan block), so the amplitude decays as k ρ∞^k: fit log(amp_k / k) ~ k log ρ∞."""
    omega, h, k = 1e4, 1.0, 40
    s, _, states = integrate(GeneralizedAlpha(rho_inf=rho_inf), Spring(omega), [1.0], [0.0], h, k * h, every=True)
    amp = np.array([np.hypot(st.q[0], st.v[0] / omega) for st in states])
    ks = np.arange(10, k + 1)
    rate = np.exp(np.polyfit(ks, np.log(amp[ks] / ks), 1)[0])
    assert rate == pytest.approx(rho_inf, rel=1e-2)


def test_coefficients_and_one_file_without_numba():
    c = chung_hulbert(0.74)
    assert c.gamma == pytest.approx(0.5 - c.alpha_m + c.alpha_f)
    assert c.beta == pytest.approx(0.25 * (1.0 - c.alpha_m + c.alpha_f) ** 2)
    assert c.accel_avg and c.alpha_m < c.alpha_f <= 0.5
    src = inspect.getsource(genalpha)
    assert "numba" not in src and "njit" not in src and src.count("\n") < 100
