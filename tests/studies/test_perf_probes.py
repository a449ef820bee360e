"""daebench.studies.perf.probes: how `daebench perf` measures — a fresh process's CPU time
against a busy loop of known length, wall against CPU time of a sleep, an empty kernel cache
and results folder of its own, and a command's output lines stamped as they come."""

from __future__ import annotations

import os
import time

import pytest

from daebench.studies.perf import probes


def test_wall_counts_a_sleep_and_cpu_does_not():
    _, w = probes.wall(lambda: time.sleep(0.2))
    _, c = probes.cpu(lambda: time.sleep(0.2))
    assert w >= 0.2 and c < 0.05


def test_a_fresh_processs_cpu_time_is_its_busy_loop():
    """The child burns 0.5 s of CPU (process_time measured in the child); the parent's
    account of the child's user + system time agrees (a shared machine adds a little)."""
    code = ("import time\nt = time.process_time()\nwhile time.process_time() - t < 0.5:\n    pass\n"
            "print(time.process_time())")
    cpu, proc = probes.run_python(code, [], dict(os.environ), timeout=60)
    assert proc.returncode == 0
    assert cpu == pytest.approx(float(proc.stdout), abs=0.15) and cpu >= 0.5


def test_fresh_cache_is_empty_and_its_own_and_goes_away():
    with probes.fresh_cache() as env:
        cache, results = env["NUMBA_CACHE_DIR"], env["DAEBENCH_RESULTS"]
        assert cache != os.environ.get("NUMBA_CACHE_DIR") and not os.path.exists(cache)
        assert os.path.dirname(cache) == os.path.dirname(results)
        root = os.path.dirname(cache)
        assert os.path.isdir(root) and os.listdir(root) == []
    assert not os.path.exists(root)


def test_a_commands_lines_are_stamped_in_order():
    elapsed, stamps, rc = probes.run_command(["--help"], dict(os.environ), timeout=120)
    assert rc == 0 and stamps and stamps == sorted(stamps) and 0.0 < stamps[-1] <= elapsed
