"""The driver's contact state as a value (daebench.driver.contact_state.ContactState): the event
functions locate and apply an impact from it and the phase's Problem alone, against the
exact free fall of a ball onto the ground."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core.problem import Problem
from daebench.core.system import State
from daebench.driver.contact_state import ContactState, Event, EventKind
from daebench.driver.events import find_event
from daebench.driver.transitions import apply_event
from daebench.models import build_system
from daebench.models.scenes import load_scene

G = 9.81


def fall(t: float) -> State:
    """Exact free fall from x = 1 m at rest."""
    return State(t, np.array([1.0 - 0.5 * G * t * t]), np.array([-G * t]))


def ball(e: float):
    system = build_system(load_scene("ball", {"contact.restitution": e, "gravity.g": G}))
    problem = Problem(system)
    return system, problem, ContactState.start(problem, fall(0.0).q, constraint=True, continuous=False)


@pytest.mark.parametrize("e", [0.8, 0.0])
def test_impact_located_and_applied_from_the_state_value(e):
    system, problem, cs = ball(e)
    assert cs.armed.tolist() == [True] and cs.active == [] and not cs.in_contact
    t_hit = math.sqrt(2.0 / G)
    ev = find_event(cs, fall(0.4), fall(0.5), problem, fall)
    assert ev.kind is EventKind.CLOSE and ev.contact == 0 and ev.t == pytest.approx(t_hit, abs=1e-12)
    after = apply_event(cs, ev, fall(ev.t), problem, 0.0)
    v_minus = G * t_hit
    assert after.v[0] == pytest.approx(e * v_minus, rel=1e-9)
    (imp,) = cs.impacts
    assert imp.vn_minus == pytest.approx(-v_minus, rel=1e-9)
    assert cs.d_impacts == pytest.approx(0.5 * (1.0 - e * e) * v_minus ** 2, rel=1e-9)  # m = 1 kg
    # e = 0: the contact stays closed and the next phase has it as a constraint
    assert cs.active == ([] if e > 0.0 else [0])
    assert cs.phase(system).active == tuple(cs.active)
    assert not cs.armed[0]


def test_release_reads_the_consistent_force_not_the_integrators_multiplier():
    """A ball closed on the ground (e = 0) under gravity: its consistent contact force is
    m g > 0 at every state on the ground, so no step opens it, whatever multiplier the
    integrator's step returned (here −1 N: what an index-3 step's position correction can
    produce); the open event of the old rule (λ of the step turning negative) must not come."""
    system, problem, cs = ball(0.0)
    apply_event(cs, Event(0.45, EventKind.CLOSE, 0), fall(0.45), problem, 0.0)
    assert cs.active == [0]
    closed = cs.phase(system)
    rest = lambda t, lam: State(t, np.zeros(1), np.zeros(1), np.zeros(1), np.array([lam]))
    ev = find_event(cs, rest(0.5, 1.0), rest(0.6, -1.0), closed, lambda t: rest(t, 1.0 - 20.0 * (t - 0.5)))
    assert ev is None and cs.active == [0]


def test_states_are_independent_values():
    _, problem, a = ball(0.8)
    _, _, b = ball(0.8)
    find_event(a, fall(0.4), fall(0.5), problem, fall)
    apply_event(a, Event(math.sqrt(2.0 / G), EventKind.CLOSE, 0), fall(math.sqrt(2.0 / G)), problem, 0.0)
    assert len(a.impacts) == 1 and b.impacts == [] and b.armed[0]
