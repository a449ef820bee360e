"""Velocities in L¹ and the impulse measure (daebench.harness.scoring.nonsmooth) against
planted errors whose distances are known in closed form."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pytest

from daebench.core.observables import Observable, Observables
from daebench.harness.scoring import nonsmooth
from daebench.harness.scoring.pipeline import Run, Truth

TIMES, IMPULSES = (0.2, 0.5, 0.7), (1.0, 0.5, 0.25)


def test_a_planted_1_percent_error_in_one_impulse():
    """Λ_run − Λ_truth = 0.01 Λ₂ from t₂ on: the distance is 0.01 Λ₂ (T − t₂) / T."""
    wrong = (1.0, 0.505, 0.25)
    d = nonsmooth.impulse_distance((TIMES, wrong, None, None), (TIMES, IMPULSES, None, None), 1.0)
    assert d == pytest.approx(0.01 * 0.5 * (1.0 - 0.5), rel=1e-12)
    assert nonsmooth.impulse_distance((TIMES, IMPULSES, None, None), (TIMES, IMPULSES, None, None), 1.0) == 0.0


def test_an_impact_moved_costs_its_impulse_times_the_shift():
    moved = (0.2, 0.5 + 3e-3, 0.7)
    d = nonsmooth.impulse_distance((moved, IMPULSES, None, None), (TIMES, IMPULSES, None, None), 2.0)
    assert d == pytest.approx(0.5 * 3e-3 / 2.0, rel=1e-9)


def test_a_contact_force_against_the_impulse_it_integrates_to():
    """Truth: a triangular force of 0.2 N s over [0.3, 0.4] s (peak at 0.35 s); the run: one
    impulse of 0.2 N s at 0.35 s. Λ_truth rises as 0.1 s² (s = (t − 0.3)/0.05) to 0.1 N s at
    0.35 s: each half differs from Λ_run by ∫0.1 s² = 0.05 · 0.1 / 3 N s²."""
    t = np.linspace(0.0, 1.0, 10001)
    f = 4.0 * np.clip(1.0 - np.abs(t - 0.35) / 0.05, 0.0, None)
    d = nonsmooth.impulse_distance(((0.35,), (0.2,), None, None), ((), (), t, f), 1.0)
    assert d == pytest.approx(2 * 0.05 * 0.1 / 3, rel=1e-4)


@dataclass
class _Scene:
    cols: tuple[str, ...]

    def get(self, key, default=None):
        return list(self.cols) if key == "output.observables" else default


@dataclass
class _System:
    n_contacts: int = 1


@dataclass
class _Impact:
    t: float
    impulse: float
    law: str = "newton"


def test_the_velocity_l1_error_of_a_jump_a_little_late():
    """v jumps from −1 to +1 at 0.5 s in the truth and at 0.5 + δ in the run: the max error
    is the jump (2) whatever δ, the L¹ error 2δ/T."""
    t = np.linspace(0.0, 1.0, 10001)
    delta = 0.01
    truth = pd.DataFrame({"t": t, "x": np.abs(t - 0.5), "v": np.where(t < 0.5, -1.0, 1.0)})
    run_v = np.where(t < 0.5 + delta - 1e-9, -1.0, 1.0)
    run = pd.DataFrame({"t": t, "x": np.abs(t - 0.5), "v": run_v})
    d = Observables([Observable("x", "m", derivative="v"), Observable("v", "m/s")])
    r = Run(_Scene(("x", "v")), _System(), run, [_Impact(0.5 + delta, 2.0)], d)
    tr = Truth(truth, (0.5,), trust_t=1.0, trust_impacts=1, impulses=(2.0,))
    out = nonsmooth.measure(r, tr)
    assert out["err_v_l1"] == pytest.approx(2 * delta, rel=0.02)
    assert "err_x_l1" not in out                                    # a position: no L¹ column
    assert out["err_impulse_measure"] == pytest.approx(2.0 * delta, rel=1e-9)
    assert out["err_impulse_measure_rel"] == pytest.approx(delta, rel=1e-9)
    no_impulses = Truth(truth, (0.5,), trust_t=1.0, trust_impacts=1)
    assert math.isnan(nonsmooth.measure(r, no_impulses)["err_impulse_measure"])
    assert nonsmooth.measure(Run(_Scene(("x", "v")), _System(0), run, [], d), tr) == {}
