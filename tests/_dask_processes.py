"""A real Dask cluster for tests: a scheduler and workers started as processes of their own
on loopback ports (``python -m distributed.cli.dask_scheduler`` / ``dask_worker``), so that
``kill -9`` of either is a fault a LocalCluster cannot show. Everything started is stopped
by :meth:`Cluster.stop` (the fixture calls it whatever the test did)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

START_LIMIT_S = 60.0   # a scheduler or worker that is not up by then fails the test
SETTLE_S = 2.0         # s the scheduler is given to hear the last words of workers just frozen


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """A scheduler at tcp://127.0.0.1:<port> and the workers :meth:`worker` started."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.port = free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.scheduler: subprocess.Popen | None = None
        self.workers: list[subprocess.Popen] = []
        self.logs: list[Path] = []

    def _start(self, module: str, *args: str) -> subprocess.Popen:
        log = self.folder / f"{module.rsplit('.', 1)[-1]}-{len(self.logs)}.log"
        self.logs.append(log)
        with open(log, "w") as fh:
            return subprocess.Popen([sys.executable, "-m", module, *args], stdout=fh, stderr=subprocess.STDOUT,
                                    env=dict(os.environ), cwd=self.folder, start_new_session=True)

    def start_scheduler(self) -> None:
        self.scheduler = self._start("distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port",
                                     str(self.port), "--no-dashboard")
        self._wait(lambda: self._listening(), "the scheduler to listen")

    def worker(self, nanny: bool = False) -> subprocess.Popen:
        """A worker of one thread at tcp://127.0.0.1:<port> (its ``address``), joined when this returns."""
        before = self.n_workers()
        port = free_port()
        w = self._start("distributed.cli.dask_worker", self.address, "--nthreads", "1", "--no-dashboard",
                        "--host", "127.0.0.1", "--worker-port", str(port),
                        "--nanny" if nanny else "--no-nanny", "--death-timeout", "60")
        w.address = f"tcp://127.0.0.1:{port}"
        self.workers.append(w)
        self._wait(lambda: self.n_workers() > before, "a worker to join")
        return w

    def _listening(self) -> bool:
        try:
            with socket.create_connection(("127.0.0.1", self.port), timeout=1):
                return True
        except OSError:
            return False

    def n_workers(self) -> int:
        """Workers the scheduler knows (asked by a short-lived client)."""
        if not self._listening():
            return 0
        from dask.distributed import Client

        try:
            with Client(self.address, timeout=10) as c:
                return len(c.scheduler_info(n_workers=-1)["workers"])
        except OSError:
            return 0

    def _wait(self, cond, what: str) -> None:
        t0 = time.monotonic()
        while not cond():
            if any(p.poll() is not None for p in [self.scheduler, *self.workers[-1:]] if p is not None):
                raise AssertionError(f"a cluster process ended while waiting for {what}: {self.tail()}")
            if time.monotonic() - t0 > START_LIMIT_S:
                raise AssertionError(f"no {what} after {START_LIMIT_S} s: {self.tail()}")
            time.sleep(0.2)

    def tail(self) -> str:
        return "\n".join(f"--- {p.name}\n{p.read_text()[-1500:]}" for p in self.logs if p.exists())

    @staticmethod
    def kill9(p: subprocess.Popen | None) -> None:
        if p is not None and p.poll() is None:
            os.kill(p.pid, signal.SIGKILL)
            p.wait(timeout=30)

    def kill9_a_worker_holding_a_run(self, workers: list[subprocess.Popen]) -> subprocess.Popen:
        """Freeze ``workers`` (SIGSTOP: no run of theirs can finish or start any more), let the
        scheduler settle, then SIGKILL one the scheduler says is processing a run, or else holds
        a finished run's result, and thaw the others; the worker killed. So the kill hits a
        run however fast the runs are (a worker killed between two runs would hold none)."""
        from dask.distributed import Client

        for w in workers:
            os.kill(w.pid, signal.SIGSTOP)
        time.sleep(SETTLE_S)
        with Client(self.address, timeout=10) as c:
            holding = [a for a, keys in c.processing().items() if keys]
            holding += [a for where in c.who_has().values() for a in where]
        victim = next((w for w in workers if w.address in holding), None)
        assert victim is not None, f"no frozen worker holds a run: {holding}"
        self.kill9(victim)
        for w in workers:
            if w is not victim:
                os.kill(w.pid, signal.SIGCONT)
        return victim

    def stop(self) -> None:
        for p in [*self.workers, self.scheduler]:
            if p is not None and p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGKILL)   # its own session: a nanny's worker goes too
                except ProcessLookupError:
                    pass
                p.wait(timeout=30)
        self.workers, self.scheduler = [], None
