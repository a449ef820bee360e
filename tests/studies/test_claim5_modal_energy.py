"""Claim 5 of the beam-impact paper is judged on modal energies: a history that is one
linearised mode in free vibration, q = q₀ + A φ_k sin ω_k t, carries E_k = ½ ω_k² A² at every
time and nothing in the other flexible modes (mass-normalised φ, ΦᵀMΦ = I)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
import scipy.linalg as sla

from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.studies.hht_beam_impact.claims import _mode_energies


@pytest.mark.parametrize("k", [0, 2, 4])
def test_one_mode_in_free_vibration_has_its_closed_form_energy(k):
    N, A = 5, 1e-3
    system = build_system(load_scene("beam-impact", {"discretization.n": N}))
    M, K = system.linearisation()
    w2, phi = sla.eigh(K, M)        # the eigenproblem solved here, not by the code under test
    flex = np.flatnonzero(w2 > 0)
    j = flex[k]
    w = np.sqrt(w2[j])
    t = np.linspace(0.0, 4 * np.pi / w, 200)
    q0 = system.initial_state()[0]
    q = q0 + A * np.outer(np.sin(w * t), phi[:, j])     # the history starts at q₀, as a run does
    v = A * w * np.outer(np.cos(w * t), phi[:, j])
    names = system.coordinate_names
    h = pd.DataFrame({"t": t, **{f"q_{c}": q[:, i] for i, c in enumerate(names)},
                      **{f"v_{c}": v[:, i] for i, c in enumerate(names)}})
    omega, E = _mode_energies(SimpleNamespace(scene="beam-impact"), N, h)
    assert omega.size == N and omega[k] == pytest.approx(w, rel=1e-12)
    assert np.allclose(E[:, k], 0.5 * w * w * A * A, rtol=1e-9)
    others = np.delete(E, k, axis=1)
    assert np.max(others) < 1e-12 * 0.5 * w * w * A * A
