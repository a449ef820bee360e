"""Shape-function bases and tables (daebench.models.shapes) against independent truth."""

from __future__ import annotations

import numpy as np
import pytest

from daebench.models.shapes import (
    MAX_MODES,
    cantilever_roots,
    composite_gauss,
    fem_basis,
    foreshortening_matrices,
    modal_basis,
    tabulate,
)

# βL of the first cantilever modes (Blevins, Formulas for natural frequency and mode shape)
PUBLISHED_ROOTS = [1.87510406871196, 4.69409113297418, 7.85475743823761, 10.9955407348755, 14.1371683910465]


def test_roots_solve_characteristic_equation():
    z = cantilever_roots(MAX_MODES)
    # cos z cosh z = −1 ⇔ cos z + sech z = 0 (the well-scaled form; cosh z ~ 1e15 at mode 12)
    assert np.all(np.abs(np.cos(z) + 1.0 / np.cosh(z)) < 1e-14)
    assert np.allclose(z[:5], PUBLISHED_ROOTS, rtol=1e-13, atol=0)
    assert np.all(np.diff(z) > 2.8)  # roots approach (2i − 1)π/2


@pytest.mark.parametrize("L", [1.0, 1.8])
def test_modes_orthonormal_and_stiffness_diagonal(L):
    b = modal_basis(L, MAX_MODES, axial=True)
    tab = tabulate(b, np.array([L]), foreshortening=False)
    w = tab.w
    M = (tab.at.phy * w[:, None]).T @ tab.at.phy / L
    assert np.abs(M - np.eye(MAX_MODES)).max() < 1e-12
    beta = b.roots / L
    K = (tab.at.ddphy * w[:, None]).T @ tab.at.ddphy / L / np.sqrt(np.outer(beta**4, beta**4))
    assert np.abs(K - np.eye(MAX_MODES)).max() < 1e-12
    Max = (tab.at.phx * w[:, None]).T @ tab.at.phx
    assert np.abs(Max - 0.5 * L * np.eye(MAX_MODES)).max() < 1e-13
    # clamped–free: w(0) = w'(0) = 0, tip value ±2 with this normalization
    s0 = b.evaluate(np.array([0.0, L]))
    assert np.abs(s0.phy[0]).max() < 1e-13 and np.abs(s0.dphy[0]).max() < 1e-10
    assert np.allclose(np.abs(s0.phy[1]), 2.0, atol=1e-12)
    # free end: w''(L) = w'''(L) = 0 (the first checked here)
    assert np.abs(s0.ddphy[1] / beta**2).max() < 1e-11


def test_modes_match_high_precision_textbook_form():
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 60
    L = 1.0
    b = modal_basis(L, MAX_MODES, axial=False)
    x = np.linspace(0.0, L, 23)
    got = b.evaluate(x).phy
    for i, z in enumerate(b.roots):
        zr = mp.findroot(lambda t: mp.cos(t) * mp.cosh(t) + 1, mp.mpf(z))
        sig = (mp.cosh(zr) + mp.cos(zr)) / (mp.sinh(zr) + mp.sin(zr))
        for k, xk in enumerate(x):
            bx = zr * mp.mpf(xk) / L
            ref = mp.cosh(bx) - mp.cos(bx) - sig * (mp.sinh(bx) - mp.sin(bx))
            assert abs(got[k, i] - float(ref)) < 1e-12


def test_mode_quadrature_is_converged():
    """The fixed composite rule integrates mode-12 products to 1e-12 (vs a 4× finer rule)."""
    L = 1.0
    b = modal_basis(L, MAX_MODES)
    tab = tabulate(b, np.array([L]), foreshortening=False)
    xf, wf = composite_gauss(np.linspace(0, L, 41), 16)
    f = b.evaluate(xf)
    for a_, af in ((tab.at.phy, f.phy), (tab.at.dphy, f.dphy)):
        ref = (af * wf[:, None]).T @ af
        got = (a_ * tab.w[:, None]).T @ a_
        assert np.abs(got - ref).max() < 1e-12 * max(1.0, np.abs(ref).max())


@pytest.mark.parametrize("basis", [modal_basis(1.3, 6), fem_basis(1.3, 5)], ids=["modes", "fem"])
def test_foreshortening_matrices_against_fine_quadrature(basis):
    L = basis.length
    xs = np.array([0.0, 0.11, 0.5, 0.777, 1.0]) * L
    H = foreshortening_matrices(basis, xs)
    for x, Hx in zip(xs, H):
        if x == 0.0:
            assert np.abs(Hx).max() == 0.0
            continue
        # independent: 40 sub-panels of 8-point Gauss between consecutive breakpoints below x
        edges = np.union1d(basis.breakpoints[basis.breakpoints < x], [x])
        fine = np.unique(np.concatenate([np.linspace(a, b, 41) for a, b in zip(edges[:-1], edges[1:])]))
        xq, wq = composite_gauss(fine, 8)
        d = basis.evaluate(xq).dphy
        ref = (d * wq[:, None]).T @ d
        assert np.abs(Hx - ref).max() < 1e-12 * np.abs(ref).max()
        assert np.allclose(Hx, Hx.T, atol=0)


def test_fem_hermite_interpolates_cubics_exactly():
    L, ne = 2.0, 4
    b = fem_basis(L, ne)
    nodes = np.linspace(0, L, ne + 1)[1:]

    def w(x):
        return 0.3 * x**2 - 0.1 * x**3  # w(0) = w'(0) = 0

    def dw(x):
        return 0.6 * x - 0.3 * x**2

    B = np.ravel(np.column_stack([w(nodes), dw(nodes)]))
    x = np.linspace(0, L, 37)
    s = b.evaluate(x)
    assert np.allclose(s.phy @ B, w(x), atol=1e-14)
    assert np.allclose(s.dphy @ B, dw(x), atol=1e-13)
    assert np.allclose(s.ddphy @ B, 0.6 - 0.6 * x, atol=1e-12)
    u = 0.01 * nodes
    assert np.allclose(s.phx @ u, 0.01 * x, atol=1e-15)


def test_builders_refuse_bad_sizes():
    with pytest.raises(ValueError):
        modal_basis(1.0, 13)
    with pytest.raises(ValueError):
        fem_basis(1.0, 0)
