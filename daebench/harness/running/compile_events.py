"""numba's compile events, listened to in one place.

* :data:`COMPILE_DEPTH` — per thread, how deep it is inside numba's compiler lock: the
  wall-time cap waits while its thread compiles
  (:mod:`daebench.harness.running.deadline`), and a run's progress notice says
  "compiling" only while some thread is (:func:`compiling`).
* :func:`compiled_during` — whether numba compiled while a call ran (its ``numba:compile``
  event fires on a cache miss only): a timed call that compiled does not count.
* :func:`recording` — every function compiled while a block runs, with its own compile
  time and the LLVM share (the compile census of ``daebench perf``).
"""

from __future__ import annotations

import threading
from typing import Any, Callable

from numba.core import event


class _CompileDepth:
    """Per thread, how deep it is inside numba's compiler lock (numba's event API; the
    callbacks run in the compiling thread)."""

    def __init__(self) -> None:
        self.depth: dict[int, int] = {}

    def on_start(self, event: Any) -> None:
        tid = threading.get_ident()
        self.depth[tid] = self.depth.get(tid, 0) + 1

    def on_end(self, event: Any) -> None:
        tid = threading.get_ident()
        self.depth[tid] = self.depth.get(tid, 1) - 1

    def compiling(self, thread_id: int) -> bool:
        return self.depth.get(thread_id, 0) > 0


def _install_compile_depth() -> _CompileDepth:
    class Listener(_CompileDepth, event.Listener):
        pass

    listener = Listener()
    event.register("numba:compiler_lock", listener)
    return listener


COMPILE_DEPTH = _install_compile_depth()


def compiling() -> bool:
    """Whether some thread of this process is inside the compiler (or loading its cache) now."""
    return any(d > 0 for d in list(COMPILE_DEPTH.depth.values()))


def compiled_during(fn: Callable[[], Any]) -> tuple[Any, bool]:
    """``fn()`` and whether numba compiled anything while it ran (its ``numba:compile``
    event fires on a cache miss only, not when compiled code loads from the cache)."""
    with event.install_recorder("numba:compile") as rec:
        result = fn()
    return result, bool(rec.buffer)
