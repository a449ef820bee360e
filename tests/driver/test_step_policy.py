"""The run's step rules (daebench.driver.step_policy): what the driver derives from the
free and contact steps, and that it takes its steps from the policy, not the integrator."""

from __future__ import annotations

import pytest

from daebench.driver.simulate import simulate
from daebench.driver.step_policy import StepPolicy
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.stepping.watch import NEAR_STEPS


def test_the_steps_a_phase_starts_with():
    p = StepPolicy(1e-4, 1e-6)
    assert p.start_step(False) == 1e-4 and p.start_step(True) == 1e-6
    assert p.start_step(True, halvings=3) == 1e-6 / 8
    assert p.near_h == NEAR_STEPS * 1e-4
    assert p.zeno_step(1e-6) == 1e-6 and StepPolicy(1e-4, adaptive=True).zeno_step(1e-6) == 0.0


def test_without_a_smaller_contact_step_there_is_no_proximity_rule():
    assert StepPolicy(1e-4).h_contact == 1e-4 and StepPolicy(1e-4).near_h == 0.0
    assert StepPolicy(1e-4, 1e-3).near_h == 0.0 and StepPolicy(1e-4, 1e-3).start_step(True) == 1e-3


def test_an_integrators_settings_make_its_policy():
    integ = get_integrator("hht")(h=2e-4, h_contact=1e-6)
    assert StepPolicy.of(integ) == StepPolicy(2e-4, 1e-6, False)
    assert StepPolicy.of(get_integrator("hht")(h=2e-4)) == StepPolicy(2e-4, 2e-4, False)
    assert StepPolicy.of(get_integrator("hht")(h=2e-4, adaptive=True)).adaptive


@pytest.mark.parametrize("h, h_contact", [(0.0, None), (1e-3, 0.0), (-1.0, 1e-3)])
def test_a_policy_without_positive_steps_is_refused(h, h_contact):
    with pytest.raises(ValueError, match="steps > 0"):
        StepPolicy(h, h_contact)


def test_the_driver_steps_as_the_policy_says_not_as_the_integrator_was_set():
    scene = load_scene("pendulum").with_overrides({"t_end": 0.1})
    system = build_system(scene)
    runs = {}
    for policy in (None, StepPolicy(5e-4)):
        integ = get_integrator("hht")(h=1e-3)
        runs[policy] = simulate(system, integ, scene.t_end, 0.01, policy=policy)
    assert runs[None].counters["steps"] == 100
    assert runs[StepPolicy(5e-4)].counters["steps"] == 200
