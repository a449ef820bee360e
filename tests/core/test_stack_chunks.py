"""The frame-stack chunks kept while numba compiles (daebench.core.stack_chunks), judged by
the kernel's own count of page faults: a Python call 300 frames deep leaves CPython's first
16 KiB chunk, and on CPython 3.11/3.12 every such call maps fresh chunks (≥ 4 faults each)
and unmaps them on return. Inside a compile the kept chunks serve the next call; outside,
and with DAEBENCH_STACK_CHUNKS=0, CPython's own allocator is left alone."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

_CHILD = r"""
import ctypes, json, resource
from numba.core import event
import daebench
from daebench.core import stack_chunks as sc

def deep(n):
    return 0 if n == 0 else deep(n - 1)

def faults_of_calls(k=500, depth=300):
    deep(depth)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(k):
        deep(depth)
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before

def allocator():
    a = sc._Arena()
    ctypes.pythonapi.PyObject_GetArenaAllocator(ctypes.byref(a))
    return a.alloc, a.free

outside = allocator()
with event.trigger_event("numba:compile"):
    with event.trigger_event("numba:compile"):      # nested: the outermost owns the wrapping
        during = allocator()
        inside = faults_of_calls()
        objects = [list(range(i % 50)) for i in range(200_000)]   # pymalloc arenas through the wrapper
    still = allocator()
checksum = sum(len(o) for o in objects)
del objects
print(json.dumps({"inside": inside, "outside": faults_of_calls(), "swapped": during != outside,
                  "nested_kept": still == during, "restored": allocator() == outside,
                  "kept_after": int(sc.KEEPER.store[0]) if sc.KEEPER and sc.KEEPER.wrapper else None,
                  "checksum": checksum}))
"""


def _child(flag: str) -> dict:
    env = dict(os.environ, DAEBENCH_STACK_CHUNKS=flag)
    out = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(sys.implementation.name != "cpython" or sys.version_info >= (3, 13),
                    reason="CPython 3.13+ keeps a chunk itself (gh-142183)")
def test_kept_chunks_remove_the_page_faults_of_deep_calls_while_compiling():
    on, off = _child("1"), _child("0")
    assert off["inside"] >= 4 * 500 and off["outside"] >= 4 * 500     # every call maps its chunks afresh
    assert on["inside"] < 50                                           # the kept chunks serve them
    assert on["outside"] >= 4 * 500                                    # outside a compile: CPython's own
    assert on["swapped"] and on["nested_kept"] and on["restored"] and on["kept_after"] == 0
    assert not off["swapped"] and off["restored"]
    assert on["checksum"] == off["checksum"] == sum(i % 50 for i in range(200_000))
