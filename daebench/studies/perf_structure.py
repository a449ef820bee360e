"""`daebench perf`, issue 21: cost that follows the structure — the FE models' banded
iteration matrices and IDA's native backend, each as a ratio against a peer measured in
the same run.

* **Banded FE** (:func:`fe_scaling`): ``hht`` CPU time per step on rod-wall for 50 … 400
  elements (n = 4·(elements + 1)), with the model's declared bordered-banded structure
  (:class:`daebench.core.linalg.Sparsity`) and, as the peer, with dense LU (the same
  system with its declaration removed); the fitted exponent p of cost ∝ n^p for each.
  Targets: banded ≤ 0.5 ms per step at 200 elements, p ≤ 1.3.
* **IDA** (:func:`ida_backends`): CPU time per step of ``ida`` on beam-impact with
  ``backend=native`` and ``backend=sksundae``, interleaved (native, sksundae, native),
  and whether their histories are identical.

CPU time (``time.process_time``) rather than wall time: the figures stay meaningful on a
shared, loaded machine. Every timed run follows an untimed one in the same process (the
compiled code is loaded, not compiled, inside the timing).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from daebench.driver.simulate import simulate
from daebench.harness.runner import make_integrator, run_scene
from daebench.models import build_system
from daebench.models.scenes import load_scene


def _cpu(fn):
    t = time.process_time()
    out = fn()
    return out, time.process_time() - t


def _rod_wall_run(elements: int, t_end: float, h: float, dense: bool) -> tuple[int, float]:
    scene = load_scene("rod-wall", [f"rod.elements={elements}", f"t_end={t_end}"])
    warm = load_scene("rod-wall", [f"rod.elements={elements}", "t_end=4e-6"])
    system = build_system(scene)
    if dense:
        system.sparsity = None  # the peer: no declared structure, dense LU
    simulate(system, make_integrator("hht", {"h": h}), warm.t_end, warm["output.dt"])
    res, cpu = _cpu(lambda: simulate(system, make_integrator("hht", {"h": h}), scene.t_end, scene["output.dt"]))
    return int(res.counters["steps"]), cpu


def fe_scaling(elements: tuple[int, ...] = (50, 100, 200, 400), t_end: float = 2e-4, h: float = 1e-7,
               dense_up_to: int = 400) -> dict[str, Any]:
    """hht per-step CPU time on rod-wall, banded vs dense (module docstring)."""
    rows = []
    for el in elements:
        n = 4 * (el + 1)
        steps, cpu = _rod_wall_run(el, t_end, h, dense=False)
        row = {"elements": el, "n": n, "steps": steps, "ms_per_step_banded": 1e3 * cpu / steps}
        if el <= dense_up_to:
            steps_d, cpu_d = _rod_wall_run(el, t_end, h, dense=True)
            row["ms_per_step_dense"] = 1e3 * cpu_d / steps_d
            row["dense_over_banded"] = row["ms_per_step_dense"] / row["ms_per_step_banded"]
        rows.append(row)

    def exponent(key: str) -> float:
        pts = [(r["n"], r[key]) for r in rows if key in r]
        if len(pts) < 2:
            return math.nan
        x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
        return float(np.polyfit(x, y, 1)[0])

    at200 = next((r["ms_per_step_banded"] for r in rows if r["elements"] == 200), math.nan)
    p = exponent("ms_per_step_banded")
    return {"rows": rows, "h": h, "t_end": t_end, "exponent_banded": p, "exponent_dense": exponent("ms_per_step_dense"),
            "target_ms_200": 0.5, "target_exponent": 1.3, "met": bool(at200 <= 0.5 and p <= 1.3)}


def ida_backends(t_end: float = 0.1) -> dict[str, Any]:
    """ida on beam-impact, native vs sksundae, interleaved (module docstring)."""
    scene = load_scene("beam-impact", [f"t_end={t_end}"])
    for backend in ("native", "sksundae"):  # untimed: load the compiled code
        run_scene(load_scene("beam-impact", ["t_end=0.002"]), "ida", {"backend": backend}, write=False)
    rows, hist = [], {}
    for backend in ("native", "sksundae", "native"):
        (rec, res), cpu = _cpu(lambda: run_scene(scene, "ida", {"backend": backend}, write=False))
        steps = int(rec.counters["steps"])
        rows.append({"backend": backend, "steps": steps, "cpu_s": cpu, "us_per_step": 1e6 * cpu / max(steps, 1)})
        hist[backend] = res.history
    num = hist["native"].select_dtypes("number").columns
    same = bool(hist["native"][num].equals(hist["sksundae"][num]))
    nat = min(r["us_per_step"] for r in rows if r["backend"] == "native")
    sks = next(r["us_per_step"] for r in rows if r["backend"] == "sksundae")
    return {"rows": rows, "t_end": t_end, "sksundae_over_native": sks / nat, "identical_histories": same}


def markdown(fe: dict[str, Any] | None, ida: dict[str, Any] | None) -> list[str]:
    """Lines of perf.md for these figures."""
    L: list[str] = []
    if fe:
        L += ["", "## Banded FE iteration matrices (rod-wall, hht, CPU ms per step)", "",
              "| elements | n | banded | dense | dense / banded |", "|---|---|---|---|---|"]
        for r in fe["rows"]:
            d = r.get("ms_per_step_dense")
            L.append(f"| {r['elements']} | {r['n']} | {r['ms_per_step_banded']:.3f} | "
                     f"{'' if d is None else f'{d:.3f}'} | {r.get('dense_over_banded', math.nan):.1f} |")
        L.append(f"\nexponent of cost in n: banded {fe['exponent_banded']:.2f}, dense {fe['exponent_dense']:.2f} "
                 f"(targets: ≤ {fe['target_exponent']}, ≤ {fe['target_ms_200']} ms at 200 elements: "
                 f"{'met' if fe['met'] else 'NOT met'})")
    if ida:
        L += ["", f"## IDA backends (beam-impact, t_end {ida['t_end']:g} s, CPU)", "",
              "| backend | steps | CPU [s] | µs per step |", "|---|---|---|---|"]
        for r in ida["rows"]:
            L.append(f"| {r['backend']} | {r['steps']} | {r['cpu_s']:.2f} | {r['us_per_step']:.1f} |")
        L.append(f"\nsksundae / native: {ida['sksundae_over_native']:.1f}×; histories identical: "
                 f"{ida['identical_histories']}")
    return L
