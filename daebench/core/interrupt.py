"""Cooperative stops: another thread asks a run to stop; the run raises where it is safe.

A wall-time cap (:func:`daebench.harness.running.deadline.deadline`) used to raise its
exception in the running thread asynchronously, at whatever Python bytecode came next.
Inside a Python model's kernel called from compiled code (``numba.objmode``) or inside a
weakref callback that left the exception pending ("SystemError: <weakref …> returned a
result with an exception set": a survey row reported it as the run's error). Now the
watchdog first *requests* the stop (:func:`request`), and the driver honours it at its
safe points — after every call of the integrator and at every phase start
(:func:`check`) — which it reaches at least every compiled batch of steps. Only a run that
does not come back to a safe point within the watchdog's grace time (a plugin stuck in its
own step) is interrupted asynchronously.

A run's own code may raise ``KeyboardInterrupt`` (or ``SystemExit``) too; a run must not
end the program for it, while Ctrl-C must. :func:`signals_counted` counts the signal
handlers that run during a run, so :func:`from_signal` tells the two apart.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Any, Callable, Iterator

_LOCK = threading.Lock()
_REQUESTS: dict[int, type[BaseException]] = {}


class RunTimeout(BaseException):
    """A run exceeded its wall-time cap (a BaseException so that a plugin's broad
    ``except Exception`` cannot swallow it)."""


def request(thread_id: int, exc: type[BaseException]) -> None:
    """Ask the thread ``thread_id`` to raise ``exc`` at its next safe point."""
    with _LOCK:
        _REQUESTS[thread_id] = exc


def withdraw(thread_id: int) -> bool:
    """Drop the request for ``thread_id``; whether one was still pending."""
    with _LOCK:
        return _REQUESTS.pop(thread_id, None) is not None


def pending(thread_id: int) -> bool:
    """Whether a request for ``thread_id`` has not been honoured yet."""
    with _LOCK:
        return thread_id in _REQUESTS


def check() -> None:
    """A safe point: raise the exception requested for this thread, if any."""
    if _REQUESTS:  # the common case costs one dict truth test
        with _LOCK:
            exc = _REQUESTS.pop(threading.get_ident(), None)
        if exc is not None:
            raise exc()


# -- telling a real interrupt from one a run's own code raised -----------------------------------------
_SIGNALS = [0]   # interrupts raised by a signal handler (Ctrl-C, SIGTERM as an interrupt) in this process


def signal_count() -> int:
    """How many signal handlers ran under :func:`signals_counted` so far; a
    ``KeyboardInterrupt`` raised while the count stayed the same did not come from a signal
    (a plugin raised it)."""
    return _SIGNALS[0]


@contextmanager
def signals_counted() -> Iterator[None]:
    """Count the SIGINT and SIGTERM handlers that run inside the block (the main thread's
    Python handlers are wrapped; elsewhere no handler can be set and none is counted: a
    signal's ``KeyboardInterrupt`` reaches the main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    saved = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        old = signal.getsignal(sig)
        if callable(old):
            def counted(signum: int, frame: Any, _old: Callable = old) -> Any:
                _SIGNALS[0] += 1
                return _old(signum, frame)
            saved[sig] = old
            signal.signal(sig, counted)
    try:
        yield
    finally:
        for sig, old in saved.items():
            signal.signal(sig, old)


def from_signal(exc: BaseException, count_before: int) -> bool:
    """Whether ``exc`` is an interrupt a signal caused (Ctrl-C, SIGTERM made an interrupt),
    a wall-time cap (:class:`RunTimeout`), or another exception — False for a
    ``KeyboardInterrupt`` raised by code while no signal arrived since ``count_before``."""
    if isinstance(exc, RunTimeout):
        return True
    return isinstance(exc, KeyboardInterrupt) and _SIGNALS[0] != count_before


def describe_raised(exc: BaseException) -> str:
    """What ended a run, in words: ``ZeroDivisionError: division by zero``; an exit or an
    interrupt raised by the run's own code says that a run cannot end the program."""
    text = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    if isinstance(exc, SystemExit):
        return (f"the run's code raised SystemExit({exc.code!r}) — a run cannot end the program; the run "
                f"failed there (an integrator or model that calls sys.exit() or exit())")
    if isinstance(exc, KeyboardInterrupt):
        return (f"the run's code raised {type(exc).__name__} with no Ctrl-C or signal — a run cannot end the "
                f"program; the run failed there")
    return text
