"""Faults of a real Dask cluster are faults of the cluster, not of the runs: a scheduler and
workers started here as processes of their own on loopback ports, killed with SIGKILL. A
lost scheduler stops the sweep in one line with the runs in flight interrupted (never
`error`), and `--resume` on the restarted cluster runs them; a lost worker makes its run a
`crashed` row once (no other worker runs it behind the sweep's back) and a cluster left
without workers is reported within --no-workers-timeout; a scheduler address is checked
within the connect timeout, saying what answered there."""

from __future__ import annotations

import http.server
import json
import os
import signal
import socket
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import pandas as pd
import pytest

pytest.importorskip("dask.distributed")

from _dask_processes import Cluster, free_port  # noqa: E402

from daebench.harness.sweeps import dask_cluster  # noqa: E402
from daebench.harness.sweeps.executors import ExecutorError  # noqa: E402

# runs of a second or two each once a worker has loaded its kernels; one thread a worker
BENCH = ["bench", "pendulum", "-i", "hht,newmark", "--steps", "2e-5,1e-5", "--set", "t_end=0.5",
         "--reference", "none", "--repeats", "1"]
WAIT_S = 120.0


@pytest.fixture()
def cluster(tmp_path):
    c = Cluster(tmp_path)
    try:
        yield c
    finally:
        c.stop()


def daebench(*args: str, results: Path) -> subprocess.Popen:
    env = dict(os.environ, DAEBENCH_RESULTS=str(results), COLUMNS="200")
    return subprocess.Popen([sys.executable, "-m", "daebench.cli.app", *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def stored(results: Path, name: str) -> int:
    db = results / "bench" / f"{name}.rows.sqlite"
    if not db.exists():
        return 0
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5) as con:   # never creates it
            return con.execute("SELECT COUNT(*) FROM rows").fetchone()[0]
    except sqlite3.Error:
        return 0


def until(cond, proc: subprocess.Popen, what: str) -> None:
    t0 = time.monotonic()
    while not cond():
        assert proc.poll() is None, f"the sweep ended before {what}: {proc.communicate()}"
        assert time.monotonic() - t0 < WAIT_S, f"no {what} after {WAIT_S} s"
        time.sleep(0.1)


def busy(c: Cluster) -> bool:
    """A worker is processing a run (asked by a client of the test's own)."""
    from dask.distributed import Client

    with Client(c.address, timeout=10) as client:
        return any(client.processing().values())


def one_line_no_traceback(err: str, what: str) -> None:
    assert "Traceback" not in err and what in err, err


def table(results: Path, name: str) -> pd.DataFrame:
    return pd.read_parquet(results / "bench" / f"{name}.parquet")


def kill_the_scheduler_mid_sweep(cluster: Cluster, res: Path, name: str, workers: int = 1) -> str:
    """A sweep on a new cluster of ``workers``, its scheduler killed once a row is stored
    and a run is in flight; the sweep's stderr (it exits 1, saying so in one line)."""
    cluster.start_scheduler()
    for _ in range(workers):
        cluster.worker()
    p = daebench(*BENCH, "--scheduler", cluster.address, "--name", name, results=res)
    until(lambda: stored(res, name) >= 1, p, "a first row")
    until(lambda: busy(cluster), p, "a run in flight")
    cluster.kill9(cluster.scheduler)
    _, err = p.communicate(timeout=WAIT_S)
    assert p.returncode == 1, err
    one_line_no_traceback(err, f"lost the Dask scheduler at {cluster.address}")
    return err


def resume_to_the_end(cluster: Cluster, res: Path, name: str) -> pd.DataFrame:
    """``--resume`` of sweep ``name`` on ``cluster``: it exits 0 with every planned run completed, once."""
    p = daebench(*BENCH, "--scheduler", cluster.address, "--name", name, "--resume", results=res)
    _, err = p.communicate(timeout=WAIT_S * 2)
    assert p.returncode == 0, err
    full = table(res, name)
    assert sorted(full.run) == [0, 1, 2, 3] and (full.status == "completed").all()
    return full


def test_a_lost_scheduler_interrupts_the_runs_in_flight_and_resume_runs_them(cluster, tmp_path):
    res = tmp_path / "results"
    err = kill_the_scheduler_mid_sweep(cluster, res, "d3")
    assert "continue with: daebench bench" in err and "--resume" in err
    part = table(res, "d3")
    assert len(part) == 4 and "error" not in set(part.status) and (part.status == "interrupted").sum() >= 1
    done = set(part.run[part.status == "completed"])

    cluster.stop()
    cluster.start_scheduler()      # the same address, restarted
    cluster.worker()
    full = resume_to_the_end(cluster, res, "d3")
    kept = part[part.run.isin(done)].set_index("run")
    assert (full.set_index("run").loc[sorted(done), "digest"] == kept["digest"]).all()   # finished rows kept


def stored_rows(results: Path, name: str) -> list[dict]:
    db = results / "bench" / f"{name}.rows.sqlite"
    if not db.exists():
        return []
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5) as con:
            return [json.loads(r) for (r,) in con.execute("SELECT row FROM rows")]
    except sqlite3.Error:
        return []


def held_on(c: Cluster, address: str) -> tuple[int, int]:
    """(runs processing, results held) on the worker at ``address``, as the scheduler says."""
    from dask.distributed import Client

    with Client(c.address, timeout=10) as client:
        return (len(client.processing().get(address, ())),
                sum(address in where for where in client.who_has().values()))


def executed(c: Cluster, address: str) -> int:
    """The runs the worker at ``address`` has finished (its own count)."""
    from dask.distributed import Client

    with Client(c.address, timeout=10) as client:
        return client.run(lambda dask_worker: dask_worker.state.executed_count, workers=[address])[address]


def kill9_the_worker_holding_a_result(cluster: Cluster, sweep: subprocess.Popen, worker, res: Path,
                                      name: str) -> None:
    """Freeze the sweep (SIGSTOP) until its run on ``worker`` has finished there, the result
    unread; SIGKILL the worker, then thaw the sweep: it never saw where the run ran, nor its
    result. (Frozen between two runs, with none on the worker, the sweep is thawed a moment.)
    A result the worker holds may be one the sweep has read and not yet released, so "unread"
    is a finished run of the only worker without a stored row."""
    t0 = time.monotonic()
    while True:
        assert sweep.poll() is None and time.monotonic() - t0 < WAIT_S, "no run held by the worker"
        os.kill(sweep.pid, signal.SIGSTOP)
        while held_on(cluster, worker.address)[0]:   # a run in progress: it finishes, unread
            time.sleep(0.2)
        if held_on(cluster, worker.address)[1] and executed(cluster, worker.address) > stored(res, name):
            break
        os.kill(sweep.pid, signal.SIGCONT)
        time.sleep(0.3)
    cluster.kill9(worker)
    os.kill(sweep.pid, signal.SIGCONT)


def the_only_worker_lost_mid_sweep(cluster: Cluster, res: Path, name: str, no_workers_s: str,
                                   holding: str = "a run"):
    """A sweep on a cluster of one worker (--no-nanny: nothing restarts it), killed once a
    first row is stored, while it holds ``holding``: "a run" in progress or "a result" the
    sweep has not read; the sweep and the worker killed."""
    cluster.start_scheduler()
    only = cluster.worker()
    p = daebench(*BENCH, "--scheduler", cluster.address, "--name", name, "--no-workers-timeout", no_workers_s,
                 results=res)
    until(lambda: stored(res, name) >= 1, p, "a first row")
    if holding == "a run":
        assert cluster.kill9_a_worker_holding_a_run([only]) is only
    else:
        kill9_the_worker_holding_a_result(cluster, p, only, res, name)
    return p, only


LOST = {"a run": "was lost while it ran", "a result": "was lost with its result, before the sweep had read it"}


def the_crashed_row(part: pd.DataFrame, worker, holding: str | None = "a run") -> int:
    """The one ``crashed`` row names the worker killed and what was lost, with no ``error``
    among the rows; its run. ``holding`` None: either loss (a worker killed while it runs a
    run may have finished it a moment before: then its result went with it)."""
    crashed = part[part.status == "crashed"]
    assert len(crashed) == 1 and "error" not in set(part.status), part[["run", "status", "message"]]
    said = [LOST[holding]] if holding else list(LOST.values())
    assert any(f"its Dask worker {worker.address} {w}" in crashed.message.iloc[0] for w in said), crashed.message.iloc[0]
    assert crashed.lost_worker.iloc[0] == worker.address
    return int(crashed.run.iloc[0])


@pytest.mark.parametrize("holding", ["a run", "a result"])
def test_a_lost_worker_is_a_crashed_row_once_and_no_workers_is_reported(cluster, tmp_path, holding):
    res = tmp_path / "results"
    p, only = the_only_worker_lost_mid_sweep(cluster, res, "w", "5", holding)
    _, err = p.communicate(timeout=WAIT_S)
    assert p.returncode == 1, err
    one_line_no_traceback(err, f"the Dask cluster at {cluster.address} has had no workers for 5 s "
                               f"(--no-workers-timeout)")
    part = table(res, "w")
    # "a run": the frozen worker killed may be processing one or hold a result it finished just
    # before it was frozen (kill9_a_worker_holding_a_run takes either); "a result" is exact
    lost_run = the_crashed_row(part, only, None if holding == "a run" else holding)
    assert len(part) == 4 and set(part.status) <= {"completed", "crashed", "interrupted"}

    # the resume on a new worker runs the crashed run again (the cluster failed, not the run)
    # and the interrupted ones, each once
    cluster.worker()
    full = resume_to_the_end(cluster, res, "w")
    assert "lost_worker" not in full or full.lost_worker.isna().all()
    assert lost_run in set(full.run)


def test_a_run_lost_with_its_worker_is_not_redone_by_a_worker_that_joins(cluster, tmp_path):
    """The only worker killed holding a run; once its ``crashed`` row is stored a new worker
    joins within the no-workers bound: the sweep ends with the crashed row and every other
    run completed, and the new worker ran only the runs that had no row."""
    res = tmp_path / "results"
    p, only = the_only_worker_lost_mid_sweep(cluster, res, "j", "120")
    until(lambda: any(r["status"] == "crashed" for r in stored_rows(res, "j")), p, "a crashed row")
    had_rows = len(stored_rows(res, "j"))
    new = cluster.worker()
    _, err = p.communicate(timeout=WAIT_S * 2)
    assert p.returncode == 1 and "gave no verdict (crashed)" in err, err
    full = table(res, "j")
    the_crashed_row(full, only, holding=None)   # the point here: not run again behind the sweep's back
    assert sorted(full.run) == [0, 1, 2, 3] and (full.status == "completed").sum() == 3
    assert executed(cluster, new.address) == 4 - had_rows


def processing(c: Cluster) -> dict[str, list]:
    from dask.distributed import Client

    with Client(c.address, timeout=10) as client:
        return {a: list(k) for a, k in client.processing().items() if k}


@pytest.mark.slow
def test_a_bench_survives_kill9_of_its_scheduler_and_of_a_worker_with_a_local_runs_numbers(cluster, tmp_path):
    """The scheduler killed mid-sweep and restarted, then a busy worker of two killed: after
    the resumes every planned row is there once, none `error`, each equal to the row of the
    same run on local worker processes (history digest, steps, errors)."""
    res = tmp_path / "results"
    local = daebench(*BENCH, "--name", "local", "-j", "1", results=res)
    kill_the_scheduler_mid_sweep(cluster, res, "k", workers=2)
    statuses = [set(table(res, "k").status)]

    cluster.stop()
    cluster.start_scheduler()
    workers = [cluster.worker(), cluster.worker()]
    p = daebench(*BENCH, "--scheduler", cluster.address, "--name", "k", "--resume", results=res)
    until(lambda: processing(cluster), p, "a run in flight")
    cluster.kill9_a_worker_holding_a_run(workers)
    _, err = p.communicate(timeout=WAIT_S * 2)
    statuses.append(set(table(res, "k").status))
    assert p.returncode == 1 and "gave no verdict (crashed)" in err, err    # the other worker went on

    resume_to_the_end(cluster, res, "k")
    assert local.wait(timeout=WAIT_S * 2) == 0, local.communicate()
    assert "interrupted" in statuses[0] and "crashed" in statuses[1] and "error" not in set.union(*statuses)
    k, loc = table(res, "k").set_index("run"), table(res, "local").set_index("run")
    for col in ("label", "digest", "steps", "err_theta_max"):
        assert list(k[col]) == list(loc[col]), col


# ---- what answers at a wrong address ----------------------------------------------------------
class _Server:
    """A loopback TCP server in a thread: ``answer(conn)`` speaks for each connection."""

    def __init__(self, answer) -> None:
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.answer = answer
        self.conns: list[socket.socket] = []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            threading.Thread(target=self.answer, args=(conn,), daemon=True).start()

    def close(self) -> None:
        self.sock.close()
        for c in self.conns:
            c.close()


def _http_400(conn: socket.socket) -> None:   # answers any bytes with 400, as a web server does to garbage
    try:
        if conn.recv(1024):
            conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
    except OSError:
        pass


def _garbage(conn: socket.socket) -> None:
    conn.sendall(b"\xff" * 64)


def _silent(conn: socket.socket) -> None:
    pass


def _connect(address: str, timeout: float) -> BaseException | None:
    """connect_dask in a thread, joined with a bound (the old code hung ~200 s on an HTTP server)."""
    out: list[BaseException | None] = []

    def go() -> None:
        try:
            dask_cluster.connect_dask(address, 1, timeout=timeout)[1]()
            out.append(None)
        except BaseException as exc:   # the refusal is what the test reads
            out.append(exc)

    t = threading.Thread(target=go, daemon=True)
    t.start()
    t.join(timeout + 20.0)
    assert out, f"connect_dask({address}) still waiting {timeout + 20:g} s after a connect timeout of {timeout:g} s"
    return out[0]


@pytest.mark.parametrize("answer, said", [
    (_http_400, "an HTTP server answers at 127.0.0.1:{port} ('HTTP/1.1 400 Bad Request'), not a Dask scheduler"),
    (_garbage, "the service at 127.0.0.1:{port} is not a Dask scheduler: its first bytes b'\\xff\\xff"),
    (_silent, "something accepts connections at 127.0.0.1:{port} but sent no Dask handshake within 2 s"),
])
def test_a_wrong_address_is_named_within_the_connect_timeout(answer, said):
    srv = _Server(answer)
    try:
        exc = _connect(f"tcp://127.0.0.1:{srv.port}", 2.0)
    finally:
        srv.close()
    assert isinstance(exc, ExecutorError), exc
    assert said.format(port=srv.port) in str(exc) and "dask scheduler" in str(exc)


def test_nothing_listening_and_an_http_server_on_the_command_line(tmp_path):
    port = free_port()
    exc = _connect(f"tcp://127.0.0.1:{port}", 2.0)
    assert isinstance(exc, ExecutorError) and f"nothing listens at 127.0.0.1:{port} (connection refused)" in str(exc)

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args) -> None:
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    try:
        p = daebench(*BENCH, "--scheduler", f"tcp://127.0.0.1:{httpd.server_port}", results=tmp_path)
        _, err = p.communicate(timeout=120)
    finally:
        httpd.shutdown()
        httpd.server_close()
    assert p.returncode == 2, err
    one_line_no_traceback(err, f"an HTTP server answers at 127.0.0.1:{httpd.server_port} ('HTTP/1.0 200 OK')")
    assert not (tmp_path / "bench").exists() or not list((tmp_path / "bench").glob("*.parquet"))


def test_the_no_workers_bound_is_an_option_with_help_and_is_checked():
    from typer.testing import CliRunner

    from daebench.cli.app import app
    from daebench.harness.sweeps.options import Execution, SweepError

    for cmd in ("bench", "survey"):
        r = CliRunner().invoke(app, [cmd, "--help"], env={"COLUMNS": "200"})
        assert "--no-workers-timeout" in r.output and "no worker while runs wait" in r.output
    for bad in (0.0, -1.0, float("nan"), True):
        with pytest.raises(SweepError, match="--no-workers-timeout must be a positive number"):
            Execution(no_workers_timeout=bad)


def test_only_the_unread_exits_of_a_closed_client_are_dropped():
    """The client's loop drops "Task exception was never retrieved" for AllExit (a gather the
    sweep stopped waiting for) and reports any other unhandled exception as asyncio does."""
    from types import SimpleNamespace

    from distributed.client import AllExit

    from daebench.harness.sweeps.dask_cluster import _drop_unread_exits

    reported, handlers = [], []
    loop = SimpleNamespace(set_exception_handler=handlers.append,
                           default_exception_handler=reported.append)
    _drop_unread_exits(SimpleNamespace(loop=SimpleNamespace(asyncio_loop=loop)))
    (handler,) = handlers
    handler(loop, {"message": "Task exception was never retrieved", "exception": AllExit()})
    assert reported == []
    other = {"message": "Task exception was never retrieved", "exception": ValueError("a real fault")}
    handler(loop, other)
    assert reported == [other]
