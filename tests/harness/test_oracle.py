"""The exact impact oracle (daebench.harness.scoring.oracle) against closed forms: a ball
(Λ = (1 + e) m |v⁻|), two masses joined by a bilateral constraint (the joined mass takes
the impulse), a wrong restitution (relative jump error known exactly), and runs: the
event-driven driver's impacts reproduce the oracle to round-off, a Moreau–Jean step's
velocity jump is Newton's at velocity level (exact on the ball) while its impulse carries
the step's weight m g h on top of the impact's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.core.contact import Impact
from daebench.core.params import ParamError
from daebench.driver.simulate import simulate
from daebench.harness.scoring import oracle
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.scenes import load_scene

E = 0.8


def ball_system():
    return build_system(load_scene("ball", {}))


def test_ball_closed_form():
    """v⁺ = −e v⁻, Λ = (1 + e) m |v⁻| for the ball (m = 1 kg)."""
    res = oracle.exact_impact(ball_system(), np.array([0.0]), np.array([-4.0]), 0, E)
    assert res.v_plus[0] == pytest.approx(3.2, rel=1e-14)
    assert res.impulse[0] == pytest.approx(7.2, rel=1e-14)


class Joined:
    """Two masses on a line joined by x1 − x2 = 0; contact point on mass 1 (gap x1)."""

    contact_law = None

    def __init__(self, m1: float, m2: float):
        self.M = np.diag([m1, m2])

    def mass(self, q):
        return self.M

    def gap_jacobian(self, q):
        return np.array([[1.0, 0.0]])

    def constraint_jacobian(self, t, q):
        return np.array([[1.0, -1.0]])


def test_bilateral_constraint_carries_the_joined_mass():
    """Λ = (1 + e)(m1 + m2)|v⁻| and both masses rebound at −e v⁻."""
    res = oracle.exact_impact(Joined(1.0, 3.0), np.zeros(2), np.array([-2.0, -2.0]), 0, 0.5)
    assert res.impulse[0] == pytest.approx(1.5 * 4.0 * 2.0, rel=1e-13)
    assert np.allclose(res.v_plus, [1.0, 1.0], rtol=1e-13)


def test_scores_of_synthetic_records():
    """A record that rebounds with e = 0.5 where the law says 0.8: |Δv| 1.5|v⁻| against 1.8|v⁻|,
    relative error 1/6, impulse error 0.3 m|v⁻|. A record moving away (ġ⁻ > 0) and one
    without state are skipped; the first record's error is reported as err_impact1_dv."""
    sys_ = ball_system()
    good = Impact(0.45, 0, -4.0, 3.2, 0.0, impulse=7.2, q=np.zeros(1), v_minus=np.array([-4.0]),
                  v_plus=np.array([3.2]))
    soft = Impact(1.0, 0, -3.0, 1.5, 0.0, impulse=4.5, q=np.zeros(1), v_minus=np.array([-3.0]),
                  v_plus=np.array([1.5]))
    away = Impact(1.5, 0, 1.0, 1.0, 0.0, impulse=0.0, q=np.zeros(1), v_minus=np.array([1.0]),
                  v_plus=np.array([1.0]))
    bare = Impact(2.0, 0, -1.0, 0.8, 0.0)
    s = oracle.oracle_scores(sys_, [good, soft, away, bare], E)
    assert s["err_impact_dv_max"] == pytest.approx(1.0 / 6.0, rel=1e-13)
    assert s["err_impulse_max"] == pytest.approx(0.3 * 3.0, rel=1e-13)
    assert s["err_impulse_rel_max"] == pytest.approx(1.0 / 6.0, rel=1e-13)
    assert s["err_impact1_dv"] == pytest.approx(0.0, abs=1e-15)
    assert (s["oracle_impacts"], s["oracle_skipped"]) == (2, 2)
    # the episode's first-step impulse wins over the episode's sum
    ep = Impact(0.45, 0, -4.0, 3.2, 0.0, impulse=100.0, impact_impulse=7.2, q=np.zeros(1),
                v_minus=np.array([-4.0]), v_plus=np.array([3.2]))
    assert oracle.oracle_scores(sys_, [ep], E)["err_impulse_max"] == pytest.approx(0.0, abs=1e-14)
    none = oracle.oracle_scores(sys_, [bare], E)
    assert math.isnan(none["err_impact_dv_max"]) and none["oracle_skipped"] == 1


def test_bad_input_is_refused():
    with pytest.raises(ParamError, match="restitution"):
        oracle.exact_impact(ball_system(), np.zeros(1), np.array([-1.0]), 0, 1.5)
    with pytest.raises(ParamError, match="contact 3"):
        oracle.exact_impact(ball_system(), np.zeros(1), np.array([-1.0]), 3, E)
    with pytest.raises(ParamError, match="finite"):
        oracle.exact_impact(ball_system(), np.array([math.nan]), np.array([-1.0]), 0, E)


def _ball_run(integrator: str, **settings):
    sc = load_scene("ball", {"t_end": 1.3})            # two impacts (0.4515 s, 1.1740 s)
    system = build_system(sc)
    res = simulate(system, get_integrator(integrator)(**settings), sc.t_end, sc["output.dt"])
    assert res.status == "completed", res.message
    return system, res


def test_event_driven_impacts_are_the_oracle():
    """The driver applies the same impact map at the located impact: round-off."""
    system, res = _ball_run("hht", h=1e-3)
    s = oracle.oracle_scores(system, res.impacts, E)
    assert s["oracle_impacts"] == 2
    assert s["err_impact_dv_max"] < 1e-13 and s["err_impulse_rel_max"] < 1e-13


@pytest.mark.parametrize("h", [1e-3, 5e-4])
def test_moreau_jump_exact_impulse_carries_the_step_weight(h):
    """Moreau–Jean imposes ġ⁺ = −e ġ⁻ on the step's velocities: on the ball (one linear
    coordinate) the velocity jump is the exact law's to round-off; the step's percussion is
    m(v⁺ − v⁻) + m g h, so the impulse error is m g h exactly (first order in h)."""
    system, res = _ball_run("moreau", h=h)
    s = oracle.oracle_scores(system, res.impacts, E)
    assert s["oracle_impacts"] == 2
    assert s["err_impact_dv_max"] < 1e-12
    assert s["err_impulse_max"] == pytest.approx(1.0 * 9.81 * h, rel=1e-9)


def test_pipeline_measure():
    """The measure of the scoring pipeline reads the system's restitution (contact_restitution)."""
    from types import SimpleNamespace
    sys_ = ball_system()
    rec = Impact(0.45, 0, -4.0, 2.0, 0.0, impulse=6.0, q=np.zeros(1), v_minus=np.array([-4.0]),
                 v_plus=np.array([2.0]))                                    # e = 0.5 where the scene says 0.8
    s = oracle.measure(SimpleNamespace(system=sys_, impacts=[rec]), None)
    assert s["err_impact_dv_max"] == pytest.approx(1.2 / 7.2, rel=1e-12)
    assert s["err_impulse_max"] == pytest.approx(1.2, rel=1e-12)
