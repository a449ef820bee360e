"""Rule 7 of core.impact_checks on planted histories: the energy balance E − E0 − W read where
no contact is open, judged after each burst of episodes. The truth is the planted numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core.contact import Impact
from daebench.core.impact_checks import CAPTURE_GAIN_TOL, CAPTURE_REL, energy_made

T = np.linspace(0.0, 1.0, 101)


def _episode(t0: float, t1: float, impact_impulse: float = math.nan, vn_minus: float = -1.0) -> Impact:
    return Impact(t0, 0, vn_minus, math.nan, math.nan, impulse=1.0, t_end=t1, impact_impulse=impact_impulse)


def _steps(*jumps: tuple[float, float]) -> np.ndarray:
    """A balance that is constant except for a jump of size J at each time τ of (τ, J)."""
    b = np.zeros_like(T)
    for tau, jump in jumps:
        b[T > tau] += jump
    return b


def test_a_burst_that_takes_energy_out_passes_and_one_that_adds_it_fails_with_both_times_and_the_gain():
    eps = [_episode(0.2, 0.25), _episode(0.6, 0.65)]
    assert energy_made(T, _steps((0.22, -0.3), (0.62, -0.1)), eps, 1.0, 0.0) == []
    out = energy_made(T, _steps((0.22, -0.3), (0.62, +0.05)), eps, 1.0, 0.0)
    assert len(out) == 1
    assert "t = 0.59 … 0.66 s" in out[0] and "rose by +0.05 J" in out[0] and "0.05 of the energy scale" in out[0]


def test_the_gain_is_judged_across_bursts_not_per_episode():
    """Ten episodes each adding 4e-4 of the scale (below the tolerance 1e-3 one by one) make
    4e-3 together: the run fails from before the first to after the last."""
    eps = [_episode(0.1 + 0.05 * i, 0.12 + 0.05 * i) for i in range(10)]
    bal = _steps(*[(0.11 + 0.05 * i, 4e-4) for i in range(10)])
    out = energy_made(T, bal, eps, 1.0, 0.0)
    assert len(out) == 1 and "t = 0.09 … 0.58 s" in out[0] and "rose by +0.004 J" in out[0]
    assert energy_made(T, bal[:] * 0.2, eps, 1.0, 0.0) == []          # 8e-4 in all: within the tolerance


def test_energy_inside_an_open_episode_that_goes_back_is_not_a_gain():
    """The contact stores energy while it is open (a compliance, a lagged force) and gives it
    back before it ends: no contact-free time sees it."""
    bal = np.where((T > 0.3) & (T < 0.5), 0.2, 0.0)
    assert energy_made(T, bal, [_episode(0.29, 0.5)], 1.0, 0.0) == []


def test_an_impact_steps_band_is_allowed_as_rule_5_allows_it():
    """An episode recording its impact step P = 2 N s at ġ⁻ = −3 m/s has a band of
    CAPTURE_REL × 6 J = 0.06 J: a gain of 0.05 J passes, 0.07 J does not."""
    band = CAPTURE_REL * 6.0
    ep = [_episode(0.4, 0.41, impact_impulse=2.0, vn_minus=-3.0)]
    assert energy_made(T, _steps((0.405, band - 0.01)), ep, 1.0, 0.0) == []
    out = energy_made(T, _steps((0.405, band + 0.01)), ep, 1.0, 0.0)
    assert len(out) == 1 and f"{band:.3g} J of it the impact steps' band" in out[0]


def test_the_tolerance_is_relative_to_the_energy_scale_and_e_above_1_is_not_judged():
    eps = [_episode(0.2, 0.25)]
    bal = _steps((0.22, 0.5 * CAPTURE_GAIN_TOL * 100.0))          # 0.05 J
    assert energy_made(T, bal, eps, 100.0, 0.0) == []              # half the tolerance of a 100 J run
    assert len(energy_made(T, bal, eps, 10.0, 0.0)) == 1           # five times that of a 10 J run
    assert energy_made(T, bal, eps, 10.0, 1.5) == []               # e > 1 may make energy


def test_a_run_without_a_finished_burst_or_contact_free_times_is_not_judged():
    assert energy_made(T, _steps((0.5, 1.0)), [], 1.0, 0.0) == []                     # no episode ended
    assert energy_made(T, _steps((0.5, 1.0)), [_episode(0.4, math.nan)], 1.0, 0.0) == []   # open to the end
    assert energy_made(T, np.full_like(T, np.nan), [_episode(0.4, 0.5)], 1.0, 0.0) == []


@pytest.mark.parametrize("shift", [0.0, 1e-12])
def test_the_time_an_episode_starts_belongs_to_it(shift):
    """The row at the episode's first step may already carry its preparation (a projection out of
    the wall): it is not a contact-free time."""
    bal = np.zeros_like(T)
    bal[T >= 0.4 - shift] += 0.01        # at the episode's start row, then a loss inside it
    bal[T > 0.42] -= 0.5
    assert energy_made(T, bal, [_episode(0.4 - shift, 0.42)], 1.0, 0.0) == []
