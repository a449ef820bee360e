"""Granular chains (daebench.models.cradle; cases hertz-chain, tapered-chain): the compliant
chain (Hertz contacts integrated in time by IDA) and the LZB law through the event-driven
driver, checked against truth independent of both:

* Hertz's stiffness and the balls' masses, computed here from the formulas;
* two balls: Newton's law with the restitution e (cradle.two_ball_outcome; e = 1: the
  velocities exchanged), for the compliant contact as for LZB;
* conservation of momentum and energy by the compliant chain (no force from outside, no
  damping at e = 1);
* the compliant chain and LZB agree on the final velocities (LZB is the compliant chain's
  impact process with the configuration frozen: the tolerance below is that difference,
  measured, plus both solvers' errors).

Short flights (``start.gap`` 1 µm instead of 0.2 m) keep the default runs fast; the cases as
shipped run under ``-m slow``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core.lzb import NAME as LZB_NAME
from daebench.models import build_system
from daebench.models.cradle import final_velocities, two_ball_outcome
from daebench.models.scenes import load_scene
from _driver_runs import cached_run  # noqa: E402

SHORT = {"start.gap": 1e-6, "t_end": 1e-3, "output.dt": 1e-4}   # the wave has left by 0.31 ms
LZB = {"contact.law": "constraint", "contact.impact_law": "lzb"}
IDA = {"rtol": 1e-11, "atol": 1e-14}
#: compliant vs LZB final velocities [m/s]: measured 1.8e-8 (hertz-chain), 4e-8 (tapered) —
#: the rigid configuration of LZB against the compliant chain's gaps opening and closing again
#: during the wave — plus IDA's error at rtol 1e-11 (~1e-9) and LZB's at its default (~3e-9)
AGREEMENT = 1e-7


def run(case: str, overrides: dict, integrator: str, **settings):
    """(system, result) of a completed run through the driver."""
    res, system = cached_run(integrator, case, overrides, **settings)
    return system, res


def test_chain_scene_keys_give_hertz_stiffness_and_masses():
    """hertz-chain: K = (2/3) E/(1 − ν²) √(R/2) between equal balls, m = ρ (4/3)π R³;
    tapered-chain: R_i = 1 cm × 0.95^(i−1), K_i from R*_i; keys settable like every key."""
    s = build_system(load_scene("hertz-chain"))
    K = 2.0 / 3.0 * 203e9 / (1.0 - 0.09) * math.sqrt(0.005)
    assert np.allclose(s.contact_stiffness, K, rtol=1e-14) and s.contact_stiffness.size == 9
    assert np.allclose(s.masses, 7780.0 * 4.0 / 3.0 * math.pi * 0.01 ** 3, rtol=1e-14)
    assert s.contact_law.stiffness == pytest.approx(K) and np.all(s.data.scale == 1.0)
    t = build_system(load_scene("tapered-chain"))
    R = 0.01 * 0.95 ** np.arange(10)
    Rs = R[:-1] * R[1:] / (R[:-1] + R[1:])
    assert np.allclose(t.contact_stiffness, 2.0 / 3.0 * 203e9 / 0.91 * np.sqrt(Rs), rtol=1e-13)
    assert np.allclose(t.masses, 7780.0 * 4.0 / 3.0 * math.pi * R ** 3, rtol=1e-13)
    o = build_system(load_scene("hertz-chain", {"cradle.diameter": 0.04, "cradle.modulus": 100e9,
                                                "cradle.poisson": 0.25, "cradle.density": 2000.0,
                                                "start.speed": 2.0, "contact.hertz_stiffness": 1e9}))
    assert np.allclose(o.contact_stiffness, 1e9) and o.masses[0] == pytest.approx(2000.0 * 4 / 3 * math.pi * 0.02 ** 3)
    assert o.v0 == 2.0


def test_newton_cradle_scene_is_unchanged():
    """The three-ball cradle keeps its keys' values and its physics: equal 0.1 kg balls, the
    constraint law with the simultaneous Newton law, e = 1, gap 1 cm at 1 m/s."""
    sc = load_scene("newton-cradle")
    assert (sc["cradle.balls"], sc["cradle.mass"], sc["cradle.diameter"], sc["cradle.ratio"],
            sc["cradle.density"]) == (3, 0.1, 0.05, 1.0, 0.0)
    assert (sc["contact.law"], sc["contact.impact_law"], sc["contact.restitution"]) == ("constraint",
                                                                                         "simultaneous", 1.0)
    s = build_system(sc)
    assert np.array_equal(s.masses, [0.1, 0.1, 0.1]) and np.array_equal(s.data.scale, [1.0, 1.0])
    q, v = s.initial_state()
    assert np.allclose(s.gap(q), [0.01, 0.0]) and np.array_equal(v, [1.0, 0.0, 0.0])


@pytest.mark.parametrize("law, e", [("compliant", 1.0), ("lzb", 1.0), ("lzb", 0.5)])
def test_two_balls_follow_newtons_law(law, e):
    """Two steel balls: the compliant contact (e = 1, undamped; IDA) and LZB (hht through the
    driver) exchange the velocities; LZB at e = 0.5 gives Newton's law with e. To 1e-8 of
    the striker's speed (LZB's default accuracy; IDA at rtol 1e-11)."""
    over = {**SHORT, "cradle.balls": 2, "contact.restitution": e, **({} if law == "compliant" else LZB)}
    system, res = run("hertz-chain", over, "ida", **IDA) if law == "compliant" else \
        run("hertz-chain", over, "hht", h=1e-4)
    m = system.masses[0]
    assert np.abs(final_velocities(res.history) - two_ball_outcome(m, m, 1.0, 0.0, e)).max() < 1e-8


def test_hertz_chain_conserves_and_lzb_reproduces_its_wave():
    """Ten balls, compliant (IDA, rtol 1e-11): momentum and energy conserved to 1e-9 at the
    end; the last ball leaves faster than 0.98 m/s, the striker recoils. LZB through the
    driver (hht): the same final velocities to AGREEMENT, momentum exactly, all nine
    contacts' impacts at one instant, positive impulses, the law named in the record."""
    system, comp = run("hertz-chain", SHORT, "ida", **IDA)
    v = final_velocities(comp.history)
    p0, E0 = system.masses[0] * 1.0, 0.5 * system.masses[0]
    assert abs(system.momentum(v) - p0) < 1e-9 * p0
    assert abs(comp.history.E.values[-1] - E0) < 1e-9 * E0
    assert v[-1] > 0.98 and v[0] < 0.0
    assert len(comp.impacts) == 9 and max(i.t_end for i in comp.impacts) < SHORT["t_end"]
    _, lzb = run("hertz-chain", {**SHORT, **LZB}, "hht", h=1e-4)
    w = final_velocities(lzb.history)
    assert np.abs(w - v).max() < AGREEMENT
    assert abs(system.momentum(w) - p0) < 1e-15
    assert lzb.impact_law == LZB_NAME
    assert sorted(i.contact for i in lzb.impacts) == list(range(9)) and len({i.t for i in lzb.impacts}) == 1
    assert all(i.impulse > 0.0 for i in lzb.impacts)


def test_tapered_chain_lzb_agrees_with_the_compliant_chain():
    """Radii falling 5 % per ball: the last ball leaves faster than the striker came; LZB
    and the compliant chain agree to AGREEMENT (each contact's own K_i in both)."""
    system, comp = run("tapered-chain", SHORT, "ida", **IDA)
    _, lzb = run("tapered-chain", {**SHORT, **LZB}, "hht", h=1e-4)
    v, w = final_velocities(comp.history), final_velocities(lzb.history)
    assert v[-1] > 1.8 and np.abs(w - v).max() < AGREEMENT
    assert abs(system.momentum(v) - system.masses[0]) < 1e-9 * system.masses[0]


def test_hundred_ball_chain_runs_with_lzb_and_records_every_ball():
    """N = 100 under LZB: x1 … x100 and v1 … v100 in the history, the momentum kept, the
    solitary wave's last ball faster than 0.98 m/s."""
    obs = [f"v{i}" for i in range(1, 101)] + [f"x{i}" for i in range(1, 101)]
    system, res = run("hertz-chain", {**SHORT, **LZB, "cradle.balls": 100, "output.observables": ",".join(obs)},
                      "hht", h=1e-4)
    assert set(obs) <= set(res.history.columns)
    w = final_velocities(res.history)
    assert w.size == 100 and w[-1] > 0.98 and abs(system.momentum(w) - system.masses[0]) < 1e-15


@pytest.mark.slow
@pytest.mark.parametrize("case", ["hertz-chain", "tapered-chain"])
def test_shipped_chain_cases_compliant_and_lzb(case):
    """The cases as shipped (striker 0.2 m away): the compliant chain conserves momentum and
    energy to 1e-9 at t_end (IDA, rtol 1e-11); LZB agrees on the final velocities."""
    system, comp = run(case, {}, "ida", **IDA)
    v = final_velocities(comp.history)
    p0, E0 = system.masses[0], 0.5 * system.masses[0]
    assert abs(system.momentum(v) - p0) < 1e-9 * p0 and abs(comp.history.E.values[-1] - E0) < 1e-9 * E0
    _, lzb = run(case, LZB, "hht", h=1e-3)
    assert np.abs(final_velocities(lzb.history) - v).max() < AGREEMENT
