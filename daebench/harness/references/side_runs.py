"""A reference's check runs beside its main run, in forked worker processes.

A reference (:mod:`daebench.harness.references.reference`) is computed several times: the
reference run, a looser check run, a run from a perturbed start and the conditioning runs.
They are independent, so the check runs are shared between the calling process, which
makes them after its reference run, and at most ``workers`` forked processes (default: one
per core but the caller's), each making its share one after the other; the workers are
forked once the reference run has taken its first steps (:meth:`SideRuns.start` from its
progress callback: its kernels are compiled by then and the children inherit them, so a
cold cache is compiled once). Few workers, not one per run: each forked child pays
copy-on-write faults on the caller's memory it touches (hertz-chain's reference with its
five check runs in five children: 793 000 minor faults, 8.6 s of system time in them).
The runs are the same function calls on the same inputs as in one process, so their
histories are the same to the last digit.

Where ``fork`` does not exist (Windows), in a daemonic process (a sweep's worker may not
have children) or with ``parallel=False``, the check runs are made one after the other in
the calling process when their results are asked for. A worker ends
with its caller (:func:`daebench.harness.running.child_process.die_with_parent`); a worker that dies
without an answer is reported as a ``RuntimeError`` naming the run and its exit code; an
exception a run raises is raised again in the caller.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import sys
from dataclasses import dataclass, field
from typing import Any, Callable

import pandas as pd

from daebench.harness.running.child_process import describe_exit, die_with_parent


@dataclass
class RunSummary:
    """What a reference needs of a run (picklable: it crosses the process boundary)."""

    status: str
    message: str
    history: pd.DataFrame
    impacts: list[float] = field(default_factory=list)

    @classmethod
    def of(cls, res: Any) -> "RunSummary":
        """The summary of a :class:`daebench.driver.simulate.RunResult`."""
        return cls(res.status, res.message, res.history, [float(i.t) for i in res.impacts])


def _child(conn: Any, fns: list[Callable[[], RunSummary]], parent_pid: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the caller's business
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    die_with_parent(parent_pid)
    for fn in fns:
        try:
            msg: tuple = ("ok", fn())
        except BaseException as exc:  # any failure is the caller's to report
            msg = ("raised", exc, f"{type(exc).__name__}: {exc}")
        try:
            conn.send(msg)
        except Exception:  # an exception that cannot be pickled: its text
            conn.send(("raised", None, msg[2] if msg[0] == "raised" else "the result could not be sent"))


def lanes(names: list[str], workers: int) -> dict[str, int]:
    """Which lane makes each run: 1 … ``workers`` a forked worker, 0 the caller (after its
    reference run, which counts as one run of its lane), dealt in turn from lane 1."""
    order = list(range(1, workers + 1)) + [0]
    return {name: order[i % len(order)] for i, name in enumerate(names)}


class SideRuns:
    """``jobs`` ({name: function returning a RunSummary}) shared between the caller and at
    most ``workers`` forked processes (:func:`lanes`), started by :meth:`start` (or by
    :meth:`results`, which waits for them). A context manager: leaving it kills what still runs."""

    def __init__(self, jobs: dict[str, Callable[[], RunSummary]], parallel: bool = True,
                 workers: int | None = None) -> None:
        self.jobs = dict(jobs)
        self.workers = max(1, (os.cpu_count() or 2) - 1) if workers is None else int(workers)
        if self.workers < 1:
            raise ValueError(f"workers = {workers!r}: at least one forked worker (or parallel=False)")
        self.procs: dict[int, tuple[Any, Any]] = {}   # lane → (process, its pipe)
        self.lane: dict[str, int] = {}
        # a daemonic process (a sweep's worker) may not have children: there the check runs
        # are made one after the other, as where fork does not exist
        self.parallel = bool(parallel and "fork" in mp.get_all_start_methods()
                             and not mp.current_process().daemon)
        self.started = False

    def start(self, *_: Any) -> None:
        """Fork the workers (once; later calls do nothing). Takes and ignores the
        arguments of a progress callback, so that it can be one."""
        if self.started:
            return
        self.started = True
        if not (self.parallel and self.jobs):
            return
        ctx = mp.get_context("fork")
        for f in (sys.stdout, sys.stderr):  # a child flushes what it inherited: flush it here first
            try:
                f.flush()
            except (OSError, ValueError, AttributeError):
                pass
        self.lane = lanes(list(self.jobs), self.workers)
        for k in sorted(set(self.lane.values()) - {0}):
            fns = [fn for name, fn in self.jobs.items() if self.lane[name] == k]
            parent, child = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_child, args=(child, fns, os.getpid()), daemon=True,
                               name=f"daebench-reference-check-{k}")
            proc.start()
            child.close()
            self.procs[k] = (proc, parent)

    def results(self) -> dict[str, RunSummary]:
        """{name: RunSummary}, in the order of ``jobs``.

        Raises
        ------
        RuntimeError
            A worker died without an answer (killed, out of memory).
        Exception
            What a run raised (its own type where it could be pickled).
        """
        self.start()
        out = {}
        for name, fn in self.jobs.items():
            if not self.lane.get(name):
                out[name] = fn()
                continue
            proc, conn = self.procs[self.lane[name]]
            try:
                msg = conn.recv()   # a worker sends its runs' results in the order of jobs
            except (EOFError, OSError):
                proc.join()
                raise RuntimeError(f"the reference's {name} run ended without a result (its process "
                                   f"{describe_exit(proc.exitcode)})") from None
            if msg[0] == "raised":
                raise msg[1] if isinstance(msg[1], BaseException) else RuntimeError(
                    f"the reference's {name} run raised {msg[2]}")
            out[name] = msg[1]
        return out

    def close(self) -> None:
        """Kill the workers still running and release their pipes."""
        for proc, conn in self.procs.values():
            if proc.is_alive():
                proc.kill()
            proc.join()
            conn.close()
        self.procs = {}

    def __enter__(self) -> "SideRuns":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
