"""Cold start: how long a newcomer's first commands take with an empty kernel cache.

Each command runs in a fresh subprocess with ``NUMBA_CACHE_DIR`` set to a new empty
temporary folder (so every compiled kernel is compiled, as in a fresh environment),
then once more with the same folder (cache warm). Every line the command prints (stdout
and stderr) is time-stamped, which gives the time to the first output and the longest
silence — the "nothing silent over ~2 s" promise, measured.

``python -m daebench.studies.coldstart`` prints the figures; :func:`measure` returns them
(the perf study reports them).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass
from typing import Sequence

#: name → daebench arguments. The README's main job is `daebench compare beam-impact`; in an
#: empty results folder its cold run includes computing the reference (IDA rtol 1e-11).
COMMANDS: dict[str, list[str]] = {
    "run beam-impact --integrator hht": ["run", "beam-impact", "--integrator", "hht"],
    "README main job: compare beam-impact": ["compare", "beam-impact"],
}
CACHE_ENV = "NUMBA_CACHE_DIR"


@dataclass
class ColdStart:
    """Wall times [s] of one command: first run with an empty cache, then warm."""

    name: str
    command: str
    cold_s: float
    warm_s: float
    first_output_s: float      # cold run: time to its first printed line
    longest_silence_s: float   # cold run: longest gap between printed lines (and to the end)
    returncode: int


def _timed_run(args: Sequence[str], env: dict[str, str], timeout: float) -> tuple[float, list[float], int]:
    """Wall time, time stamps of every output line, return code."""
    stamps: list[float] = []
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "daebench.cli.app", *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)

    def follow(stream) -> None:
        for _ in stream:
            stamps.append(time.perf_counter() - t0)

    threads = [threading.Thread(target=follow, args=(s,), daemon=True) for s in (proc.stdout, proc.stderr)]
    for t in threads:
        t.start()
    try:
        rc = proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        rc = proc.wait()
    wall = time.perf_counter() - t0
    for t in threads:
        t.join()
    return wall, sorted(stamps), rc


def measure(commands: dict[str, list[str]] | None = None, timeout: float = 1800.0) -> list[ColdStart]:
    """Cold and warm wall time of each command (default :data:`COMMANDS`), each in a fresh
    subprocess with its own empty kernel cache and results folder."""
    out = []
    for name, args in (commands or COMMANDS).items():
        with tempfile.TemporaryDirectory(prefix="daebench-coldstart-") as tmp:
            env = dict(os.environ, **{CACHE_ENV: os.path.join(tmp, "cache"),
                                      "DAEBENCH_RESULTS": os.path.join(tmp, "results")})
            cold, stamps, rc = _timed_run(args, env, timeout)
            warm, _, _ = _timed_run(args, env, timeout)
        gaps = [b - a for a, b in zip([0.0] + stamps, stamps + [cold])]
        out.append(ColdStart(name, "daebench " + " ".join(args), cold, warm, stamps[0] if stamps else cold,
                             max(gaps), rc))
    return out


def markdown(results: Sequence[ColdStart]) -> str:
    """The figures as a Markdown table."""
    lines = ["| command | first run, empty cache [s] | warm [s] | first output [s] | longest silence [s] |",
             "|---|---|---|---|---|"]
    for r in results:
        lines.append(f"| `{r.command}` | {r.cold_s:.1f} | {r.warm_s:.1f} | {r.first_output_s:.1f} | "
                     f"{r.longest_silence_s:.1f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":  # pragma: no cover
    import json

    res = measure()
    print(markdown(res))
    print(json.dumps([asdict(r) for r in res], indent=2))
