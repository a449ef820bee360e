"""What a step costs beyond the model's own physics: the floor under steps/s.

An implicit step evaluates the model's applied force and mass matrix once per Newton
iteration (``residual_evals`` in the run's counters). However lean the integrator, a
step cannot cost less than those evaluations: the model kernel's time per call × the
evaluations per step is a floor, and 1 / floor an upper bound on steps/s that no
change to the integrator loop can pass — only a cheaper model kernel or fewer Newton
iterations can. This study measures, in one process:

* the run (best of ``repeats`` wall times of the whole ``run_scene``): steps/s and the
  residual evaluations per step;
* the model's ``mass_force`` kernel per call, called through the model's handle from a
  compiled loop (the way every integrator loop calls it), at the scene's initial state;
* the floor and the share of the step the integrator, the driver and the outputs take.

``daebench perf --section model-floor`` prints it for beam-impact (N = 5, the
protocol's hht) and the pendulum (hht, genalpha).
"""

from __future__ import annotations

import math
import time
from typing import Any, Sequence

import numpy as np
from numba import njit

from daebench.core import kernels
from daebench.core.borrow import borrow
from daebench.harness.running.runner import run_scene
from daebench.models import build_system
from daebench.models.scenes import load_scene


@njit(cache=True)
def _kernel_calls(md, t, q, v, calls):
    md = borrow(md)
    n = q.shape[0]
    M = np.empty((n, n))
    Q = np.empty(n)
    s = 0.0
    for _ in range(calls):
        kernels.mass_force(md, t, q, v, M, Q)
        s += Q[0]
    return s


def kernel_time(scene: Any, calls: int = 20000, repeats: int = 5) -> float:
    """Seconds per call of the model's ``mass_force`` kernel (best of ``repeats``)."""
    system = build_system(scene)
    q0, v0 = system.initial_state()
    md = system.kernel_handle()
    q, v = np.ascontiguousarray(q0, float), np.ascontiguousarray(v0, float)
    _kernel_calls(md, 0.0, q, v, 10)
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        _kernel_calls(md, 0.0, q, v, calls)
        best = min(best, time.perf_counter() - t0)
    return best / calls


def floor(case: str, sets: Sequence[str], integrator: str, options: dict[str, Any],
          repeats: int = 15) -> dict[str, Any]:
    """The run's steps/s beside the model-kernel floor (module docstring): the median of
    ``repeats`` wall times of the whole ``run_scene`` (the best and the slowest beside it —
    this machine's speed drifts by tens of per cent from one minute to the next)."""
    scene = load_scene(case, list(sets))
    run_scene(scene, integrator, options, write=False)  # compile / warm
    walls, rec = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        rec, _ = run_scene(scene, integrator, options, write=False)
        walls.append(time.perf_counter() - t0)
    steps = rec.counters["steps"]
    evals = rec.counters["residual_evals"] / steps
    t_kernel = kernel_time(scene)
    per_step = float(np.median(walls)) / steps
    kernel_per_step = evals * t_kernel
    return {"case": case, "settings": list(sets), "integrator": integrator, "options": options,
            "steps": steps, "steps_per_s": 1.0 / per_step, "repeats": repeats,
            "steps_per_s_range": [steps / max(walls), steps / min(walls)], "us_per_step": 1e6 * per_step,
            "residual_evals_per_step": evals, "kernel_us_per_call": 1e6 * t_kernel,
            "kernel_us_per_step": 1e6 * kernel_per_step, "bound_steps_per_s": 1.0 / kernel_per_step,
            "kernel_share": kernel_per_step / per_step}


def cases(beam_t_end: float = 0.4, pendulum_t_end: float = 10.0) -> list[tuple]:
    """beam-impact N = 5 under the protocol's hht, the pendulum under hht and genalpha."""
    pend = (f"t_end={pendulum_t_end}", f"output.dt={pendulum_t_end / 10}")
    return [("beam-impact", ("discretization.n=5", f"t_end={beam_t_end}"), "hht",
             {"h": 1e-4, "h_contact": 1e-6, "alpha": -0.15}),
            ("pendulum", pend, "hht", {"h": 1e-3, "alpha": -0.15}),
            ("pendulum", pend, "genalpha", {"h": 1e-3})]


def report() -> str:
    """The floor of each case of :func:`cases`, one line each (``daebench perf --section model-floor``)."""
    lines = []
    for r in (floor(*c) for c in cases()):
        lines.append(f"{r['case']:12s} {r['integrator']:9s} {r['steps_per_s']:9.0f} steps/s ({r['us_per_step']:6.2f} "
                     f"µs/step); {r['residual_evals_per_step']:.2f} force evaluations/step × "
                     f"{r['kernel_us_per_call']:.3f} µs = {r['kernel_us_per_step']:.2f} µs/step in the model kernel "
                     f"({100 * r['kernel_share']:.0f} %); bound {r['bound_steps_per_s']:.0f} steps/s")
    return "\n".join(lines)
