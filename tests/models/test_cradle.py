"""Newton's cradle (daebench.models.cradle): simultaneous impacts stated, not accidental.
The closed forms of the two impact laws (conservation checks), the event-capturing LCP
(moreau, nsgenalpha) giving the simultaneous Newton law exactly, and the event-driven driver (hht)
under its declared sequential law (the simultaneous one: tests/driver/test_friction_driven.py)."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.driver.simulate import simulate
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.cradle import sequential_outcome, simultaneous_outcome
from daebench.models.scenes import load_scene


def test_closed_forms_conserve_momentum_and_energy_at_e_1():
    """N = 3: (−1/3, 2/3, 2/3) v simultaneous, (0, 0, 1) v sequential; for N = 2 … 7 both
    conserve momentum and kinetic energy at e = 1; at e = 0 the simultaneous law moves
    the whole row at v/N (a plastic impact of N balls)."""
    assert np.allclose(simultaneous_outcome(3, 1.0, 1.0), [-1 / 3, 2 / 3, 2 / 3], atol=1e-14)
    assert np.allclose(sequential_outcome(3, 1.0), [0.0, 0.0, 1.0])
    for n in range(2, 8):
        for v in (simultaneous_outcome(n, 2.0, 1.0), sequential_outcome(n, 2.0)):
            assert v.sum() == pytest.approx(2.0) and (v @ v) == pytest.approx(4.0)
        assert np.allclose(simultaneous_outcome(n, 2.0, 0.0), 2.0 / n)


def _run(integrator: str, overrides: dict | None = None, **settings):
    sc = load_scene("newton-cradle", overrides or {})
    res = simulate(build_system(sc), get_integrator(integrator)(**settings), sc.t_end, sc["output.dt"])
    assert res.status == "completed", res.message
    return res


@pytest.mark.parametrize("integrator", ["moreau", pytest.param("nsgenalpha", marks=pytest.mark.slow)])
def test_capturing_schemes_apply_the_simultaneous_newton_law(integrator):
    """Both contacts of the row enter the step's contact problem together (moreau's LCP,
    nsgenalpha's index sets): the balls leave at (−1/3, 2/3, 2/3) m/s to round-off, both
    episodes start at the same step."""
    res = _run(integrator, h=1e-3)
    v = res.history[["v1", "v2", "v3"]].values[-1]
    assert np.allclose(v, simultaneous_outcome(3, 1.0, 1.0), atol=1e-10)
    starts = {i.contact: i.t for i in res.impacts}
    assert set(starts) == {0, 1} and starts[0] == starts[1]


@pytest.mark.slow
def test_event_driven_driver_resolves_the_row_sequentially():
    """hht through the event-driven driver with contact.impact_law = sequential: the impact
    map at contact 0, then at contact 1 (its gap closes with ġ < 0 right after): (0, 0, 1) m/s."""
    res = _run("hht", {"contact.impact_law": "sequential"}, h=1e-3)
    v = res.history[["v1", "v2", "v3"]].values[-1]
    assert np.allclose(v, sequential_outcome(3, 1.0), atol=1e-9)
    assert [i.contact for i in res.impacts[:2]] == [0, 1]
