"""A plugin's compiled stepper as compiled values: an edit recompiles the plugin's code only.

numba specialises a caller on the type of every argument: :func:`daebench.stepping.runner.run_phase`
— the loop every compiled method runs in, with step control, the event watch and dense
output — compiled for a plugin's method data would be compiled again (seconds) whenever
the plugin's code changes. A stepper from outside daebench therefore reaches the loop as a
:class:`MethodHandle`, one type for every plugin, as model kernels reach it
(:mod:`daebench.core.handles`):

* ``fns`` — the entry addresses of the stepper's ``start``, ``step`` and ``accept``
  (:mod:`daebench.stepping.methods`), compiled with the types of this phase;
* ``f``, ``i`` — the method data's and the workspace's scalars, array addresses and shapes.

Each entry rebuilds the plugin's own data and workspace tuples from ``f`` and ``i`` (views
of the plugin's arrays: no copy) and calls the functions the plugin registered, inlined. The
entries are generated once per data layout into a module named by daebench's source stamp
and by the digest of the plugin's registered functions and of what they reach
(:func:`daebench.core.code_digest.functions_digest`), cached on disk like the rest: the
loop is compiled once for every plugin, and an edit of the plugin compiles three small
entries. A stepper whose data the layout cannot describe (not float64/int64/bool arrays,
numbers and tuples) runs specialised, as daebench's own do.

The handle keeps the method data and workspace alive and reads their arrays in place: the
integrator keeps using its own workspace tuple (contact records, carried state).
"""

from __future__ import annotations

import importlib.util
import os
import sys
import weakref
from typing import Any, NamedTuple

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from daebench.core import code_digest, handles, numba_cache
from daebench.core.borrow import uncounted
from daebench.core.kernels import KernelError
from daebench.stepping import methods

_F = types.float64[::1]
_I = types.int64[::1]
_LAYOUT_VERSION = "1"
STEP_RESULT = types.Tuple((types.int64, types.float64))


class MethodHandle(NamedTuple):
    """A plugin stepper's entries and data in the one layout the loop is compiled for."""

    fns: np.ndarray     # int64[3]: the start, step and accept entries' addresses
    f: np.ndarray       # float64: the method data's and the workspace's float scalars
    i: np.ndarray       # int64: their int and bool scalars, every array's address and shape

    def __reduce__(self):
        raise TypeError("a MethodHandle holds memory addresses of this process and cannot be pickled")


def start_signature(ph: Any, cur: Any, cnt: Any) -> Any:
    return types.int64(_F, _I, ph, types.float64, cur, cnt)


def step_signature(ph: Any, ctl: Any, cur: Any, cnt: Any) -> Any:
    return STEP_RESULT(_F, _I, ph, ctl, types.float64, types.float64, cur, cur, cnt)


def accept_signature(cur: Any) -> Any:
    return types.none(_F, _I, types.float64, cur, cur)


def _function_value(fntype: Any) -> Any:
    """Codegen of a first-class function value of ``fntype`` at the address in the first
    argument, called with numba's own calling convention (as :func:`daebench.core.handles._function_at`)."""

    def codegen(context, builder, signature, args):
        fn = cgutils.create_struct_proxy(fntype)(context, builder)
        null = context.get_constant_null(types.voidptr)
        fn.c_addr = null
        fn.py_addr = null
        fn.jit_addr = builder.inttoptr(args[0], context.get_value_type(types.voidptr))
        return fn._getvalue()

    return codegen


# the entry at an address as a function value; its signature follows from the types of the
# other arguments, which are read for typing only
@intrinsic
def _start_at(typingctx, addr, ph, cur, cnt):
    fntype = types.FunctionType(start_signature(ph, cur, cnt))
    return fntype(addr, ph, cur, cnt), _function_value(fntype)


@intrinsic
def _step_at(typingctx, addr, ph, ctl, cur, cnt):
    fntype = types.FunctionType(step_signature(ph, ctl, cur, cnt))
    return fntype(addr, ph, ctl, cur, cnt), _function_value(fntype)


@intrinsic
def _accept_at(typingctx, addr, cur):
    fntype = types.FunctionType(accept_signature(cur))
    return fntype(addr, cur), _function_value(fntype)


def _h_start(meth, ws, ph, t, cur, cnt):
    return _start_at(meth.fns[0], ph, cur, cnt)(meth.f, meth.i, ph, t, cur, cnt)


def _h_step(meth, ws, ph, ctl, t, h, cur, new, cnt):
    return _step_at(meth.fns[1], ph, ctl, cur, cnt)(meth.f, meth.i, ph, ctl, t, h, cur, new, cnt)


def _h_accept(meth, ws, h, prev, cur):
    _accept_at(meth.fns[2], cur)(meth.f, meth.i, h, prev, cur)


methods.start.register(MethodHandle, uncounted(_h_start))
methods.step.register(MethodHandle, uncounted(_h_step))
methods.accept.register(MethodHandle, uncounted(_h_accept))


# -- the generated entries ------------------------------------------------------------------------
_SOURCE = '''# generated by daebench.stepping.method_handles: a plugin stepper's entries over (f, i) (do not edit)
from numba import njit
from daebench.stepping import methods as _methods
from daebench.core.handles import _carray, _f64_at, _i64_at, _b1_at


@njit(inline='always')
def _unpack(f, i):
    return {expr}


_start = njit(inline='always')(_methods.start.implementation(_C0).py_func)
_step = njit(inline='always')(_methods.step.implementation(_C0).py_func)
_accept = njit(inline='always')(_methods.accept.implementation(_C0).py_func)


@njit(cache=True)
def start(f, i, ph, t, cur, cnt):
    meth, ws = _unpack(f, i)
    return _start(meth, ws, ph, t, cur, cnt)


@njit(cache=True)
def step(f, i, ph, ctl, t, h, cur, new, cnt):
    meth, ws = _unpack(f, i)
    return _step(meth, ws, ph, ctl, t, h, cur, new, cnt)


@njit(cache=True)
def accept(f, i, h, prev, cur):
    meth, ws = _unpack(f, i)
    _accept(meth, ws, h, prev, cur)
'''

_MODULES: dict[tuple, Any] = {}


def applies(meth: Any) -> bool:
    """Whether ``meth`` (a method's data) runs through a handle: compiled, from outside
    daebench, with the three functions registered."""
    cls = type(meth)
    return (not numba.config.DISABLE_JIT and not code_digest.is_daebench(cls.__module__)
            and all(g.registered(cls) for g in (methods.start, methods.step, methods.accept))
            and all(hasattr(g.implementation(cls), "py_func") for g in (methods.start, methods.step, methods.accept)))


def _module(layout: Any, expr: str) -> Any:
    cls = layout.classes[0]
    impls = tuple(g.implementation(cls) for g in (methods.start, methods.step, methods.accept))
    made = (impls, *layout.key)
    if made in _MODULES:
        return _MODULES[made]
    digest = code_digest.functions_digest(impls, [_LAYOUT_VERSION, numba_cache.source_stamp(), *layout.key])
    name = f"_daebench_method_{cls.__name__.lower()}_{digest[:16]}"
    path = handles._directory() / f"{name}.py"
    if not path.exists():
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(_SOURCE.format(expr=expr))
        os.replace(tmp, path)  # concurrent workers write the same text: either copy is right
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    for k, c in enumerate(layout.classes):  # the classes are given, not imported: a notebook's too
        setattr(module, f"_C{k}", c)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    module.__daebench_fns__ = {}
    _MODULES[made] = module
    return module


def _entries(module: Any, ph: Any, ctl: Any, cur: Any, cnt: Any) -> np.ndarray:
    """The entries' addresses compiled (or loaded) for these argument types."""
    tph, tctl, tcur, tcnt = (numba.typeof(x) for x in (ph, ctl, cur, cnt))
    key = (tph, tctl, tcur, tcnt)
    fns = module.__daebench_fns__.get(key)
    if fns is None:
        fns = np.array([handles._jit_address(module.start, start_signature(tph, tcur, tcnt)),
                        handles._jit_address(module.step, step_signature(tph, tctl, tcur, tcnt)),
                        handles._jit_address(module.accept, accept_signature(tcur))], dtype=np.int64)
        fns.flags.writeable = False
        module.__daebench_fns__[key] = fns
    return fns


_KEEP: dict[int, Any] = {}


def handle(meth: Any, ws: Any, ph: Any, ctl: Any, cur: Any, cnt: Any) -> MethodHandle | None:
    """The :class:`MethodHandle` of a plugin's method data ``meth`` and workspace ``ws`` for a
    phase ``ph`` with step control ``ctl``, states like ``cur`` and counters ``cnt``; None
    when the layout cannot describe them (the stepper then runs specialised)."""
    layout = handles._Layout()
    try:
        expr = layout.expr((meth, ws), type(meth).__name__)
    except KernelError:
        return None
    module = _module(layout, expr)
    i = np.array(layout.i, dtype=np.int64)
    _KEEP[id(i)] = (meth, ws)
    weakref.finalize(i, _KEEP.pop, id(i), None)
    return MethodHandle(_entries(module, ph, ctl, cur, cnt), np.array(layout.f, dtype=np.float64), i)
