"""How `daebench perf` measures: timers around a call, and a command run in a fresh process
with an empty kernel cache (so every kernel is compiled, as in a fresh environment).

* :func:`wall` and :func:`cpu` — a call and its wall (``perf_counter``) or CPU
  (``process_time``) seconds;
* :func:`fresh_cache` — an environment with ``NUMBA_CACHE_DIR`` and ``DAEBENCH_RESULTS`` in
  a new temporary folder (removed afterwards); the processes given it share that cache;
* :func:`run_command` — ``daebench ARGS`` in a fresh process: its wall time and the time
  stamp of every line it prints;
* :func:`run_python` — Python code in a fresh process: its CPU time (user + system, less
  sensitive to the machine's load than wall time) and what it printed.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Sequence

#: the command line, run by module name (a study does not import the CLI layer above it)
DAEBENCH = [sys.executable, "-m", "daebench.cli.app"]


def wall(fn: Callable[[], Any]) -> tuple[Any, float]:
    """``fn()`` and its wall time [s]."""
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def cpu(fn: Callable[[], Any]) -> tuple[Any, float]:
    """``fn()`` and the CPU time of this process while it ran [s]."""
    t = time.process_time()
    out = fn()
    return out, time.process_time() - t


@contextmanager
def fresh_cache(prefix: str = "daebench-perf-") -> Iterator[dict[str, str]]:
    """This process's environment with an empty kernel cache and results folder of its own."""
    with tempfile.TemporaryDirectory(prefix=prefix) as tmp:
        yield dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, "cache"),
                   DAEBENCH_RESULTS=os.path.join(tmp, "results"))


def run_command(args: Sequence[str], env: dict[str, str], timeout: float) -> tuple[float, list[float], int]:
    """``daebench *args`` in a fresh process: wall time, time stamps of every output line
    (stdout and stderr), return code."""
    stamps: list[float] = []
    t0 = time.perf_counter()
    proc = subprocess.Popen([*DAEBENCH, *args], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    def follow(stream: Any) -> None:
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
    elapsed = time.perf_counter() - t0
    for t in threads:
        t.join()
    return elapsed, sorted(stamps), rc


def run_python(code: str, args: Sequence[str], env: dict[str, str], timeout: float
               ) -> tuple[float, subprocess.CompletedProcess]:
    """``python -c code *args`` in a fresh process: its CPU time [s] and the finished process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True,
                          timeout=timeout, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), proc
