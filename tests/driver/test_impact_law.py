"""The unilateral contact law as the driver applies it, and the checks that hold it to it.

Closed forms: Newton's law as an LCP gives no impulse to a separating contact and the
simultaneous law its textbook split; the acceleration-level contact LCP gives a box on two
supports the statics' forces and opens the support a torque unloads. Independent checks:
an adhesive impulse planted in a real run's record is caught by the invariant check
(:mod:`daebench.core.impact_checks`) and by the oracle (:mod:`daebench.harness.scoring.oracle`,
solved by another route), and a driver whose law pulls makes a run that does not
complete. On beam-impact, the runs the old driver filled with pulling impulses have none."""

from __future__ import annotations


import numpy as np
import pytest

import daebench
from daebench.core import impact_checks
from daebench.core.contact import Impact
from daebench.core.frictional_impact import frictional_impact
from daebench.core.linalg import solve_structured
from daebench.core.resting_contacts import resting_lcp
from daebench.driver import impact_laws
from daebench.harness.scoring import oracle
from _driver_runs import cached_run  # noqa: E402  (tests/ is on sys.path under pytest)


def test_newton_lcp_gives_a_separating_contact_no_impulse():
    """Two independent unit masses, one approaching at −2 m/s, one separating at +1 m/s,
    e = 0.5: Λ = (1 + e)·2 = 3 N s on the first, none on the second (the equality map
    gave the second −1.5 N s, pulling it shut)."""
    res = frictional_impact(np.eye(2), np.eye(2), np.zeros((2, 2)), np.zeros(2), np.array([-2.0, 1.0]), 0.5)
    np.testing.assert_allclose(res.impulse_n, [3.0, 0.0], atol=1e-14)
    np.testing.assert_allclose(res.v_plus, [1.0, 1.0], atol=1e-14)


@pytest.mark.parametrize("b, h", [(0.1, 0.3), (0.2, 0.5), (0.25, 0.25)])
def test_rocking_block_corner_impact_with_friction_is_housners(b, h):
    """A 2b × 2h block rocking on its corner 1 hits the floor with corner 0 (μ = 1, e = 0): both
    corners' tangent rows are the same row (a degenerate LCP). The law's answer is Housner's: corner 0 sticks,
    corner 1 lifts off without an impulse, ω⁺/ω⁻ = 1 − (3/2) sin²α, sin α = b/R, R² = b² + h²."""
    m = 1.0
    M = np.diag([m, m, m * (b * b + h * h) / 3.0])
    GN = np.array([[0.0, 1.0, -b], [0.0, 1.0, b]])     # ∂(corner height)/∂(x, y, θ) at θ = 0
    GT = np.array([[1.0, 0.0, h], [1.0, 0.0, h]])      # ∂(corner abscissa)/∂(x, y, θ): one row twice
    w = 0.61
    v = np.array([-w * h, -w * b, w])                  # turning about corner 1 (+b, −h): at rest
    assert np.allclose(GN[1] @ v, 0.0) and np.allclose(GT @ v, 0.0) and GN[0] @ v < 0
    res = frictional_impact(M, GN, GT, np.array([1.0, 1.0]), v, np.array([0.0, 0.0]))
    assert res.ok
    assert res.vn_plus.min() >= -1e-12 and res.impulse_n.min() >= 0.0
    assert res.impulse_n[1] == pytest.approx(0.0, abs=1e-12)
    assert abs(res.impulse_t[0]) <= res.impulse_n[0] * (1 + 1e-12) and abs(res.vt_plus[0]) < 1e-12
    sin2 = b * b / (b * b + h * h)
    assert res.v_plus[2] / w == pytest.approx(1.0 - 1.5 * sin2, rel=1e-12)
    assert res.energy_loss > 0.0


def test_resting_lcp_two_supports_closed_form():
    """A box (m = 2 kg, J = 0.5 kg m²) on supports at x = ∓w/2 (w = 1 m) under gravity and a
    torque τ about its centre: λ₁,₂ = m g/2 ± τ/w while both are loaded; past τ = m g w/2
    the second support's force would be negative: it opens (λ₂ = 0, g̈₂ > 0) and the box
    rocks about the first, whose force follows from ÿ − (w/2)φ̈ = 0."""
    m, J, w, g = 2.0, 0.5, 1.0, 9.81
    M = np.diag([m, m, J])                       # q = (x, y, φ) of the centre
    G = np.array([[0.0, 1.0, -w / 2], [0.0, 1.0, w / 2]])   # gaps of the two corners (small φ)
    for tau in (1.0, 20.0):
        a_free = np.array([0.0, -g, tau / J])
        sol = resting_lcp(M, np.zeros((0, 3)), G, a_free, np.zeros(2))
        if tau < m * g * w / 2:
            np.testing.assert_allclose(sol.force, [m * g / 2 + tau / w, m * g / 2 - tau / w], rtol=1e-13)
            assert sol.closed.tolist() == [True, True] and np.abs(sol.gap_acc).max() < 1e-12
        else:
            # rocking about corner 1 alone: ÿ − (w/2) φ̈ = 0 with m ÿ = λ − m g, J φ̈ = τ − λ w/2 (corner 1 at −w/2)
            lam = (g + (w / 2) * tau / J) / (1 / m + (w / 2) ** 2 / J)
            np.testing.assert_allclose(sol.force, [lam, 0.0], rtol=1e-13, atol=1e-12)
            assert sol.closed.tolist() == [True, False] and sol.gap_acc[1] > 0.0


def _d(imp) -> dict:
    return imp if isinstance(imp, dict) else imp.as_dict()




def _planted(rec: Impact, system, P: float) -> Impact:
    """The record's state with the normal velocity reversed (the contact separates) and an
    impulse P applied to it anyway."""
    vm = -np.asarray(rec.v_minus)
    M = np.atleast_2d(system.mass(rec.q))
    Gq = np.atleast_2d(system.gap_jacobian(rec.q))
    vp = vm + np.linalg.solve(M, Gq[0] * P)
    return Impact(rec.t + 0.1, rec.contact, float(Gq[0] @ vm), float(Gq[0] @ vp), 0.0, True, P,
                  impact_impulse=P, restitution=rec.restitution, q=rec.q, v_minus=vm, v_plus=vp)


def test_planted_adhesive_impulse_is_caught_by_invariants_and_oracle():
    """A real run's first impact passes both checks (oracle to round-off); the same state
    with the contact separating and a pulling impulse applied is flagged by both."""
    r, system = cached_run("hht", "ball", {"contact.restitution": 0.8}, h=1e-3)
    good = r.impacts[0]
    bad = _planted(good, system, -2.0)
    assert impact_checks.violations([good], 0.8) == []
    found = impact_checks.violations([good, bad], 0.8)
    assert any("pulls" in f for f in found) and any("separating" in f for f in found)
    assert "break the unilateral contact law" in impact_checks.verdict(found)
    ok = oracle.oracle_scores(system, [good], 0.8)
    assert ok["err_impact_dv_max"] < 1e-12 and ok["oracle_impacts"] == 1
    caught = oracle.oracle_scores(system, [good, bad], 0.8)
    assert caught["err_impact_dv_max"] == pytest.approx(1.0)     # the law makes no jump; the run made one
    assert caught["err_impulse_max"] == pytest.approx(2.0, rel=1e-12)


def test_a_driver_whose_impact_law_pulls_does_not_complete(monkeypatch):
    """Plant the old equality map (Λ of either sign) in the driver: the ball's run says it
    broke the law instead of completing."""
    def equality(M, GN, GT, mu, v, e, held):
        res = frictional_impact(M, GN, GT, mu, v, e, held)
        vn = GN @ v
        W = GN @ solve_structured(M, GN.T)       # M: the driver's mass (an operator for a lumped model)
        P = -np.linalg.solve(W, (1.0 + np.atleast_1d(e)) * vn) - 1.0   # one N s of pull on top
        vp = v + solve_structured(M, GN.T @ P)
        return res.__class__(vp, P, np.zeros_like(P), vn, GN @ vp, np.zeros_like(P), 0.0)

    monkeypatch.setattr(impact_laws, "frictional_impact", equality)
    r = daebench.run("ball", integrator="hht", h=1e-3, overrides={"contact.restitution": 0.8})
    assert r.status == "failed" and "break the unilateral contact law" in r.message


@pytest.mark.parametrize("integrator", ["hht", "newmark", "genalpha"])
@pytest.mark.parametrize("e", [0.0, 0.5])
def test_beam_impact_first_burst_has_no_pulling_impact(integrator, e):
    """The first contact burst (0.37–0.40 s) at the protocol's h = 5e-5 s, h_contact = 1e-6 s:
    every recorded impact approaches and pushes (the old driver recorded up to 16 pulling
    impulses a run here), and the run's record passes the invariant check."""
    r = daebench.run("beam-impact", integrator=integrator, h=5e-5, h_contact=1e-6,
                     overrides={"contact.restitution": e, "t_end": 0.4})
    assert r.status == "completed", r.message
    assert len(r.impacts) >= 1
    for imp in r.impacts:
        assert _d(imp)["impulse"] > 0.0 and _d(imp)["vn_minus"] < 0.0, _d(imp)


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["hht", "newmark", "genalpha"])
@pytest.mark.parametrize("h", [1e-4, 5e-5, 2.5e-5])
@pytest.mark.parametrize("e", [0.0, 0.5])
def test_beam_impact_whole_second_has_no_pulling_impact(integrator, h, e):
    r = daebench.run("beam-impact", integrator=integrator, h=h, h_contact=1e-6, overrides={"contact.restitution": e})
    assert r.status == "completed", r.message
    assert all(_d(i)["impulse"] > 0.0 and _d(i)["vn_minus"] < 0.0 for i in r.impacts)


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["hht", "genalpha"])
def test_slider_crank_clearance_has_no_pulling_impact(integrator):
    r = daebench.run("slider-crank-clearance", integrator=integrator, h=1e-5)
    assert r.status == "completed", r.message
    assert len(r.impacts) >= 1 and all(_d(i)["impulse"] > 0.0 and _d(i)["vn_minus"] < 0.0 for i in r.impacts)


# -- the invariants over the case library ---------------------------------------------------------
#: (case, t_end covering its first impacts) for the suite; the slow sweep runs every case whole
SHORT_CASES = [("ball", 1.0), ("spring-wall", 0.7), ("beam-impact", 0.4), ("falling-rod", None),
               ("newton-cradle", None), ("rocking-block", 0.5), ("slider-crank-clearance", 0.005),
               ("chain-impact", None)]
FAST_INTEGRATORS = ["hht", "genalpha", "ida", "moreau", "nsgenalpha"]


def _runs_of(case: str, integrators, t_end: float | None):
    """Every applicable integrator at its default step (or tolerance) and at half of it (a
    tenth): the run's status (a record that breaks the law makes it 'failed' with that
    message), skipping the integrators the case refuses before the first step."""
    from daebench.integrators.base import IntegratorError

    over = {} if t_end is None else {"t_end": t_end}
    for name in integrators:
        info = daebench.integrator_info(name)
        defaults = {s.name: s.default for s in info.settings}
        for k in (0, 1):
            opts = {"rtol": 1e-4 * 0.1 ** k} if name == "ida" else {"h": defaults.get("h", 1e-3) * 0.5 ** k}
            try:
                r = daebench.run(case, integrator=name, overrides=over, run_cap=120, **opts)
            except (daebench.ParamError, IntegratorError):
                break  # not applicable to this case
            yield name, opts, r


@pytest.mark.parametrize("case, t_end", SHORT_CASES)
def test_no_run_record_breaks_the_unilateral_law(case, t_end):
    broken = [(n, o, r.message) for n, o, r in _runs_of(case, FAST_INTEGRATORS, t_end)
              if "unilateral contact law" in r.message]
    assert broken == []


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(daebench.cases()["case"]))
def test_no_run_record_breaks_the_unilateral_law_whole_library(case):
    names = sorted(daebench.integrator_infos())
    broken = [(n, o, r.message) for n, o, r in _runs_of(case, names, None) if "unilateral contact law" in r.message]
    assert broken == []
