"""Regularised Coulomb friction of the compliant contact laws (daebench.core.phase:
F_T = −μ F_N tanh(v_T / v_ε) along the contact's tangent row) on block-incline under hht,
against the closed forms of daebench.models.rigid2d_exact and the regularisation's own
predictions:

* once |v_T| ≫ v_ε the sliding decelerations are g (sin φ + μ cos φ) up the slope and
  g (sin φ − μ cos φ) back down (the force deficit μ F_N (1 − tanh(|v_T|/v_ε)) ≤
  2 μ F_N e^{−2|v_T|/v_ε} is nil at |v_T| ≥ 20 v_ε);
* the reversal through |v| ≲ v_ε takes Δt = v_ε ∫ [1/a_reg − 1/a_Coulomb] du (u = v/v_ε)
  longer than Coulomb's (Δt < 0: the weak friction at small downhill slip lets the block
  gather speed sooner), so the sliding-back velocity is offset by g (sin φ − μ cos φ) Δt ∝ v_ε;
* a block held by friction (tan φ < μ) creeps at v_ε artanh(tan φ / μ): ∝ v_ε;
* the energy balance closes with the friction work booked (its error the integrator's:
  second order in h), and the friction work is μ m g cos φ times the path length;
* the force's Jacobian (the Newton loops' ∂Q/∂v) has the analytic slope μ F_N sech²/v_ε;
* friction is refused where it cannot act: a model without a ``tangent`` kernel, the
  ``constraint`` law under an event-driven integrator without the capability, a bad v_ε.

Cold-cache cost: the hht loop on rigid2d (~60 s CPU, shared with other rigid2d hht runs);
each run after that is 0.5–2.5 s.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core.params import ParamError
from daebench.core.problem import Problem
from daebench.core.scene import SceneError
from daebench.harness.running import checks as guards
from daebench.integrators.applicability import check_capabilities
from daebench.integrators.base import IntegratorError
from daebench.integrators.registry import get_integrator
from daebench.models import build_system, check_friction_kernel
from daebench.models.rigid2d_exact import incline_motion, incline_stop
from daebench.models.scenes import load_scene
from _driver_runs import cached_run  # noqa: E402

G, PHI, V0 = 9.81, math.radians(30.0), 3.0
PENALTY = {"contact.law": "penalty", "contact.penalty_stiffness": 1e6, "contact.penalty_damping": 2e3}
HERTZ = {"contact.law": "hertz", "contact.hertz_stiffness": 1e8}
H = 2e-4


def run(overrides: dict, h: float = H):
    return cached_run("hht", "block-incline", overrides, h=h)[0].history


def decelerations(mu: float) -> tuple[float, float]:
    return G * (math.sin(PHI) + mu * math.cos(PHI)), G * (math.sin(PHI) - mu * math.cos(PHI))


def reversal_lag(mu: float, v_eps: float, span: float = 40.0, n: int = 400_001) -> float:
    """Δt = v_ε ∫ [1/a_reg(u) − 1/a_Coulomb(u)] du over u = v/v_ε: how much longer the
    regularised block takes than Coulomb's to pass from sliding up to sliding down (the
    integrand is nil beyond |u| = 20, to e^{−40})."""
    u = np.linspace(-span, span, n)
    s, c = math.sin(PHI), math.cos(PHI)
    f = 1.0 / (G * (s + mu * c * np.tanh(u))) - 1.0 / (G * (s + mu * c * np.sign(u)))
    return v_eps * float(np.trapezoid(f, u))


@pytest.mark.parametrize("law", [PENALTY, HERTZ], ids=["penalty", "hertz"])
def test_sliding_decelerations_match_coulomb_once_slip_exceeds_v_eps(law):
    """μ = 0.3 < tan 30°, v_ε = 1 mm/s: slopes of ẋ(t) where |ẋ| ≥ 20 v_ε (after the 20 ms
    in which the block settles into the compliant ground) against −g (sin φ ± μ cos φ), to
    the regularisation's bound 2 μ g cos φ e^{−40} plus 1e-6 relative (the compliant
    contact's small pitch and normal motion); the motion up the slope against the exact one."""
    mu, v_eps = 0.3, 1e-3
    hist = run({**law, "contact.friction": mu, "contact.friction_velocity": v_eps})
    t, vx = hist.t.values, hist.vx.values
    a1, a2 = decelerations(mu)
    bound = 2 * mu * G * math.cos(PHI) * math.exp(-40.0)
    up, down = (vx >= 20 * v_eps) & (t > 0.02), vx <= -20 * v_eps
    assert up.sum() > 300 and down.sum() > 500
    assert abs(np.polyfit(t[up], vx[up], 1)[0] + a1) <= bound + 1e-6 * a1
    assert abs(np.polyfit(t[down], vx[down], 1)[0] + a2) <= bound + 1e-6 * a1
    x, v = incline_motion(V0, PHI, mu, G, t)
    ts, _ = incline_stop(V0, PHI, mu, G)
    before = (t < ts - 0.01) & (t > 0.02)
    assert np.abs(vx[before] - v[before]).max() < 1e-5 and np.abs(hist.x.values[before] - x[before]).max() < 1e-5


def test_reversal_lag_matches_the_regularisation_and_scales_with_v_eps():
    """After the stop the velocity differs from Coulomb's by g (sin φ − μ cos φ) Δt(v_ε)
    (:func:`reversal_lag`), within 2 %: the rest is the compliant block's pitch transient
    when friction reverses, which fades as the reversal time v_ε/a grows past the contact's
    pitch period (2.9 ms here): measured 0.4 % at v_ε = 2 cm/s."""
    mu = 0.3
    _, a2 = decelerations(mu)
    offsets = []
    for v_eps in (2e-2, 4e-2):
        hist = run({**PENALTY, "contact.friction": mu, "contact.friction_velocity": v_eps, "t_end": 0.7})
        t = hist.t.values
        late = t > 0.6
        offset = hist.vx.values[late] - incline_motion(V0, PHI, mu, G, t[late])[1]
        assert np.ptp(offset) < 1e-6   # a constant lag: the same deceleration as Coulomb's
        predicted = a2 * reversal_lag(mu, v_eps)   # v_reg(t) = v_Coulomb(t − Δt), ẍ = −a2
        assert offset.mean() == pytest.approx(predicted, rel=0.02)
        offsets.append(offset.mean())
    assert offsets[1] / offsets[0] == pytest.approx(2.0, rel=0.02)


def test_held_block_creeps_at_a_speed_proportional_to_v_eps():
    """μ = 0.7 > tan 30°: after the stop the regularised friction holds the block only by a
    creep down the slope at v_ε artanh(tan φ / μ) (where μ F_N tanh(v/v_ε) = m g sin φ;
    F_N = m g cos φ in the steady creep), 50 ms after the stop on."""
    mu = 0.7
    ts, xs = incline_stop(V0, PHI, mu, G)
    creep = []
    for v_eps in (1e-3, 2e-3):
        hist = run({**PENALTY, "contact.friction": mu, "contact.friction_velocity": v_eps, "t_end": 0.5})
        after = hist[hist.t > ts + 0.05]
        expected = -v_eps * math.atanh(math.tan(PHI) / mu)
        assert after.vx.values == pytest.approx(expected, rel=1e-6)   # measured: 1e-9
        assert abs(after.x.values[0] - xs) < 10 * v_eps * 0.05 + 1e-4   # stopped near x_s, creeping since
        creep.append(float(after.vx.values.mean()))
    assert creep[1] / creep[0] == pytest.approx(2.0, rel=1e-6)


def test_energy_balance_closes_with_the_friction_work():
    """E − E0 − W_contact stays at the integrator's error (falls ≥ 2.5× when h halves: HHT
    is second order), while the booked friction work is the whole story: −μ m g cos φ × the
    path length (up to x_s and back), within 1e-4."""
    mu = 0.3
    residual = {}
    for h in (2e-4, 1e-4):
        hist = run({**PENALTY, "contact.friction": mu, "contact.friction_velocity": 1e-3, "t_end": 0.5}, h=h)
        scale = hist.E.values[0] + abs(hist.W_contact.values[-1])
        residual[h] = float(np.abs(hist.energy_residual.values).max())
        assert residual[h] < 1e-6 * scale
        _, xs = incline_stop(V0, PHI, mu, G)
        path = xs + (xs - (hist.x.values[-1] - hist.x.values[0]))
        assert hist.W_contact.values[-1] == pytest.approx(-mu * G * math.cos(PHI) * path, rel=1e-4)
    assert residual[2e-4] / residual[1e-4] > 2.5, residual


def test_friction_force_and_its_velocity_jacobian_are_analytic():
    """At a penetration of 10 µm under both bottom corners (F_N = k δ = 10 N each) and slip
    v_T = v_ε/2: Q_x adds −2 μ F_N tanh(1/2) and the phase's ∂Q_x/∂ẋ (central differences,
    what the Newton loops use) is −2 μ F_N sech²(1/2)/v_ε."""
    mu, v_eps, k, delta = 0.3, 1e-3, 1e6, 1e-5
    sc = load_scene("block-incline", {**PENALTY, "contact.penalty_damping": 0.0, "contact.friction": mu,
                                      "contact.friction_velocity": v_eps})
    system = build_system(sc)
    p = Problem(system)
    q = np.array([0.0, 0.1 - delta, 0.0])    # half-height 0.1: the bottom corners at g = −δ
    v = np.array([0.5 * v_eps, 0.0, 0.0])
    fn = k * delta
    Q = p.force(0.0, q, v)
    assert Q[0] == pytest.approx(-G * math.sin(PHI) - 2 * mu * fn * math.tanh(0.5), rel=1e-12)
    Kq, Kv = p.force_jacobian(0.0, q, v)
    assert Kv[0, 0] == pytest.approx(-2 * mu * fn / math.cosh(0.5) ** 2 / v_eps, rel=1e-6)
    assert Kq[0, 1] == pytest.approx(2 * mu * k * math.tanh(0.5), rel=1e-6)   # ∂F_T/∂y via F_N = k(−y + …)
    assert p.contact_power(q, v) == pytest.approx(-2 * mu * fn * math.tanh(0.5) * v[0], rel=1e-12)


def test_friction_is_refused_where_it_cannot_act():
    """A model without a ``tangent`` kernel asked for μ > 0; the ``constraint`` law under an
    event-driven integrator that does not declare friction (the compliant laws are
    accepted by every integrator the driver runs them under); a non-positive or
    non-finite v_ε."""
    ball = build_system(load_scene("ball"))
    with pytest.raises(SceneError, match=r"contact\.friction = 0\.3.*no 'tangent' kernel"):
        check_friction_kernel(ball, 0.3, "model 'ball'")
    check_friction_kernel(ball, 0.0)
    check_friction_kernel(build_system(load_scene("block-incline", PENALTY)), 0.3)
    with pytest.raises(ParamError, match=r"contact\.friction"):
        load_scene("ball", {"contact.friction": 0.3})   # a model without the key: unknown key

    sc = load_scene("block-incline", {**PENALTY, "contact.friction": 0.3})
    constraint = sc.with_overrides({"contact.law": "constraint"})
    for name in ("hht", "newmark", "genalpha", "baumgarte"):
        cls = get_integrator(name)
        guards.check_applicable(sc, cls)
        check_capabilities(cls, False, contact_law="penalty", n_contacts=4, friction=True)
        check_capabilities(cls, False, contact_law="hertz", n_contacts=4, friction=True)
        if not cls.capabilities.friction:
            with pytest.raises(IntegratorError, match=r"friction.*contact\.law=penalty"):
                guards.check_applicable(constraint, cls)
            with pytest.raises(IntegratorError, match="friction"):
                check_capabilities(cls, True, contact_law="constraint", n_contacts=4, friction=True)
    with pytest.raises(IntegratorError, match="resolves contacts itself"):   # capturing: the law, not friction
        guards.check_applicable(sc, get_integrator("moreau"))
    for bad in (0.0, -1e-3, float("nan"), float("inf")):
        with pytest.raises(ParamError, match=r"contact\.friction_velocity"):
            load_scene("block-incline", {**PENALTY, "contact.friction_velocity": bad})


@pytest.mark.slow
@pytest.mark.parametrize("integrator, settings", [("newmark", {"h": H}), ("genalpha", {"h": H}), ("ida", {})])
def test_other_driver_integrators_apply_the_same_friction(integrator, settings):
    """The regularised force is the phase's, so every integrator the driver runs it under
    integrates the same smooth problem: sliding up (|v_T| ≫ v_ε) each matches Coulomb's
    closed form to 1e-7 m/s and closes its energy balance, friction work booked, to 1e-6 J
    (hht: test_sliding_decelerations_match_coulomb_once_slip_exceeds_v_eps)."""
    mu = 0.3
    res, _ = cached_run(integrator, "block-incline", {**PENALTY, "contact.friction": mu, "t_end": 0.3}, **settings)
    hist = res.history
    t = hist.t.values
    late = t > 0.02
    assert np.abs(hist.vx.values[late] - incline_motion(V0, PHI, mu, G, t[late])[1]).max() < 1e-7
    assert np.abs(hist.energy_residual.values).max() < 1e-6
    assert hist.W_contact.values[-1] == pytest.approx(-mu * G * math.cos(PHI) * (hist.x.values[-1] - hist.x.values[0]),
                                                      rel=1e-4)
