"""Shared by the compiled-vs-Python tests: run a scene on both paths and compare histories."""

import numpy as np

from daebench.runner import run_scene


def both(monkeypatch, scene, integrator, opts):
    """(record, result) of the Python path (DAEBENCH_COMPILED=0), then of the compiled one."""
    out = {}
    for flag in ("0", "1"):
        monkeypatch.setenv("DAEBENCH_COMPILED", flag)
        out[flag] = run_scene(scene, integrator, opts, write=False)
    return out["0"], out["1"]


# algorithmic quantities: C̈ = C_q a − γ and λ of the index-3 form are differences of
# accelerations ~1e5 (beam impact), so their round-off is ~1e-10 of that size, not of O(1)
LOOSE = ("Cddot", "lambda_")


def assert_same_history(h0, h1, tol):
    """Every column equal to ``tol`` × its scale (max(1, max |column|); 1e5 for LOOSE ones)."""
    assert list(h0.columns) == list(h1.columns)
    assert len(h0) == len(h1)
    for c in h0.columns:
        a, b = h0[c].to_numpy(float), h1[c].to_numpy(float)
        scale = max(1.0, float(np.nanmax(np.abs(a))) if np.isfinite(a).any() else 1.0)
        if c.startswith(LOOSE):
            scale = max(scale, 1e5)
        assert np.allclose(a, b, rtol=0.0, atol=tol * scale, equal_nan=True), (c, np.nanmax(np.abs(a - b)))
