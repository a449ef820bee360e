"""daebench.stepping.lcp_avg's Dormand–Prince 5(4) tableau against the Runge–Kutta order
conditions (Butcher): the 5th-order weights b satisfy all 17 conditions up to order 5, the
embedded 4th-order weights b̂ = b − e those up to order 4 and not all of order 5; the
stages are consistent (Σ_j a_ij = c_i) and the last stage is the FSAL one (row 7 = b)."""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import pytest

from daebench.stepping.lcp_avg import DP_A, DP_B, DP_C, DP_E

A = np.zeros((7, 7))
A[:, :DP_A.shape[1]] = DP_A          # stored 7 × 6: the last stage's column is zero (explicit)


def _trees(order: int):
    """Rooted trees as nested tuples of children, up to ``order`` nodes."""
    trees = {1: [()]}
    for n in range(2, order + 1):
        out = set()
        for parts in _partitions(n - 1):
            for combo in itertools.product(*[trees[p] for p in parts]):
                out.add(tuple(sorted(combo)))
        trees[n] = sorted(out)
    return trees


def _partitions(n, largest=None):
    largest = n if largest is None else largest
    if n == 0:
        yield ()
        return
    for k in range(min(n, largest), 0, -1):
        for rest in _partitions(n - k, k):
            yield (k,) + rest


def _size(t):
    return 1 + sum(_size(c) for c in t)


def _gamma(t):
    g = _size(t)
    for c in t:
        g *= _gamma(c)
    return g


def _phi_stage(t):
    """Vector over stages: Φ_i(t) = Π over children (A · Φ(child))_i."""
    v = np.ones(7)
    for c in t:
        v = v * (A @ _phi_stage(c))
    return v


def _residuals(b, order):
    out = []
    for n, ts in _trees(order).items():
        for t in ts:
            out.append((n, float(b @ _phi_stage(t)) - 1.0 / _gamma(t)))
    return out


def test_the_tree_count_is_butchers():
    assert [len(v) for v in _trees(5).values()] == [1, 1, 2, 4, 9]     # 17 conditions to order 5


def test_consistency_and_fsal():
    np.testing.assert_allclose(A.sum(axis=1), DP_C, atol=1e-15)
    np.testing.assert_allclose(A[6], DP_B, atol=1e-15)
    assert Fraction(DP_B[0]).limit_denominator(10_000) == Fraction(35, 384)


def test_fifth_order_weights_meet_every_condition_to_order_five():
    assert max(abs(r) for _, r in _residuals(DP_B, 5)) < 1e-15


def test_embedded_weights_are_fourth_order_not_fifth():
    bhat = DP_B - DP_E
    res = _residuals(bhat, 5)
    assert max(abs(r) for n, r in res if n <= 4) < 1e-15
    assert max(abs(r) for n, r in res if n == 5) > 1e-4
    assert bhat.sum() == pytest.approx(1.0, abs=1e-15)
