"""Error measures that survive impacts (daebench.harness.scoring.impact_metrics).

Independent truths: closed-form histories (a cubic that Hermite interpolation must
reproduce exactly; sinusoids whose shifted copies must score zero after
re-synchronisation), the kinetic-energy loss of a Newton impact computed by the KKT solve
of daebench.core.contact.impact_map, and — on beam-impact — the order 2 of HHT-α and the
trapezoidal Newmark rule measured from a step-halving sweep against an IDA reference.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from daebench.harness.scoring import impact_metrics as IM
from daebench.harness.scoring import metrics
from daebench.core.contact import impact_map
from daebench.core.observables import Observable, Observables

#: θ as the hub–beam declares it: short name 'theta', Hermite with ω [rad/s]
THETA = Observable("theta_deg", "deg", short="theta", derivative="omega", derivative_factor=180.0 / math.pi)
DECLARED = Observables([THETA])


def _hist(t, theta_rad, omega=None, **cols):
    d = {"t": t, "theta_deg": np.degrees(theta_rad)}
    if omega is not None:
        d["omega"] = omega
    d.update(cols)
    return pd.DataFrame(d)


# ---- sampling --------------------------------------------------------------------------
def test_hermite_with_omega_is_exact_for_a_cubic_and_linear_is_not():
    t = np.linspace(0.0, 1.0, 11)
    th, om = 0.3 * t**3 - t + 0.2, 0.9 * t**2 - 1.0      # dθ/dt = ω
    seg = _hist(t, th, om)
    x = np.linspace(0.0, 1.0, 97)
    exact = np.degrees(0.3 * x**3 - x + 0.2)
    deriv = DECLARED.derivative("theta_deg")             # θ [deg] has dθ/dt = ω [rad/s]·180/π
    assert np.max(np.abs(metrics.dense(seg, "theta_deg", x, deriv) - exact)) < 1e-12
    lin = metrics.dense(seg.drop(columns="omega"), "theta_deg", x, deriv)
    assert np.max(np.abs(lin - exact)) > 1e-3     # the cubic's curvature shows between rows


def test_whole_run_error_at_run_times_against_a_dense_reference():
    ref_t = np.linspace(0.0, 1.0, 20001)                # oversampled reference
    run_t = np.linspace(0.0, 1.0, 101)
    w = 300.0                                           # a tone the run's rows alias
    ref = _hist(ref_t, np.sin(w * ref_t), w * np.cos(w * ref_t))
    run = _hist(run_t, np.sin(w * run_t) + 1e-6 * run_t)   # the run errs by 1e-6 t rad
    acc = metrics.accuracy(run, ref, ["theta_deg"], declared=DECLARED)
    assert acc["err_theta_final"] == pytest.approx(math.degrees(1e-6), rel=1e-4)
    assert acc["err_theta_max"] == pytest.approx(math.degrees(1e-6), rel=1e-4)


# ---- before the first impact and per window ------------------------------------------------
def _bouncing(t: np.ndarray, impacts: list[float], phase: float = 0.0) -> np.ndarray:
    """A smooth signal that restarts at each impact: sin of the time since the last one."""
    since = t - np.array([max([x for x in [0.0] + impacts if x <= s]) for s in t])
    return 0.01 * np.sin(40.0 * since + phase) + 0.1 * since


def test_resynchronised_windows_score_zero_for_a_shifted_event_sequence():
    ref_imp = [0.30, 0.55, 0.80]
    run_imp = [0.3004, 0.5504, 0.8004]                  # every impact 0.4 ms late, motion identical
    t_ref, t_run = np.arange(0, 20001) * 5e-5, np.arange(0, 1001) * 1e-3
    ref = _hist(t_ref, _bouncing(t_ref, ref_imp))
    run = _hist(t_run, _bouncing(t_run, run_imp))
    w = IM.window_errors(run, run_imp, ref, ref_imp, [THETA])
    assert w["windows_matched"] == 3 == w["windows_ref"]
    assert w["err_win_theta_max"] < 2e-3              # linear interpolation of the reference only
    whole = metrics.accuracy(run, ref, ["theta_deg"], ref_impacts=ref_imp, declared=DECLARED)
    assert whole["err_theta_max"] > 20 * w["err_win_theta_max"]   # the whole-run error sees the shift
    pre = IM.pre_impact_errors(run, ref, ref_imp[0], [THETA])
    assert pre["err_pre_theta_max"] < 2e-3


def test_window_matching_stops_at_the_first_unmatched_impact():
    ref = [0.30, 0.31, 0.60]
    assert IM.match_impacts([0.3001, 0.3102, 0.6001], ref) == 3
    assert IM.match_impacts([0.3001, 0.6001], ref) == 1       # the run missed the 0.31 chatter impact
    assert IM.match_impacts([0.3001, 0.3045, 0.6001], ref) == 1  # 5.5 ms off, its neighbour 10 ms away: not matched
    assert IM.match_impacts([], ref) == 0
    t = np.arange(0, 1001) * 1e-3
    h = _hist(t, _bouncing(t, ref))
    w = IM.window_errors(h, [0.3001, 0.6001], h, ref, [THETA])
    assert w["windows_matched"] == 1 and math.isnan(w["err_win_theta_max"]) and math.isfinite(w["err_winm_theta_max"])


# ---- energy per impact ---------------------------------------------------------------------------
class _Rigid:
    """Two bodies on a line coupled by a bilateral constraint x1 − x2 = 0, the first striking a wall."""

    def __init__(self, bilateral: bool):
        self.M = np.diag([2.0, 3.0, 0.5])
        self.bil = bilateral

    def mass(self, q):
        return self.M

    def gap_jacobian(self, q):
        return np.array([[1.0, 0.2, -0.4]])

    def constraint_jacobian(self, t, q):
        return np.array([[1.0, -1.0, 0.0]]) if self.bil else np.zeros((0, 3))


@pytest.mark.parametrize("bilateral", [False, True])
@pytest.mark.parametrize("e", [0.0, 0.3])
def test_exact_impact_loss_equals_the_kkt_impact_map(bilateral, e):
    sys_ = _Rigid(bilateral)
    v = np.array([-1.0, -1.0, 0.7]) if bilateral else np.array([-1.3, 0.4, 0.7])
    Cb = sys_.constraint_jacobian(0.0, None) if bilateral else None
    res = impact_map(sys_.M, sys_.gap_jacobian(None), v, e, Cb)
    assert IM.exact_impact_loss(sys_, np.zeros(3), v, 0, e) == pytest.approx(res.energy_loss, rel=1e-12)


def test_reference_losses_from_the_cumulative_dissipation():
    t = np.arange(0, 11) * 0.1
    d = np.where(t > 0.32, 0.5, 0.0) + np.where(t > 0.71, 0.25, 0.0)
    ref = pd.DataFrame({"t": t, "D_impacts": d})
    assert IM.reference_impact_losses(ref, [0.32, 0.71]) == [0.5, 0.25]
    assert math.isnan(IM.reference_impact_losses(ref, [0.32, 0.33])[0])   # two impacts in one bracket


# ---- beam-impact: order 2 before the first impact ---------------------------------------------------
# N = 1 keeps every step of the sweep in the asymptotic range: the error before the first impact is
# the phase error of the highest mode, which is O(h²) only once hω_top is small (N = 1: ω_top ≈ 400
# rad/s, hω ≤ 0.04 at 1e-4 s; N = 5: 1.1e4 rad/s needs h ≲ 3e-6 s) and stays above the round-off
# floor of the displacement-form Newmark update (≈ 1e-8 m at the tip, reached near h = 3e-6 s).
ORDER_STEPS = (1e-4, 5e-5, 2.5e-5, 1.25e-5)


@pytest.fixture(scope="module")
def order_sweep(tmp_path_factory):
    import os

    from daebench.harness.sweeps import options, sweep as bench
    from daebench.models.scenes import load_scene

    old = os.environ.get("DAEBENCH_RESULTS")
    os.environ["DAEBENCH_RESULTS"] = str(tmp_path_factory.mktemp("results"))
    try:
        sc = load_scene("beam-impact", {"discretization.n": 1, "t_end": 0.38})
        df = bench.run_sweep(sc, *options.from_keywords(
            ["hht", "newmark"], dict(steps=list(ORDER_STEPS), options={"h_contact": 1e-6}, reference="compute",
                                     write=False, executor="inline", repeats=1)))
    finally:
        if old is None:
            os.environ.pop("DAEBENCH_RESULTS")
        else:
            os.environ["DAEBENCH_RESULTS"] = old
    return df


@pytest.mark.parametrize("integrator", ["hht", "newmark"])
@pytest.mark.parametrize("measure", ["err_pre_theta_max", "err_pre_theta_l2", "err_impact1_t"])
def test_pre_impact_errors_fall_with_order_two(order_sweep, integrator, measure):
    d = order_sweep[order_sweep["integrator"] == integrator].sort_values("h", ascending=False)
    assert list(d["status"]) == ["completed"] * len(ORDER_STEPS)
    e = d[measure].to_numpy(float)
    orders = np.log2(e[:-1] / e[1:])
    assert np.all((orders > 1.8) & (orders < 2.2)), (integrator, measure, e, orders)


def test_driver_impacts_lose_the_exact_impact_map_energy(order_sweep):
    # the driver applies the Newton impact map: what it removes is the closed form to round-off
    assert np.all(order_sweep["impact_loss_dev_rel"] < 1e-10)
    assert np.all(order_sweep["impact1_loss"] > 0.1)   # J: the first strike removes most of ½ m v² of the tip
