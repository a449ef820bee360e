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
