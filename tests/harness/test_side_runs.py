"""A reference's check runs beside its main run: shared between the caller and a few forked
workers where a process may have children, one after the other in a sweep's (daemonic)
worker, with the same results either way."""

from __future__ import annotations

import multiprocessing as mp
import os

import pandas as pd

from daebench.harness.references.side_runs import RunSummary, SideRuns, lanes


def _summary(k: int) -> RunSummary:
    return RunSummary("completed", f"pid {os.getpid()}", pd.DataFrame({"t": [0.0, 1.0], "x": [k, k * k]}),
                      [0.5 * k])


JOBS = {"loose": lambda: _summary(2), "perturbed": lambda: _summary(3)}


def _in_a_daemon(conn) -> None:
    try:
        with SideRuns(JOBS) as side:
            res = side.results()
        conn.send({k: (v.history["x"].tolist(), v.impacts, v.message == f"pid {os.getpid()}")
                   for k, v in res.items()})
    except BaseException as exc:  # the test's to report
        conn.send(f"{type(exc).__name__}: {exc}")
    finally:
        os._exit(0)  # a fork of the test process: leave without its exit handlers


def test_check_runs_are_forked_where_children_are_allowed():
    with SideRuns(JOBS, workers=2) as side:
        res = side.results()
    assert {k: v.history["x"].tolist() for k, v in res.items()} == {"loose": [2, 4], "perturbed": [3, 9]}
    pids = {v.message for v in res.values()}
    assert len(pids) == 2 and f"pid {os.getpid()}" not in pids   # each in a worker of its own


def test_one_worker_shares_the_runs_with_the_caller():
    """Five check runs, one worker (two cores): the worker makes three, the caller two after its
    reference run — one child's copy-on-write faults instead of five."""
    assert lanes(list("abcde"), 1) == {"a": 1, "b": 0, "c": 1, "d": 0, "e": 1}
    assert lanes(list("abcde"), 2) == {"a": 1, "b": 2, "c": 0, "d": 1, "e": 2}
    jobs = {k: (lambda k=k: _summary(k)) for k in range(1, 6)}
    with SideRuns(jobs, workers=1) as side:
        res = side.results()
    assert [v.history["x"].tolist() for v in res.values()] == [[k, k * k] for k in range(1, 6)]
    where = [v.message for v in res.values()]
    assert where[1] == where[3] == f"pid {os.getpid()}"
    assert where[0] == where[2] == where[4] != where[1]


def test_check_runs_in_a_sweeps_daemonic_worker_run_there_with_the_same_results():
    """A daemonic process may not have children (multiprocessing refuses it): a reference
    computed inside a sweep's worker made every row of its scene an error row."""
    ctx = mp.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_in_a_daemon, args=(child,), daemon=True)
    proc.start()
    assert parent.poll(60), "the worker sent nothing"
    got = parent.recv()
    proc.join(timeout=60)
    assert got == {"loose": ([2, 4], [1.0], True), "perturbed": ([3, 9], [1.5], True)}
