"""Planar Coulomb friction in Moreau–Jean (daebench.stepping.friction) and nonsmooth
generalized-α (daebench.stepping.nsga_friction) against closed forms
(daebench.models.rigid2d_exact): the block on an incline (slide, stop, stick or slide
back), Housner's rocking block (ω ratio 1 − 1.5 sin²α per impact), the falling rod
(frictionless, slipping and sticking impacts); the Lemke solver of the frictional LCP;
integrators without friction refused before the first step.

Fixed-step event capturing is first order wherever the motion switches inside a step (an
impact, a stop): the tests measure the error at three steps and assert it falls like h.

Cold-cache cost: two compiled loops (moreau, nsgenalpha) on the rigid2d model (~45 s CPU
each); each run after that is well under a second.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core.lcp import LCP_RAY, lcp_work, lemke_work, solve_lcp, solve_lcp_lemke
from daebench.driver.simulate import simulate
from daebench.harness.running import checks as guards
from daebench.integrators.base import IntegratorError
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.rigid2d_exact import (housner_ratio, incline_motion, incline_stop, rocking_impact_omegas,
                                           rod_impact)
from daebench.models.scenes import load_scene
from _driver_runs import cached_run, slope  # noqa: E402

STEPS = (1e-3, 5e-4, 2.5e-4)
EXACT = {"moreau": 1e-12, "nsgenalpha": 1e-8}   # constant deceleration: exact up to round-off / Newton tolerance
G = 9.81


def run(scene: str, overrides: dict | None = None, integrator: str = "moreau", **settings):
    return cached_run(integrator, scene, overrides, **settings)


# -- the LCP solver of the friction cone ------------------------------------------------------------
def _friction_lcp(rng, nc: int, n: int = 3):
    """A random planar frictional-contact LCP in the layout of daebench.stepping.friction."""
    B = rng.normal(size=(n, n))
    S = B @ B.T + 0.5 * np.eye(n)
    Gn, T = rng.normal(size=(nc, n)), rng.normal(size=(nc, n))
    mu = rng.uniform(0.1, 1.0, nc)
    Si = np.linalg.inv(S)
    D = np.vstack([Gn, T, -T])
    m = 4 * nc
    A = np.zeros((m, m))
    A[:3 * nc, :3 * nc] = D @ Si @ D.T
    for i in range(nc):
        A[nc + i, 3 * nc + i] = A[2 * nc + i, 3 * nc + i] = 1.0
        A[3 * nc + i, i], A[3 * nc + i, nc + i], A[3 * nc + i, 2 * nc + i] = mu[i], -1.0, -1.0
    vfree = rng.normal(size=n)
    b = np.concatenate([Gn @ vfree, T @ vfree, -T @ vfree, np.zeros(nc)])
    return A, b, Gn, T, Si, mu, vfree


def test_lemke_solves_the_friction_cone_lcp_and_agrees_with_murty_on_p_matrices():
    """Frictional LCPs (not P-matrices): z ≥ 0, w ≥ 0, zᵀw = 0, and Coulomb's law holds at
    every contact (|P_T| ≤ μ P_N; sliding ⇒ P_T = −μ P_N sign U_T). On SPD problems the
    solution is Murty's; an LCP without solution ends on a ray (LCP_RAY), not a loop."""
    rng = np.random.default_rng(3)
    for nc in (1, 2, 4):
        for _ in range(30):
            A, b, Gn, T, Si, mu, vfree = _friction_lcp(rng, nc)
            m = b.size
            z, w = np.zeros(m), np.zeros(m)
            assert solve_lcp_lemke(A, b, m, z, w, lemke_work(m)) >= 0
            scale = 1.0 + np.abs(b).max()
            assert z.min() >= 0.0 and w.min() >= -1e-9 * scale and abs(z @ w) <= 1e-9 * scale * (1 + z.max())
            pn, pt = z[:nc], z[nc:2 * nc] - z[2 * nc:3 * nc]
            v = vfree + Si @ (Gn.T @ pn + T.T @ pt)
            ut = T @ v
            assert np.all(np.abs(pt) <= mu * pn + 1e-9 * scale)
            sliding = np.abs(ut) > 1e-8 * scale
            assert np.allclose(pt[sliding], -mu[sliding] * pn[sliding] * np.sign(ut[sliding]), atol=1e-8 * scale)
    for k in (1, 3, 6):
        B = rng.normal(size=(k, k))
        A, b = B @ B.T + 0.1 * np.eye(k), rng.normal(size=k)
        z, w, z2, w2 = np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k)
        assert solve_lcp_lemke(A, b, k, z, w, lemke_work(k)) >= 0
        solve_lcp(A, b, np.ones(k, bool), z2, w2, lcp_work(k))
        assert np.allclose(z, z2, atol=1e-10)
    z, w = np.zeros(1), np.zeros(1)
    assert solve_lcp_lemke(np.array([[-1.0]]), np.array([-1.0]), 1, z, w, lemke_work(1)) == LCP_RAY


# -- block on an incline --------------------------------------------------------------------------------
@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_block_incline_slides_up_stops_and_slides_back_first_order(integrator):
    """μ = 0.3 < tan 30°: exact while sliding up (constant deceleration, trapezoidal
    positions), then the step [t_k, t_k + h] that holds the stop t_s = t_k + τ: its one
    friction impulse opposes the end velocity, so it ends at rest if τ ≥ h a₂/a₁ (the
    slide back starts at t_k + h, late by h − τ) and sliding at a₁τ − a₂h otherwise. The
    run's final velocity is that prediction to round-off, and its error from the exact
    solution is ≤ a₂(1 − a₂/a₁) h: first order, with the constant of the analysis."""
    phi, mu, v0, t_end = math.radians(30.0), 0.3, 3.0, 1.0
    a1, a2 = G * (math.sin(phi) + mu * math.cos(phi)), G * (math.sin(phi) - mu * math.cos(phi))
    ts, _ = incline_stop(v0, phi, mu, G)
    for h in (2e-3, *STEPS):
        res, _ = run("block-incline", integrator=integrator, h=h)
        hist = res.history
        x, v = incline_motion(v0, phi, mu, G, hist.t.values)
        k = math.floor(ts / h)
        tau = ts - k * h
        v1 = 0.0 if tau >= h * a2 / a1 else a1 * tau - a2 * h
        assert hist.vx.values[-1] == pytest.approx(v1 - a2 * (t_end - (k + 1) * h), abs=1e-9)
        t = hist.t.values
        up = (t <= k * h) & (np.abs(t / h - np.round(t / h)) < 1e-6)   # the step points before the stop
        assert np.abs(hist.x.values[up] - x[up]).max() < EXACT[integrator]   # exact while sliding up
        assert np.abs(hist.vx.values - v).max() <= a2 * (1 - a2 / a1) * h * (1 + 1e-9)
        assert np.abs(hist.x.values - x).max() <= (a2 * (1 - a2 / a1) * h * (t_end - ts) + a1 * h * h) * (1 + 1e-9)
        assert np.abs(hist.theta.values).max() < 1e-12 and hist.gap.min() > -1e-12   # flat on the slope


@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_block_incline_sticks_when_tan_phi_below_mu(integrator):
    """μ = 0.7 > tan 30°: the block stops at x_s = v0²/(2g(sin φ + μ cos φ)) and stays there
    (ẋ = 0 exactly after the stop); x_s within the position error of the stop step,
    which is v_k (h − τ)/2 = a₁τ(h − τ)/2 ≤ a₁h²/8 (trapezoidal positions over the step
    that ends at rest)."""
    mu, phi = 0.7, math.radians(30.0)
    ts, xs = incline_stop(3.0, phi, mu, G)
    a1 = G * (math.sin(phi) + mu * math.cos(phi))
    for h in STEPS:
        res, _ = run("block-incline", {"contact.friction": mu}, integrator=integrator, h=h)
        hist = res.history
        after = hist[hist.t > ts + h]
        assert np.abs(after.vx.values).max() < EXACT[integrator]
        assert np.ptp(after.x.values) < EXACT[integrator]
        assert abs(after.x.values[-1] - xs) <= a1 * h * h / 8 * (1 + 1e-6)
        x, v = incline_motion(3.0, phi, mu, G, hist.t.values)
        before = hist.t.values < ts - h
        assert np.abs(hist.x.values[before] - x[before]).max() < EXACT[integrator]   # exact while sliding


# -- Housner's rocking block --------------------------------------------------------------------------
@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_rocking_block_housner_ratio_first_order(integrator):
    """ω after / before each of the first four impacts → 1 − 1.5 sin²α = 0.942308, and |ω|
    before them → the closed form (energy about the pivot, then Housner's ratio); both
    errors fall like h (the scheme's velocities at the impact step's start)."""
    r = housner_ratio(0.2, 1.0)
    assert r == pytest.approx(1 - 1.5 * math.sin(math.atan(0.2)) ** 2)
    exact = rocking_impact_omegas(0.2, 1.0, math.atan(0.2) / 2, G, 4)
    err_r, err_w = [], []
    for h in STEPS:
        res, _ = run("rocking-block", integrator=integrator, h=h)
        imps = [i for i in res.impacts if i.t > 0][:4]
        assert [i.contact for i in imps] == [1, 0, 1, 0]   # the bottom corners in turn
        wm = np.array([abs(i.v_minus[2]) for i in imps])
        wp = np.array([abs(i.v_plus[2]) for i in imps])
        err_r.append(np.abs(wp / wm - r).max())
        err_w.append(np.abs(wm - exact).max())
    assert err_r[-1] < 2e-3 and err_w[-1] < 3e-3, (err_r, err_w)
    assert 0.9 < slope(STEPS, err_r) < 1.1, err_r
    if integrator == "moreau":
        assert slope(STEPS, err_w) > 0.7, err_w
    else:   # |ω⁻| at the start of nsgenalpha's impact step: within 6e-3, not monotone in h
        assert max(err_w) < 6e-3, err_w


# -- the falling rod ------------------------------------------------------------------------------------
@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
@pytest.mark.parametrize("mu, regime", [(0.0, "frictionless"), (0.2, "slip"), (0.8, "stick")])
def test_falling_rod_impact_closed_form(mu, regime, integrator):
    """Velocities after the impact against Newton's law with Coulomb friction (closed form
    with the stick/slip decision of rigid2d_exact.rod_impact; stick needs μ ≥ 0.4 here);
    first order in h (nonsmooth generalized-α: at least first order, its error falls
    unevenly, 1.3–1.8 over these steps). Stick: the contact point leaves the impact without slip."""
    theta, vy = math.radians(30.0), -math.sqrt(2 * G * 0.2)
    pn, pt, v_exact = rod_impact(1.0, theta, vy, 0.0, 0.5, mu)
    assert (pt == 0.0) if regime == "frictionless" else (abs(pt) < mu * pn - 1e-9) == (regime == "stick")
    err = []
    for h in STEPS:
        res, system = run("falling-rod", {"contact.friction": mu}, integrator=integrator, h=h)
        imp = res.impacts[0]
        assert imp.contact == 0 and abs(imp.t - math.sqrt(2 * 0.2 / G)) <= h
        err.append(np.abs(imp.v_plus - v_exact).max())
        if regime == "stick":
            slip = imp.v_plus[0] + 0.5 * math.cos(imp.q[2]) * imp.v_plus[2]
            assert abs(slip) < 0.01 * abs(vy) * h / 1e-3
    assert err[-1] < 1e-2, err
    assert 0.75 < slope(STEPS, err) < (1.2 if integrator == "moreau" else 2.0), err   # ≥ first order


# -- capabilities -----------------------------------------------------------------------------------------
def test_integrators_without_friction_are_refused_before_the_first_step():
    """baumgarte (event-driven) and lcp (event-capturing, frictionless) refuse a scene with
    μ > 0, naming the integrators that apply friction; with μ = 0 the same scene is accepted.
    hht, newmark and genalpha take friction through the driver (tests/driver/test_friction_driven.py)."""
    sc = load_scene("block-incline")
    own_law = {"lcp": {"contact.law": "complementarity"}}   # lcp resolves its contacts: their law is its own
    for name in ("baumgarte", "lcp"):
        with pytest.raises(IntegratorError, match=r"friction.*\(genalpha, hht, moreau, newmark, nsgenalpha\)"):
            guards.check_applicable(sc.with_overrides(own_law.get(name, {})), get_integrator(name))
    guards.check_applicable(sc.with_overrides({"contact.friction": 0.0}), get_integrator("baumgarte"))
    for name in ("moreau", "hht"):
        guards.check_applicable(sc, get_integrator(name))
    assert all(get_integrator(n).capabilities.friction for n in ("moreau", "nsgenalpha", "hht", "newmark", "genalpha"))
    assert not get_integrator("baumgarte").capabilities.friction


def test_driver_refuses_friction_for_an_integrator_without_it():
    """The driver's own capability check (the API path, no harness guard): baumgarte on a
    case with μ > 0 is refused before the first step."""
    sc = load_scene("block-incline")
    with pytest.raises(IntegratorError, match=r"friction.*moreau"):
        simulate(build_system(sc), get_integrator("baumgarte")(h=1e-3), sc.t_end, sc["output.dt"])
