"""The check of an explicit method's step before its first step (daebench.harness.running.checks
.check_step on daebench.stepping.stability): the limit it states is the boundary whole runs
show, its fastest modes are the dense eigensolver's, a step beyond a strict limit is refused
with the limit and the fix, h = auto takes the limit, and Baumgarte's ABM4 beyond its
interval runs — and diverges — with a warning in its record.

Cold-cache cost: central differences on the planar FE model and baumgarte on beam-impact
(compiled once each), then seconds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sl

from daebench.harness.running import checks
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.integrators.base import IntegratorError
from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.stepping.stability import CENTRAL, linearize_system, strict_interval, tangent_matrices

# the rod (ν = 0.3: axial and transverse motion coupled) against a soft penalty wall from the
# start (its touch seeds every mode; 1e3 N/m adds nothing to ω_max): ~200 steps at the limit
ROD = {"start.gap": 0.0, "t_end": 3e-4, "contact.law": "penalty", "contact.penalty_stiffness": 1e3, "rod.nu": 0.3}


def rod_limit() -> float:
    sc = load_scene("rod-wall", ROD)
    return strict_interval(CENTRAL) / float(linearize_system(build_system(sc), top=1).omega.max())


def test_central_interval_is_two():
    """Central differences (β = 0, γ = ½) on ẍ = −ω²x: |ρ| ≤ 1 exactly for hω ≤ 2."""
    assert strict_interval(CENTRAL) == pytest.approx(2.0, abs=1e-12)


@pytest.mark.parametrize("fraction, status", [(0.98, "completed"), (1.02, "diverged")])
def test_central_limit_is_the_boundary_runs_show(fraction, status):
    """Just below the stated limit 2/ω_max the rod's run completes; just above it the fastest
    mode grows by |ρ| ≈ 1.5 a step and the run diverges (the check switched off, as the
    stability map's trials do)."""
    sc = load_scene("rod-wall", ROD)
    h = fraction * rod_limit()
    rec, _ = run_scene(sc, "central", {"h": h}, write=False, step_check=False)
    assert rec.status == status, rec.message


def test_fastest_modes_are_the_dense_eigensolvers():
    """Lanczos on M^{-1/2} K M^{-1/2} (a large FE model with lumped mass) against the dense
    generalized eigensolver on the same assembled matrices: the four fastest ω agree."""
    system = build_system(load_scene("slider-slot", {"slider.mesh_size": 0.25e-3}))
    assert system.n > 600   # the Lanczos path
    q0, v0 = (np.asarray(x, float) for x in system.initial_state())
    M, K, _ = tangent_matrices(system, q0, v0)
    dense = np.sqrt(sl.eigh(K, M, eigvals_only=True)[-4:])
    fast = linearize_system(system, top=4).omega
    assert np.abs(fast / dense - 1.0).max() < 1e-8


def test_refusal_states_the_limit_and_auto_takes_it():
    """h beyond 2/ω_max is refused before any step with the limit and the fix; h = auto runs at
    0.9 × the limit and the record says so; a default h beyond it is replaced the same way."""
    sc = load_scene("rod-wall", ROD)
    limit = rod_limit()
    with pytest.raises(IntegratorError, match=r"h ≤ .* s; give --opt h=.*h=auto"):
        run_scene(sc, "central", {"h": 1.5 * limit}, write=False)
    rec, _ = run_scene(sc, "central", {"h": "auto"}, write=False)
    assert rec.status == "completed", rec.message
    assert rec.settings["h"] == pytest.approx(checks.AUTO_FRACTION * limit, rel=1e-12)
    assert len(rec.warnings) == 1 and rec.warnings[0].startswith("h = auto: took h =")
    integ = make_integrator("central", {})
    default_h = integ.settings["h"]
    warnings, chosen = checks.check_step(sc, build_system(sc), integ)
    assert warnings[0].startswith("the default h") and chosen == pytest.approx(checks.AUTO_FRACTION * limit, rel=1e-12)
    assert integ.settings["h"] == default_h           # the check changes nothing; the run takes a new integrator
    assert integ.with_step(chosen).settings["h"] == chosen and integ.settings["h"] == default_h
    with pytest.raises(IntegratorError, match="unconditionally stable"):
        checks.check_step(sc, build_system(sc), make_integrator("hht", {"h": "auto"}))


def test_baumgarte_beyond_its_interval_warns_and_diverges():
    """ABM4-PECE has no interval of |ρ| ≤ 1: beyond the step the stability study predicts for
    the run it is not refused (the paper's protocol runs it there) but warned, and diverges;
    within it, no warning and the run completes."""
    sc = load_scene("beam-impact", {"t_end": 0.05})
    rec, _ = run_scene(sc, "baumgarte", {"h": 1e-4}, write=False)
    assert rec.status == "diverged" and rec.warnings and "expected to diverge" in rec.warnings[0]
    rec, _ = run_scene(sc, "baumgarte", {"h": 2e-5}, write=False)
    assert rec.status == "completed" and not rec.warnings
    rec, _ = run_scene(sc, "baumgarte", {"h": "auto"}, write=False)
    assert rec.status == "completed" and math.isfinite(rec.settings["h"]) and rec.warnings
