"""The source's time-averaged-gap LCP scheme (integrator lcp-avg).

Independent truth:
* the closed form of the scheme for one rigid contact (the integrator's docstring):
  the gap obeys g̈ + (3/h)ġ + (6/h²)g = 0 while the force acts; its switch-on, duration,
  peak force, deepest penetration and rebound follow from the solution of that linear
  ODE, evaluated here with scipy root finders and compared with the quoted constants
  and with runs (a beam element translating rigidly onto the foundation at v₀ = 1 m/s:
  each node is one rigid contact of its lumped mass);
* momentum and energy of the collision: impulse m (1 + e) v₀, energy lost ½ m v₀² (1 − e²).
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

import daebench
from daebench.integrators.base import IntegratorError
from daebench.integrators.lcp_avg import LcpAvg, contact_forces
from daebench.models.corotational import Frame
from daebench.core.problem import Problem
from daebench.driver.simulate import simulate
from daebench.core.system import State

V0 = 1.0


def closed_form(h: float = 1.0, v0: float = 1.0) -> dict[str, float]:
    """Switch-on gap, duration, peak force (per unit mass), deepest gap and restitution of the
    scheme for a rigid mass meeting rigid ground at v0 (see LcpAvg's docstring)."""
    wn = math.sqrt(6.0) / h
    zeta = math.sqrt(6.0) / 4.0
    wd = wn * math.sqrt(1.0 - zeta**2)
    g0, gd0 = h * v0 / 2.0, -v0
    B = (gd0 + zeta * wn * g0) / wd

    def g(t):
        return math.exp(-zeta * wn * t) * (g0 * math.cos(wd * t) + B * math.sin(wd * t))

    def gd(t):
        e = math.exp(-zeta * wn * t)
        return e * (-zeta * wn * (g0 * math.cos(wd * t) + B * math.sin(wd * t))
                    + wd * (-g0 * math.sin(wd * t) + B * math.cos(wd * t)))

    def force(t):  # f/m = −(6/h²)(g + (h/2)ġ)
        return -(6.0 / h**2) * (g(t) + 0.5 * h * gd(t))

    t_off = brentq(force, 0.2 * h, 3.0 * h, xtol=1e-15 * h)   # f > 0 on (0, t_off)
    peak = -minimize_scalar(lambda t: -force(t), bounds=(0.0, t_off), method="bounded",
                            options={"xatol": 1e-12 * h}).fun
    t_min = brentq(gd, 0.0, t_off, xtol=1e-15 * h)
    return {"switch_on": g0, "duration": t_off, "peak": peak, "min_gap": g(t_min), "e": gd(t_off) / v0}


def test_closed_form_gives_the_quoted_constants():
    cf = closed_form()
    assert cf["switch_on"] == 0.5
    assert cf["duration"] == pytest.approx(1.622, abs=5e-4)
    assert cf["peak"] == pytest.approx(1.209, abs=5e-4)
    assert cf["min_gap"] == pytest.approx(-0.0726, abs=5e-5)
    assert cf["e"] == pytest.approx(0.0877, abs=5e-5)


class FallingElement(Frame):
    def initial_state(self):
        q, v = super().initial_state()
        v[[1, 4]] = -V0  # both nodes' y
        return q, v


def falling_element(h_avg: float) -> tuple[Frame, float]:
    """One beam element, both nodes contact points, translating rigidly towards the foundation
    at v₀ (no gravity): lumped mass and node gaps make the LCP diagonal, so each node is the
    rigid single contact of the closed form with m = its lumped mass (the element stays
    unstrained: both nodes feel the same force history). Returns the system and m."""
    rhoA = 1.0
    fr = FallingElement(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0, 1]]), 1e6, 1e3, rhoA, 1e-6,
                        contact_nodes=(0, 1), h0=2.0 * h_avg * V0)
    return fr, 0.5 * rhoA


@pytest.mark.parametrize("h_avg", [1e-3, 4e-3])
def test_one_rigid_contact_matches_the_closed_form(h_avg):
    """Every quantity to 1 % of the closed form (both nodes)."""
    cf = closed_form(h_avg, V0)
    fr, m = falling_element(h_avg)
    integ = LcpAvg(h_avg=h_avg, rtol=1e-10, atol=1e-13, h=h_avg / 100.0)
    r = simulate(fr, integ, 5.0 * h_avg, h_avg / 1000.0)
    assert r.status == "completed", r.message
    assert sorted(e.contact for e in r.impacts) == [0, 1]
    p = Problem(fr)
    hist = r.history
    for ep in r.impacts:
        on_gap = 2.0 * h_avg * V0 - V0 * ep.t
        e = ep.vn_plus / -ep.vn_minus
        measured = {"switch_on": on_gap, "duration": ep.t_end - ep.t, "min_gap": ep.min_gap, "e": e,
                    "peak": peak_force(integ, p, ep.contact) / m}
        print(f"h_avg = {h_avg:g}, node {ep.contact}:", {k: (measured[k], cf[k]) for k in cf})
        for k in cf:
            assert measured[k] == pytest.approx(cf[k], rel=0.01), k
        assert ep.vn_minus == pytest.approx(-V0, rel=1e-12)
        assert ep.impulse == pytest.approx(m * (1.0 + e) * V0, rel=1e-6)
        assert ep.energy_loss == pytest.approx(0.5 * m * V0**2 * (1.0 - e * e), rel=1e-6)
    assert hist["E_elastic"].max() < 1e-20 * hist["E"].iloc[0]
    # the contact work booked by the driver closes the energy balance once the episodes are over
    after = hist["t"] > max(ep.t_end for ep in r.impacts) + 0.1 * h_avg
    assert np.max(np.abs(hist["energy_residual"][after])) < 1e-9 * hist["E"].iloc[0]
    assert hist["W_contact"].iloc[-1] == pytest.approx(-sum(ep.energy_loss for ep in r.impacts), rel=1e-9)


def peak_force(integ: LcpAvg, p: Problem, contact: int) -> float:
    """The largest force the scheme applied at the accepted steps' states: re-run the stepping
    by hand from the start and evaluate the force at every step end."""
    q, v = p.system.initial_state()
    fresh = LcpAvg(**integ.settings)
    a, lam = p.acceleration(0.0, q, v)
    fresh.start(p, State(0.0, q, v, a, lam), integ.settings["h"])
    best = 0.0
    h_avg = integ.settings["h_avg"]
    while fresh.state.t < 5.0 * h_avg * (1.0 - 1e-12):
        s = fresh.step(5.0 * h_avg)
        best = max(best, float(contact_forces(p, h_avg, s.t, s.q, s.v)[contact]))
    return best


def test_lcp_avg_refuses_what_it_cannot_treat():
    with pytest.raises(IntegratorError, match="resolves contacts itself"):
        daebench.run("chain-impact", integrator="lcp-avg", overrides={"t_end": 1e-3})  # Hertz law
    with pytest.raises(IntegratorError):
        daebench.run("pendulum", integrator="lcp-avg", overrides={"t_end": 1e-3})     # no contacts
