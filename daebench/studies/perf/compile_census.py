"""What a cold run compiles: every function numba compiles for one daebench command, with
its own compile time, from an empty kernel cache.

The command runs in a fresh process with an empty kernel cache (:func:`.probes.fresh_cache`)
and ``NUMBA_OPT`` as given (numba's default, 3, when not). The child listens to numba's
``numba:compile`` events (:func:`daebench.harness.running.compile_events.recording`): a compile event spans the typing,
lowering and LLVM work of one function for one signature, *including* the compiles of the
callees it triggers; each function's **own** time is its span minus its nested compiles'
spans, so the own times add up to the total compile time. ``numba:llvm_lock`` spans are
summed as the LLVM share (optimisation and machine-code emission, also repeated for every
caller that links a callee's module).

``daebench compile-report -- run beam-impact --integrator hht`` prints the table (per
function: specializations, machine-code bytes, own compile time split into typing, lowering
and LLVM); ``daebench perf --section compile`` that of the main job in small
(:data:`MAIN_JOB`); :func:`census` returns it. A second run of the command in the same cache folder gives the
warm CPU time, so the compile share is measured, not assumed.
"""

from __future__ import annotations

import json
import os
import resource
import runpy
import sys
import tempfile
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Sequence

from daebench.harness.running.compile_events import recording
from daebench.studies.perf import loaded_code, probes

#: ``census([MAIN_JOB])``: the main job in small (:data:`.loaded_code.MAIN_JOB`, each of
#: `daebench compare beam-impact`'s integrators through an impact) instead of a command
MAIN_JOB = "main-job"


@dataclass
class Compiled:
    """One function compiled for one signature."""

    name: str          # module.qualname
    signature: str
    own_s: float       # wall seconds spent on this function alone (nested compiles excluded)
    total_s: float     # its span, nested compiles included
    typing_s: float = 0.0    # of own_s: type inference
    lowering_s: float = 0.0  # of own_s: lowering to LLVM IR
    llvm_s: float = 0.0      # of own_s: LLVM optimisation and machine code
    code_bytes: int = 0      # machine code of its library (callees linked into it included)


@dataclass
class Census:
    """The compile census of one command (wall seconds; CPU of the child process)."""

    command: str
    opt: str
    cold_cpu_s: float
    warm_cpu_s: float
    compile_s: float                    # sum of own times = time inside numba:compile spans
    llvm_s: float                       # inside numba:llvm_lock spans
    returncode: int
    functions: list[Compiled] = field(default_factory=list)

    def by_function(self) -> list[tuple[str, int, int, float]]:
        """(function, specializations, machine-code bytes, own seconds), largest code first."""
        acc: dict[str, list] = defaultdict(lambda: [0, 0, 0.0])
        for f in self.functions:
            acc[f.name][0] += 1
            acc[f.name][1] += f.code_bytes
            acc[f.name][2] += f.own_s
        return sorted(((m, n, b, s) for m, (n, b, s) in acc.items()), key=lambda r: (-r[2], r[0]))

    def by_module(self) -> list[tuple[str, int, float]]:
        """(module, functions compiled, own seconds), costliest first."""
        acc: dict[str, list[float]] = defaultdict(lambda: [0, 0.0])
        for f in self.functions:
            mod = f.name.rsplit(".", 1)[0] if "." in f.name else f.name
            acc[mod][0] += 1
            acc[mod][1] += f.own_s
        return sorted(((m, int(n), s) for m, (n, s) in acc.items()), key=lambda r: -r[2])


def child(out_path: str, args: list[str]) -> int:
    """Run ``daebench *args`` in this process, recording numba's compiles. The command runs
    as the program ``python -m daebench.cli.app`` would (by module name, as
    :mod:`.coldstart` runs it: a study does not import the CLI layer above it)."""
    rc = 0
    with recording() as rec:
        sys.argv = ["daebench", *args]
        try:
            if list(args) == [MAIN_JOB]:
                loaded_code.main_job()
            else:
                runpy.run_module("daebench.cli.app", run_name="__main__", alter_sys=True)
        except SystemExit as exc:  # the command's exit code
            rc = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        except Exception as exc:  # noqa: BLE001 — the census reports the command's failure, not ours
            sys.stderr.write(f"the command failed: {type(exc).__name__}: {exc}\n")
            rc = 1
    ru = resource.getrusage(resource.RUSAGE_SELF)
    with open(out_path, "w") as f:
        json.dump({**rec, "cpu_s": ru.ru_utime + ru.ru_stime, "rc": rc}, f)
    return rc


#: the child process: ``daebench ARGS`` in it, its compiles recorded into the file OUT
_CHILD = "import sys; from daebench.studies.perf.compile_census import child; sys.exit(child(sys.argv[1], sys.argv[2:]))"


def _run(args: Sequence[str], env: dict[str, str], timeout: float) -> dict:
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as tmp:
        path = tmp.name
    try:
        _, proc = probes.run_python(_CHILD, [path, *args], env, timeout)
        with open(path) as f:
            text = f.read()
        if not text:
            tail = "\n".join(proc.stderr.strip().splitlines()[-5:])
            raise RuntimeError(f"`daebench {' '.join(args)}` ended before writing its census "
                               f"(exit {proc.returncode}; killed or crashed). Its last words:\n{tail}")
        return json.loads(text)
    finally:
        os.unlink(path)


def census(args: Sequence[str], opt: str | None = None, timeout: float = 1800.0) -> Census:
    """The compile census of ``daebench *args`` from an empty kernel cache, and its warm CPU.

    Parameters
    ----------
    args : the daebench command's arguments, e.g. ``["run", "beam-impact", "-i", "hht"]``
    opt : ``NUMBA_OPT`` for the child (0–3); None keeps the environment's (numba: 3)
    timeout : seconds per run
    """
    with probes.fresh_cache("daebench-census-") as env:
        if opt is not None:
            env["NUMBA_OPT"] = str(opt)
        cold = _run(args, env, timeout)
        warm = _run(args, env, timeout)
    fns = [Compiled(**f) for f in cold["functions"]]
    fns.sort(key=lambda f: -f.own_s)
    what = (f"the main job ({loaded_code.MAIN_JOB_CASE} {' '.join(loaded_code.MAIN_JOB_OVERRIDES)}: "
            + ", ".join(n for n, _ in loaded_code.MAIN_JOB) + ")") if list(args) == [MAIN_JOB] else "daebench " + " ".join(args)
    return Census(what, env.get("NUMBA_OPT", "3 (numba default)"), cold["cpu_s"],
                  warm["cpu_s"], sum(f.own_s for f in fns), cold["llvm_s"], cold["rc"], fns)


def markdown(c: Census, top: int = 15) -> str:
    """The census as Markdown: totals, the largest functions (specializations, machine code)
    and the costliest compiles (typing, lowering, LLVM)."""
    code = sum(f.code_bytes for f in c.functions)
    lines = [f"`{c.command}` (NUMBA_OPT {c.opt}; exit {c.returncode})", "",
             f"- CPU from an empty cache {c.cold_cpu_s:.1f} s, warm {c.warm_cpu_s:.1f} s "
             f"(compiling ≈ {c.cold_cpu_s - c.warm_cpu_s:.1f} s)",
             f"- {len(c.functions)} function compiles, {code / 1e6:.2f} MB of machine code, "
             f"{c.compile_s:.1f} s of wall time inside them, of which LLVM {c.llvm_s:.1f} s "
             f"(wall times: inflated by other load on the machine)", "",
             "| function | specializations | machine code [kB] | own time [s] |", "|---|---|---|---|"]
    lines += [f"| {m} | {n} | {b / 1e3:.0f} | {s:.2f} |" for m, n, b, s in c.by_function()[:top]]
    lines += ["", "| module | compiles | own time [s] |", "|---|---|---|"]
    lines += [f"| {m} | {n} | {s:.2f} |" for m, n, s in c.by_module()[:top]]
    lines += ["", "| function | own [s] | typing | lowering | LLVM | code [kB] | signature |",
              "|---|---|---|---|---|---|---|"]
    lines += [f"| {f.name} | {f.own_s:.2f} | {f.typing_s:.2f} | {f.lowering_s:.2f} | {f.llvm_s:.2f} | "
              f"{f.code_bytes / 1e3:.0f} | {f.signature[:60]} |" for f in c.functions[:top]]
    return "\n".join(lines) + "\n"
