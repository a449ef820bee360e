"""What every peer worker shares (standard library and numpy only: a worker runs in the peer's
own interpreter, which need not have daebench's dependencies).

The request (JSON on stdin): ``sheet`` (the case sheet of `daebench export`), ``method``,
``h`` [s], ``csv`` (the trajectory file to write), ``label``. The worker writes the file in
the format `daebench score` reads (a ``t`` column and the case's observables in its units,
``# key: value`` metadata lines first) and its impacts beside it as ``<file>-impacts.csv``
(columns ``t``, ``contact``), then prints one JSON line: ``cpu_s`` (the CPU time of the
simulation loop in this process, set-up and writing excluded), ``steps``, ``impacts``,
``rows``, ``code``, ``method``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any, Callable


class Refused(Exception):
    """The peer cannot run this case or method (the message says what it can)."""


def request() -> dict[str, Any]:
    return json.loads(sys.stdin.read())


def values(sheet: dict[str, Any]) -> dict[str, Any]:
    """The scene's keys and values from the case sheet's ``parameters``."""
    return {p["key"]: p["value"] for p in sheet["parameters"]}


def steps_of(t_end: float, h: float) -> int:
    """Fixed steps that land on t_end (the step must divide it within 1e-9 of a step)."""
    n = int(round(t_end / h))
    if n < 1 or abs(n * h - t_end) > 1e-9 * h * max(n, 1):
        raise Refused(f"step h = {h!r} s does not divide t_end = {t_end!r} s; choose h = t_end / n")
    return n


def timed(loop: Callable[[], Any]) -> tuple[Any, float]:
    """(loop(), its CPU time in this process [s])."""
    c0 = time.process_time()
    out = loop()
    return out, time.process_time() - c0


def write(req: dict[str, Any], columns: list[str], rows: list[tuple[float, ...]],
          impacts: list[tuple[float, int]] | None, meta: dict[str, Any]) -> None:
    """The trajectory file, its impacts file beside it (None: a case without contacts, no
    file), and the result line on stdout."""
    path = Path(req["csv"])
    lines = [f"# {k}: {v}" for k, v in {"label": req["label"], **meta}.items()]
    lines.append(",".join(columns))
    lines += [",".join(repr(float(x)) for x in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    imp = impacts_path(path)
    if impacts is not None:
        imp.write_text("t,contact\n" + "".join(f"{float(t)!r},{int(c)}\n" for t, c in impacts))
    print(json.dumps({"cpu_s": float(meta["cost_s"]), "steps": meta["steps"],
                      "impacts": None if impacts is None else len(impacts), "rows": len(rows),
                      "code": meta["code"], "method": meta["method"],
                      "impacts_file": None if impacts is None else str(imp)}))


def impacts_path(path: Path) -> Path:
    """``<file>-impacts.csv`` beside the trajectory file."""
    return path.with_name(path.stem + "-impacts.csv")


def main(run: Callable[[dict[str, Any]], None]) -> None:
    """Run ``run(request)``; a refusal is exit 3 with its message on stderr."""
    try:
        run(request())
    except Refused as exc:
        sys.stderr.write(f"{exc}\n")
        sys.exit(3)
