"""Runs through the driver, cached per test process (several tests read the same runs),
and the slope of a log-log error sweep — shared by the event-capturing test files."""

from __future__ import annotations

import numpy as np

from daebench.driver.simulate import simulate
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.scenes import load_scene

_RUNS: dict = {}


def cached_run(integrator: str, scene: str, overrides: dict | None = None, **settings):
    """(SimulationResult, system) of a completed run; asserts it completed."""
    key = (integrator, scene, tuple(sorted((overrides or {}).items())), tuple(sorted(settings.items())))
    if key not in _RUNS:
        sc = load_scene(scene, overrides or {})
        system = build_system(sc)
        res = simulate(system, get_integrator(integrator)(**settings), sc.t_end, sc["output.dt"])
        assert res.status == "completed", res.message
        _RUNS[key] = (res, system)
    return _RUNS[key]


def slope(h, err) -> float:
    """Least-squares slope of log(err) against log(h): the measured order."""
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])
