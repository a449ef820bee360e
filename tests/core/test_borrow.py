"""core.borrow: the hot loop's arguments without reference counting, same values, same memory."""

import sys
from typing import NamedTuple

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from daebench.core.borrow import borrow


class Inner(NamedTuple):
    a: np.ndarray
    k: int


class Outer(NamedTuple):
    x: np.ndarray
    inner: Inner
    h: float
    M: np.ndarray


@njit
def _work(data, reps):
    d = borrow(data)
    s = 0.0
    for _ in range(reps):
        v = d.x[1:]                      # a slice of a borrowed array: a view of the same memory
        for i in range(v.shape[0]):
            v[i] += d.h * d.inner.a[i % d.inner.a.shape[0]]
        s += d.M[1, 0] * d.inner.k
    return s


def test_borrowed_values_alias_the_originals_and_leave_reference_counts_alone():
    x = np.zeros(4)
    a = np.array([1.0, 2.0])
    M = np.array([[0.0, 1.0], [3.0, 0.0]])
    data = Outer(x, Inner(a, 2), 0.5, M)
    before = [sys.getrefcount(o) for o in (x, a, M)]
    s = _work(data, 10)
    assert s == 10 * 3.0 * 2
    # 10 passes of x[1:] += 0.5 · a[i mod 2]: written through the borrowed view into x itself
    np.testing.assert_array_equal(x, [0.0, 5.0, 10.0, 5.0])
    assert [sys.getrefcount(o) for o in (x, a, M)] == before


def test_python_side_is_the_identity():
    data = Outer(np.zeros(2), Inner(np.ones(1), 1), 1.0, np.eye(2))
    assert borrow(data) is data


@intrinsic
def _owner(typingctx, arr):
    """The address of an array's owner record (its meminfo) as seen by compiled code."""
    def codegen(context, builder, sig, args):
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        return builder.ptrtoint(ary.meminfo, ir.IntType(64))

    return types.int64(arr), codegen


@njit
def _owners(data):
    d = borrow(data)
    return _owner(data.x), _owner(d.x), _owner(d.inner.a), _owner(d.M)


def test_borrowed_arrays_have_no_owner_record():
    data = Outer(np.zeros(3), Inner(np.ones(2), 1), 1.0, np.eye(2))
    own, *borrowed = _owners(data)
    assert own != 0 and borrowed == [0, 0, 0]


# -- uncounted: compiled without reference counting ----------------------------------------------
import pytest  # noqa: E402
from numba.core.errors import TypingError  # noqa: E402

from daebench.core.borrow import copy_to, uncounted  # noqa: E402
from daebench.core.dispatch import generic  # noqa: E402


def _scaled_sum(data, out):
    v = data.x[1:]
    s = 0.0
    for i in range(v.shape[0]):
        s += data.h * v[i] * data.inner.a[i % data.inner.a.shape[0]]
    out[0] = s


def _nrt_calls(dispatcher) -> int:
    asm = dispatcher.inspect_asm(dispatcher.signatures[0])
    return sum(1 for line in asm.splitlines() if "NRT_incref" in line or "NRT_decref" in line)


def test_uncounted_function_has_no_reference_counting_and_the_same_result():
    counted, free = njit(_scaled_sum), uncounted(_scaled_sum, cache=False)  # cached code cannot be inspected
    data = Outer(np.arange(5.0), Inner(np.array([1.0, -2.0]), 1), 0.5, np.eye(2))
    out_c, out_f = np.zeros(1), np.zeros(1)
    counted(data, out_c)
    free(data, out_f)
    assert out_f[0] == out_c[0] == 0.5 * (1 * 1 - 2 * 2 + 3 * 1 - 4 * 2)
    assert _nrt_calls(counted) > 0      # numba counts the tuple's arrays and the view
    assert _nrt_calls(free) == 0


def test_uncounted_function_refuses_to_allocate_at_compile_time():
    @uncounted
    def allocates(n):
        return np.zeros(n).sum()

    with pytest.raises(TypingError):
        allocates(3)


def test_copy_to_copies_elementwise():
    @uncounted
    def f(dst, src):
        copy_to(dst[1:], src)

    dst = np.zeros(4)
    f(dst, np.array([1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(dst, [0.0, 1.0, 2.0, 3.0])


class _Counted(NamedTuple):
    n: int


class _Free(NamedTuple):
    n: int


@generic
def _total(data):
    """Sum of ones of length data.n."""


def _allocating_total(data):
    return np.ones(data.n).sum()


_total.register(_Counted, njit(_allocating_total))
_total.register(_Free, uncounted(_allocating_total))


@njit
def _call_total(data):
    return _total(data)


def test_dispatch_compiles_each_implementation_with_its_own_counting():
    # the same body: with reference counting it compiles and runs; registered uncounted it is
    # compiled without (so its allocation is refused) — the registration's option reaches numba
    assert _call_total(_Counted(4)) == 4.0
    with pytest.raises(TypingError):
        _call_total(_Free(4))
