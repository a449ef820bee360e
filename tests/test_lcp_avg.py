"""The source's time-averaged-gap LCP scheme (integrator lcp-avg).

Independent truth:
* the closed form of the scheme for one rigid contact (the integrator's docstring):
  the gap obeys g̈ + (3/h)ġ + (6/h²)g = 0 while the force acts; its switch-on, duration,
  peak force, deepest penetration and rebound follow from the solution of that linear
  ODE, evaluated here with scipy root finders and compared with the quoted constants
  and with runs (two free 1-kg masses of the chain: m_eff = 0.5 kg, v₀ = 1 m/s);
* momentum and energy of a two-body collision: impulse m_eff (1 + e) v₀, energy lost
  ½ m_eff v₀² (1 − e²).
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

import daebench
from daebench.integrators.base import IntegratorError
from daebench.integrators.lcp_avg import contact_forces
from daebench.models import build_system
from daebench.problem import Problem

V0 = 1.0
M_EFF = 0.5   # two free 1-kg masses
PAIR = {"chain.stiffness": 0.0, "chain.velocity": V0, "contact.law": "complementarity"}


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


@pytest.mark.parametrize("h_avg", [1e-3, 4e-3])
def test_one_rigid_contact_matches_the_closed_form(h_avg):
    """Two free masses meet at v₀ = 1 m/s; every quantity to 1 % of the closed form."""
    cf = closed_form(h_avg, V0)
    pull = 2.0 * h_avg
    t_end = pull / V0 + 3.0 * h_avg
    over = {**PAIR, "chain.pull": pull, "t_end": t_end, "output.dt": h_avg / 1000.0}
    r = daebench.run("chain-impact", integrator="lcp-avg", overrides=over, h_avg=h_avg, rtol=1e-10, atol=1e-13,
                     h=h_avg / 100.0)
    assert r.status == "completed", r.message
    assert len(r.impacts) == 1
    ep = r.impacts[0]
    on_gap = pull - V0 * ep["t"]                       # m3 approaches the resting m4 at v₀
    e = ep["vn_plus"] / -ep["vn_minus"]
    system = build_system(r.scene)
    p = Problem(system)
    f = np.array([contact_forces(p, h_avg, t, q, v)[0] for t, q, v in zip(r.t, r.q, r.v)])
    measured = {"switch_on": on_gap, "duration": ep["t_end"] - ep["t"], "peak": f.max() / M_EFF,
                "min_gap": ep["min_gap"], "e": e}
    print(f"h_avg = {h_avg:g}:", {k: (measured[k], cf[k]) for k in cf})
    for k in cf:
        assert measured[k] == pytest.approx(cf[k], rel=0.01), k
    assert f.min() >= 0.0
    assert ep["vn_minus"] == pytest.approx(-V0, rel=1e-12)
    assert ep["impulse"] == pytest.approx(M_EFF * (1.0 + e) * V0, rel=1e-6)
    assert ep["energy_loss"] == pytest.approx(0.5 * M_EFF * V0**2 * (1.0 - e * e), rel=1e-6)
    # the contact work booked by the driver closes the energy balance once the episode is over
    hist = r.observables
    after = hist["t"] > ep["t_end"] + 0.1 * h_avg  # past the step in which the episode ended
    assert np.max(np.abs(hist["energy_residual"][after])) < 1e-9 * 0.5 * M_EFF * V0**2
    assert hist["W_contact"].iloc[-1] == pytest.approx(-ep["energy_loss"], rel=1e-9)


def test_lcp_avg_refuses_what_it_cannot_treat():
    with pytest.raises(IntegratorError, match="resolves contacts itself"):
        daebench.run("chain-impact", integrator="lcp-avg", overrides={"t_end": 1e-3})  # Hertz law
    with pytest.raises(IntegratorError):
        daebench.run("pendulum", integrator="lcp-avg", overrides={"t_end": 1e-3})     # no contacts
