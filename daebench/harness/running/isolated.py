"""Work that may not come back, run where it can be stopped: a forked child process.

The wall-time cap of a run (:mod:`.deadline`) stops a run at its next safe point, or at
the next Python bytecode of a run that reaches none. Neither reaches code that never
returns to Python: a plugin blocked in ``time.sleep``, a socket or a lock, or looping in
its own compiled code. Such code is stopped only by ending the process it runs in, so a
capped call of a plugin's code runs in a child process forked from this one (it knows
every class registered here): :func:`call` waits for the child's answer until the cap
plus :data:`KILL_AFTER_S`, then kills it and raises
:class:`~daebench.core.interrupt.RunTimeout`. Progress calls made in the child are
forwarded to the caller's callback; the child's value or exception comes back pickled.

Only on systems with ``fork`` (Linux, macOS); elsewhere :func:`available` is False and the
caller runs the work in its own process (the cooperative cap then bounds what reaches a
safe point or Python bytecode, nothing else).
"""

from __future__ import annotations

import os
import pickle
import select
import signal
import struct
import sys
import time
import traceback
from typing import Any, Callable

from daebench.core.interrupt import RunTimeout
from daebench.harness.running.child_process import describe_exit, die_with_parent


class RunCrashed(RuntimeError):
    """The process a run was isolated in died without an answer (a signal, ``os._exit``): the
    run crashed, as a sweep's worker process would have — a 'crashed' row, not an error."""

KILL_AFTER_S = 5.0   # beyond the cap, the time the child gets to stop by itself before it is killed
_HEADER = struct.Struct("!Q")


def available() -> bool:
    """Whether work can be run in a forked child here."""
    return hasattr(os, "fork")


def is_plugin(obj: Any) -> bool:
    """Whether ``obj``'s class is defined outside daebench (a plugin's or a notebook's)."""
    return not type(obj).__module__.startswith("daebench.")


def _send(fd: int, message: tuple) -> None:
    try:
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:  # noqa: BLE001 - an answer that cannot travel is said in words
        data = pickle.dumps(("raised", RuntimeError(f"the child's answer could not be sent back: {exc}"), ""))
    view = memoryview(_HEADER.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view):]


def _child(fd: int, fn: Callable[[Callable[[float], None] | None], Any], forward: bool, parent: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # Ctrl-C is the parent's business: it kills this child
    die_with_parent(parent)
    try:
        value = fn((lambda t: _send(fd, ("progress", t))) if forward else None)
        _send(fd, ("done", value, ""))
    except BaseException as exc:  # noqa: BLE001 - everything goes back to the parent
        text = "".join(traceback.format_exception(exc))
        try:
            pickle.dumps(exc)
        except Exception:  # noqa: BLE001
            exc = RuntimeError(f"{type(exc).__name__}: {exc}")
        _send(fd, ("raised", exc, text))


def _read(fd: int, n: int, until: float) -> bytes | None:
    """``n`` bytes from ``fd`` before the monotonic time ``until``; None at end of file;
    raises TimeoutError when the time is up."""
    out = b""
    while len(out) < n:
        left = until - time.monotonic()
        if left <= 0 or not select.select([fd], [], [], left)[0]:
            raise TimeoutError
        chunk = os.read(fd, n - len(out))
        if not chunk:
            return None
        out += chunk
    return out


def call(fn: Callable[[Callable[[float], None] | None], Any], cap: float,
         progress: Callable[[float], None] | None = None, what: str = "run") -> tuple[Any, str]:
    """``fn(progress)`` in a forked child; its value and, when it raised, the formatted
    traceback ('' otherwise). The child's exception is raised here again.

    Raises
    ------
    RunTimeout
        When the child has not answered within ``cap`` + :data:`KILL_AFTER_S` seconds (it is killed).
    RuntimeError
        When the child died without an answer (how it ended is said).
    """
    sys.stdout.flush()
    sys.stderr.flush()
    rfd, wfd = os.pipe()
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child's side (its coverage is not collected)
        code = 0
        try:
            os.close(rfd)
            _child(wfd, fn, progress is not None, parent)
        except BaseException:  # noqa: BLE001
            code = 1
        finally:
            os._exit(code)
    os.close(wfd)
    until = time.monotonic() + float(cap) + KILL_AFTER_S
    answer = None
    try:
        while True:
            head = _read(rfd, _HEADER.size, until)
            body = _read(rfd, _HEADER.unpack(head)[0], until) if head is not None else None
            if body is None:
                break
            msg = pickle.loads(body)
            if msg[0] == "progress":
                if progress is not None:
                    progress(msg[1])
                continue
            answer = msg
            break
    except TimeoutError:
        _kill(pid)
        raise RunTimeout(f"{what} exceeded the wall-time cap of {cap:g} s (its code did not stop by itself "
                         f"within {KILL_AFTER_S:g} s more: its process was killed)") from None
    except BaseException:
        _kill(pid)   # Ctrl-C or a failure here: the child does not outlive the call
        raise
    finally:
        os.close(rfd)
    _, status = os.waitpid(pid, 0)
    if answer is None:
        code = os.waitstatus_to_exitcode(status)
        raise RunCrashed(f"the {what}'s process ended without an answer ({describe_exit(code)})")
    if answer[0] == "raised":
        raise answer[1]
    return answer[1], answer[2]


def _kill(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    except (ProcessLookupError, ChildProcessError):
        pass
