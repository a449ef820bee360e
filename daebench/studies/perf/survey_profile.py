"""Where a survey's time goes, per case and stage: `daebench survey` run as usual (its
workers, rounds and budget) with its stages wrapped in timers, each call one line
``{pid, case, stage, wall, cpu}`` of a JSON-lines file; :func:`table` sums them per case.

Stages, in the workers: ``warm-up`` (the first run of a code path in a worker: loading its
compiled kernels from the cache), ``timed`` (the first timed call), ``repeats`` (timed calls
after it, made only while a call is shorter than the timing rule's SHORT_RUN_S),
``system build``, ``truth`` (the reference loaded for scoring), ``score:<measure>`` (each
measure of the scoring pipeline; ``score:graphdist`` is the graph distance), ``digest``,
``energy``. In the survey's process: ``import`` (the process's start to the survey
imported), ``plan``, ``references`` (prepared, loaded and checked once per case),
``writing`` (rows into the store; the survey's tables and figures: ``survey write``),
``repeat check``, ``case`` (a case's wall time, its runs on two workers included).

Run as ``python -m daebench.studies.perf.survey_profile OUT.jsonl NAME --cases a,b
--budget 150 --jobs 2``; ``--table OUT.jsonl`` prints the per-case table (markdown).
Workers are forked, so the wrappers installed here are theirs too.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import time
from collections import defaultdict
from pathlib import Path
from typing import Any, Callable

from daebench.harness.scoring import pipeline
from daebench.harness.sweeps import row, store
from daebench.workflows import survey

WORKER_STAGES = ("warm-up", "timed", "repeats", "system build", "truth", "digest", "energy")
MAIN_STAGES = ("case", "plan", "references", "writing", "repeat check")


class Recorder:
    """Appends one line per timed call to ``path``; ``case`` is the case being run."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.case = "(all)"

    def emit(self, stage: str, wall: float, cpu: float, case: str | None = None) -> None:
        with open(self.path, "a") as f:
            f.write(json.dumps({"pid": os.getpid(), "case": case or self.case, "stage": stage,
                                "wall": wall, "cpu": cpu}) + "\n")

    def wrap(self, stage: str, fn: Callable) -> Callable:
        @functools.wraps(fn)
        def timed(*args: Any, **kwargs: Any) -> Any:
            w0, c0 = time.perf_counter(), time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                self.emit(stage, time.perf_counter() - w0, time.process_time() - c0)
        return timed


def since_start() -> float:
    """Wall seconds since this process started (Linux: /proc/self/stat's start time)."""
    ticks = int(Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()[19])
    return time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf("SC_CLK_TCK")


def install(rec: Recorder) -> None:
    """Wrap the survey's stages (module docstring) with ``rec``'s timers."""
    execute = row.execute

    def execute_in_case(spec: Any, scene: Any, *args: Any, **kwargs: Any) -> Any:
        rec.case = scene.name
        return execute(spec, scene, *args, **kwargs)

    row.execute = survey.execute = execute_in_case
    time_call = row.time_call

    def timed_calls(fn, repeats=3, warmup=True, time_cap=60.0, short_s=1.0, warmup_fn=None):
        n = [0]

        def counted():
            n[0] += 1
            return rec.wrap("timed" if n[0] == 1 else "repeats", fn)()
        wf = rec.wrap("warm-up", warmup_fn) if warmup_fn is not None else None
        return time_call(counted, repeats=repeats, warmup=warmup, time_cap=time_cap, short_s=short_s, warmup_fn=wf)

    row.time_call = timed_calls
    row.build_system = rec.wrap("system build", row.build_system)
    row.history_digest = rec.wrap("digest", row.history_digest)
    row.metrics.energy_balance = rec.wrap("energy", row.metrics.energy_balance)
    measures = tuple(rec.wrap("score:" + (m.__name__ if m.__module__.endswith("pipeline")
                                          else m.__module__.rsplit(".", 1)[-1]), m) for m in pipeline.MEASURES)
    score = pipeline.score
    pipeline.score = lambda run, truth, which=None: score(run, truth, measures if which is None else which)
    pipeline.truth = rec.wrap("truth", pipeline.truth)
    run_case = survey.run_case

    def case(scene: Any, *args: Any) -> Any:
        rec.case = scene.name
        return rec.wrap("case", run_case)(scene, *args)

    survey.run_case = case
    survey._reference = rec.wrap("references", survey._reference)
    survey.repeat_check = rec.wrap("repeat check", survey.repeat_check)
    survey.compare.plan = rec.wrap("plan", survey.compare.plan)
    store.SweepStore.append = rec.wrap("writing", store.SweepStore.append)
    survey.write = rec.wrap("survey write", survey.write)


def table(path: Path) -> str:
    """Per case: the survey process's stages (wall) and the workers' stages summed over the
    workers (wall; CPU in the totals row); graph distance and the rest of scoring apart."""
    rows = [json.loads(line) for line in open(path)]
    agg: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(lambda: [0.0, 0.0]))
    for r in rows:
        a = agg[r["case"]][r["stage"]]
        a[0] += r["wall"]
        a[1] += r["cpu"]
    for c in agg.values():   # scoring without the graph distance
        other = [0.0, 0.0]
        for k in [k for k in c if k.startswith("score:") and k != "score:graphdist"]:
            other = [other[0] + c[k][0], other[1] + c[k][1]]
        c["scoring"], c["graph distance"] = other, c.get("score:graphdist", [0.0, 0.0])
    cols = list(MAIN_STAGES) + list(WORKER_STAGES[:4]) + ["scoring", "graph distance", "digest"]
    cases = [c for c in agg if "case" in agg[c]]
    out = ["| case | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    tot = defaultdict(lambda: [0.0, 0.0])
    for c in cases:
        out.append(f"| {c} | " + " | ".join(f"{agg[c][k][0]:.1f}" if k in agg[c] else "" for k in cols) + " |")
        for k in cols:
            if k in agg[c]:
                tot[k] = [tot[k][0] + agg[c][k][0], tot[k][1] + agg[c][k][1]]
    out.append("| **wall** | " + " | ".join(f"{tot[k][0]:.1f}" for k in cols) + " |")
    out.append("| CPU | " + " | ".join(f"{tot[k][1]:.1f}" for k in cols) + " |")
    for stage in ("import", "survey", "survey write"):
        for r in rows:
            if r["stage"] == stage and r["case"] == "(all)":
                out.append(f"\n{stage}: {r['wall']:.1f} s wall, {r['cpu']:.1f} s CPU")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("name", nargs="?")
    ap.add_argument("--cases", default="")
    ap.add_argument("--budget", type=float, default=150.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--table", action="store_true", help="print the table of OUT and stop")
    a = ap.parse_args(argv)
    if a.table:
        print(table(a.out))
        return
    if not a.name:
        ap.error("NAME (the survey's name) is needed to run one")
    rec = Recorder(a.out)
    rec.emit("import", since_start(), time.process_time(), "(all)")
    install(rec)
    opts = survey.SurveyOptions(cases=tuple(c for c in a.cases.split(",") if c), budget_s=a.budget, jobs=a.jobs,
                                name=a.name, overwrite=True, progress=False)
    w0, c0 = time.perf_counter(), time.process_time()
    res = survey.run_survey(opts)   # writes its tables and figures (the 'survey write' stage)
    rec.emit("survey", time.perf_counter() - w0, time.process_time() - c0, "(all)")
    print(f"{len(res.table)} rows in {res.wall_s:.1f} s")


if __name__ == "__main__":  # pragma: no cover
    main()
