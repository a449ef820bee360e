"""One worker pool across many sweeps (daebench.harness.sweeps.executors.shared_pool, used by
`daebench survey` for all its cases and rounds): the same processes serve every sweep,
what a worker loaded stays loaded, and nothing is lost — a crash, a hung run and an
interrupted sweep each cost one row (or none), and the pool goes on with a new worker."""

from __future__ import annotations

import os
import time

import pytest

from daebench.core.params import ParamError
from daebench.harness.sweeps import executors as X

_LOADED: set[str] = set()   # what this worker has "loaded" (a kernel, in a real sweep)


def work(spec: tuple[str, int]) -> dict:
    """A run: its pid, whether its 'kernel' was already loaded in this worker; 'crash'
    kills the worker, 'hang' sleeps past the backstop, 'interrupt' raises Ctrl-C in the run."""
    kind, i = spec
    if kind == "crash":
        os._exit(3)
    if kind == "hang":
        time.sleep(60)
    if kind == "interrupt":
        raise KeyboardInterrupt("raised by the run")
    warm = kind in _LOADED
    _LOADED.add(kind)
    return {"run": i, "pid": os.getpid(), "warm": warm, "status": "completed"}


def made(spec, status, message):
    return {"run": spec[1], "status": status, "message": message}


def sweep(specs, jobs=2, fn=work, backstop=None):
    rows = []
    X.run_processes(specs, fn, jobs, rows.append, made, backstop_s=backstop)
    return sorted(rows, key=lambda r: r["run"])


def live(pids) -> list[int]:
    out = []
    for p in pids:
        try:
            state = open(f"/proc/{p}/stat").read().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            out.append(p)
    return out


def test_one_pool_serves_every_sweep_and_keeps_what_workers_loaded():
    """Three sweeps (three 'cases') in one shared pool: two worker processes in all, and
    from the second sweep on every run finds its kernel loaded. Without the pool each
    sweep starts new workers, which load again."""
    with X.shared_pool(2) as pool:
        rows = [sweep([("k", i) for i in range(4)]) for _ in range(3)]
        pids = {r["pid"] for rs in rows for r in rs}
        assert len(pids) == 2 and pool.started == 2
        assert all(r["warm"] for r in rows[1] + rows[2])
        assert [r["run"] for r in rows[2]] == [0, 1, 2, 3]
    assert live(pids) == []                                   # the workers end with the block
    a, b = sweep([("k", 0)], jobs=1), sweep([("k", 0)], jobs=1)
    assert a[0]["pid"] != b[0]["pid"] and not a[0]["warm"] and not b[0]["warm"]   # no pool: new workers, cold


def test_a_crash_and_a_hang_cost_one_row_each_and_the_pool_goes_on():
    """In the shared pool a worker that dies (os._exit(3)) and one stuck beyond the
    backstop become 'crashed' and 'timeout' rows; new workers take their place, the next
    sweep runs on them, and a run raising KeyboardInterrupt is an 'error' row."""
    with X.shared_pool(2) as pool:
        rows = sweep([("k", 0), ("crash", 1), ("k", 2), ("hang", 3), ("interrupt", 4), ("k", 5)], backstop=1.0)
        assert [r["status"] for r in rows] == ["completed", "crashed", "completed", "timeout", "error", "completed"]
        assert "exited with code 3" in rows[1]["message"] and "its worker was killed" in rows[3]["message"]
        assert "KeyboardInterrupt: raised by the run" in rows[4]["message"]
        assert pool.started == 4                               # two replacements
        again = sweep([("k", i) for i in range(4)])
        assert [r["status"] for r in again] == ["completed"] * 4
        assert {r["pid"] for r in again} == {w.proc.pid for w in pool.workers}


def test_an_interrupted_sweep_kills_only_the_busy_worker():
    """Ctrl-C while one worker runs and the other is idle: every finished row was handed
    over, the busy worker is killed, the idle one stays for the next sweep."""
    rows: list[dict] = []

    def on_row(row):
        rows.append(row)
        raise KeyboardInterrupt

    with X.shared_pool(2) as pool:
        with pytest.raises(KeyboardInterrupt):
            X.run_processes([("k", 0), ("hang", 1)], work, 2, on_row, made)
        assert [r["run"] for r in rows] == [0] and len(pool.workers) == 1
        kept = pool.workers[0].proc.pid
        again = sweep([("k", 0), ("k", 1)])
        assert kept in {r["pid"] for r in again} and pool.started == 3


def test_what_the_pool_cannot_hold_runs_on_workers_of_its_own():
    """A run function that cannot be pickled (a closure), or more jobs than the pool has,
    runs as without the pool (same rows); a second pool in one process and a bad job
    count are refused."""
    with X.shared_pool(1) as pool:
        closure = lambda spec: {**work(spec), "closure": True}   # noqa: E731
        rows = sweep([("k", 0), ("k", 1)], fn=closure)
        assert [r["closure"] for r in rows] == [True, True] and pool.started == 0
        rows = sweep([("k", 0), ("k", 1)], jobs=2)
        assert len({r["pid"] for r in rows}) == 2 and pool.started == 0
        with pytest.raises(X.ExecutorError, match="already open"):
            with X.shared_pool(1):
                pass
    with pytest.raises(ParamError, match="--jobs"):
        X.WorkerPool(0)
