"""Per-step cost of daebench's Moreau–Jean (``moreau``) against Siconos' Moreau–Jean
(``siconos-mj``, :mod:`daebench.peers.siconos`) on the same case and the same fixed step,
measured in one run (``daebench perf --section peer-cost``).

Both are the same scheme — θ = ½ for the smooth part, one LCP of the contacts closing in the
step, Newton's impact law at velocity level — so the ratio of CPU time per step is the cost of
one implementation against the other. daebench's is timed in this process (``process_time``
of :func:`daebench.harness.running.runner.run_scene`, compiled kernels warm: one run first,
untimed; its output every ``output.dt`` included); Siconos' in its own process (the worker's
``process_time`` of its time-stepping loop, set-up excluded, a row kept at every step). Each
figure is the median of :data:`REPEATS` interleaved runs, and beside the cost stands each
run's max error against the exact solution where the case has one, and the largest difference
between the two codes' trajectories at daebench's output times, so the two are seen to compute
the same thing.
"""

from __future__ import annotations

import math
import tempfile
import time
from typing import Any

import numpy as np
import pandas as pd

from daebench.harness.running.runner import run_scene
from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.peers import PEERS, PeerUnavailable, run_peer

#: (case, observable compared, fixed steps [s]) timed
CASES = (("ball", "x", (1e-3, 2.5e-4)), ("slider-crank-clearance", "theta", (1e-5,)))
REPEATS = 3


def _max_error(scene: Any, t: np.ndarray, x: np.ndarray, obs: str) -> float:
    """max |x − exact| (NaN: the case has no exact solution)."""
    fn = getattr(build_system(scene), "exact_observables", None)
    try:
        exact = fn(t)[obs] if fn is not None else None
    except ValueError:
        exact = None
    return float(np.max(np.abs(x - exact))) if exact is not None else math.nan


def measure(cases: tuple = CASES, repeats: int = REPEATS) -> list[dict[str, Any]]:
    """One row per (case, h): CPU time per step of each code [µs], their ratio, the errors."""
    peer = PEERS["siconos-mj"]
    rows = []
    for case, obs, steps in cases:
        sc = load_scene(case)
        run_scene(sc, "moreau", {"h": steps[0]}, write=False)   # compiled kernels warm
        for h in steps:
            ours, theirs = [], []
            with tempfile.TemporaryDirectory(prefix="daebench-peer-cost-") as tmp:
                for _ in range(repeats):
                    c0 = time.process_time()
                    rec, res = run_scene(sc, "moreau", {"h": h}, write=False)
                    ours.append(((time.process_time() - c0) / res.counters["steps"], res))
                    (pr,) = run_peer(peer, sc, [h], tmp)
                    theirs.append(pr.cpu_s / pr.steps)
                data = pd.read_csv(pr.file, comment="#")
            res = ours[-1][1]
            us, them = 1e6 * float(np.median([o[0] for o in ours])), 1e6 * float(np.median(theirs))
            t, mine = res.history["t"].to_numpy(), res.history[obs].to_numpy()
            other = np.interp(t, data["t"].to_numpy(), data[obs].to_numpy())
            rows.append({"case": case, "observable": obs, "h": h, "steps": int(res.counters["steps"]),
                         "status": res.status, "moreau_us_per_step": us, "siconos_mj_us_per_step": them,
                         "ratio_moreau_over_siconos": us / them if them > 0 else math.nan,
                         "moreau_err_max": _max_error(sc, t, mine, obs),
                         "siconos_err_max": _max_error(sc, data["t"].to_numpy(), data[obs].to_numpy(), obs),
                         "difference_max": float(np.max(np.abs(mine - other))), "code": pr.code})
    return rows


def markdown(rows: list[dict[str, Any]] | None) -> str:
    """The section as Markdown (a note when Siconos is not installed)."""
    if rows is None:
        return ("## daebench's Moreau–Jean against Siconos'\n\nnot measured: Siconos is not installed "
                f"(`{PEERS['siconos-mj'].install}`)\n")
    lines = ["## daebench's Moreau–Jean against Siconos'", "",
             f"CPU time per step, median of {REPEATS} interleaved runs in one process each (Siconos: "
             f"{rows[0]['code'] if rows else ''}, in its own process); both θ = ½ with one LCP per step.", "",
             "| case | h [s] | steps | moreau [µs/step] | Siconos MJ [µs/step] | moreau / Siconos | "
             "observable | max error moreau | max error Siconos | max difference |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['case']} | {r['h']:g} | {r['steps']} | {r['moreau_us_per_step']:.3g} | "
              f"{r['siconos_mj_us_per_step']:.3g} | {r['ratio_moreau_over_siconos']:.3g} | {r['observable']} | "
              f"{r['moreau_err_max']:.3e} | {r['siconos_err_max']:.3e} | {r['difference_max']:.3e} |"
              for r in rows]
    lines += ["", "Errors against the exact solution (NaN: the case has none); the difference is between the two "
                  "codes' trajectories at daebench's output times."]
    return "\n".join(lines) + "\n"


def report() -> str:
    """`daebench perf --section peer-cost`."""
    try:
        return markdown(measure())
    except PeerUnavailable:
        return markdown(None)
