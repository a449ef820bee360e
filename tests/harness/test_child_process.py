"""daebench.harness.running.child_process: how a worker ended, in words, and a worker that
ends with its parent (the kernel's parent-death signal and the poll)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

from daebench.harness.running.child_process import describe_exit


def test_exit_codes_in_words():
    assert describe_exit(0) == "exited with code 0"
    assert describe_exit(3) == "exited with code 3"
    assert describe_exit(-signal.SIGSEGV) == "killed by signal SIGSEGV"
    assert describe_exit(-signal.SIGKILL) == "killed by signal SIGKILL"
    assert describe_exit(-250) == "killed by signal 250"          # no such signal: its number
    assert describe_exit(None) == "worker vanished"


def test_a_worker_ends_when_its_parent_is_killed(tmp_path):
    """A parent starts a child that arms die_with_parent and sleeps an hour; the parent is
    killed with SIGKILL (no clean-up of its own runs); the child is gone within seconds."""
    pidfile = tmp_path / "child.pid"
    parent = textwrap.dedent(f"""
        import os, sys, time
        pid = os.fork()
        if pid == 0:
            from daebench.harness.running.child_process import die_with_parent
            die_with_parent(os.getppid())
            open({str(pidfile)!r}, "w").write(str(os.getpid()))
            time.sleep(3600)
            os._exit(0)
        time.sleep(3600)
    """)
    p = subprocess.Popen([sys.executable, "-c", parent])
    child = None
    try:
        deadline = time.monotonic() + 60
        while not pidfile.exists() or not pidfile.read_text():
            assert time.monotonic() < deadline, "the child never started"
            time.sleep(0.05)
        child = int(pidfile.read_text())
        os.kill(child, 0)                                   # alive while its parent is
        p.kill()
        p.wait()
        deadline = time.monotonic() + 10
        while True:
            try:
                os.kill(child, 0)
            except ProcessLookupError:
                break
            # reparented to init/a subreaper: it may linger as a zombie until reaped
            try:
                with open(f"/proc/{child}/stat") as fh:
                    if fh.read().split(")")[-1].split()[0] == "Z":
                        break
            except FileNotFoundError:
                break
            assert time.monotonic() < deadline, "the child outlived its parent by 10 s"
            time.sleep(0.05)
    finally:
        if p.poll() is None:
            p.kill()
        if child is not None:          # never left sleeping when the test fails
            try:
                os.kill(child, signal.SIGKILL)
            except ProcessLookupError:
                pass
