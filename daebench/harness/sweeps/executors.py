"""Where a sweep's runs execute: this process or worker processes (a Dask cluster:
:mod:`.dask_cluster`).

Every executor takes the planned runs and a function ``fn(spec) -> row`` that never
raises for an ordinary failure (:func:`daebench.harness.sweeps.row.execute`), and hands each row to
``on_row`` in the calling process as soon as it exists (the sweep stores it on disk
there). What a run cannot report itself becomes its row here:

* a worker process that dies (segfault, ``os._exit``, out of memory) → status
  ``crashed`` with the signal or exit code; a new worker takes the next run, so one
  crash costs one row (the stdlib ``ProcessPoolExecutor`` marks every pending run of a
  broken pool failed, hence this small pool);
* a run that outlives its wall-time cap even though :func:`daebench.harness.running.deadline.deadline`
  should have stopped it (stuck in C code) → its worker is killed, status ``timeout``;
* a ``KeyboardInterrupt`` or ``SystemExit`` raised *by the run* in a worker (workers
  ignore SIGINT: only the sweep's own process reacts to Ctrl-C) → status ``error``.

SIGINT (``KeyboardInterrupt`` in the calling process) kills the workers at once and
propagates, after every finished row has been handed over; SIGTERM does the same while
runs execute (:func:`sigterm_as_interrupt`: ``kill PID`` keeps the rows and the table like
Ctrl-C). A worker never outlives its sweep: on Linux the kernel kills it when the process
that started it dies (``PR_SET_PDEATHSIG``, so even ``kill -9`` of the sweep leaves no
orphan), and everywhere a watcher thread in the worker ends it within
``PARENT_POLL_S`` once its parent is gone (:mod:`daebench.harness.running.child_process`).

**One pool for many sweeps.** A worker keeps what its runs loaded (numba kernels, the
models' modules, :mod:`daebench.harness.sweeps.row`'s warm-up record) for as long as it
lives. By default each :func:`run_processes` call starts its own workers and ends them;
inside ``with shared_pool(jobs):`` every call of this process runs on the same workers
(the survey: all cases and rounds), each call's run function sent to a worker once
(pickled; a function that cannot be pickled runs on workers of its own, as without the
pool). A worker that crashes or is killed is replaced by a new one; a worker busy when
the sweep is interrupted is killed. Integrators registered in this process after the
pool started are not known to its workers.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import pickle
import signal
import threading
import time
from collections import deque
from contextlib import contextmanager
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Iterator, Sequence

from daebench.core.params import ParamError
from daebench.harness.running.child_process import describe_exit, die_with_parent

POLL_S = 0.25               # how often the pool looks at its workers
BACKSTOP_GRACE_S = 30.0     # a run is killed this long after its cap would have stopped it

Row = dict[str, Any]


class ExecutorError(ParamError):
    """An executor that cannot be used (bad job count, unreachable scheduler …)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM received while a sweep's runs execute: handled as Ctrl-C (rows kept, table written)."""


@contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """While the block runs (in the main thread), SIGTERM raises :class:`Terminated` —
    a KeyboardInterrupt, so the sweep stops as on Ctrl-C: finished rows kept, the
    partial table written, the resume command printed."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: Any) -> None:
        raise Terminated("terminated (SIGTERM)")

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def run_inline(specs: Sequence[Any], fn: Callable[[Any], Row], on_row: Callable[[Row], None],
               on_running: Callable[[list[Any]], None] | None = None) -> None:
    """Each run in this process, one after the other (no crash isolation: for debugging
    and for callers that registered integrators in this process only)."""
    with sigterm_as_interrupt():
        for s in specs:
            if on_running is not None:
                on_running([s])
            on_row(fn(s))


# ---- worker processes ----------------------------------------------------------------
def _worker_main(conn: Connection, fn: Callable[[Any], Row] | None, parent_pid: int) -> None:
    """A worker's loop: ``("fn", f)`` sets the run function, ``("run", spec)`` runs one
    spec and answers ``("row", row)`` (or ``("raised", why)``), ``None`` ends it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the sweep's business, not the worker's
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the sweep's handler (inherited through fork)
    die_with_parent(parent_pid)
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        kind, payload = msg
        if kind == "fn":
            fn = payload
            continue
        try:
            conn.send(("row", fn(payload)))  # type: ignore[misc]
        except BaseException as exc:  # KeyboardInterrupt/SystemExit raised by the run itself
            conn.send(("raised", f"{type(exc).__name__}: {exc}"))


@dataclass
class _Worker:
    proc: Any
    conn: Connection
    fn: Any = None        # the run function this worker holds
    spec: Any = None
    started: float = 0.0


def _context() -> Any:
    # fork: workers inherit the loaded modules and kernels (and integrators registered in
    # this process); spawn where fork does not exist
    return mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")


class WorkerPool:
    """Up to ``jobs`` worker processes, started when first needed and kept until
    :meth:`close` (see the module docstring: one pool for many sweeps)."""

    def __init__(self, jobs: int) -> None:
        if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
            raise ExecutorError(f"--jobs must be a whole number of worker processes >= 1, got {jobs!r}")
        self.jobs = jobs
        self.workers: list[_Worker] = []
        self.started = 0          # worker processes started over the pool's life (replacements included)
        self._ctx = _context()

    def spawn(self, fn: Callable[[Any], Row] | None) -> _Worker:
        """A new worker holding ``fn`` (inherited through fork, or pickled under spawn)."""
        parent, child = self._ctx.Pipe()
        proc = self._ctx.Process(target=_worker_main, args=(child, fn, os.getpid()), daemon=True)
        proc.start()
        child.close()
        self.started += 1
        return _Worker(proc, parent, fn)

    def discard(self, w: _Worker) -> None:
        """Kill ``w`` (if alive) and release its pipe."""
        if w.proc.is_alive():
            w.proc.kill()
        w.proc.join()
        w.conn.close()

    def close(self) -> None:
        """End every worker: an idle one is asked to stop, a busy or stuck one is killed."""
        for w in self.workers:
            if w.spec is None and w.proc.is_alive():
                try:
                    w.conn.send(None)
                except OSError:
                    pass
        deadline = time.monotonic() + 2.0
        for w in self.workers:
            if w.spec is not None:  # interrupted mid-run: stop it now
                w.proc.kill()
            w.proc.join(timeout=max(0.0, deadline - time.monotonic()))
            if w.proc.is_alive():
                w.proc.kill()
                w.proc.join()
            w.conn.close()
        self.workers = []


_SHARED: WorkerPool | None = None   # the pool of `with shared_pool(...)`, in the process that opened it
_SHARED_PID = -1


@contextmanager
def shared_pool(jobs: int) -> Iterator[WorkerPool]:
    """Within the block, every :func:`run_processes` call of this process with at most
    ``jobs`` workers runs on the same worker processes; they end with the block."""
    global _SHARED, _SHARED_PID
    if _SHARED is not None and _SHARED_PID == os.getpid():
        raise ExecutorError("a shared worker pool is already open in this process")
    pool = WorkerPool(jobs)
    _SHARED, _SHARED_PID = pool, os.getpid()
    try:
        yield pool
    finally:
        _SHARED, _SHARED_PID = None, -1
        pool.close()


def _picklable(fn: Any) -> bool:
    try:
        pickle.dumps(fn)
    except Exception:  # lambdas, local functions, objects holding a lock …
        return False
    return True


def run_processes(specs: Sequence[Any], fn: Callable[[Any], Row], jobs: int, on_row: Callable[[Row], None],
                  make_row: Callable[[Any, str, str], Row],
                  on_running: Callable[[list[Any]], None] | None = None,
                  backstop_s: float | None = None) -> None:
    """Runs on ``jobs`` worker processes, one run per worker at a time: the shared pool's
    workers inside :func:`shared_pool` (when ``jobs`` fits it and ``fn`` can be pickled),
    else workers started and ended here.

    ``make_row(spec, status, message)`` builds the row of a run that could not report
    itself; ``backstop_s`` is the wall time after which a run's worker is killed."""
    shared = _SHARED if _SHARED is not None and _SHARED_PID == os.getpid() else None
    if shared is not None and (jobs > shared.jobs or not _picklable(fn)):
        shared = None
    pool = shared if shared is not None else WorkerPool(max(1, jobs))
    pending = deque(specs)
    with sigterm_as_interrupt():
        try:
            _run_pool(pending, pool, fn, max(1, min(jobs, len(specs))), on_row, make_row, on_running, backstop_s)
        finally:
            if shared is None:
                pool.close()
            else:  # a worker still busy was interrupted mid-run: it goes, the others stay for the next sweep
                for w in [w for w in pool.workers if w.spec is not None]:
                    pool.discard(w)
                    pool.workers.remove(w)


def _run_pool(pending: deque, pool: WorkerPool, fn: Callable[[Any], Row], n: int,
              on_row: Callable[[Row], None], make_row: Callable[[Any, str, str], Row],
              on_running: Callable[[list[Any]], None] | None, backstop_s: float | None) -> None:
    workers = pool.workers
    while len(workers) < n:
        workers.append(pool.spawn(fn))
    mine = workers[:n]
    while pending or any(w.spec is not None for w in mine):
        for i, w in enumerate(mine):
            if w.spec is None and pending:
                if not w.proc.is_alive():  # a kept worker that ended while idle (killed from outside)
                    pool.discard(w)
                    workers[workers.index(w)] = mine[i] = w = pool.spawn(fn)
                if w.fn is not fn:
                    w.conn.send(("fn", fn))
                    w.fn = fn
                w.spec, w.started = pending.popleft(), time.monotonic()
                w.conn.send(("run", w.spec))
        busy = [w for w in mine if w.spec is not None]
        if on_running is not None:
            on_running([w.spec for w in busy])
        wait([w.conn for w in busy] + [w.proc.sentinel for w in busy], timeout=POLL_S)
        for i, w in enumerate(mine):
            if w.spec is None:
                continue
            row, gone = None, False
            if w.conn.poll():
                try:
                    kind, payload = w.conn.recv()
                    row = payload if kind == "row" else make_row(w.spec, "error", f"the run raised {payload}")
                except (EOFError, OSError):
                    pass  # died while sending: handled as a crash below
            if row is None and not w.proc.is_alive():
                w.proc.join()
                row, gone = make_row(w.spec, "crashed", f"worker process {describe_exit(w.proc.exitcode)}"), True
            elif row is None and backstop_s is not None and time.monotonic() - w.started > backstop_s:
                row, gone = make_row(w.spec, "timeout", f"run still going after {backstop_s:g} s (beyond its "
                                                        f"wall-time cap); its worker was killed"), True
            if row is None:
                continue
            if gone:  # a new worker takes its place, in the pool and in this sweep
                pool.discard(w)
                new = pool.spawn(fn)
                workers[workers.index(w)] = mine[i] = new
            else:
                w.spec = None
            on_row(row)
