"""daebench.workflows.verify_cases: which smooth case with an exact solution `daebench verify`
runs an integrator on (index-3 methods the pendulum, ODE-only ones the oscillator without
its wall, contact-resolving ones the oscillator with its wall out of reach), the step
settings of an order sweep, and the slope that measures an order (against planted power laws)."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.integrators.registry import get_integrator
from daebench.workflows import verify_cases as vc


@pytest.mark.parametrize("name, scene, law", [("hht", "pendulum", None), ("ida", "pendulum", None),
                                              ("central", "spring-wall", None),
                                              ("moreau", "spring-wall", "constraint"),
                                              ("lcp", "spring-wall", "complementarity")])
def test_each_integrator_gets_the_first_smooth_case_it_runs(name, scene, law):
    case, sc = vc.smooth_case(get_integrator(name))
    assert case is not None, sc
    assert sc.name == scene
    if law is not None:
        assert sc["contact.law"] == law and sc["contact.wall"] == -1.0     # the wall out of reach
    if name == "central":
        assert sc["effects.contact"] is False


def test_fixed_settings_turn_adaptivity_off_only_where_it_exists():
    assert vc.fixed_settings(get_integrator("ida"), {"rtol": 1e-6}, 1e-3) == {"rtol": 1e-6, "h": 1e-3,
                                                                                "adaptive": False}
    assert vc.fixed_settings(get_integrator("central"), {}, 1e-4) == {"h": 1e-4}


@pytest.mark.parametrize("p", [1.0, 2.0, 4.0])
def test_the_slope_recovers_a_planted_order(p):
    h = np.array([1e-2, 5e-3, 2.5e-3, 1.25e-3])
    assert vc.slope(h, 3.0 * h ** p) == pytest.approx(p, abs=1e-12)
