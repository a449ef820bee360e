"""The interpreter's frame-stack chunks kept for reuse while numba compiles.

CPython 3.11 keeps its frames on a stack of 16 KiB chunks and returns a chunk to the
operating system (``munmap``) as soon as its first frame returns; a call depth that goes
back and forth across a chunk's edge maps and unmaps a chunk at every crossing
(CPython issue gh-142183, fixed in 3.13 and 3.14 by keeping one chunk, not in 3.11 or
3.12). numba's compiler is deep Python recursion and crosses such an edge hundreds of
thousands of times: a cold ``daebench run beam-impact --integrator hht`` took 1.29 – 1.33
million page faults and 7.6 – 8.2 s of system time of its 43.5 – 46.3 s CPU (``perf record -e
page-faults``: 86 % in ``_PyThreadState_BumpFramePointerSlow``); with the chunks kept, 0.17
million and 1.3 s of 36.7 – 39.2 s (docs/performance.md).

While numba compiles (its ``numba:compile`` event, outermost), the interpreter's arena
allocator (``PyObject_SetArenaAllocator``, which serves those chunks and pymalloc's
arenas) is wrapped by one that keeps up to :data:`KEEP` freed chunks of the chunk size and
hands them out again; everything else goes to the allocator it wraps. The wrapper is two
small functions in machine code built once per process by llvmlite (a few milliseconds; no
numba compile, so the compile census sees nothing of it). At the end of the
compile the wrapped allocator is put back and the kept chunks are returned through it.
Both allocators map and unmap the same way, so a block allocated under one may be freed
under the other. The allocator runs with the GIL held, as CPython calls it.

Off with ``DAEBENCH_STACK_CHUNKS=0``, and where it does not apply: another interpreter
than CPython, a 32-bit build (the two functions take every argument as 64 bits),
``DAEBENCH_COMPILED=0`` (nothing compiles).
"""

from __future__ import annotations

import ctypes
import sys
from typing import Any

from numba.core import config, event

from daebench.core.switches import switched_off

#: CPython's DATA_STACK_CHUNK_SIZE (Python/pystate.c): the size of an ordinary chunk
CHUNK = 16 * 1024
#: chunks kept at most (128 KiB); a crossing needs one
KEEP = 8


class _Arena(ctypes.Structure):
    _fields_ = [("ctx", ctypes.c_void_p), ("alloc", ctypes.c_void_p), ("free", ctypes.c_void_p)]


def _compiled_pair() -> Any:
    """``alloc(ctx, size)`` and ``free(ctx, ptr, size)`` in machine code (llvmlite, as the
    allocator must not run Python). ``ctx`` is the store, an int64 array: ``[kept,
    chunk_1 … chunk_KEEP, wrapped ctx, wrapped alloc, wrapped free]``. Every argument an
    int64, as pointers and ``size_t`` pass on the 64-bit ABIs. Returns the execution engine."""
    from llvmlite import binding as llvm
    from llvmlite import ir

    i64 = ir.IntType(64)
    module = ir.Module(name="daebench_stack_chunks")

    def function(name: str, ret: Any, nargs: int) -> tuple[Any, Any, Any]:
        fn = ir.Function(module, ir.FunctionType(ret, [i64] * nargs), name=name)
        b = ir.IRBuilder(fn.append_basic_block("entry"))
        base = b.inttoptr(fn.args[0], i64.as_pointer())
        return fn, b, lambda k: b.gep(base, [k if isinstance(k, ir.Value) else ir.Constant(i64, k)])

    def wrapped(b: Any, at: Any, slot: int, ty: Any, args: list) -> Any:
        return b.call(b.inttoptr(b.load(at(slot)), ty.as_pointer()), [b.load(at(KEEP + 1)), *args])

    one, chunk = ir.Constant(i64, 1), ir.Constant(i64, CHUNK)
    fn, b, at = function("alloc", i64, 2)
    size, kept = fn.args[1], b.load(at(0))
    with b.if_then(b.and_(b.icmp_unsigned("==", size, chunk), b.icmp_unsigned(">", kept, ir.Constant(i64, 0)))):
        left = b.sub(kept, one)
        b.store(left, at(0))
        b.ret(b.load(at(b.add(left, one))))
    b.ret(wrapped(b, at, KEEP + 2, ir.FunctionType(i64, [i64, i64]), [size]))

    fn, b, at = function("free", ir.VoidType(), 3)
    ptr, size, kept = fn.args[1], fn.args[2], b.load(at(0))
    with b.if_then(b.and_(b.icmp_unsigned("==", size, chunk), b.icmp_unsigned("<", kept, ir.Constant(i64, KEEP)))):
        b.store(ptr, at(b.add(kept, one)))
        b.store(b.add(kept, one), at(0))
        b.ret_void()
    wrapped(b, at, KEEP + 3, ir.FunctionType(ir.VoidType(), [i64, i64, i64]), [ptr, size])
    b.ret_void()

    llvm.initialize_native_target()
    llvm.initialize_native_asmprinter()
    parsed = llvm.parse_assembly(str(module))
    parsed.verify()
    engine = llvm.create_mcjit_compiler(parsed, llvm.Target.from_default_triple().create_target_machine())
    engine.finalize_object()
    return engine


def _build(prev: _Arena) -> tuple[_Arena, Any, Any]:
    """The wrapping allocator for ``prev``: (its struct, its store, prev's free as ctypes)."""
    engine = _compiled_pair()
    store = (ctypes.c_uint64 * (KEEP + 4))()
    store[KEEP + 1], store[KEEP + 2], store[KEEP + 3] = prev.ctx or 0, prev.alloc, prev.free
    wrapper = _Arena(ctypes.addressof(store), engine.get_function_address("alloc"),
                     engine.get_function_address("free"))
    wrapper._keep = (engine, store)      # the machine code and the store live as long as the struct
    prev_free = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t)(prev.free)
    return wrapper, store, prev_free


class ChunkKeeper(event.Listener):
    """Wraps the arena allocator from the outermost compile's start to its end."""

    def __init__(self) -> None:
        self.depth = 0
        self.active = False
        self.failed = False
        self.wrapper: _Arena | None = None

    def on_start(self, event: Any) -> None:
        self.depth += 1
        if self.depth == 1:
            self.wrap()

    def on_end(self, event: Any) -> None:
        self.depth -= 1
        if self.depth == 0:
            self.unwrap()

    def wrap(self) -> None:
        api = ctypes.pythonapi
        prev = _Arena()
        api.PyObject_GetArenaAllocator(ctypes.byref(prev))
        if self.wrapper is None:
            if self.failed:
                return
            try:
                self.wrapper, self.store, self.prev_free = _build(prev)
            except Exception as exc:  # a speed aid must not break the compile it serves
                self.failed = True
                print(f"daebench: frame-stack chunks are not kept ({type(exc).__name__}: {exc}); compiling "
                      "goes on at CPython's own pace (set DAEBENCH_STACK_CHUNKS=0 to silence this)", file=sys.stderr)
                return
            self.prev = prev
        if prev.alloc != self.prev.alloc or prev.free != self.prev.free:
            return                    # someone else replaced the allocator since: leave theirs alone
        api.PyObject_SetArenaAllocator(ctypes.byref(self.wrapper))
        self.active = True

    def unwrap(self) -> None:
        if not self.active:
            return
        ctypes.pythonapi.PyObject_SetArenaAllocator(ctypes.byref(self.prev))
        self.active = False
        store = self.store
        for i in range(int(store[0])):
            self.prev_free(self.prev.ctx, store[1 + i], CHUNK)
        store[0] = 0


def applies() -> bool:
    """Whether the chunks are kept (64-bit CPython, compiling on, not switched off)."""
    return (sys.implementation.name == "cpython" and ctypes.sizeof(ctypes.c_void_p) == 8 and not config.DISABLE_JIT
            and not switched_off("DAEBENCH_STACK_CHUNKS"))


KEEPER: ChunkKeeper | None = None


def install() -> None:
    """Listen to numba's compiles (idempotent; see the module docstring)."""
    global KEEPER
    if KEEPER is not None or not applies():
        return
    api = ctypes.pythonapi
    api.PyObject_GetArenaAllocator.argtypes = [ctypes.POINTER(_Arena)]
    api.PyObject_SetArenaAllocator.argtypes = [ctypes.POINTER(_Arena)]
    KEEPER = ChunkKeeper()
    event.register("numba:compile", KEEPER)
