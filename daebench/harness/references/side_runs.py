"""A reference's check runs beside its main run, in forked worker processes.

A reference (:mod:`daebench.harness.references.reference`) is computed three times: the reference
run, a looser check run and a run from a perturbed start. The three are independent, so
the two check runs are forked from the calling process once the reference run there has
taken its first steps (:meth:`SideRuns.start` from its progress callback: its kernels are
compiled by then and the children inherit them, so a cold cache is compiled once, not
three times); on two cores the whole takes about the time of the two longer runs instead
of the sum of the three. The runs are the same function calls on the same inputs as in
one process, so their histories are the same to the last digit.

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


def _child(conn: Any, fn: Callable[[], RunSummary], parent_pid: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the caller's business
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    die_with_parent(parent_pid)
    try:
        msg: tuple = ("ok", fn())
    except BaseException as exc:  # any failure is the caller's to report
        msg = ("raised", exc, f"{type(exc).__name__}: {exc}")
    try:
        conn.send(msg)
    except Exception:  # an exception that cannot be pickled: its text
        conn.send(("raised", None, msg[2] if msg[0] == "raised" else "the result could not be sent"))
    conn.close()


class SideRuns:
    """``jobs`` ({name: function returning a RunSummary}) in forked processes, started by
    :meth:`start` (or by :meth:`results`, which waits for them). A context manager:
    leaving it kills what still runs."""

    def __init__(self, jobs: dict[str, Callable[[], RunSummary]], parallel: bool = True) -> None:
        self.jobs = dict(jobs)
        self.procs: dict[str, tuple[Any, Any]] = {}
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
        for name, fn in self.jobs.items():
            parent, child = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_child, args=(child, fn, os.getpid()), daemon=True,
                               name=f"daebench-reference-{name}")
            proc.start()
            child.close()
            self.procs[name] = (proc, parent)

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
            if name not in self.procs:
                out[name] = fn()
                continue
            proc, conn = self.procs[name]
            try:
                msg = conn.recv()
            except (EOFError, OSError):
                proc.join()
                raise RuntimeError(f"the reference's {name} run ended without a result (its process "
                                   f"{describe_exit(proc.exitcode)})") from None
            proc.join()
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
