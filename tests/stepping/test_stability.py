"""The stability map: the methods' computed stability functions against closed forms, and
the measured largest stable step against the linear prediction on beam-impact, and the
report the command writes (daebench.workflows.stability_report: table, figure)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from daebench.integrators.family import chung_hulbert, hht_coefficients
from daebench.models.scenes import load_scene
from daebench.workflows.stability import (AbmPece, Bisection, NewmarkMember, divergence_time, linearize, log_growth,
                                          predict, run_interval, stability_map, strict_interval, trial_length)


def member(c) -> NewmarkMember:
    return NewmarkMember(c.alpha_m, c.alpha_f, c.beta, c.gamma, c.accel_avg)


# -- the methods -----------------------------------------------------------------------------------
def test_newmark_members_match_their_closed_forms():
    trap = NewmarkMember(0.0, 0.0, 0.25, 0.5)
    assert strict_interval(trap) == math.inf
    assert max(abs(trap.radius(w) - 1.0) for w in (0.1, 1.0, 10.0, 1e4)) < 1e-12   # energy-conserving
    # γ = ½, 2β < γ: stable for Ω ≤ 1/√(γ/2 − β) (Fox–Goodwin β = 1/12: √6)
    for beta in (1.0 / 12.0, 1.0 / 6.0):
        assert strict_interval(NewmarkMember(0.0, 0.0, beta, 0.5)) == pytest.approx(1.0 / math.sqrt(0.25 - beta),
                                                                                    abs=2e-3)
    for alpha in (-0.15, -1.0 / 3.0):          # HHT: unconditionally stable, ρ∞ = (1 + α)/(1 − α)
        m = member(hht_coefficients(alpha))
        assert strict_interval(m) == math.inf
        assert m.radius(1e6) == pytest.approx((1 + alpha) / (1 - alpha), abs=2e-4)  # slow: double root
    for rho in (0.0, 0.5, 0.74):               # generalized-α (acceleration averaging): ρ∞ as chosen
        m = member(chung_hulbert(rho))
        assert strict_interval(m) == math.inf
        assert m.radius(1e6) == pytest.approx(rho, abs=2e-3)


def test_abm4_pece_polynomial_is_fourth_order_and_weakly_unstable():
    """The principal root follows e^{iΩ} to O(Ω⁵) (order 4), exceeds 1 for every Ω > 0
    (no strict interval) and a parasitic root takes over near Ω = 0.93."""
    from daebench.stepping import abm

    m = AbmPece()
    for w in (0.02, 0.05, 0.1):
        z = 1j * w
        coef = [1.0, -(1 + z * (abm.AM0 + abm.AM1) + z * z * abm.AM0 * abm.AB0),
                -(z * abm.AM2 + z * z * abm.AM0 * abm.AB1), -(z * abm.AM3 + z * z * abm.AM0 * abm.AB2),
                -(z * z * abm.AM0 * abm.AB3)]
        roots = np.roots(coef)
        principal = roots[np.argmin(np.abs(roots - np.exp(z)))]
        # local error C₅Ω⁵ with the Adams–Moulton corrector's constant 19/720 (the predictor's enters at Ω⁶)
        assert abs(principal - np.exp(z)) / w**5 == pytest.approx(19.0 / 720.0, rel=0.15)
        assert m.radius(w) > 1.0
    assert strict_interval(m) < 0.02
    # short runs: the boundary is the parasitic root's crossing; long runs: the weak growth
    assert 0.93 < run_interval(m, 500, math.log(1e6)) < 0.97
    assert 0.4 < run_interval(m, 1e4, math.log(1e6)) < 0.6


def test_abm4_growth_from_the_rk4_start_matches_the_recurrence():
    """g_n(Ω) from the roots of the polynomial equals iterating the PECE steps on y′ = iΩy/h
    after three RK4 steps (an independent loop over the stepper's coefficients)."""
    from daebench.stepping import abm

    def iterate(w, n):
        z = 1j * w
        R = 1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24
        y = [1.0 + 0j, R, R**2, R**3]
        for _ in range(3, n):
            f = [z * v for v in y[-4:]]
            yp = y[-1] + abm.AB0 * f[3] + abm.AB1 * f[2] + abm.AB2 * f[1] + abm.AB3 * f[0]
            y.append(y[-1] + abm.AM0 * z * yp + abm.AM1 * f[3] + abm.AM2 * f[2] + abm.AM3 * f[1])
        return math.log(abs(y[-1]))

    for w in (0.3, 0.9, 0.95, 1.03, 1.5):
        for n in (20, 83, 400):
            assert log_growth(AbmPece(), n, w)[0] == pytest.approx(iterate(w, n), abs=1e-8)


# -- measured against predicted -------------------------------------------------------------------
def _ritz_pinned_rod(n_modes: int, L: float, EI: float, rhoA: float) -> np.ndarray:
    """Frequencies of a rod pinned at x = 0 (no hub inertia) whose deflection is x θ plus
    the first ``n_modes`` clamped–free beam modes, by Rayleigh–Ritz on a fine grid: written
    here from the shapes' closed form, not the model's tables (gravity left out: it moves
    the top frequency by ~1e-5)."""
    roots = [1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349, 14.1371683910][:n_modes]
    x = np.linspace(0.0, L, 20001)
    shapes, curv = [], []
    for r in roots:
        b = r / L
        sig = (math.cosh(r) + math.cos(r)) / (math.sinh(r) + math.sin(r))
        shapes.append(np.cosh(b * x) - np.cos(b * x) - sig * (np.sinh(b * x) - np.sin(b * x)))
        curv.append(b * b * (np.cosh(b * x) + np.cos(b * x) - sig * (np.sinh(b * x) + np.sin(b * x))))
    basis, d2 = np.array([x] + shapes), np.array([np.zeros_like(x)] + curv)
    M = rhoA * np.trapezoid(basis[:, None, :] * basis[None, :, :], x, axis=2)
    K = EI * np.trapezoid(d2[:, None, :] * d2[None, :, :], x, axis=2)
    import scipy.linalg as sla
    return np.sqrt(np.abs(sla.eigh(K, M, eigvals_only=True)))


def test_linearization_of_beam_impact_gives_the_pinned_free_frequencies():
    """J_h = 0, N = 5 clamped–free modes: the four lowest bending frequencies are the
    continuum pinned–free rod's (β L the roots of tan = tanh) within 1 % (a Ritz basis
    approaches them from above: 0.57 % at the fourth); the fifth, a
    property of the discretization, is the Rayleigh–Ritz value of the same basis computed
    independently (11 145 rad/s against the continuum's 6 792)."""
    lin = linearize(load_scene("beam-impact", {"discretization.n": 5}))
    L, EI, rhoA = 1.0, 6.8952e10 * 7.85e-9, 2.7667e3 * 3.14e-4   # cases/beam-impact.toml
    ritz = _ritz_pinned_rod(5, L, EI, rhoA)
    bending = np.sort(lin.omega[lin.omega > 1.0])
    assert len(bending) == 5
    continuum = np.array([3.9266023120, 7.0685827500, 10.2101761242, 13.3517687778, 16.4933614313]) ** 2 \
        * math.sqrt(EI / rhoA) / L ** 2
    np.testing.assert_allclose(bending[:4], continuum[:4], rtol=1e-2)   # measured: 0.57 % at the fourth
    assert bending[-1] == pytest.approx(ritz[-1], rel=1e-4) and bending[-1] > 1.6 * continuum[4]
    hub = linearize(load_scene("beam-impact", {"discretization.n": 5, "hub.inertia": 1e3}))
    # a heavy hub clamps the rod: the 5th clamped–free bending frequency, 794.0 Hz (docs/sources.md §G.2)
    assert hub.omega.max() / (2 * math.pi) == pytest.approx(794.0, rel=2e-3)


def _check_agreement(df, tol):
    """Linear theory's stable step (h_pred, from the eigenvalues of the linearised beam and the
    method's stability region) against the step the runs measured: inside the bisection's
    bracket [h_stable, h_unstable], widened by one bisection step (a factor 1 + tol)."""
    for r in df.itertuples():
        print(f"\n{r.label} N = {r.N}: predicted {r.h_pred:.4g} s, measured [{r.h_stable:.4g}, {r.h_unstable:.4g}] s")
        assert r.unstable_status == "diverged" and r.h_stable < r.h_unstable, r
        assert r.h_stable / (1.0 + tol) <= r.h_pred <= r.h_unstable * (1.0 + tol), r


def test_baumgarte_boundary_agrees_with_the_prediction_reduced():
    """N = 3, 5 (measured 2.33e-4–2.37e-4 and 8.4e-5–8.5e-5 s; predicted 2.32e-4 and 8.5e-5 s)."""
    df = stability_map(load_scene("beam-impact"), [("baumgarte", {})], [3, 5], Bisection(h_min=1e-5, h_max=1e-3,
                                                                                        tol=0.02))
    _check_agreement(df, 0.02)
    assert (df["unstable_status"] == "diverged").all()
    # a whole run (1 s) is never predicted more stable than its 80-period trial
    assert (df["t_run"] == 1.0).all() and (df["h_pred_run"] <= df["h_pred"] * (1 + 1e-9)).all()
    # measured over the whole run (impacts included): below the trial's bracket (N = 3: 1.00e-4–1.02e-4 s,
    # N = 5: 2.9e-5–3.0e-5 s), and linear theory from the start state over-predicts it by 15–17 %
    assert (df["unstable_status_run"] == "diverged").all() and (df["h_unstable_run"] < df["h_stable"]).all()
    assert (df["h_pred_run"] > df["h_unstable_run"]).all() and (df["h_pred_run"] < 1.25 * df["h_stable_run"]).all()


@pytest.mark.slow
def test_stability_map_agrees_with_the_prediction_full():
    methods = [("baumgarte", {}), ("baumgarte", {"delta": 1000.0, "epsilon": 5000.0}),
               ("newmark", {"beta": 1.0 / 12.0}), ("hht", {"alpha": -0.15})]
    bis = Bisection(jobs=2)
    df = stability_map(load_scene("beam-impact"), methods, [3, 5, 7, 9], bis)
    _check_agreement(df, bis.tol)


def test_prediction_is_a_fixed_point_in_h():
    lin = linearize(load_scene("beam-impact", {"discretization.n": 3}))
    p = predict(AbmPece(), lin, 0.05)
    assert p["h_pred"] * p["omega_limiting"] == pytest.approx(p["interval"])
    assert p["omega_limiting"] == pytest.approx(lin.omega.max())


def test_cli_writes_table_and_figure(tmp_path):
    from daebench.cli import sweeps as cli_sweeps

    app = typer.Typer()
    app.command("noop")(lambda: None)
    cli_sweeps.register(app)
    res = CliRunner().invoke(app, ["stability", "beam-impact", "-m", "baumgarte", "--n", "3", "--tol", "0.3",
                                   "--h-min", "1e-4", "--h-max", "1e-3", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    assert "| baumgarte | 3 |" in res.output and "1/1 rows agree" in res.output
    for ext in ("md", "csv", "parquet", "png"):
        assert (tmp_path / f"beam-impact-stability.{ext}").stat().st_size > 0
    bad = CliRunner().invoke(app, ["stability", "beam-impact", "-m", "baumgarte:delta=-1", "--out", str(tmp_path)])
    assert bad.exit_code == 2 and "delta" in bad.output


def test_linear_theory_predicts_when_a_full_run_diverges():
    """A heavy hub (J_h = 1 kg m², clamped rod), N = 5, h = 1e-4 s: hω_top = 0.499, where
    ABM4-PECE's principal root grows 0.15 % a step; the top bending mode, seeded by gravity,
    passes the driver's threshold in free flight before the first impact. Predicted 0.704 s,
    measured 0.705 s (the first output time after the crossing; outputs every 1 ms)."""
    from daebench.harness.running.runner import make_integrator, run_scene

    sc = load_scene("beam-impact", {"discretization.n": 5, "hub.inertia": 1.0})
    t_pred = divergence_time(AbmPece(), linearize(sc), 1e-4)
    _, res = run_scene(sc, make_integrator("baumgarte", {"h": 1e-4, "h_contact": 1e-6}), write=False)
    print(f"\npredicted {t_pred:.4f} s, diverged at {res.t_final:.4f} s: {res.message}")
    assert res.status == "diverged" and not res.impacts
    assert t_pred <= res.t_final <= t_pred + 2e-3


# -- the hub variant (issue 16, item 2) --------------------------------------------------------------
def test_hub_variant_is_beam_impact_with_a_hub():
    a, b = load_scene("beam-impact"), load_scene("beam-impact-hub")
    diff = {k for k in set(a.values) | set(b.values) if a.values.get(k) != b.values.get(k)}
    assert diff == {"name", "description", "hub.inertia"}
    assert b["hub.inertia"] == 0.03
    lin = linearize(b.with_overrides({"discretization.n": 7}))
    # clamped–free mode 7 (docs/sources.md §G.2)
    assert lin.omega.max() / (2 * math.pi) == pytest.approx(1657.0, rel=2e-3)


def _baumgarte_run(n: int, h: float):
    from daebench.harness.running.runner import make_integrator, run_scene

    sc = load_scene("beam-impact-hub", {"discretization.n": n})
    return run_scene(sc, make_integrator("baumgarte", {"h": h, "h_contact": 1e-6}), write=False)[1]


def test_hub_variant_n9_diverges_at_3e_5_when_predicted():
    """N = 9 at h = 3e-5 s: hω_top = 0.53, free-flight growth reaches the threshold at 0.181 s
    (predicted), before the first impact; measured 0.182 s."""
    sc = load_scene("beam-impact-hub", {"discretization.n": 9})
    t_pred = divergence_time(AbmPece(), linearize(sc), 3e-5)
    res = _baumgarte_run(9, 3e-5)
    assert res.status == "diverged" and t_pred <= res.t_final <= t_pred + 2e-3


@pytest.mark.slow
def test_hub_variant_reproduces_the_published_baumgarte_pattern_at_3e_5():
    """N = 3, 5, 7 complete the second (with 5, 13, 19 impacts), N = 9 diverges; at the
    published h = 1e-4 s N = 5 diverges already (0.59 s)."""
    assert [_baumgarte_run(n, 3e-5).status for n in (3, 5, 7, 9)] == ["completed"] * 3 + ["diverged"]
    assert _baumgarte_run(5, 1e-4).status == "diverged"


def test_whole_run_prediction_explains_the_calibrated_n9_divergence():
    """The calibrated variant's step, 2.5e-5 s: the 80-period trial predicts Baumgarte stable
    up to 5.3e-5 s at N = 9, the 1 s run only up to 2.0e-5 s — and the run diverges at the
    time linear theory gives (0.366 s; measured 0.367 s); at N = 7 the whole run's limit,
    3.8e-5 s, is above the step, and the run completes."""
    sc9 = load_scene("beam-impact-hub", {"discretization.n": 9})
    lin9 = linearize(sc9)
    trial = trial_length(sc9, lin9, 80.0)
    assert predict(AbmPece(), lin9, trial)["h_pred"] > 2.5e-5 > predict(AbmPece(), lin9, sc9.t_end)["h_pred"]
    res = _baumgarte_run(9, 2.5e-5)
    t_pred = divergence_time(AbmPece(), lin9, 2.5e-5)
    assert res.status == "diverged" and t_pred <= res.t_final <= t_pred + 2e-3
    lin7 = linearize(load_scene("beam-impact-hub", {"discretization.n": 7}))
    assert predict(AbmPece(), lin7, 1.0)["h_pred"] > 2.5e-5
