"""The event-capturing family is held to the unilateral law's energy rule: with e ≤ 1 no
contact makes energy — at an impact step, or by the work of the contact impulses — and a
run where one does fails, naming where and how much (Newton's law with Coulomb friction
and e > 0 can make energy in a Moreau–Jean step: Glocker; Studer 2009)."""

from __future__ import annotations

import re

import numpy as np
import pytest

import daebench
from daebench.core import impact_checks
from daebench.core.contact import Impact

ROD = {"contact.restitution": 1.0, "contact.friction": 1.0, "start.omega": 20.0}


def _made(message: str) -> float:
    return float(re.search(r"the contact step made ([0-9.e+-]+) J", message).group(1))


@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_a_rod_whose_frictional_impact_makes_energy_fails_with_the_place_and_the_energy(integrator):
    """falling-rod, e = 1, μ = 1, ω₀ = 20 rad/s: the impact step raises E = T + V (no other
    force acts) by ~9.7 J; the run says so, at the impact time, with the jump the history shows."""
    r = daebench.run("falling-rod", integrator, h=1e-4, overrides=ROD)
    assert r.status == "failed" and "break the unilateral contact law" in r.message
    assert "t = 0.2462" in r.message and "contact 0" in r.message and "e = 1 ≤ 1" in r.message
    E = r.observables["E"].to_numpy()
    jump = float(np.max(E) - E[0])          # the history's own energy, from the model's terms
    assert jump > 9.0 and _made(r.message) == pytest.approx(jump, rel=1e-2)
    assert "the contact impulses did +" in r.message     # the booked contact work says the same


@pytest.mark.parametrize("integrator, overrides", [
    ("moreau", {}),                                                    # Housner's block: e = 0, μ = 1
    ("moreau", {"contact.restitution": 0.5, "contact.friction": 0.5}),
    ("nsgenalpha", {}),
])
def test_dissipative_contacts_complete_and_take_energy_out(integrator, overrides):
    r = daebench.run("rocking-block", integrator, h=1e-4, overrides=overrides)
    assert r.status == "completed", r.message
    E = r.observables["E"].to_numpy()
    # the contacts only take energy out; the steps of a resting contact let E drift (+2e-6 of E0 measured)
    assert E.max() <= E[0] * (1.0 + 1e-5) and E[-1] < 0.999 * E[0]


def test_the_contact_work_rule_names_the_largest_rise_above_the_running_minimum():
    book = impact_checks.ContactWork()
    for t, w in ((0.1, -1.0), (0.2, -3.0), (0.3, -2.5), (0.4, -2.9), (0.5, -1.0), (0.6, -4.0)):
        book.add(t, w)
    (line,) = book.violations(energy_scale=10.0, restitution=0.5)
    assert "t = 0.2 … 0.5 s" in line and "+2 J" in line and "e = 0.5 ≤ 1" in line
    assert book.violations(energy_scale=10.0, restitution=1.2) == []     # e > 1 may make energy
    quiet = impact_checks.ContactWork()
    for t, w in ((0.1, -1.0), (0.2, -1.0 + 1e-4)):    # a persistent contact's drift: 1e-5 of the scale
        quiet.add(t, w)
    assert quiet.violations(energy_scale=10.0, restitution=1.0) == []    # below the tolerance


def test_the_impact_step_rule_reads_capturing_episodes_only():
    made = Impact(0.25, 0, -9.8, 9.8, -9.7, impulse=9.0, impact_impulse=9.0)   # a capturing episode (no e)
    driver = Impact(0.25, 0, -9.8, 9.8, -9.7, impulse=9.0, impact_impulse=9.0, restitution=1.0)  # rule 4's
    assert len(impact_checks.capturing_violations([made, driver], 22.9, 1.0)) == 1
    assert impact_checks.capturing_violations([made], 22.9, None)        # no restitution: ≤ 1 by physics
    assert impact_checks.capturing_violations([made], 22.9, 1.5) == []
