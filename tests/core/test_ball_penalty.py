"""The ball under the penalty law (a spring–dashpot ground, declared k and c): the law a
compliant peer code shares with daebench. Held to an independent integration of the same
law (scipy's DOP853 with the contact's start and end located as events)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench import api

from _penalty_ball import C, K, M, penalty_ball_height as _truth


def test_export_declares_the_penalty_law_and_a_reference_truth(tmp_path):
    sheet = api.export_case("ball", overrides=["contact.law=penalty"], out=tmp_path).sheet
    keys = {r["key"]: r["value"] for r in sheet["contact"]["keys"]}
    assert sheet["contact"]["law"] == "penalty" and sheet["contact"]["continuous"]
    assert keys["contact.penalty_stiffness"] == K and keys["contact.penalty_damping"] == C
    assert sheet["scoring"]["truth"].startswith("a reference")       # the rigid closed form does not hold


def test_the_default_damping_gives_the_scenes_restitution_for_the_unclipped_oscillator():
    zeta = C / (2 * math.sqrt(K * M))
    assert math.exp(-zeta * math.pi / math.sqrt(1 - zeta ** 2)) == pytest.approx(0.8, abs=0.005)


@pytest.mark.slow
def test_ida_on_the_penalty_ball_matches_an_independent_integration():
    r = api.run("ball", "ida", overrides=["contact.law=penalty", "t_end=0.7"], write=False)
    assert r.status == "completed"
    t = r.observables["t"].to_numpy()
    x = r.observables["x"].to_numpy()
    assert np.max(np.abs(x - _truth(t))) < 1e-6
    assert x.min() < -0.005                       # it penetrates (≈ v/ω = 4.43/316 m) and rebounds
    assert x[-1] > 0.3
