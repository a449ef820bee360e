"""Banded and bordered-banded LU (daebench.core.linalg) against dense LU and numpy.

A banded matrix with random entries (pivoting needed: no diagonal dominance), and a
bordered-banded one (a band plus a few dense rows and columns in scattered positions,
as a floating frame's DOFs and constraint rows give the finite-element models), solved
through the declared structure, must give the dense solution to round-off.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from daebench.core.linalg import (band_from_dense, band_lu_factor, band_lu_solve, bordered_factor,
                                  bordered_solve, bordered_work, lu_factor, lu_solve)


def _banded(rng, n, kl, ku):
    A = rng.standard_normal((n, n))
    i, j = np.indices((n, n))
    A[(i - j > kl) | (j - i > ku)] = 0.0
    return A


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 40), kl=st.integers(0, 6), ku=st.integers(0, 6), seed=st.integers(0, 2**31 - 1))
def test_band_lu_equals_dense_lu(n, kl, ku, seed):
    rng = np.random.default_rng(seed)
    A = _banded(rng, n, kl, ku)
    b = rng.standard_normal(n)
    if abs(np.linalg.det(A)) < 1e-8 or np.linalg.cond(A) > 1e8:
        return
    AB = np.zeros((2 * kl + ku + 1, n))
    band_from_dense(A, np.arange(n), n, kl, ku, AB)
    piv = np.zeros(n, np.int64)
    assert band_lu_factor(AB, kl, ku, piv) == 0
    x = b.copy()
    band_lu_solve(AB, kl, ku, piv, x)
    D = A.copy()
    dpiv = np.zeros(n, np.int64)
    assert lu_factor(D, dpiv) == 0
    xd = b.copy()
    lu_solve(D, dpiv, xd)
    scale = np.linalg.cond(A) * np.abs(xd).max() * 1e-15
    assert np.max(np.abs(x - xd)) <= 10 * scale + 1e-300
    # the same pivots as the dense LU (LAPACK's rule on the same columns)
    assert np.array_equal(piv, dpiv)


@settings(max_examples=30, deadline=None)
@given(nb=st.integers(2, 50), k=st.integers(0, 5), kl=st.integers(1, 5), ku=st.integers(1, 5),
       seed=st.integers(0, 2**31 - 1))
def test_bordered_solve_equals_dense(nb, k, kl, ku, seed):
    rng = np.random.default_rng(seed)
    nx = nb + k
    B = _banded(rng, nb, kl, ku) + 4.0 * np.eye(nb)
    A = np.zeros((nx, nx))
    A[:nb, :nb] = B
    A[:nb, nb:] = rng.standard_normal((nb, k))
    A[nb:, :nb] = rng.standard_normal((k, nb))
    A[nb:, nb:] = rng.standard_normal((k, k))
    perm = rng.permutation(nx)                 # the structure sits in scattered positions
    P = np.eye(nx)[perm]
    Ap = P.T @ A @ P                          # Ap[perm[i], perm[j]] = A[i, j]
    if np.linalg.cond(Ap) > 1e8 or np.linalg.cond(B) > 1e8:
        return
    b = rng.standard_normal(nx)
    bw = bordered_work(perm, nb, kl, ku)
    assert bordered_factor(Ap, bw) == 0
    x = b.copy()
    bordered_solve(bw, x)
    xe = np.linalg.solve(Ap, b)
    assert np.max(np.abs(x - xe)) <= 1e-9 * max(1.0, np.abs(xe).max())


def test_rod_wall_declares_a_narrow_band():
    """The planar rod's stiffness couples neighbouring cross-sections only: in the mesh
    numbering the band is a few DOFs wide whatever the length; the frame's 4 DOFs border."""
    from daebench import api
    from daebench.models import build_system

    for elements in (20, 80):
        system = build_system(api.load_scene("rod-wall", {"rod.elements": elements}))
        sp = system.sparsity()
        assert sp.n_banded == system.n - 4
        assert sp.kl == sp.ku <= 8
        assert sorted(sp.order) == list(range(system.n))
        assert sp.mass_band == 0 and sp.constant_mass


def test_rod_wall_hht_banded_equals_dense():
    """hht on rod-wall (impact on the wall: the contacts close as constraint rows) with the
    declared structure and with dense LU: the same history to round-off."""
    from daebench import api
    from daebench.driver.simulate import simulate
    from daebench.harness.running.runner import make_integrator
    from daebench.models import build_system

    scene = api.load_scene("rod-wall", {"rod.elements": 20, "t_end": 1.2e-5})
    runs = {}
    for mode in ("banded", "dense"):
        system = build_system(scene)
        if mode == "dense":
            system.sparsity = None   # no declared structure: dense LU
        res = simulate(system, make_integrator("hht", {"h": 1e-7}), scene.t_end, scene["output.dt"],
                       record_states=True)
        assert res.status == "completed"
        runs[mode] = res
    a, b = runs["banded"], runs["dense"]
    assert a.counters["steps"] == b.counters["steps"] and len(a.impacts) == len(b.impacts) >= 1
    for key in ("q", "v"):
        scale = np.abs(b.states[key]).max()
        assert np.max(np.abs(a.states[key] - b.states[key])) <= 1e-12 * scale


def test_solve_structured_equals_scipy_banded_and_dense():
    """The driver's solves (a banded mass matrix; an augmented [[M, Bᵀ], [B, 0]]) through the
    measured band give scipy.linalg.solve_banded's / numpy's dense answer to round-off."""
    from scipy.linalg import solve_banded

    from daebench.core.linalg import half_bandwidths, solve_structured

    rng = np.random.default_rng(7)
    n, kl, ku = 300, 3, 2
    M = _banded(rng, n, kl, ku) + 6.0 * np.eye(n)
    assert half_bandwidths(M, n) == (kl, ku)
    b = rng.standard_normal((n, 3))
    ab = np.zeros((kl + ku + 1, n))
    for j in range(n):
        for i in range(max(0, j - ku), min(n, j + kl + 1)):
            ab[ku + i - j, j] = M[i, j]
    x = solve_structured(M, b)
    xs = solve_banded((kl, ku), ab, b)
    assert np.max(np.abs(x - xs)) <= 1e-13 * np.abs(xs).max()
    # an augmented system, border of 4 rows (a diagonal M: the FE models' lumped mass)
    Md = np.diag(rng.uniform(0.5, 2.0, n))
    B = rng.standard_normal((4, n))
    A = np.block([[Md, B.T], [B, np.zeros((4, 4))]])
    rhs = rng.standard_normal(n + 4)
    x = solve_structured(A, rhs, n)
    xe = np.linalg.solve(A, rhs)
    assert np.max(np.abs(x - xe)) <= 1e-12 * np.abs(xe).max()
    # LAPACK where it is the cheaper (small, or wide band) and for a singular A its error
    small = rng.standard_normal((20, 20)) + 5 * np.eye(20)
    assert np.array_equal(solve_structured(small, rhs[:20]), np.linalg.solve(small, rhs[:20]))
    S = A.copy()
    S[n:, :] = 0.0
    S[:, n:] = 0.0
    try:
        solve_structured(S, rhs, n)
    except np.linalg.LinAlgError:
        pass
    else:
        raise AssertionError("a singular augmented system must raise LinAlgError")


def test_rod_wall_penalty_hht_banded_equals_dense():
    """Under a continuous contact law (penalty) the iteration matrix is assembled densely and
    checked against the declared structure before the bordered-banded factorization: the
    same history as dense LU to round-off, and the rod is pushed back (the law acts)."""
    from daebench import api

    scene = api.load_scene("rod-wall", {"rod.elements": 20, "t_end": 1.2e-5, "contact.law": "penalty"})
    a, b = _banded_and_dense(scene, 1e-7)
    scale = np.abs(b.states["v"]).max()
    assert np.max(np.abs(a.states["v"] - b.states["v"])) <= 1e-12 * scale
    assert np.max(np.abs(a.states["q"] - b.states["q"])) <= 1e-12 * np.abs(b.states["q"]).max()
    assert a.states["v"][-1, 0] > -0.99        # the struck end's x-velocity: slowed by the wall from -1 m/s


def test_fe_scaling_study_counts_the_steps(tmp_path):
    """The structure study at tiny sizes: every run takes t_end / h steps (fixed step), one
    or more Newton iterations each; its files are written and state the targets."""
    import json

    from daebench.studies.perf import structure as perf_structure

    perf_structure.scaling_report((8, 16), 2e-5, dense_up_to=8, repeats=1, out=tmp_path)
    fe = json.loads((tmp_path / "fe_scaling.json").read_text())
    rows = fe["rows"]
    assert [r["elements"] for r in rows] == [8, 16] and [r["n"] for r in rows] == [36, 68]
    assert all(abs(r["steps"] - 200) <= 2 and r["newton_per_step"] >= 1.0 for r in rows)
    assert all(r["ms_per_step"] > 0 for r in rows) and "ms_per_step_dense" in rows[0]
    assert "ms_per_step_dense" not in rows[1]
    assert json.loads((tmp_path / "fe_scaling.json").read_text())["target_exponent"] == 1.3
    assert "exponent ≤ 1.3" in (tmp_path / "fe_scaling.md").read_text()


def test_corotational_frame_declares_a_band_and_hht_agrees_with_dense():
    """A co-rotational frame of 2 × 22 elements (134 DOFs, each element coupling its own six
    end coordinates) declares a band a few DOFs wide; hht through it gives the dense LU's
    history to round-off. The default double pendulum (50 DOFs) declares none (dense LU)."""
    from daebench import api
    from daebench.models import build_system

    assert build_system(api.load_scene("double-pendulum")).sparsity() is None
    scene = api.load_scene("double-pendulum", {"links.elements": 22, "t_end": 5e-3, "output.dt": 1e-3})
    system = build_system(scene)
    sp = system.sparsity()
    assert system.n == 134 and sp.n_banded == 134 and sp.kl == sp.ku <= 8 and sp.mass_band == 0
    a, b = _banded_and_dense(scene, 1e-4)
    for key in ("q", "v"):
        assert np.max(np.abs(a.states[key] - b.states[key])) <= 1e-12 * np.abs(b.states[key]).max()
    assert np.max(np.abs(b.states["v"][-1])) > 1e-3      # it moved (falls under gravity)


def _banded_and_dense(scene, h):
    """hht runs of ``scene`` through the declared structure and with it removed (dense LU)."""
    from daebench.driver.simulate import simulate
    from daebench.harness.running.runner import make_integrator
    from daebench.models import build_system

    runs = []
    for dense in (False, True):
        system = build_system(scene)
        if dense:
            system.sparsity = None
        res = simulate(system, make_integrator("hht", {"h": h}), scene.t_end, scene["output.dt"],
                       record_states=True)
        assert res.status == "completed"
        runs.append(res)
    return runs
