"""The driver's impact laws as objects, each against a closed form.

Three equal unit balls in a row touching (gaps g₀ = x₁ − x₀, g₁ = x₂ − x₁ both 0), the
first arriving at 1 m/s, e = 1: Newton's law on both contacts at once gives
(−1/3, 2/3, 2/3) m/s (the simultaneous LCP's textbook answer; energy and momentum kept);
on the impacting contact alone the equal masses exchange velocities, (0, 1, 0) m/s, and
the second contact's impact is the next event. A closed contact is held by the
sequential law (its row joins the bilateral ones) and takes part in the simultaneous one.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core.contact import IMPACT_LAWS
from daebench.driver.impact_laws import LAWS

M = np.eye(3)
GQ = np.array([[-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]])
V = np.array([1.0, 0.0, 0.0])
G = np.zeros(2)
NO_ROWS = np.zeros((0, 3))


def _impact(key: str, active: list[int] = ()):
    law = LAWS[key]
    part, held = law.participants(0, G, GQ, V, list(active), set(), False, NO_ROWS)
    res = law.solve(None, part, M, GQ[part], np.zeros_like(GQ[part]), np.zeros(len(part)), V,
                    np.ones(len(part)), held, 0.0, 0)
    return part, held, res


def test_simultaneous_newton_gives_the_cradles_textbook_split():
    part, held, res = _impact("simultaneous")
    assert part == [0, 1] and held.shape == (0, 3)
    assert np.allclose(res.v_plus, [-1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0], atol=1e-12)
    assert res.energy_loss == pytest.approx(0.0, abs=1e-12)
    assert res.v_plus.sum() == pytest.approx(1.0, abs=1e-12)


def test_sequential_newton_exchanges_the_velocities_of_the_impacting_pair():
    part, held, res = _impact("sequential")
    assert part == [0] and held.shape == (0, 3)
    assert np.allclose(res.v_plus, [0.0, 1.0, 0.0], atol=1e-12)


def test_a_closed_contact_is_held_by_the_sequential_law_and_joins_the_simultaneous_one():
    part, held, res = _impact("sequential", active=[1])
    assert part == [0] and np.array_equal(held, GQ[[1]])
    # balls 1 and 2 move as one body of mass 2: (1 − 2)/(1 + 2) and 2/(1 + 2)
    assert np.allclose(res.v_plus, [-1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0], atol=1e-12)
    assert _impact("simultaneous", active=[1])[0] == [0, 1]


def test_a_separating_contact_off_its_surface_takes_no_part():
    law = LAWS["simultaneous"]
    part, _ = law.participants(0, np.array([0.0, 1e-3]), GQ, V, [], set(), False, NO_ROWS)
    assert part == [0]


def test_each_law_names_itself_and_what_its_records_carry():
    mu0 = np.zeros(2)
    assert LAWS["simultaneous"].name(mu0).endswith(", simultaneous")
    assert LAWS["sequential"].name(mu0).endswith(", sequential")
    assert LAWS["simultaneous"].record == LAWS["sequential"].record == "newton"
    assert LAWS["lzb"].record == "lzb" and math.isnan(LAWS["lzb"].restitution(0.5))
    assert LAWS["simultaneous"].zeno_rules and not LAWS["lzb"].zeno_rules
    assert set(LAWS) == set(IMPACT_LAWS)          # every choice the scene offers is a law here


def test_lzb_without_a_contact_stiffness_is_refused_by_name():
    class Rigid:
        pass
    with pytest.raises(ValueError, match="contact_stiffness"):
        LAWS["lzb"].solve(Rigid(), [0, 1], M, GQ, np.zeros_like(GQ), np.zeros(2), V, np.ones(2), NO_ROWS, 0.0, 0)

