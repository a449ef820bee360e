"""Borrowed views: the hot loops' arrays without numba's reference counting.

numba counts references to every array it moves: extracting an array from a tuple,
passing it to a function that is not inlined, slicing it — each is an atomic increment
and a matching decrement of the array's owner record (its *meminfo*). In the stepping
loop the arrays travel inside tuples (method, workspace, phase, states) through several
layers of calls on every Newton iteration: on the 2-coordinate pendulum 42 % of the
samples of a run sat on these atomic instructions (``perf record``, 1 000 s simulated).

:func:`borrow` returns the same value with every array's owner record set to null (and
its Python parent dropped): numba's increment and decrement test for null and return, so
the counting costs a predictable branch instead of a locked instruction. This is sound
only while the original value is alive and only inside the call that borrowed it: the
caller of the compiled loop holds the originals for the whole call, and a borrowed array
must never be returned to Python or stored beyond the call (numba could not keep its
memory alive). :func:`daebench.stepping.runner.run_phase` borrows its arguments on entry
and returns scalars only.

Borrowing leaves the calls themselves: a function that is not inlined still increments
every array of its arguments on entry (each array inside a workspace tuple too) and
decrements it on exit, one call to numba's ``NRT_incref``/``NRT_decref`` each — 20 such calls
in the machine code of :func:`daebench.core.phase.constraints` typed for the pendulum (numba
0.68), none when it is compiled uncounted. :func:`uncounted` compiles
a function without reference counting at all (numba's ``_nrt=False``): for functions that
allocate nothing and return no array, which is what the per-step functions below the runner
are. numba refuses to compile an allocation in such a function, so the rule is checked
where it matters, at compile time. numba compiles a callee that does not say otherwise with
its caller's setting: a function an uncounted one calls must allocate nothing and return no
array either (or be compiled with ``_nrt=True`` explicitly, as the counted implementations
of :mod:`daebench.core.dispatch` are).
"""

from __future__ import annotations

from typing import Any

from numba import njit, types
from numba.core import cgutils
from numba.extending import lower_builtin, type_callable


def _has_array(ty: types.Type) -> bool:
    if isinstance(ty, types.Array):
        return True
    if isinstance(ty, types.BaseTuple):
        return any(_has_array(t) for t in ty.types)
    return False


def _borrowed(context: Any, builder: Any, ty: types.Type, value: Any) -> Any:
    if isinstance(ty, types.Array):
        ary = context.make_array(ty)(context, builder, value)
        ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
        ary.parent = cgutils.get_null_value(ary.parent.type)
        return ary._getvalue()
    if isinstance(ty, types.BaseTuple):
        for k, member in enumerate(ty.types):
            if _has_array(member):
                inner = _borrowed(context, builder, member, builder.extract_value(value, k))
                value = builder.insert_value(value, inner, k)
    return value


def borrow(value: Any) -> Any:
    """``value`` (an array, or a tuple/NamedTuple holding arrays at any depth) with every
    array's owner reference dropped in compiled code: no reference counting on it (module
    docstring for when this is sound). Scalars and array-free members pass through
    unchanged; called from Python (and under ``DAEBENCH_COMPILED=0``) it returns ``value``."""
    return value


# typed and lowered at the call site (no function of its own to compile: an overload's
# implementation is compiled as a function for every argument type, and for the loop's
# whole argument tuple that was seconds of LLVM time per loop)
@type_callable(borrow)
def _type_borrow(context):
    def typer(value):
        return value

    return typer


@lower_builtin(borrow, types.Any)
def _lower_borrow(context, builder, sig, args):
    return _borrowed(context, builder, sig.args[0], args[0])


def uncounted(fn: Any = None, **options: Any) -> Any:
    """``njit(cache=True, _nrt=False, **options)``: a compiled function without reference
    counting (module docstring) — for a function that allocates nothing and returns no array;
    numba rejects an allocation in it when it compiles. Registered as a stepper's or a kernel's
    implementation (:mod:`daebench.core.dispatch`) it is compiled so too."""
    deco = njit(**{"cache": True, **options, "_nrt": False})
    return deco if fn is None else deco(fn)


@njit(inline="always")
def copy_to(dst, src):
    """``dst[:] = src`` in an :func:`uncounted` function: numba's slice assignment checks the
    two for overlap and may copy through a temporary (an allocation); an element loop cannot."""
    for i in range(src.shape[0]):
        dst[i] = src[i]
