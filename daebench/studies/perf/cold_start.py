"""Cold start: how long a newcomer's first commands take with an empty kernel cache.

Each command runs in a fresh process with an empty kernel cache (:func:`.probes.fresh_cache`:
every kernel is compiled, as in a fresh environment), then once more with the same cache
(warm). Every line the command prints (stdout
and stderr) is time-stamped, which gives the time to the first output and the longest
silence — the "nothing silent over ~2 s" promise, measured.

``daebench perf --section cold-start`` prints the figures; :func:`measure` returns them
(``daebench perf`` reports them with ``coldstart`` on).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from daebench.studies.perf import probes

#: name → daebench arguments. The README's main job is `daebench compare beam-impact`; in an
#: empty results folder its cold run includes computing the reference (IDA rtol 1e-11).
COMMANDS: dict[str, list[str]] = {
    "run beam-impact --integrator hht": ["run", "beam-impact", "--integrator", "hht"],
    "README main job: compare beam-impact": ["compare", "beam-impact"],
}


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


def measure(commands: dict[str, list[str]] | None = None, timeout: float = 1800.0) -> list[ColdStart]:
    """Cold and warm wall time of each command (default :data:`COMMANDS`), each in a fresh
    subprocess with its own empty kernel cache and results folder."""
    out = []
    for name, args in (commands or COMMANDS).items():
        with probes.fresh_cache("daebench-coldstart-") as env:
            cold, stamps, rc = probes.run_command(args, env, timeout)
            warm, _, _ = probes.run_command(args, env, timeout)
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
