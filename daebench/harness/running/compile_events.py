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
import time
from contextlib import contextmanager
from typing import Any, Callable, Iterator

import llvmlite.binding as ll
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


def text_bytes(obj: bytes) -> int:
    """Bytes of machine code in an object file: the sizes of its text sections."""
    return sum(s.size() for s in ll.ObjectFileRef.from_data(obj).sections() if s.is_text())


def code_bytes(library: Any) -> int:
    """Bytes of machine code in a compiled function's library (:func:`text_bytes` of the
    object numba emitted): its own code and every callee linked into it. 0 when numba kept
    no object (caching of objects disabled for that library)."""
    obj = getattr(library, "_compiled_object", None)
    return text_bytes(obj) if obj else 0


def _pass_seconds(cres: Any, word: str) -> float:
    times = (getattr(cres, "metadata", None) or {}).get("pipeline_times", {})
    return sum(t.run for passes in times.values() for name, t in passes.items() if word in name)


@contextmanager
def recording() -> Iterator[dict]:
    """Record numba's compiles while the block runs: yields ``{"functions": [...], "llvm_s": x}``
    (filled as compiles end; each function a :class:`Compiled` as a dict: its own time split
    into typing (type inference, callees' compiles excluded), lowering (LLVM excluded), LLVM
    (optimisation and machine code) and the rest, and its machine-code bytes)."""
    stack: list[list] = []          # [name, signature, start, nested seconds, own LLVM seconds]
    rec: dict = {"functions": [], "llvm_s": 0.0}
    llvm_start = [0.0]

    class Compiles(event.Listener):
        def on_start(self, event):
            d = event.data
            disp = d["dispatcher"]
            py = getattr(disp, "py_func", None)
            name = f"{getattr(py, '__module__', '?')}.{getattr(py, '__qualname__', repr(disp))}"
            stack.append([name, ", ".join(str(a) for a in d["args"]), time.perf_counter(), 0.0, 0.0])

        def on_end(self, event):
            name, sig, t0, nested, llvm = stack.pop()
            span = time.perf_counter() - t0
            if stack:
                stack[-1][3] += span
            cres = event.data["dispatcher"].overloads.get(tuple(event.data["args"]))
            typing = max(0.0, _pass_seconds(cres, "type_inference") - nested)
            lowering = max(0.0, _pass_seconds(cres, "native_lowering") - llvm)
            rec["functions"].append({"name": name, "signature": sig[:200], "own_s": span - nested,
                                     "total_s": span, "typing_s": typing, "lowering_s": lowering,
                                     "llvm_s": llvm,
                                     "code_bytes": code_bytes(getattr(cres, "library", None))})

    class Llvm(event.Listener):
        def on_start(self, event):
            llvm_start[0] = time.perf_counter()

        def on_end(self, event):
            span = time.perf_counter() - llvm_start[0]
            rec["llvm_s"] += span
            if stack:
                stack[-1][4] += span

    listeners = [("numba:compile", Compiles()), ("numba:llvm_lock", Llvm())]
    for kind, lis in listeners:
        event.register(kind, lis)
    try:
        yield rec
    finally:
        for kind, lis in listeners:
            event.unregister(kind, lis)
