"""Coulomb friction and declared impact laws in the event-driven driver (daebench.driver):
the simultaneous and sequential Newton laws on Newton's cradle, the Newton–Coulomb impact
LCP (Pfeiffer & Glocker; daebench.core.frictional_impact) against the falling rod's closed
forms, stick and slip phases (daebench.driver.stickslip) on the block on an incline and
Housner's rocking block, and Painlevé's paradox ending a run with its verdict.

The impact map is exact (no step enters it) and hht is exact on the constant accelerations
of free flight and of sliding, so most checks are to round-off; the rocking block's
phases are smooth rotations (second order).

Cold-cache cost: hht's compiled loop on the cradle model and on Python-protocol models (the
frictional phases) — each compiled once, then seconds per run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core.frictional_impact import LAW_NEWTON, LAW_NEWTON_COULOMB, frictional_impact
from daebench.core.params import ParamError
from daebench.driver.simulate import simulate
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.cradle import sequential_outcome, simultaneous_outcome
from daebench.models.rigid2d_exact import (housner_ratio, incline_motion, incline_stop, rocking_impact_omegas,
                                           rod_impact)
from daebench.models.scenes import load_scene

G = 9.81


def run(scene: str, overrides: dict | None = None, integrator: str = "hht", t_end: float | None = None,
        **settings):
    sc = load_scene(scene, overrides or {})
    res = simulate(build_system(sc), get_integrator(integrator)(**settings), t_end or sc.t_end, sc["output.dt"])
    return res


# -- the declared impact law: Newton's cradle -------------------------------------------------------
@pytest.mark.parametrize("law, exact", [("simultaneous", simultaneous_outcome(3, 1.0, 1.0)),
                                        ("sequential", sequential_outcome(3, 1.0))])
def test_cradle_outcome_follows_the_declared_impact_law(law, exact):
    """hht through the driver: (−1/3, 2/3, 2/3) m/s under the simultaneous law (both
    contacts in one LCP, both impacts at the same instant), (0, 0, 1) m/s under the
    sequential one; the run record names the law."""
    res = run("newton-cradle", {"contact.impact_law": law}, h=1e-3)
    assert res.status == "completed", res.message
    v = res.history[["v1", "v2", "v3"]].values[-1]
    assert np.abs(v - exact).max() < 1e-12
    assert res.impact_law == f"{LAW_NEWTON}, {law}"
    first = [i for i in res.impacts if i.t == res.impacts[0].t]
    assert abs(first[0].t - 0.01) < 1e-12 and [i.contact for i in first[:2]] == [0, 1]
    if law == "simultaneous":   # the energy balance holds: e = 1 loses nothing
        assert abs(res.history.E.values[-1] - res.history.E.values[0]) < 1e-12


def test_simultaneous_law_is_the_default_and_agrees_with_moreau():
    """No key given: the simultaneous law — the outcome moreau's LCP gives (agreement between
    the families to round-off)."""
    sc = load_scene("newton-cradle")
    assert sc["contact.impact_law"] == "simultaneous"
    driven = run("newton-cradle", h=1e-3).history[["v1", "v2", "v3"]].values[-1]
    captured = run("newton-cradle", integrator="moreau", h=1e-3).history[["v1", "v2", "v3"]].values[-1]
    assert np.abs(driven - captured).max() < 1e-10


def test_impact_law_key_is_validated():
    with pytest.raises(ParamError, match="impact_law"):
        load_scene("newton-cradle", {"contact.impact_law": "both"})


# -- the Newton–Coulomb impact LCP ---------------------------------------------------------------------
@pytest.mark.parametrize("mu", [0.0, 0.2, 0.4, 0.8, 2.0])
@pytest.mark.parametrize("vx", [0.0, 0.5, -0.7])
def test_frictional_impact_lcp_matches_the_rod_closed_form(mu, vx):
    """The Pfeiffer–Glocker LCP against rigid2d_exact.rod_impact (stick or slip decided
    there by enumeration): impulses and velocities to round-off; the law's name."""
    theta, vy, e, L = math.radians(30.0), -1.981, 0.5, 1.0
    pn, pt, vp = rod_impact(L, theta, vy, vx, e, mu)
    h = 0.5 * L
    M = np.diag([1.0, 1.0, L * L / 12.0])
    GN = np.array([[0.0, 1.0, h * math.sin(theta)]])
    GT = np.array([[1.0, 0.0, h * math.cos(theta)]])
    r = frictional_impact(M, GN, GT, [mu], np.array([vx, vy, 0.0]), e)
    assert r.ok
    assert abs(r.impulse_n[0] - pn) < 1e-14 and abs(r.impulse_t[0] - pt) < 1e-14
    assert np.abs(r.v_plus - vp).max() < 1e-14
    assert abs(r.impulse_t[0]) <= mu * r.impulse_n[0] * (1 + 1e-12)
    assert r.energy_loss > 0.0


@pytest.mark.parametrize("mu", [0.0, 0.2, 0.8])
def test_falling_rod_impact_through_the_driver_is_the_closed_form(mu):
    """falling-rod under hht: the impact comes at √(2 · 0.2 / g) to EVENT_TOL and its
    post-impact velocities are Newton–Coulomb's closed form to round-off (frictionless,
    slip at μ = 0.2, stick at μ = 0.8); the record names the law."""
    res = run("falling-rod", {"contact.friction": mu}, h=1e-3, t_end=0.25)
    assert res.status == "completed", res.message
    imp = res.impacts[0]
    assert imp.contact == 0 and abs(imp.t - math.sqrt(2 * 0.2 / G)) < 1e-12
    pn, pt, v_exact = rod_impact(1.0, imp.q[2], imp.v_minus[1], imp.v_minus[0], 0.5, mu)
    assert abs(imp.q[2] - math.radians(30.0)) < 1e-12
    assert np.abs(imp.v_plus - v_exact).max() < 1e-13
    assert imp.impulse == pytest.approx(pn, abs=1e-13)
    assert res.impact_law == (LAW_NEWTON if mu == 0.0 else LAW_NEWTON_COULOMB) + ", simultaneous"
    if mu == 0.8:   # stick: the contact point leaves the impact without slip
        assert abs(imp.v_plus[0] + 0.5 * math.cos(imp.q[2]) * imp.v_plus[2]) < 1e-13


# -- stick and slip phases: the block on an incline ----------------------------------------------------
@pytest.mark.parametrize("integrator", ["hht", "newmark", "genalpha"])
@pytest.mark.parametrize("mu", [0.3, 0.7])
def test_block_incline_slides_stops_and_sticks_or_slides_back_exactly(integrator, mu):
    """μ = 0.3 < tan 30°: slide up, stop at t_s, slide back; μ = 0.7 > tan 30°: stop and
    stick at x_s. The accelerations are constant in each phase, which the Newmark family
    integrates exactly, and the stop is located to EVENT_TOL: the whole history is the
    closed form to round-off at any step (h = 10 ms here), the block stays flat on the
    slope, and the energy balance (slip friction's work booked as W_friction) closes."""
    phi = math.radians(30.0)
    res = run("block-incline", {"contact.friction": mu}, integrator=integrator, h=1e-2)
    assert res.status == "completed", res.message
    hist = res.history
    x, v = incline_motion(3.0, phi, mu, G, hist.t.values)
    assert np.abs(hist.x.values - x).max() < 1e-11
    assert np.abs(hist.vx.values - v).max() < 1e-11
    assert np.abs(hist.theta.values).max() < 1e-14 and abs(hist.gap.min()) < 1e-14
    ts, xs = incline_stop(3.0, phi, mu, G)
    if mu > math.tan(phi):
        after = hist[hist.t > ts]
        assert np.abs(after.x.values - xs).max() < 1e-12 and np.abs(after.vx.values).max() < 1e-12
    assert abs(res.energy_residual) < 1e-11
    work = hist.W_friction.values[-1]   # −μ m g cos φ × the distance slid
    assert work == pytest.approx(-mu * G * math.cos(phi) * (2 * xs - x[-1] if mu < math.tan(phi) else xs), rel=1e-11)


# -- Housner's rocking block ----------------------------------------------------------------------------
@pytest.mark.slow
def test_rocking_block_housner_ratio_under_hht():
    """Corners sticking (μ = 1), no bounce: at each impact the simultaneous Newton–Coulomb
    LCP of both bottom corners gives the new corner the impulse and lifts the old one, and
    |ω⁺|/|ω⁻| = 1 − 1.5 sin²α to round-off (the impact map is exact); |ω⁻| before the
    impacts converges to the closed form at second order (hht on the smooth rotations)."""
    r = housner_ratio(0.2, 1.0)
    exact = rocking_impact_omegas(0.2, 1.0, math.atan(0.2) / 2, G, 2)
    errs = []
    for h in (2e-3, 1e-3):
        res = run("rocking-block", h=h, t_end=1.0)
        assert res.status == "completed", res.message
        imps = [i for i in res.impacts if i.t > 0]
        assert [i.contact for i in imps] == [1, 0] and all(i.closed for i in imps)
        ratio = np.array([abs(i.v_plus[2]) / abs(i.v_minus[2]) for i in imps])
        assert np.abs(ratio - r).max() < 1e-13
        errs.append(np.abs(np.array([abs(i.v_minus[2]) for i in imps]) - exact).max())
    assert errs[-1] < 2e-6, errs
    assert 1.7 < math.log2(errs[0] / errs[1]) < 2.3, errs


def test_rocking_block_impacts_on_the_degenerate_corner_lcp_are_housners():
    """newmark at h = 5e-4 s meets, at its second impact, a Newton–Coulomb LCP whose two
    corners share one tangent row and whose data are round-off zeros: finite-precision
    pivoting ended there at a point that was not a solution (the new corner still
    approaching, kinetic energy made). The end point is checked and the ties broken, so
    every impact is Housner's: |ω⁺|/|ω⁻| = 1 − 1.5 sin²α, the old corner lifting."""
    res = run("rocking-block", integrator="newmark", h=5e-4, t_end=2.0)
    assert res.status == "completed", res.message
    imps = [i for i in res.impacts if i.t > 0]
    assert len(imps) >= 3 and [i.contact for i in imps[:3]] == [1, 0, 1]
    ratio = np.array([abs(i.v_plus[2]) / abs(i.v_minus[2]) for i in imps])
    assert np.abs(ratio - housner_ratio(0.2, 1.0)).max() < 1e-12, ratio


# -- Painlevé's paradox ---------------------------------------------------------------------------------
def test_painleve_slip_ends_the_run_with_its_verdict():
    """A rod resting on its lower end at 30°, sliding (U_T = +1 m/s) with μ = 2 > 4/3: the
    normal force of the slip phase would pull while the free end would fall into the
    ground (W_NN − μ W_NT < 0) — the run ends 'failed' naming Painlevé's paradox, no hang,
    no traceback. Sliding the other way (or at μ = 0.5) is consistent and completes."""
    bad = {"contact.friction": 2.0, "start.gap": 0.0, "start.vx": 1.0, "contact.restitution": 0.0}
    res = run("falling-rod", bad, h=1e-3, t_end=0.05)
    assert res.status == "failed" and "Painlevé" in res.message, res.message
    for ok in ({**bad, "start.vx": -1.0}, {**bad, "contact.friction": 0.5}):
        res = run("falling-rod", ok, h=1e-3, t_end=0.05)
        assert res.status == "completed", res.message


@pytest.mark.slow
def test_rocking_block_corner_slides_when_the_stick_force_leaves_the_cone():
    """μ = 0.1: the pivot corner sticks from the release until the friction the rotation
    about it needs, |F_T|/F_N (Newton–Euler about the fixed corner, from the run's own θ, ω),
    reaches μ — then the driver's located 'slide' event lets it slip. The corner's
    position is held to 1e-12 m until 10 µs before that crossing and moves on from 20 µs after."""
    mu, b, h, m = 0.1, 0.1, 0.5, 1.0
    res = run("rocking-block", {"contact.friction": mu, "output.dt": 1e-5}, h=1e-3, t_end=0.25)
    assert res.status == "completed", res.message
    H = res.history
    t, th, w = H.t.values, H.theta.values, H.omega.values
    p, r = -b, -h                                         # the pivot: bottom-left corner
    xc = H.x.values + p * np.cos(th) - r * np.sin(th)
    rpg = -np.array([p * np.cos(th) - r * np.sin(th), p * np.sin(th) + r * np.cos(th)])   # pivot → centre
    io = m * (4 * b * b + 4 * h * h) / 12 + m * (rpg ** 2).sum(0)
    alpha = rpg[0] * (-m * G) / io
    ft = m * (-alpha * rpg[1] - w ** 2 * rpg[0])
    fn = m * (alpha * rpg[0] - w ** 2 * rpg[1]) + m * G
    k = np.flatnonzero(np.abs(ft) / fn > mu)[0]
    ratio = np.abs(ft) / fn
    ts = t[k - 1] + (mu - ratio[k - 1]) * (t[k] - t[k - 1]) / (ratio[k] - ratio[k - 1])
    assert 0.2 < ts < 0.23
    assert np.abs(xc[t < ts - 1e-5] - xc[0]).max() < 1e-12
    moved = np.abs(xc[t > ts + 2e-5] - xc[0])   # the slip starts from rest, its acceleration from 0
    assert moved.min() > 1e-12 and (np.diff(moved) > 0).all()


def test_degenerate_frictional_impact_is_solved_and_no_solution_is_named():
    """The impact LCP of two slider corners on one wall of slider-crank-clearance (μ = 0.01,
    t = 0.18 s under hht: identical tangent rows, slipping at U_T = −27 m/s, one corner
    grazing): Lemke's pivoting ends on a ray although a solution exists; the enumeration of
    the complementary bases finds it (z ≥ 0, w ≥ 0, zᵀw = 0 to round-off), the slip one:
    λ_0R = 2 μ P_N (P_T = +μ P_N) at both corners. An LCP without a solution stays
    LCP_RAY, whose message names Painlevé."""
    from daebench.core.frictional_impact import failure_message
    from daebench.core.lcp import enumerate_lcp
    from daebench.core.lcp import LCP_RAY, lemke_work, solve_lcp_lemke

    A = np.array([[941.06411762397602, -910.78773422988775, -464.22576604058168, -464.22576604468679, 0, 0],
                  [-920.04699348914698, 931.80485836061143, 461.70015988123936, 461.70015988534448, 0, 0],
                  [-466.61120374612176, 459.31472217567870, 238.54377055400721, 238.54377055605977, 1, 0],
                  [-466.61120375024740, 459.31472217976329, 238.54377055605977, 238.54377055811233, 0, 1],
                  [0.02, 0, -1, 0, 0, 0],
                  [0, 0.02, 0, -1, 0, 0]])
    b = np.array([-3.9091234076378800e-15, -8.1734013755225209e-04, -27.219550139821365, -27.219550139821369, 0, 0])
    z, w = np.zeros(6), np.zeros(6)
    assert solve_lcp_lemke(A, b, 6, z, w, lemke_work(6)) == LCP_RAY
    z = enumerate_lcp(A, b)
    w = A @ z + b
    assert z.min() >= 0 and w.min() > -1e-12 and np.abs(z * w).max() < 1e-12
    assert z[:2].max() > 0 and np.allclose(z[2:4], 2 * 0.01 * z[:2], rtol=1e-6)
    assert enumerate_lcp(np.array([[-1.0]]), np.array([-1.0])) is None
    assert "Painlevé" in failure_message(LCP_RAY)
