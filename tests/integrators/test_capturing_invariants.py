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
    """The energy the first broken impact made, as either form of the rule states it."""
    return float(re.search(r"(?:the contact step|the impact's impulses) made ([0-9.e+-]+) J", message).group(1))


def _fractions(message: str) -> list[float]:
    return [float(x) for x in re.findall(r"J of energy, ([0-9.e+-]+) of P\|U⁻\|", message)]


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


def test_moreau_on_housners_block_with_e_1_and_friction_fails_where_the_law_makes_energy():
    """rocking-block, e = 1, μ = 1: Newton's law with Coulomb friction makes energy at the
    corner impacts of a Moreau–Jean step. The history's own energy (the model's terms) rises,
    and the share of P|U⁻| each impact makes is the same at two steps — the law's, not a
    discretization error, which would shrink with h."""
    over = {"contact.restitution": 1.0, "contact.friction": 1.0}
    runs = [daebench.run("rocking-block", "moreau", h=h, overrides=over) for h in (1e-4, 4e-5)]
    for r in runs:
        assert r.status == "failed" and "the impact's impulses made" in r.message
        assert "lower contact.restitution or contact.friction" in r.message
        E = r.observables["E"].to_numpy()
        assert float(np.max(E) - E[0]) > 1e-4      # 2.3e-4 J measured: the energy made is real
    top = [max(_fractions(r.message)) for r in runs]
    assert 1e-4 < top[0] < 1e-3 and top[1] == pytest.approx(top[0], rel=0.02)   # 4.48e-4, 4.46e-4 measured


def test_moreau_on_a_frictionless_block_with_e_1_makes_no_energy_at_its_impacts():
    """e = 1, μ = 0: the impulses' work at an impact step is zero to round-off (≤ 2.2e-16
    P|U⁻| measured), so the rule holds with no band for the scheme."""
    r = daebench.run("rocking-block", "moreau", h=1e-4, overrides={"contact.restitution": 1.0,
                                                                   "contact.friction": 0.0})
    assert r.status == "completed", r.message


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


def test_the_impact_work_rule_holds_the_impacts_own_work_to_round_off():
    """With the impact's own work booked (Moreau–Jean), a gain of 1e-6 P|U⁻| on an
    approaching contact fails; the same work on a contact its index set holds shut while it
    separates (U⁻ > 0) is no impact; the step's energy band does not apply."""
    def ep(work, u):
        return Impact(0.3, 1, -0.13, np.nan, -1.0, impulse=0.25, impact_impulse=0.25, impact_work=work, u_law=u)
    (line,) = impact_checks.capturing_violations([ep(1e-6 * 0.25 * 0.13, -0.13)], 5.0, 1.0)
    assert "made 3.25e-08 J" in line and "1e-06 of P|U⁻|" in line
    assert impact_checks.capturing_violations([ep(2.6e-5, +0.01)], 5.0, 0.1) == []
    assert impact_checks.capturing_violations([ep(-0.01, -0.13)], 5.0, 1.0) == []   # a loss
