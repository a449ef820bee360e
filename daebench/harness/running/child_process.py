"""A process started to do work for this one: it ends when its parent does, and how it
ended is said in words. Used by the sweep's worker processes
(:mod:`daebench.harness.sweeps.executors`) and a reference's check runs
(:mod:`daebench.harness.references.side_runs`)."""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time

PARENT_POLL_S = 1.0         # a worker looks this often whether its parent still exists
PR_SET_PDEATHSIG = 1        # prctl option (linux/prctl.h)


def describe_exit(code: int | None) -> str:
    """'killed by signal SIGSEGV' or 'exited with code 3'."""
    if code is None:
        return "worker vanished"
    if code < 0:
        try:
            return f"killed by signal {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exited with code {code}"


def die_with_parent(parent_pid: int) -> None:
    """Make this worker end when the sweep's process does: the kernel's parent-death signal
    on Linux, and on every system a daemon thread that polls the parent's pid."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:  # the parent died before the signal was armed
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(PARENT_POLL_S)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="daebench-parent-watch", daemon=True).start()
