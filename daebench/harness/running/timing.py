"""The timing rule of every sweep row: a warm-up, then the minimum of a few timed calls;
a call in which numba compiled does not count."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable

from daebench.harness.running.compile_events import compiled_during

#: The timing rule of every sweep row (a work-precision line must reflect the method, not
#: start-up: a first call in a process loads compiled code from the numba cache, 0.4 s for
#: beam-impact, and warms the CPU caches):
#: one warm-up call, stopped after WARMUP_CAP_S of wall time (a warm-up only has to load
#: what the run uses), then timed calls — REPEATS of them while each takes less than
#: SHORT_RUN_S (the minimum is kept), one for a longer run (its start-up is then a small
#: part of its time), and none after TIME_CAP_S of timed wall in total.
REPEATS = 3
SHORT_RUN_S = 1.0
WARMUP_CAP_S = 1.0
TIME_CAP_S = 60.0


@dataclass
class Timing:
    """Minimum wall and CPU time of the timed repeats, how many were made, and the CPU
    times' spread ((largest − smallest) / smallest; NaN for one repeat): the resolution
    below which two runs' costs are a tie."""

    wall_s: float
    cpu_s: float
    repeats: int
    result: Any = None
    cpu_spread: float = float("nan")


def time_call(fn: Callable[[], Any], repeats: int = REPEATS, warmup: bool = True,
              time_cap: float = TIME_CAP_S, short_s: float = SHORT_RUN_S,
              warmup_fn: Callable[[], Any] | None = None) -> Timing:
    """Time ``fn()`` by the rule above: a warm-up call (``warmup_fn`` if given, e.g. the
    run under a wall-time cap, else ``fn``), then the minimum wall (perf_counter) and CPU
    (process_time) of up to ``repeats`` calls, repeating only while a call takes less
    than ``short_s`` and the timed calls total less than ``time_cap``.

    At least one timed call is always made. Without ``warmup_fn``, a warm-up that alone
    exceeds ``time_cap`` is the timed call. A timed call in which numba compiled (a
    capped warm-up may stop before a code path, e.g. the first impact, is reached) is
    not counted and is made again. The last result is returned.
    """
    result = None
    walls, cpus = [], []
    if warmup:
        w0, c0 = time.perf_counter(), time.process_time()
        result = (warmup_fn or fn)()
        w, c = time.perf_counter() - w0, time.process_time() - c0
        if warmup_fn is None and w > time_cap:
            return Timing(w, c, 1, result)
    spent, discarded = 0.0, 0
    while len(walls) < max(1, int(repeats)):
        w0, c0 = time.perf_counter(), time.process_time()
        result, compiled = compiled_during(fn)
        w, c = time.perf_counter() - w0, time.process_time() - c0
        if compiled and discarded < MAX_DISCARDED:
            discarded += 1          # numba compiled in it (past a capped warm-up): not a time of the method
            continue
        walls.append(w)
        cpus.append(c)
        spent += w
        if spent > time_cap or w >= short_s:
            break
    spread = (max(cpus) - min(cpus)) / min(cpus) if len(cpus) > 1 and min(cpus) > 0 else float("nan")
    return Timing(min(walls), min(cpus), len(walls), result, spread)


#: timed calls in which numba compiled are run again, at most this many times (compilation
#: happens once per process, so one is enough; the bound only guards against a loop)
MAX_DISCARDED = 2
