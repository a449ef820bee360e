"""`daebench perf`: cost that follows the structure — the FE models' banded
iteration matrices and IDA's native backend, each as a ratio against a peer measured in
the same run.

* **Banded FE** (:func:`fe_scaling`): ``hht`` CPU time per step on rod-wall for 50 … 400
  elements (n = 4·(elements + 1)), with the model's declared bordered-banded structure
  (:class:`daebench.core.linalg.Sparsity`) and, as the peer, with dense LU (the same
  system with its declaration removed, up to 200 elements by default: its O(n³)
  factorizations make a 400-element run minutes); the fitted exponent p of cost ∝ n^p
  for the whole run's cost per step and for the marginal cost of a step (see
  :func:`fe_scaling`). Targets: ≤ 0.5 ms per step at 200 elements, p ≤ 1.3 (whole run).
  ``daebench perf --section structure`` runs this part alone.
* **IDA** (:func:`ida_backends`): CPU time per step of ``ida`` on beam-impact with
  ``backend=native`` and ``backend=sksundae``, interleaved (native, sksundae, native),
  and whether their histories are identical.

CPU time (``time.process_time``) rather than wall time: the figures stay meaningful on a
shared, loaded machine. Every timed run follows an untimed one in the same process (the
compiled code is loaded, not compiled, inside the timing).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from daebench.core.params import ParamError
from daebench.driver.simulate import simulate
from daebench.harness.files import results_dir
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.studies.perf import probes


def _rod_wall_run(elements: int, t_end: float, h: float, dense: bool, repeats: int = 1) -> tuple[int, int, float]:
    """(steps, Newton iterations, least CPU seconds of ``repeats`` runs) of hht on rod-wall."""
    scene = load_scene("rod-wall", [f"rod.elements={elements}", f"t_end={t_end}"])
    warm = load_scene("rod-wall", [f"rod.elements={elements}", "t_end=4e-6"])
    best, steps, its = math.inf, 0, 0
    for k in range(repeats + 1):
        system = build_system(scene if k else warm)
        if dense:
            system.sparsity = None  # the peer: no declared structure, dense LU
        sc = scene if k else warm
        res, cpu = probes.cpu(lambda: simulate(system, make_integrator("hht", {"h": h}), sc.t_end, sc["output.dt"]))
        if k:                       # k = 0: untimed (the compiled code is loaded, not compiled, below)
            best = min(best, cpu)
            steps, its = int(res.counters["steps"]), int(res.counters["newton_iterations"])
    return steps, its, best


def _exponent(rows: list[dict[str, Any]], key: str) -> float:
    pts = [(r["n"], r[key]) for r in rows if r.get(key, math.nan) > 0]
    if len(pts) < 2:
        return math.nan
    return float(np.polyfit(np.log([p[0] for p in pts]), np.log([p[1] for p in pts]), 1)[0])


def fe_scaling(elements: tuple[int, ...] = (50, 100, 200, 400), t_end: float = 2e-4, h: float = 1e-7,
               dense_up_to: int = 200, t_short: float = 1e-4, repeats: int = 5) -> dict[str, Any]:
    """hht per-step CPU time on rod-wall, banded vs dense (module docstring).

    Per size: the whole run's CPU time over its steps (``ms_per_step``, what the targets
    are judged on: it includes the run's setup and the driver's work at the impact), and
    the marginal cost of a step, (CPU(t_end) − CPU(t_short)) / (steps(t_end) − steps(t_short))
    (``ms_per_step_marginal``: both runs hold the same impact, t_short is inside the
    contact), each the least of ``repeats`` runs; Newton iterations per step beside them
    (they grow from 1 to 2 between 50 and 200 elements: part of the exponent)."""
    if t_short >= t_end:
        raise ParamError(f"fe_scaling: t_short ({t_short}) must be below t_end ({t_end}); e.g. t_short = t_end / 2")
    rows = []
    for el in elements:
        n = 4 * (el + 1)
        steps, its, cpu = _rod_wall_run(el, t_end, h, False, repeats)
        s_short, _, cpu_short = _rod_wall_run(el, t_short, h, False, repeats)
        row = {"elements": el, "n": n, "steps": steps, "newton_per_step": its / steps,
               "ms_per_step": 1e3 * cpu / steps,
               "ms_per_step_marginal": 1e3 * (cpu - cpu_short) / max(steps - s_short, 1)}
        if el <= dense_up_to:
            steps_d, _, cpu_d = _rod_wall_run(el, t_end, h, True, 1)
            row["ms_per_step_dense"] = 1e3 * cpu_d / steps_d
            row["dense_over_banded"] = row["ms_per_step_dense"] / row["ms_per_step"]
        rows.append(row)
    at200 = next((r["ms_per_step"] for r in rows if r["elements"] == 200), math.nan)
    p = _exponent(rows, "ms_per_step")
    return {"rows": rows, "h": h, "t_end": t_end, "t_short": t_short, "repeats": repeats,
            "load": os.getloadavg(), "exponent": p, "exponent_marginal": _exponent(rows, "ms_per_step_marginal"),
            "exponent_dense": _exponent(rows, "ms_per_step_dense"), "ms_at_200": at200,
            "target_ms_200": 0.5, "target_exponent": 1.3,
            "met_ms_200": bool(at200 <= 0.5), "met_exponent": bool(p <= 1.3),
            "met": bool(at200 <= 0.5 and p <= 1.3)}


def ida_backends(t_end: float = 0.1) -> dict[str, Any]:
    """ida on beam-impact, native vs sksundae, interleaved (module docstring)."""
    scene = load_scene("beam-impact", [f"t_end={t_end}"])
    for backend in ("native", "sksundae"):  # untimed: load the compiled code
        run_scene(load_scene("beam-impact", ["t_end=0.002"]), "ida", {"backend": backend}, write=False)
    rows, hist = [], {}
    for backend in ("native", "sksundae", "native"):
        (rec, res), cpu = probes.cpu(lambda: run_scene(scene, "ida", {"backend": backend}, write=False))
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
        L += ["", f"## Banded FE iteration matrices (rod-wall, hht, h = {fe['h']:g} s, CPU ms per step)", "",
              f"whole run = CPU of a {fe['t_end']:g} s run / its steps; marginal = the extra CPU of the "
              f"steps after t = {fe['t_short']:g} s (same impact) / their number; least of {fe['repeats']} runs; "
              f"load average {fe['load'][0]:.1f}", "",
              "| elements | n | Newton / step | whole run | marginal | dense | dense / banded |",
              "|---|---|---|---|---|---|---|"]
        for r in fe["rows"]:
            d = r.get("ms_per_step_dense")
            L.append(f"| {r['elements']} | {r['n']} | {r['newton_per_step']:.2f} | {r['ms_per_step']:.3f} | "
                     f"{r['ms_per_step_marginal']:.3f} | {'' if d is None else f'{d:.3f}'} | "
                     f"{'' if d is None else format(r['dense_over_banded'], '.1f')} |")
        L.append(f"\nexponent of the cost in n: whole run {fe['exponent']:.2f}, marginal {fe['exponent_marginal']:.2f}, "
                 f"dense {fe['exponent_dense']:.2f}. Targets (whole run): ≤ {fe['target_ms_200']} ms at 200 elements: "
                 f"{fe['ms_at_200']:.3f} ms, {'met' if fe['met_ms_200'] else 'NOT met'}; exponent ≤ "
                 f"{fe['target_exponent']}: {fe['exponent']:.2f}, {'met' if fe['met_exponent'] else 'NOT met'}")
    if ida:
        L += ["", f"## IDA backends (beam-impact, t_end {ida['t_end']:g} s, CPU)", "",
              "| backend | steps | CPU [s] | µs per step |", "|---|---|---|---|"]
        for r in ida["rows"]:
            L.append(f"| {r['backend']} | {r['steps']} | {r['cpu_s']:.2f} | {r['us_per_step']:.1f} |")
        L.append(f"\nsksundae / native: {ida['sksundae_over_native']:.1f}×; histories identical: "
                 f"{ida['identical_histories']}")
    return L


def scaling_report(elements: tuple[int, ...] = (50, 100, 200, 400), t_end: float = 2e-4, dense_up_to: int = 200,
                   repeats: int = 5, out: str | Path | None = None) -> str:
    """The rod-wall scaling alone (``daebench perf --section structure``), written to
    ``<out>/fe_scaling.json`` and ``fe_scaling.md`` (default results/perf); its Markdown."""
    fe = fe_scaling(tuple(elements), t_end, dense_up_to=dense_up_to, t_short=t_end / 2, repeats=repeats)
    folder = Path(out) if out else results_dir() / "perf"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "fe_scaling.json").write_text(json.dumps(fe, indent=2))
    text = "\n".join(markdown(fe, None)).strip() + "\n"
    (folder / "fe_scaling.md").write_text(text)
    return text + f"written: {folder}/fe_scaling.json, fe_scaling.md"
