"""`daebench perf`: the speed figures, measured in one run, as ratios.

1. **Table 1 grid** (beam-impact, 24 runs under the paper's protocol, h = 1e-4 s,
   1e-6 s in contact, 1 s each; runs that diverge or fail end early and count as they
   are): total wall time, and the speed-up over the published 47 500 s.
2. **Scaling**: ``hht`` wall time per step on beam-impact (free flight before the first
   impact, fixed h) for N = 3 … 12, the fitted exponent p of cost ∝ N^p and
   [cost(12)/cost(3)] / (12/3)².
3. **Exudyn** (optional extra ``exudyn``, :mod:`.peers`): per-step wall time and
   error against the exact solution of ``hht`` and ``genalpha`` against Exudyn's
   generalized-α (same step, same ρ∞ = (1+α)/(1−α)) on the rigid pendulum;
   and on a hinged flexible beam under gravity (same L, EI, ρA; no contact; Exudyn:
   2-D ANCF cable elements) the wall time each code needs for the same error of the
   tip angle at t_end against its own converged reference (work–precision lines
   interpolated in log–log) — for our modal model of beam-impact and, like for like,
   for as many Hermite elements with axial stretch as Exudyn has cable elements — and
   the per-step wall ratio FEM/ANCF at each h. Exudyn runs at its default Newton
   tolerances (relative 1e-8); its tip-angle error then stays near 1e-4 rad for every h
   here, and tightening them to 1e-10 cost 35–73 s per 0.3 s run (measured once, by hand).
4. **Adaptivity**: the fewest steps of adaptive ``hht`` / ``ida`` that keep the max θ
   error over the beam-impact run below 1e-6 rad (against the cached IDA reference),
   as a fraction of the paper protocol's steps; beside it a lower bound for every
   Runge–Kutta, multistep or Newmark-type integrator from the tones θ carries in free
   flight (:func:`resolution_bound`).

Plus steps per second of every integrator on beam-impact N = 5 under the protocol, and the
per-step cost of the example plugin written against the compiled interfaces
(tests/plugin_pkg, :func:`.peers.compiled_plugin`) beside the built-ins', the
event-capturing steppers' steps/s beside hht
(:func:`daebench.studies.event_capturing.step_rates`), the floor under steps/s
(:mod:`.model_floor`), the FE models' banded structure (:mod:`.structure`), and with
``coldstart`` the first-run times of the main commands with an empty kernel cache
(:mod:`.cold_start`).
Compile time (numba, first call in a process; loaded from the on-disk cache after the
first process) is measured first and reported separately; nothing else includes it.
Everything is written to ``results/perf/perf.json`` and ``perf.md``.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from daebench.core.params import ParamError
from daebench.harness.files import results_dir
from daebench.harness.running import provenance
from daebench.harness.running.runner import run_scene
from daebench.harness.sweeps import sweep
from daebench.harness.sweeps.options import Execution, SweepOptions
from daebench.models.scenes import load_scene
from daebench.studies import event_capturing
from daebench.studies.hht_beam_impact import study as beam_study
from daebench.studies.perf import (cold_start, compile_census, friction_cost, model_floor, new_model, peer_cost,
                                   probes, structure)
from daebench.studies.perf.adaptive_steps import adaptive, resolution_bound
from daebench.studies.perf.peers import compiled_plugin, exudyn_compare, pendulum_peer_markdown
from daebench.studies.perf.report import markdown
from daebench.studies.perf.settings import PUBLISHED_TABLE1_TOTAL_S, PerfSettings

__all__ = ["PerfSettings", "run_perf", "markdown"]


def compile_time() -> dict[str, float]:
    """Wall time of the first compiled calls in this process (cache load, or compilation
    when the cache is cold), for hub-beam and the pendulum."""
    out = {}
    for name, sets, integ in (("beam-impact", ["t_end=0.0002"], "hht"), ("pendulum", ["t_end=0.002"], "hht")):
        sc = load_scene(name, sets)
        _, w = probes.wall(lambda: run_scene(sc, integ, {"h": 1e-4}, write=False))
        out[name] = w
    return out


def table1(s: PerfSettings) -> dict[str, Any]:
    p = beam_study.Protocol(t_end=s.table_t_end)
    specs = [x for x in beam_study.plan(p) if x.varied["set"] == "table"]
    scene = beam_study.base_scene(p)
    unscored = SweepOptions(reference="none", execution=Execution(jobs=s.jobs, progress=False))
    df, wall = probes.wall(lambda: sweep.run_specs(specs, scene, unscored))
    runs = [{"N": int(r["N"]), "setting": r["setting"], "status": r["status"], "wall_s": float(r["wall_s"]),
             "steps": int(r.get("steps", 0) or 0), "t_final": float(r.get("t_final", math.nan))}
            for _, r in df.iterrows()]
    return {"runs": runs, "total_wall_s": wall, "sum_run_wall_s": float(df["wall_s"].sum()),
            "jobs": s.jobs, "speedup_vs_published": PUBLISHED_TABLE1_TOTAL_S / wall,
            "target_s": 120.0, "met": wall < 120.0}


def scaling(s: PerfSettings) -> dict[str, Any]:
    rows = []
    for N in s.scaling_Ns:
        sc = load_scene("beam-impact", [f"discretization.n={N}", f"t_end={s.scaling_t_end}",
                                        f"output.dt={s.scaling_t_end / 10}"])
        run_scene(sc, "hht", {"h": 1e-4}, write=False)  # warm (tables, caches)
        (rec, _), w = probes.wall(lambda: run_scene(sc, "hht", {"h": 1e-4, "alpha": -0.15}, write=False))
        rows.append({"N": N, "n": N + 1, "steps": rec.counters["steps"], "us_per_step": 1e6 * w / rec.counters["steps"]})
    N = np.array([r["N"] for r in rows], float)
    c = np.array([r["us_per_step"] for r in rows])
    p = float(np.polyfit(np.log(N), np.log(c), 1)[0]) if len(N) > 1 else math.nan
    ratio = (c[-1] / c[0]) / (N[-1] / N[0]) ** 2 if len(N) > 1 else math.nan
    return {"rows": rows, "exponent": p, "growth_over_N2": ratio, "met": bool(ratio <= 1.0)}


def integrator_rates(s: PerfSettings) -> list[dict[str, Any]]:
    sc = load_scene("beam-impact", ["discretization.n=5", f"t_end={s.rates_t_end}"])
    proto = {"h": 1e-4, "h_contact": 1e-6}
    cases = [("hht", [], {**proto, "alpha": -0.15}), ("baumgarte", [], {**proto, "delta": 10.0, "epsilon": 50.0}),
             ("newmark+hertz", ["contact.law=hertz"], dict(proto)), ("ida", [], {})]
    rows = []
    for label, sets, opts in cases:
        scx = sc.with_overrides(dict(x.split("=", 1) for x in sets)) if sets else sc
        integ = label.split("+")[0]
        (rec, _), w = probes.wall(lambda: run_scene(scx, integ, opts, write=False))
        st = rec.counters["steps"]
        rows.append({"integrator": label, "status": rec.status, "t_final": rec.t_final, "steps": st, "wall_s": w,
                     "steps_per_s": st / w if w > 0 else math.nan})
    return rows


def run_perf(s: PerfSettings, out: str | Path | None = None) -> dict[str, Any]:
    folder = Path(out) if out is not None else results_dir() / "perf"
    folder.mkdir(parents=True, exist_ok=True)
    res: dict[str, Any] = {"provenance": provenance.collect(), "load_before": os.getloadavg(),
                           "compiled": os.environ.get("DAEBENCH_COMPILED", "1"), "settings": s.__dict__}
    def save():
        (folder / "perf.json").write_text(json.dumps(res, indent=2, default=_json_default))

    res["compile_s"] = compile_time()
    res["step_rates"] = integrator_rates(s)
    save()
    res["floor"] = [model_floor.floor(*c) for c in model_floor.cases(min(0.4, s.rates_t_end), s.pendulum_T)]
    save()
    res["table1"] = table1(s) if s.table else None
    save()
    res["scaling"] = scaling(s)
    save()
    res["exudyn"] = exudyn_compare(s) if s.exudyn else {"available": False, "note": "skipped"}
    save()
    res["plugin"] = compiled_plugin(s)
    save()
    res["fe_banded"] = structure.fe_scaling(s.fe_elements, s.fe_t_end, t_short=s.fe_t_end / 2)
    save()
    res["ida_backends"] = structure.ida_backends()
    save()
    if s.capture:
        res["capture"] = event_capturing.step_rates(t_end=s.rates_t_end, repeats=s.capture_repeats).to_dict("records")
        save()
        res["friction"] = friction_cost.friction_step_rates(repeats=s.capture_repeats).to_dict("records")
        save()
    if s.coldstart:
        res["coldstart"] = [c.__dict__ for c in cold_start.measure()]
        save()
    paper_steps = next((r["steps"] for r in res["step_rates"] if r["integrator"] == "hht"), None)
    if res["table1"]:
        paper_steps = next((r["steps"] for r in res["table1"]["runs"]
                            if r["N"] == 5 and r["setting"] == "HHT α=-0.15"), paper_steps)
    res["adaptive"] = adaptive(s, paper_steps)
    res["adaptive"]["bound"] = resolution_bound(s, paper_steps)
    res["load_after"] = os.getloadavg()
    (folder / "perf.json").write_text(json.dumps(res, indent=2, default=_json_default))
    (folder / "perf.md").write_text(markdown(res))
    res["folder"] = str(folder)
    return res


def _json_default(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, np.bool_):
        return bool(x)
    return str(x)


#: `daebench perf --section NAME`: one measurement alone, as Markdown
SECTIONS = {
    "model-floor": lambda out: model_floor.report(),
    "structure": lambda out: structure.scaling_report(out=out),
    "new-model": lambda out: new_model.markdown(new_model.measure()),
    "cold-start": lambda out: cold_start.markdown(cold_start.measure()),
    "friction": lambda out: friction_cost.markdown(friction_cost.friction_step_rates()),
    "compile": lambda out: compile_census.markdown(compile_census.census([compile_census.MAIN_JOB]), top=25),
    "pendulum-peer": lambda out: pendulum_peer_markdown(PerfSettings(peer_rounds=7)),
    "peer-cost": lambda out: peer_cost.report(),
}


def run_section(name: str, out: str | Path | None = None) -> str:
    """One section of :data:`SECTIONS`, its Markdown."""
    if name not in SECTIONS:
        raise ParamError(f"unknown --section '{name}'; choose one of {', '.join(SECTIONS)}")
    return SECTIONS[name](out)
