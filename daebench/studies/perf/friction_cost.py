"""Per-step cost of Coulomb friction in the event-capturing steppers: the same case run
with its friction coefficient and with μ = 0 (``daebench perf``, with the capture rates).

Without friction Moreau–Jean solves the normal impulses by Murty's method; with friction
one LCP of four unknowns per active contact by Lemke's (:mod:`daebench.stepping.friction`).
Nonsmooth generalized-α adds two unknowns per contact to its Newton system
(:mod:`daebench.stepping.nsga_friction`). The compliant family: hht on block-incline with
penalty contact, regularised Coulomb (:mod:`daebench.core.phase`) against the same
penalty run with μ = 0 (:data:`COMPLIANT`; its cost is the tangent rows in the force and
its central-difference Jacobian). The event-driven family: hht through the driver with the
``constraint`` law (:data:`EVENT_DRIVEN`): stick and slip phases (:mod:`daebench.driver.stickslip`,
compiled by :mod:`daebench.core.coulomb`: stick rows, slip force through a small augmented
solve per force evaluation, the switches watched and the slip work booked in the compiled
loop) against the frictionless phases; over the first 0.1 s of each case (block-incline:
slipping; rocking-block: rocking on a sticking corner).

Times are wall (``perf_counter``) and CPU (``process_time``) of the same interleaved runs; the
ratios are the figures to read on a shared machine (``daebench perf --section friction``).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pandas as pd

from daebench.driver.simulate import simulate
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.scenes import load_scene

CASES = ("block-incline", "rocking-block")
INTEGRATORS = ("moreau", "nsgenalpha")
#: (case, integrator, law overrides) timed with the case's μ and μ = 0: compliant contact
COMPLIANT = (("block-incline", "hht", (("contact.law", "penalty"), ("contact.penalty_stiffness", 1e6),
                                       ("contact.penalty_damping", 2e3))),)
#: (case, integrator, overrides) timed with the case's μ and μ = 0: event-driven friction (driver)
EVENT_DRIVEN = (("block-incline", "hht", (("t_end", 0.1),)), ("rocking-block", "hht", (("t_end", 0.1),)))


def friction_step_rates(h: float = 1e-4, repeats: int = 3, cases: tuple[str, ...] = CASES,
                        integrators: tuple[str, ...] = INTEGRATORS,
                        compliant: tuple[tuple, ...] = COMPLIANT,
                        driven: tuple[tuple, ...] = EVENT_DRIVEN) -> pd.DataFrame:
    """µs per step of each integrator on each case, with the case's μ and with μ = 0, at
    the fixed step h through the driver (one warm-up run each, then the minimum of
    ``repeats`` interleaved runs); ``compliant``: further (case, integrator, overrides)
    runs, e.g. a compliant law with regularised friction; ``driven``: the same for the
    event-driven driver's stick/slip phases (:data:`EVENT_DRIVEN`).

    Returns
    -------
    DataFrame: case, integrator, law, mu, steps, wall_s, cpu_s, us_per_step, cpu_us_per_step,
    newton_per_step, friction_over_frictionless and friction_over_frictionless_cpu (on the
    rows with μ > 0).
    """
    specs = []
    for case in cases:
        mu = float(load_scene(case)["contact.friction"])
        for name in integrators:
            for m in (mu, 0.0):
                specs.append((case, name, m, ()))
    for case, name, extra in (*compliant, *driven):
        mu = float(load_scene(case)["contact.friction"])
        specs += [(case, name, mu, tuple(extra)), (case, name, 0.0, tuple(extra))]

    def once(case: str, name: str, mu: float, extra: tuple = ()) -> tuple[float, float, Any]:
        sc = load_scene(case, {**dict(extra), "contact.friction": mu})
        system = build_system(sc)
        integ = get_integrator(name)(h=h)
        t0, c0 = time.perf_counter(), time.process_time()
        res = simulate(system, integ, sc.t_end, min(sc["output.dt"], sc.t_end))
        return time.perf_counter() - t0, time.process_time() - c0, res

    for spec in specs:
        once(*spec)
    best: dict[tuple, list] = {spec: [np.inf, np.inf, None] for spec in specs}
    for _ in range(max(int(repeats), 1)):
        for spec in specs:
            wall, cpu, res = once(*spec)
            b = best[spec]
            b[0], b[1], b[2] = min(b[0], wall), min(b[1], cpu), res
    rows = []
    for (case, name, mu, extra), (wall, cpu, res) in best.items():
        steps = int(res.counters["steps"])
        law = dict(extra).get("contact.law") or load_scene(case)["contact.law"]
        rows.append({"case": case, "integrator": name, "law": law, "mu": mu, "status": res.status, "steps": steps,
                     "wall_s": wall, "cpu_s": cpu, "us_per_step": 1e6 * wall / max(steps, 1),
                     "cpu_us_per_step": 1e6 * cpu / max(steps, 1),
                     "newton_per_step": res.counters["newton_iterations"] / max(steps, 1)})
    df = pd.DataFrame(rows)
    for col, key in (("friction_over_frictionless", "us_per_step"), ("friction_over_frictionless_cpu",
                                                                     "cpu_us_per_step")):
        ratio = []
        for r in df.itertuples():
            base = df[(df.case == r.case) & (df.integrator == r.integrator) & (df.law == r.law) & (df.mu == 0.0)]
            ratio.append(getattr(r, key) / float(base[key].iloc[0]) if r.mu > 0.0 and len(base) else np.nan)
        df[col] = ratio
    return df


def markdown(df: pd.DataFrame) -> str:
    """The per-step figures as a Markdown table (``daebench perf --section friction``)."""
    lines = ["| case | integrator | law | μ | status | steps | µs/step (wall) | µs/step (CPU) | "
             "× μ = 0 (wall) | × μ = 0 (CPU) | Newton/step |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in df.itertuples():
        lines.append(f"| {r.case} | {r.integrator} | {r.law} | {r.mu:g} | {r.status} | {r.steps} | "
                     f"{r.us_per_step:.2f} | {r.cpu_us_per_step:.2f} | {r.friction_over_frictionless:.2f} | "
                     f"{r.friction_over_frictionless_cpu:.2f} | {r.newton_per_step:.2f} |")
    return "\n".join(lines) + "\n"
