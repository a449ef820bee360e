"""Metrics against independent truth: the pendulum's exact elliptic-function solution."""

from __future__ import annotations

import math
import time

import numpy as np
import pandas as pd
import pytest
from scipy.special import ellipj, ellipk

from daebench.harness.running import timing
from daebench.harness.scoring import metrics, pipeline as scoring
from daebench.integrators.hht import HHT
from daebench.models.pendulum import Pendulum, exact_theta
from daebench.harness.running.runner import run_scene
from daebench.models.scenes import load_scene

G, L, M, TH0 = 9.81, 1.0, 1.0, math.radians(30.0)
PENDULUM = scoring.declared("pendulum")   # θ scored as 'theta', x/y as the point 'pos'


def exact_history(t: np.ndarray) -> pd.DataFrame:
    """History of the exact pendulum (released from rest at 30°), energy from
    θ̇ = 2 k ω_n cn(ω_n t + K) — not from the energy integral itself."""
    wn = math.sqrt(G / L)
    k2 = math.sin(TH0 / 2) ** 2
    th = exact_theta(t, TH0, 0.0, G, L)
    _, cn, _, _ = ellipj(wn * t + ellipk(k2), k2)
    om = 2.0 * math.sqrt(k2) * wn * cn
    x, y = L * np.sin(th), -L * np.cos(th)
    ek = 0.5 * M * (L * om) ** 2
    eg = M * G * y
    return pd.DataFrame({"t": t, "theta_deg": np.rad2deg(th), "x": x, "y": y, "E_kinetic": ek,
                         "E_gravity": eg, "E": ek + eg, "D_impacts": 0.0,
                         "energy_residual": ek + eg - (ek[0] + eg[0])})


def hht_history(h: float) -> pd.DataFrame:
    _, res = run_scene(load_scene("pendulum"), HHT(h=h, alpha=0.0), write=False)
    assert res.status == "completed"
    return res.history


@pytest.fixture(scope="module")
def runs() -> dict[float, pd.DataFrame]:
    return {h: hht_history(h) for h in (1e-2, 5e-3)}


def test_error_equals_direct_error_against_exact(runs):
    hist = runs[1e-2]
    t = hist["t"].to_numpy()
    ref = exact_history(t)
    # grid = the output times, so interpolation is the identity and the metric must
    # equal the error computed by hand
    s = metrics.accuracy(hist, ref, n_grid=len(t), declared=PENDULUM)
    direct = np.abs(hist["theta_deg"].to_numpy() - np.rad2deg(Pendulum(theta0_deg=30.0).exact_theta(t)))
    assert s["err_theta_max"] == pytest.approx(direct.max(), rel=1e-12)
    assert s["err_theta_final"] == pytest.approx(direct[-1], rel=1e-12)
    assert s["err_theta_l2"] == pytest.approx(math.sqrt(np.mean(direct**2)), rel=1e-12)
    pos = np.hypot(hist["x"] - ref["x"], hist["y"] - ref["y"]).to_numpy()
    assert s["err_pos_max"] == pytest.approx(pos.max(), rel=1e-12)
    assert s["err_theta_max"] > 0.0


def test_order_two_error_shrinks_fourfold(runs):
    t = np.linspace(0.0, 1.0, 1001)
    ref = exact_history(t)
    e1 = metrics.accuracy(runs[1e-2], ref, declared=PENDULUM)["err_theta_max"]
    e2 = metrics.accuracy(runs[5e-3], ref, declared=PENDULUM)["err_theta_max"]
    assert 3.5 < e1 / e2 < 4.5


def test_exact_solution_has_zero_energy_residual():
    hist = exact_history(np.linspace(0.0, 2.0, 2001))
    e = metrics.energy_balance(hist)
    assert e["energy_resid_max"] < 1e-13
    assert e["energy_ok"]


def test_drifting_energy_is_flagged():
    hist = exact_history(np.linspace(0.0, 2.0, 2001))
    hist["E"] = hist["E"] + 1e-3 * hist["t"]  # a linear drift of 1 mJ/s
    e = metrics.energy_balance(hist)
    assert not e["energy_ok"]
    assert e["energy_resid_max"] == pytest.approx(2e-3, rel=1e-6)
    assert e["energy_resid_final"] == pytest.approx(2e-3, rel=1e-6)


def test_partial_history_has_nan_errors():
    ref = exact_history(np.linspace(0.0, 1.0, 101))
    s = metrics.accuracy(ref.iloc[:50], ref, declared=PENDULUM)
    assert math.isnan(s["err_theta_max"])


def test_impact_times_and_rebound_apex():
    t = np.linspace(0.0, 1.0, 1001)
    # a bouncing height: impacts at 0.2 and 0.6, parabolic flight with apex 0.04 at 0.4
    gap = np.where((t > 0.2) & (t < 0.6), 1.0 * (t - 0.2) * (0.6 - t), 0.0)
    hist = pd.DataFrame({"t": t, "gap": gap})
    ta, ya = metrics.rebound_apex(hist, [0.2, 0.6], "gap")
    assert ta == pytest.approx(0.4, abs=1e-9) and ya == pytest.approx(0.04, rel=1e-9)
    ev = metrics.impact_time_errors([0.2, 0.61], [0.2, 0.6, 0.9])
    assert ev["impacts"] == 2 and ev["impacts_ref"] == 3
    assert ev["err_impact2_t"] == pytest.approx(0.01)
    assert ev["err_impact_t_max"] == pytest.approx(0.01)
    assert math.isnan(metrics.rebound_apex(pd.DataFrame({"t": t, "gap": 0 * t}), [0.2], "gap")[0])


def test_time_call_takes_minimum_and_respects_cap():
    calls = []

    def fn():
        calls.append(1)
        return len(calls)

    tm = timing.time_call(fn, repeats=3)
    assert len(calls) == 4 and tm.repeats == 3 and tm.result == 4
    assert 0.0 <= tm.wall_s < 0.1 and tm.cpu_s >= 0.0
    import time
    tm = timing.time_call(lambda: time.sleep(0.05), repeats=5, time_cap=0.01)
    assert tm.repeats == 1
    # the default rule: a capped warm-up (warmup_fn), then repeats only while a run is short
    warm = []
    tm = timing.time_call(lambda: time.sleep(0.03), short_s=0.02, warmup_fn=lambda: warm.append(1))
    assert tm.repeats == 1 and warm == [1] and tm.wall_s >= 0.03
    tm = timing.time_call(lambda: None, short_s=0.02)
    assert tm.repeats == timing.REPEATS == 3


@pytest.mark.parametrize("w1, w2", [(1100.0, 9000.0), (1103.7, 9011.3)])  # on and off the FFT bins
def test_oscillation_spectrum_recovers_tones_about_a_trend(w1, w2):
    """Two tones of known amplitude on a large smooth trend: amplitudes to 1 %, the
    highest tone above a level found at its frequency, the strong tone's sidelobes not
    mistaken for tones."""
    from daebench.harness.scoring.metrics import highest_frequency_above, oscillation_spectrum

    t = np.arange(0.0, 0.4, 2.5e-5)
    x = 0.3 + 2.0 * t - t**2 + np.sin(3.0 * t) + 3e-3 * np.sin(w1 * t + 0.3) + 5e-6 * np.sin(w2 * t + 1.0)
    om, amp = oscillation_spectrum(t, x)
    for w, a in ((w1, 3e-3), (w2, 5e-6)):
        near = (om > 0.95 * w) & (om < 1.05 * w)
        assert amp[near].max() == pytest.approx(a, rel=1e-2)
    bin_ = 2 * np.pi / 0.4
    w_top, a_top = highest_frequency_above(om, amp, 1e-6, 0.4)
    assert abs(w_top - w2) < bin_ and a_top == pytest.approx(5e-6, rel=1e-2)
    w_top, a_top = highest_frequency_above(om, amp, 1e-5, 0.4)   # only the strong tone is above
    assert abs(w_top - w1) < bin_ and a_top == pytest.approx(3e-3, rel=1e-2)
    assert highest_frequency_above(om, amp, 1e-2, 0.4) == (0.0, 0.0)


def test_free_windows_split_at_closed_phases_and_impacts():
    from daebench.harness.scoring.metrics import free_windows

    t = np.round(np.arange(0.0, 1.0 + 1e-9, 0.01), 10)
    hist = pd.DataFrame({"t": t, "n_active": [0] * 30 + [1] * 5 + [0] * 66})
    assert free_windows(hist, 0.1) == [(0.0, 0.28), (0.36, 1.0)]
    assert free_windows(hist, 0.1, breaks=[0.705]) == [(0.0, 0.28), (0.36, 0.68), (0.73, 1.0)]
    assert free_windows(hist, 0.33, breaks=[0.705]) == []


def test_accuracy_refuses_a_reference_without_a_requested_observable():
    """A missing column must not silently drop its score."""
    t = np.linspace(0.0, 1.0, 11)
    ref = pd.DataFrame({"t": t, "theta_deg": t})
    with pytest.raises(ValueError, match="no column x"):
        metrics.accuracy(ref, ref, ["theta_deg", "x"], declared=PENDULUM)


def test_time_call_does_not_count_a_call_in_which_numba_compiled():
    """A capped warm-up can stop before a code path (e.g. the first impact) compiles; the
    timed call that then compiles is made again, so compilation never enters a row's time."""
    import numba

    @numba.njit
    def fresh(x):           # a new dispatcher: its first call compiles
        return x + 1.0

    calls = []

    def fn():
        calls.append(1)
        if len(calls) == 1:
            time.sleep(0.05)
            fresh(1.0)

    tm = timing.time_call(fn, repeats=2, warmup=False)
    assert len(calls) == 3 and tm.repeats == 2 and tm.wall_s < 0.04
