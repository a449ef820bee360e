"""A reference's check runs beside its main run: forked where a process may have children,
one after the other in a sweep's (daemonic) worker, with the same results either way."""

from __future__ import annotations

import multiprocessing as mp
import os

import pandas as pd

from daebench.harness.references.side_runs import RunSummary, SideRuns


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
    with SideRuns(JOBS) as side:
        res = side.results()
    assert {k: v.history["x"].tolist() for k, v in res.items()} == {"loose": [2, 4], "perturbed": [3, 9]}
    assert all(v.message != f"pid {os.getpid()}" for v in res.values())   # each ran in its own process


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
