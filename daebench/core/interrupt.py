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
"""

from __future__ import annotations

import threading

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
