"""The double-pendulum case: co-rotational links, revolute joints in the coordinates, the
published qualitative outcome, and the agreement of the event-driven and the
time-averaged-gap treatments.

Independent truth: rigid motions of either link about its joint store nothing (the
joints transmit no moment); energy conservation of the undamped free fall (E is a first
integral); agreement between two different contact treatments (event-driven IDA with the
impact map vs the source's force-level LCP inside Dormand–Prince), whose first contact
must agree to the averaging window h_avg (the LCP force starts h_avg/2 before contact
for a rigid approach, see test_lcp_avg.py).
"""

import math

import numpy as np
import pytest

import daebench
from daebench.models import build_system
from daebench.models.doublependulum import contact_outcome
from daebench.core.scene import SceneError
from daebench.models.scenes import load_scene

SMALL = {"links.elements": 4}


def test_coordinates_and_joints_transmit_no_moment():
    s = load_scene("double-pendulum", {**SMALL, "effects.gravity": False, "effects.damping": False})
    dp = build_system(s)
    assert dp.n == 6 * 4 + 2   # pivot: its rotation; 8 nodes × (x, y, θ); link 2's own joint rotation
    q0, v0 = dp.initial_state()
    assert np.max(np.abs(dp.applied_force(0.0, q0, v0))) == 0.0
    L = s["links.length"]
    for phi1, phi2 in ((0.7, -2.0), (-1.2, 3.5)):
        q = q0.copy()
        for a in range(1, 9):  # link 1 turned by phi1 about the pivot, link 2 by phi2 about the joint
            k = dp._trans[a]
            if a <= 4:
                r = a * L / 4
                q[k:k + 2] = (r * math.cos(phi1), r * math.sin(phi1))
            else:
                r = (a - 4) * L / 4
                q[k:k + 2] = (L * math.cos(phi1) + r * math.cos(phi2), L * math.sin(phi1) + r * math.sin(phi2))
        for i, name in enumerate(dp.coordinate_names):
            if name.startswith("th"):
                rid = int(name[2:])
                q[i] = phi2 if 4 < rid <= 8 or rid == 9 else phi1
        assert np.max(np.abs(dp.applied_force(0.0, q, np.zeros(dp.n)))) < 1e-6  # EA = 6.3e5 N
        assert dp.energy(q, np.zeros(dp.n))["elastic"] < 1e-18


def test_bad_scene_values_name_the_key():
    with pytest.raises(SceneError, match="damping.hs"):
        load_scene("double-pendulum", {"damping.hs": 0.0})
    with pytest.raises(SceneError, match="pivot.height"):
        build_system(load_scene("double-pendulum", {"pivot.height": 4.0}))


def test_free_fall_conserves_energy():
    """Undamped, before the first contact: E is a first integral; lcp-avg's forces are 0."""
    over = {**SMALL, "effects.damping": False, "contact.law": "complementarity", "t_end": 0.5,
            "output.dt": 1e-2}
    r = daebench.run("double-pendulum", integrator="lcp-avg", overrides=over, rtol=1e-8, atol=1e-10)
    assert r.status == "completed", r.message
    E0 = r.observables["E"].iloc[0]
    assert r.impacts == []
    assert r.energy_residual < 1e-7 * E0
    assert r.observables["E_kinetic"].iloc[-1] > 0.2 * E0  # it did fall


@pytest.fixture(scope="module")
def first_contact_runs():
    over = {**SMALL, "t_end": 0.85, "output.dt": 1e-3}
    ida = daebench.run("double-pendulum", integrator="ida", overrides=over, rtol=1e-6)
    avg = {h: daebench.run("double-pendulum", integrator="lcp-avg", overrides={**over, "contact.law": "complementarity"},
                           h_avg=h) for h in (1e-3, 1e-2)}
    return ida, avg


def test_first_contact_agrees_to_the_averaging_window(first_contact_runs):
    ida, avg = first_contact_runs
    assert ida.status == "completed", ida.message
    o_ida = contact_outcome(ida.observables, ida.impacts)
    print("ida", o_ida)
    assert o_ida.first_contact == pytest.approx(o_ida.episode_start, abs=1e-5)  # the impact time
    assert o_ida.rebound_speed == 0.0 and not o_ida.rebounds                  # e = 0: no rebound
    assert o_ida.approach_speed > 5.0
    for h, r in avg.items():
        assert r.status == "completed", r.message
        o = contact_outcome(r.observables, r.impacts)
        print(f"lcp-avg h_avg = {h:g}", o)
        assert abs(o.first_contact - o_ida.first_contact) < h
        assert o_ida.first_contact - h <= o.episode_start < o.first_contact   # the force starts early
        assert o.max_penetration < 0.1 * h * o.approach_speed                 # closed form: 0.0726 h v₀ (rigid)


def test_energy_balances_close(first_contact_runs):
    ida, avg = first_contact_runs
    E0 = ida.observables["E"].iloc[0]
    assert ida.observables["D_impacts"].iloc[-1] > 0.0  # the plastic impacts dissipated
    assert ida.energy_residual < 1e-5 * E0               # rtol 1e-6
    for r in avg.values():
        assert r.observables["W_contact"].iloc[-1] < 0.0
        assert r.energy_residual < 1e-4 * E0             # rtol 1e-4


@pytest.mark.slow
def test_the_published_outcome_with_both_treatments():
    """The whole case: no rebound, contact most of the time while the tip slides several
    metres, lift-off; the two treatments agree on every number."""
    ida = daebench.run("double-pendulum", integrator="ida", rtol=1e-6)
    avg = daebench.run("double-pendulum", integrator="lcp-avg", overrides={"contact.law": "complementarity"},
                       h_avg=1e-2)
    o1, o2 = (contact_outcome(r.observables, r.impacts) for r in (ida, avg))
    print(o1, o2, sep="\n")
    for o, r in ((o1, ida), (o2, avg)):
        assert r.status == "completed"
        assert not o.rebounds and o.contact_fraction > 0.6 and o.max_hop < 0.1
        assert abs(o.slide) > 3.0 and math.isfinite(o.lift_off)
    assert abs(o1.first_contact - o2.first_contact) < 1e-2
    assert o1.lift_off == pytest.approx(o2.lift_off, abs=1e-2)
    assert o1.slide == pytest.approx(o2.slide, rel=0.02)
    E0 = ida.observables["E"].iloc[0]
    assert ida.energy_residual < 1e-5 * E0 and avg.energy_residual < 1e-4 * E0
