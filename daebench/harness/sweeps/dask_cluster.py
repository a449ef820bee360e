"""A sweep's runs on a Dask cluster, with the cluster's faults told apart from the runs'.

* **The address is checked first** (:func:`probe_scheduler`): within the connect timeout
  the port must answer as a Dask scheduler does (it speaks first: an 8-byte frame length
  and its handshake). Nothing listening, an HTTP server (the dashboard's port, say), a
  service that sends other bytes, or one that accepts and stays silent are each named,
  before a client is made.
* **A lost scheduler** stops the sweep with :class:`ClusterLost` (one line: what was lost
  and where); the runs in flight get no row (they are ``interrupted`` in the partial
  table) so that ``--resume`` on a restarted cluster runs them.
* **A lost worker**: the sweep follows the scheduler's own account of each worker that
  leaves the cluster unasked (``kill -9``, out of memory, its machine gone; the scheduler's
  ``remove-worker`` event, to which the sweep subscribes before its first run is submitted,
  names the runs it had on that worker). Such a run becomes a ``crashed`` row naming the
  worker whether or not the sweep ever saw where it ran, and its future is released, so
  that no worker — one already there, or one that joins later — runs it for the sweep
  again (the scheduler may already have handed it to another worker: that run is
  cancelled and its result never used; a scheduler started with
  ``distributed.scheduler.allowed-failures: 0`` hands it to none). A run that had finished
  on the worker but whose result went with it is ``crashed`` the same way. Such a row
  carries ``lost_worker``: a ``--resume`` runs it again, as the cluster, not the run,
  failed (:meth:`daebench.harness.sweeps.store.SweepStore.open`). A worker the scheduler
  retires on purpose (``retire_workers``) hands its runs on and crashes none.
* **No workers**: a cluster that has had no worker for ``no_workers_s`` seconds while
  runs wait stops the sweep with :class:`ClusterLost` (the bound is ``--no-workers-timeout``);
  the runs lost with the last worker are ``crashed`` rows first, the others interrupted.

A ``KilledWorker`` raised by the scheduler itself is a ``crashed`` row too: after one
worker's death (``allowed-failures: 0``) it is a lost worker's row as above; after several
(the run was on that many workers that died: the run likely kills them) a row a resume
keeps. The distributed library's own log lines (reconnection attempts, tracebacks of a
closed comm) are held back while a sweep runs on the cluster: the sweep says what
happened, once.
"""

from __future__ import annotations

import logging
import socket
import struct
import time
from collections import deque
from contextlib import contextmanager
from typing import Any, Callable, Iterator, Sequence
from urllib.parse import urlsplit

from daebench.harness.sweeps.executors import POLL_S, ExecutorError, Row

DASK_CONNECT_TIMEOUT = 10.0   # s to reach a Dask scheduler and hear its handshake
NO_WORKERS_TIMEOUT = 60.0     # s a cluster may have no worker while runs wait (--no-workers-timeout)
CLOSE_TIMEOUT = 5.0           # s to close a client (its scheduler may be gone)
RESULT_S = 1.0                # s to read a finished run's row before looking at the cluster again (doubled
                              # on each try of the same run, up to RESULT_MAX_S)
RESULT_MAX_S = 60.0
HANDSHAKE_MAX_BYTES = 1 << 20  # a scheduler's handshake is some hundred bytes
HTTP_PROBE_S = 2.0            # of the connect timeout, kept to ask a silent port whether it speaks HTTP
DEFAULT_PORT = 8786


class ClusterLost(ExecutorError):
    """The Dask scheduler, or every worker, was lost while runs were in flight. The runs
    without a row are interrupted (``--resume`` runs them); the sweep attaches its partial
    ``table``, the ``path`` written and the table's ``name``. The command line exits 1."""

    exit_code = 1
    table: Any = None
    path: Any = None
    name: str | None = None


def _endpoint(address: str) -> tuple[str, int]:
    parts = urlsplit(address)
    try:
        port = parts.port or DEFAULT_PORT
    except ValueError:
        raise ExecutorError(f"--scheduler {address!r}: the port is not a number (e.g. tcp://host:8786)") from None
    if not parts.hostname:
        raise ExecutorError(f"--scheduler {address!r} names no host (e.g. tcp://127.0.0.1:8786)")
    return parts.hostname, port


def _read(sock: socket.socket, n: int, until: float) -> bytes:
    """Up to ``n`` bytes before the monotonic time ``until`` (fewer when the peer closes or is silent)."""
    data = b""
    while len(data) < n:
        left = until - time.monotonic()
        if left <= 0:
            break
        sock.settimeout(left)
        try:
            chunk = sock.recv(n - len(data))
        except (socket.timeout, TimeoutError):
            break
        except OSError:
            break
        if not chunk:
            break
        data += chunk
    return data


def probe_scheduler(address: str, timeout: float) -> None:
    """Check, within ``timeout`` seconds, that a Dask scheduler answers at the ``tcp://``
    ``address`` (other schemes are left to the client).

    Raises
    ------
    ExecutorError
        Saying what answered: nothing (connection refused, no route, no answer in time), an
        HTTP server, a service whose first bytes are not a Dask handshake, or one silent.
    """
    if not address.startswith("tcp://"):
        return
    host, port = _endpoint(address)
    where = f"{host}:{port}"
    lead = f"cannot reach the Dask scheduler at {address}: "
    hint = ("start one with `dask scheduler` (its port is 8786 by default; 8787 is its dashboard), or use "
            "--scheduler local")
    until = time.monotonic() + timeout
    try:
        sock = socket.create_connection((host, port), timeout=timeout)
    except (socket.timeout, TimeoutError):
        raise ExecutorError(f"{lead}no answer from {where} within {timeout:g} s; {hint}") from None
    except ConnectionRefusedError:
        raise ExecutorError(f"{lead}nothing listens at {where} (connection refused); {hint}") from None
    except OSError as exc:
        raise ExecutorError(f"{lead}{exc.strerror or exc}; {hint}") from None
    with sock:
        head = _read(sock, 8, until - min(HTTP_PROBE_S, timeout / 5))
        if not head:   # a Dask scheduler speaks first; an HTTP server waits for a request
            try:
                sock.sendall(f"GET / HTTP/1.0\r\nHost: {host}\r\n\r\n".encode())
            except OSError:
                pass
            reply = _read(sock, 64, until)
            if reply.startswith(b"HTTP/"):
                status = reply.split(b"\r\n", 1)[0].decode("latin-1")
                raise ExecutorError(f"{lead}an HTTP server answers at {where} ({status!r}), not a Dask scheduler; "
                                    f"{hint}")
            raise ExecutorError(f"{lead}something accepts connections at {where} but sent no Dask handshake within "
                                f"{timeout:g} s" + (f" (its answer to an HTTP request: {reply[:40]!r})" if reply
                                                    else "") + f": not a Dask scheduler; {hint}")
        if head.startswith(b"HTTP/"):
            raise ExecutorError(f"{lead}an HTTP server answers at {where} ({head!r}…), not a Dask scheduler; {hint}")
        (n,) = struct.unpack("<Q", head.ljust(8, b"\0"))
        body = _read(sock, min(n, HANDSHAKE_MAX_BYTES), until) if 0 < n <= HANDSHAKE_MAX_BYTES else b""
        if len(head) < 8 or not 0 < n <= HANDSHAKE_MAX_BYTES or len(body) < n or b"compression" not in body:
            raise ExecutorError(f"{lead}the service at {where} is not a Dask scheduler: its first bytes "
                                f"{(head + body)[:24]!r} are no Dask handshake; {hint}")


def connect_dask(scheduler: Any, jobs: int, timeout: float | None = None) -> tuple[Any, Callable[[], None]]:
    """A ``dask.distributed.Client`` for ``scheduler`` ("local": a local cluster of
    ``jobs`` single-threaded worker processes; an address such as tcp://host:8786, first
    checked by :func:`probe_scheduler` within ``timeout`` (default
    :data:`DASK_CONNECT_TIMEOUT`); or a Client) and the function that releases what
    was created here (it gives up after :data:`CLOSE_TIMEOUT` on a scheduler that is gone).

    Raises
    ------
    ExecutorError
        Without dask.distributed, for an unknown scheduler form, or one that does not answer
        as a Dask scheduler within ``timeout``.
    """
    try:
        from dask.distributed import Client, LocalCluster  # lazy: dask, an optional extra
    except ImportError:
        raise ExecutorError("the Dask executor needs dask.distributed: pip install 'daebench[dask]' "
                            "(or pip install \"dask[distributed]\")") from None
    if isinstance(scheduler, Client):
        return scheduler, lambda: None
    if scheduler in (None, "local"):
        cluster = LocalCluster(n_workers=max(1, int(jobs)), threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)

        def close() -> None:
            client.close()
            cluster.close()
        return client, close
    if not isinstance(scheduler, str) or "://" not in scheduler:
        raise ExecutorError(f"--scheduler must be 'local' or an address such as tcp://host:8786; got {scheduler!r}")
    timeout = DASK_CONNECT_TIMEOUT if timeout is None else timeout
    probe_scheduler(scheduler, timeout)
    try:
        with quiet_distributed():
            client = Client(scheduler, timeout=timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ExecutorError(f"cannot reach the Dask scheduler at {scheduler} within {timeout:g} s "
                            f"({type(exc).__name__}); is it running? Start one with `dask scheduler`, or use "
                            f"--scheduler local") from None
    _drop_unread_exits(client)

    def release() -> None:
        with quiet_distributed():
            try:
                client.close(timeout=CLOSE_TIMEOUT)
            except Exception:   # noqa: BLE001  the scheduler is gone: nothing left to release there
                pass
    return client, release


def _drop_unread_exits(client: Any) -> None:
    """A result the sweep stopped waiting for (its read timed out: :func:`_finished`) leaves a
    gather task in the client's event loop that ends with ``AllExit`` when the client closes;
    no one reads it, and asyncio printed "Task exception was never retrieved" with a traceback
    into the sweep's own report of the lost cluster, at whatever moment the task was freed.
    The client's loop drops exactly those; any other unhandled exception is reported as before."""
    from distributed.client import AllExit   # lazy: dask, an optional extra; the client exists

    loop = getattr(getattr(client, "loop", None), "asyncio_loop", None)
    if loop is None:
        return

    def handler(lp: Any, context: dict) -> None:
        if not isinstance(context.get("exception"), AllExit):
            lp.default_exception_handler(context)

    loop.set_exception_handler(handler)


@contextmanager
def quiet_distributed() -> Iterator[None]:
    """Hold back the distributed library's log lines below CRITICAL (a lost scheduler makes
    it log reconnection attempts and tracebacks); the sweep reports the fault itself."""
    names = [n for n in list(logging.root.manager.loggerDict) if n.split(".")[0] in ("distributed", "tornado")]
    loggers = [logging.getLogger(n) for n in ["distributed", "tornado", *names]]   # some have levels of their own
    old = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for lg, lv in zip(loggers, old):
            lg.setLevel(lv)


class _Cluster:
    """What this sweep asks the scheduler, each question turned into :class:`ClusterLost`
    when the scheduler has gone (the client is no longer running)."""

    def __init__(self, client: Any) -> None:
        self.client = client
        self.address = str(getattr(client.scheduler, "address", None) or client.scheduler)

    def lost(self, why: str) -> ClusterLost:
        return ClusterLost(f"lost the Dask scheduler at {self.address} ({why}); the runs in flight are "
                           f"interrupted: restart the cluster and run the same command with --resume")

    def ask(self, call: Callable[[], Any]) -> Any:
        if self.client.status != "running":
            raise self.lost(f"its connection closed; the client is {self.client.status}")
        try:
            return call()
        except Exception as exc:
            if self.client.status != "running" or type(exc).__name__ in ("CommClosedError", "ClosedClientError"):
                raise self.lost("its connection closed") from None
            raise

    def workers(self) -> dict[str, int]:
        """{worker address: threads} of the workers the scheduler knows now."""
        try:
            info = self.ask(lambda: self.client.scheduler_info(n_workers=-1))
        except TypeError:   # a distributed before 2025 lists every worker unasked
            info = self.ask(self.client.scheduler_info)
        return {a: int(w.get("nthreads", 1)) for a, w in info.get("workers", {}).items()}


class _LostRuns:
    """The runs each worker that left the cluster unasked had, from the scheduler's
    ``remove-worker`` events (topic "all"): ``{key: (worker address, "ran" or "result")}``
    ("result": it had finished there, its result not yet read). Called in the client's
    event loop for every event; any handler that was there before is called too."""

    TOPIC = "all"

    def __init__(self, client: Any) -> None:
        self.client = client
        self.keys: dict[Any, tuple[str, str]] = {}
        self.unnamed: str | None = None     # a worker whose event named no runs (an old distributed)
        self.before = getattr(client, "_event_handlers", {}).get(self.TOPIC)
        client.subscribe_topic(self.TOPIC, self)   # sent ahead of any submit on the same stream

    def __call__(self, event: tuple[float, Any]) -> Any:
        msg = event[1] if isinstance(event, tuple) and len(event) == 2 else None
        if isinstance(msg, dict) and msg.get("action") == "remove-worker" and not msg.get("expected"):
            worker = str(msg.get("worker"))
            if "processing-tasks" not in msg:
                self.unnamed = worker
            for k in msg.get("lost-computed-tasks", ()):
                self.keys.setdefault(k, (worker, "result"))
            for k in msg.get("processing-tasks", ()):
                self.keys[k] = (worker, "ran")
        return self.before(event) if self.before is not None else None

    def check(self) -> None:
        """Raise :class:`ClusterLost` if a worker was lost and the scheduler did not say with which runs."""
        if self.unnamed is not None:
            import distributed  # lazy: its version for the message; the client has loaded it

            raise ClusterLost(f"the Dask worker {self.unnamed} was lost, and this distributed "
                              f"({distributed.__version__}) does not say which runs it had, so the runs in flight "
                              f"are interrupted; upgrade it (pip install -U 'dask[distributed]') and run the same "
                              f"command with --resume")

    def close(self) -> None:
        if self.client.status != "running":
            return
        if self.before is not None:
            self.client.subscribe_topic(self.TOPIC, self.before)
        else:
            self.client.unsubscribe_topic(self.TOPIC)


def _lost_row(spec: Any, worker: str, what: str, make_row: Callable[[Any, str, str], Row]) -> Row:
    when = "while it ran" if what == "ran" else "with its result, before the sweep had read it"
    row = make_row(spec, "crashed", f"its Dask worker {worker} was lost {when} (killed, out of memory, or its "
                                    f"machine gone); --resume runs it again")
    row["lost_worker"] = worker
    return row


def run_dask(specs: Sequence[Any], fn: Callable[[Any], Row], client: Any, on_row: Callable[[Row], None],
             make_row: Callable[[Any, str, str], Row], on_running: Callable[[list[Any]], None] | None = None,
             backstop_s: float | None = None, no_workers_s: float = NO_WORKERS_TIMEOUT) -> None:
    """Runs as Dask futures, no more in flight than the cluster has threads (so that a
    future's age is its run time, for the backstop), the cluster's faults handled as the
    module docstring says. The wall-time cap itself acts inside the worker
    (:func:`daebench.harness.running.deadline.deadline` works in worker threads); a run that
    outlives the backstop gets a 'timeout' row and the sweep goes on without it (Dask
    cannot kill a running thread: it finishes or dies with its worker).

    Raises
    ------
    ClusterLost
        The scheduler was lost, or the cluster had no worker for ``no_workers_s`` s.
    """
    cluster = _Cluster(client)
    pending = deque(specs)
    flying: dict[Any, tuple[Any, float]] = {}
    tries: dict[Any, int] = {}                  # future → times its result was not read in time
    idle_since: float | None = None             # since when the cluster has had no worker
    with quiet_distributed():
        lost = cluster.ask(lambda: _LostRuns(client))
        try:
            while pending or flying:
                workers = cluster.workers()
                now = time.monotonic()
                if workers:
                    idle_since = None
                else:
                    idle_since = now if idle_since is None else idle_since
                    if now - idle_since > no_workers_s:
                        raise ClusterLost(
                            f"the Dask cluster at {cluster.address} has had no workers for {no_workers_s:g} s "
                            f"(--no-workers-timeout) with {len(pending) + len(flying)} run(s) waiting; start "
                            f"workers (`dask worker {cluster.address}`) and run the same command with --resume")
                while pending and len(flying) < max(1, sum(workers.values())):
                    s = pending.popleft()
                    f = cluster.ask(lambda: client.submit(fn, s, pure=False))
                    flying[f] = (s, time.monotonic())
                if on_running is not None:
                    on_running([s for s, _ in flying.values()])
                if not any(f.done() for f in flying):
                    time.sleep(POLL_S)
                lost.check()
                for f in list(flying):
                    spec, started = flying[f]
                    if f.key in lost.keys:    # before done(): a run another worker redid is still lost
                        f.cancel()   # released: no other worker runs it again behind the sweep's back
                        row = _lost_row(spec, *lost.keys.pop(f.key), make_row)
                    elif f.done():
                        row = _finished(f, spec, make_row, cluster, min(RESULT_S * 2 ** tries.get(f, 0),
                                                                        RESULT_MAX_S))
                        if row is None:       # its result could not be read yet: its worker may be gone
                            tries[f] = tries.get(f, 0) + 1
                            continue
                    elif backstop_s is not None and time.monotonic() - started > backstop_s:
                        f.cancel()
                        row = make_row(spec, "timeout", f"run still going after {backstop_s:g} s (beyond its "
                                                        f"wall-time cap); abandoned")
                    else:
                        continue
                    del flying[f]
                    tries.pop(f, None)
                    on_row(row)
        finally:
            if client.status == "running":
                for f in flying:
                    try:
                        f.cancel()
                    except Exception:   # noqa: BLE001  the scheduler went meanwhile
                        pass
                try:
                    lost.close()
                except Exception:   # noqa: BLE001  the scheduler went meanwhile
                    pass


def _finished(f: Any, spec: Any, make_row: Callable[[Any, str, str], Row], cluster: _Cluster,
              wait_s: float) -> Row | None:
    """The row of a future that is done: its result, or what ended it; None when it is not
    read within ``wait_s`` (the worker holding the result may be gone: the sweep looks at
    the cluster's losses, then tries again). A cancelled future (the scheduler's connection
    lost, or someone cancelled it) stops the sweep."""
    if f.status == "cancelled":
        raise cluster.lost("its futures were cancelled") if cluster.client.status != "running" else ClusterLost(
            f"a run's future was cancelled on the Dask cluster at {cluster.address} (by another client or the "
            f"scheduler); the runs in flight are interrupted: run the same command with --resume")
    try:
        if f.status == "finished":
            return cluster.ask(lambda: f.result(timeout=wait_s))
        exc = cluster.ask(lambda: f.exception(timeout=wait_s))   # KilledWorker (the scheduler gave up), a raised run …
    except ClusterLost:
        raise
    except TimeoutError:      # reading a done future: only the gather, or the scheduler's answer, can time out
        return None
    except Exception as read:  # noqa: BLE001  the future changed state while read (its result lost): look again
        if not f.done():
            return None
        exc = read             # a row or an exception that cannot be read here
    if type(exc).__name__ == "KilledWorker":
        worker = getattr(getattr(exc, "last_worker", None), "address", None)
        if getattr(exc, "allowed_failures", None) == 0 and worker:   # one worker died: the cluster failed
            return _lost_row(spec, str(worker), "ran", make_row)
        return make_row(spec, "crashed", f"{type(exc).__name__}: {exc}")
    return make_row(spec, "error", f"{type(exc).__name__}: {exc}")
