"""The wall-time cap of a run (:func:`deadline`).

A watchdog thread asks the thread that runs the simulation to stop
(:mod:`daebench.core.interrupt`): the driver raises :class:`RunTimeout` at its next safe
point, after the integrator's call (at least every compiled batch of steps). It works in
any thread (a Dask worker runs tasks in threads, where SIGALRM cannot reach). A run that
reaches no safe point within :data:`GRACE_S` (a plugin stuck in its own step) is
interrupted at its next Python bytecode instead — but never while numba compiles in that
thread (:data:`daebench.harness.running.compile_events.COMPILE_DEPTH`): an exception
raised inside numba's compiler (LLVM calls back into Python) killed the worker process or
left an error on a cold cache, so such an interrupt waits for the compilation's end.
"""

from __future__ import annotations

import ctypes
import math
import threading
from contextlib import contextmanager
from typing import Any, Iterator

from daebench.core.interrupt import RunTimeout, pending, request, withdraw
from daebench.core.params import ParamError
from daebench.harness.running.compile_events import COMPILE_DEPTH

RECHECK_S = 0.05    # while the capped thread compiles, the watchdog looks again this often
GRACE_S = 2.0       # a run that has not reached a safe point this long after the cap is interrupted


class RunCapError(ParamError):
    """A wall-time cap that is not a finite number of seconds > 0."""


def _raise_in(thread_id: int, exc: type[BaseException] | None) -> None:
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread_id),
                                               ctypes.py_object(exc) if exc is not None else None)


@contextmanager
def deadline(seconds: float | None) -> Iterator[None]:
    """Raise :class:`RunTimeout` in the calling thread once ``seconds`` of wall time have
    passed inside the ``with`` block (None or 0: no cap).

    Raises
    ------
    RunCapError
        If ``seconds`` is negative or not finite.
    """
    if seconds is None or seconds == 0:
        yield
        return
    check_run_cap(seconds)
    target = threading.get_ident()
    lock = threading.Lock()
    state = {"active": True, "fired": False, "async": False}

    timers: list[threading.Timer] = []

    def arm(delay: float) -> None:
        timer = threading.Timer(delay, fire)
        timer.daemon = True
        timers.append(timer)
        timer.start()

    def fire() -> None:
        with lock:
            if not state["active"]:
                return
            state["fired"] = True
            request(target, RunTimeout)  # honoured at the driver's next safe point (core.interrupt)
            arm_late(GRACE_S)

    def late() -> None:
        with lock:
            if not state["active"] or not pending(target):
                return
            if COMPILE_DEPTH.compiling(target):
                arm_late(RECHECK_S)     # never inside numba's compiler: once it is done
                return
            withdraw(target)
            state["async"] = True
            _raise_in(target, RunTimeout)  # no safe point within the grace time: interrupt it

    def arm_late(delay: float) -> None:
        timer = threading.Timer(delay, late)
        timer.daemon = True
        timers.append(timer)
        timer.start()

    arm(float(seconds))
    try:
        yield
    except RunTimeout:
        raise RunTimeout(f"run exceeded the wall-time cap of {seconds:g} s") from None
    except Exception as exc:
        if not state["async"]:
            raise
        # the asynchronous RunTimeout (a run that reached no safe point within the grace time)
        # landed in a Python model's call from compiled code (numba.objmode): numba's own
        # exception handling then fails with it pending ("SystemError: … returned a result
        # with an exception set", or a garbled TypeError). The run is over its cap either way
        raise RunTimeout(f"run exceeded the wall-time cap of {seconds:g} s") from exc
    finally:
        with lock:
            for timer in timers:
                timer.cancel()
            state["active"] = False
            unhonoured = withdraw(target)   # the block ended before its next safe point
            if state["async"]:
                _raise_in(target, None)     # the block ended just as the interrupt came: drop it
    if state["fired"] and unhonoured:
        raise RunTimeout(f"run exceeded the wall-time cap of {seconds:g} s")


def check_run_cap(seconds: Any) -> float | None:
    """A run cap in seconds: None, or a finite number > 0."""
    if seconds is None:
        return None
    try:
        s = float(seconds)
    except (TypeError, ValueError):
        raise RunCapError(f"the run cap must be a number of seconds, got {seconds!r}") from None
    if not math.isfinite(s) or s <= 0:
        raise RunCapError(f"the run cap must be a finite number of seconds > 0, got {seconds!r} "
                          f"(e.g. --run-cap 600; leave it out for no cap)")
    return s
