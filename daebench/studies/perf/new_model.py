"""What a new model costs to compile when every integrator loop is already cached.

Kernels reach the integrator loops as compiled values (:mod:`daebench.core.handles`), so a
model added to a warm cache should compile its own kernels once and nothing else, whatever
integrators then run it. This study measures that, in fresh processes sharing one new
kernel cache (``NUMBA_CACHE_DIR``):

1. ``warm-up``: the *first* cases (comma-separated; by default pendulum and ball: the two
   mass layouts — dense, and ball's constant diagonal — each a numba type of its own, and
   one case without and one with contacts, so that every code path the new model takes is
   compiled; from ball alone, falling-rod's dense mass compiles the hht loop again) run with every
   integrator of the list (compiles the loops, the phase functions and those models'
   kernels — the cold cost), and the shared default kernels are compiled
   (:func:`daebench.core.handles.compile_shared_defaults`: library code that the first model
   leaving a kernel to its default pays once per cache — no model of pendulum and ball's
   kind uses the finite-difference Jacobians, crank does);
2. ``new``: the *second* case runs with the same integrators (its kernels are new, the
   loops are cached);
3. ``again``: the same runs once more (everything cached).

The new model's compile cost is CPU(new) − CPU(again): the same runs, the same imports,
only the compilation differs. CPU time is the child's user + system time, less sensitive
to the machine's load than wall time. ``daebench perf --section new-model`` prints it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Sequence

from daebench.studies.perf import probes

INTEGRATORS = ("hht", "newmark", "genalpha", "baumgarte", "ida", "moreau", "nsgenalpha")
_CHILD = """
import json, sys
from daebench import api
from daebench.core.handles import compile_shared_defaults
from daebench.core.params import ParamError
from daebench.harness.running.compile_events import recording
cases, t_end, names = sys.argv[1].split(","), sys.argv[2], sys.argv[3].split(",")
ran = {}
with recording() as rec:
    if sys.argv[4] == "warm-up":  # the library's shared default kernels are library code, not the new model's
        compile_shared_defaults()
    for case in cases:
        for name in names:
            try:
                step = {} if name == "ida" else {"h": 1e-3}  # IDA chooses its own steps
                ran[name] = api.run(case, name, overrides=[f"t_end={t_end}"], **step).status
            except ParamError as exc:  # the integrator does not apply to this case (friction, contacts …)
                ran[name] = "refused: " + str(exc).splitlines()[0][:80]
print(json.dumps({"ran": ran, "compiled": rec["functions"]}))
"""


@dataclass
class NewModelCost:
    """CPU seconds of each stage and what each integrator did."""

    first: str
    new: str
    warmup_cpu_s: float
    new_cpu_s: float
    again_cpu_s: float
    new_model_compile_cpu_s: float
    runs: dict[str, str]
    compiled: list[dict] = field(default_factory=list)  # the new stage's compiles (compile_census.Compiled)


def _child_cpu(args: Sequence[str], env: dict[str, str], timeout: float) -> tuple[float, dict]:
    cpu, proc = probes.run_python(_CHILD, args, env, timeout)
    if proc.returncode != 0:
        raise RuntimeError(f"new-model study child failed ({' '.join(args)}):\n{proc.stderr[-2000:]}")
    return cpu, json.loads(proc.stdout.strip().splitlines()[-1])


def measure(first: str = "pendulum,ball", new: str = "crank", integrators: Sequence[str] = INTEGRATORS,
            t_end: float = 0.05, timeout: float = 3600.0) -> NewModelCost:
    """The three stages of the module docstring, in a new empty kernel cache."""
    names = ",".join(integrators)
    with probes.fresh_cache("daebench-newmodel-") as env:
        warm, _ = _child_cpu([first, str(t_end), names, "warm-up"], env, timeout)
        fresh, out = _child_cpu([new, str(t_end), names, "new"], env, timeout)
        again, _ = _child_cpu([new, str(t_end), names, "again"], env, timeout)
    compiled = sorted(out["compiled"], key=lambda f: -f["own_s"])
    return NewModelCost(first, new, warm, fresh, again, fresh - again, out["ran"], compiled)


def markdown(r: NewModelCost, top: int = 25) -> str:
    ran = [k for k, v in r.runs.items() if not v.startswith("refused")]
    return (f"| stage | CPU [s] |\n|---|---|\n| cold: `{r.first}` × {len(INTEGRATORS)} integrators | "
            f"{r.warmup_cpu_s:.1f} |\n| new model `{r.new}` (loops cached) | {r.new_cpu_s:.1f} |\n"
            f"| `{r.new}` again (all cached) | {r.again_cpu_s:.1f} |\n\n"
            f"New model's compile cost: **{r.new_model_compile_cpu_s:.1f} s CPU** for the {len(ran)} integrators "
            f"that ran it ({', '.join(ran)}; target ≤ 10 s).\n\n"
            f"What the new stage compiled ({len(r.compiled)} compiles, {sum(f['own_s'] for f in r.compiled):.1f} s "
            f"wall inside them):\n\n| function | own [s] | signature |\n|---|---|---|\n"
            + "".join(f"| {f['name']} | {f['own_s']:.2f} | {f['signature'][:70]} |\n" for f in r.compiled[:top]))
