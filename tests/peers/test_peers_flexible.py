"""Exudyn's geometrically exact beam (ANCF cable elements, daebench.peers.workers.exudyn_worker)
against daebench's hub–beam (floating frame, deflection coupled to first order), both with
generalized-α at the same step: two codes and two formulations of one Euler–Bernoulli beam.
daebench's model drops the terms of relative size (w/L)², so the two must agree closely at a
small drive and part at the rate theory says — 100-fold for a 10-fold torque — not at random.
A test whose peer is not installed is skipped with the reason."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import daebench
from daebench import api
from daebench.peers import PEERS, PeerRefused, base
from _peers import needs_exudyn

H = 2e-3
SPAN = "t_end=2.0"      # the torque pulse (T = 2 s)


def apart(tmp_path, tau0: float) -> tuple[float, float, float]:
    """(max |Δθ| [deg], max |Δw2| / max |w2|, max |w2| [m]) between the two codes at torque ``tau0``."""
    sets = [f"torque.tau0={tau0}", SPAN]
    (run,) = base.run_peer(PEERS["exudyn-ga"], api.load_scene("hub-beam", sets), [H], tmp_path)
    peer = pd.read_csv(run.file, comment="#")
    own = daebench.run("hub-beam", "genalpha", h=H, write=False, overrides=sets).observables
    t = np.asarray(own["t"])           # daebench's output times: every fifth step of the peer's
    rows = np.searchsorted(peer["t"].to_numpy(), t - 1e-9)
    assert np.max(np.abs(peer["t"].to_numpy()[rows] - t)) < 1e-9
    d_theta = np.max(np.abs(peer["theta_deg"].to_numpy()[rows] - np.asarray(own["theta_deg"])))
    w2 = np.asarray(own["tip_w2"])
    return float(d_theta), float(np.max(np.abs(peer["tip_w2"].to_numpy()[rows] - w2)) / np.max(np.abs(w2))), \
        float(np.max(np.abs(w2)))


@pytest.fixture(scope="module")
def small_and_ten_times(tmp_path_factory):
    return apart(tmp_path_factory.mktemp("small"), 0.07), apart(tmp_path_factory.mktemp("ten"), 0.7)


@needs_exudyn
def test_exudyn_and_daebench_agree_on_the_hub_beam_at_a_small_deflection(small_and_ten_times):
    (d_theta, rel_w2, w2), _ = small_and_ten_times
    print(f"small drive: |Δθ| {d_theta:.2e} deg, |Δw2|/|w2| {rel_w2:.2e}, max |w2| {w2:.3e} m")
    assert 5e-3 < w2 < 1.5e-2           # w/L ≈ 0.5 %
    assert d_theta < 1e-4 and rel_w2 < 3e-4, (d_theta, rel_w2)


@needs_exudyn
def test_the_codes_part_as_the_square_of_the_deflection(small_and_ten_times):
    (_, small, w_small), (_, ten, w_ten) = small_and_ten_times
    print(f"|Δw2|/|w2| {small:.2e} → {ten:.2e} (×{ten / small:.1f}); max |w2| ×{w_ten / w_small:.2f}")
    assert 9.0 < w_ten / w_small < 11.0                 # linear response: ten times the deflection
    assert 50.0 < ten / small < 200.0, (small, ten)     # (w/L)²: a hundredfold


@needs_exudyn
@pytest.mark.parametrize("scene, sets, named", [
    ("beam-impact", [], "discretization.kind = 'fem' only"),
    ("hub-beam", ["effects.gravity=true"], "effects.gravity = False"),
    ("hub-beam", ["start.omega=1"], "start.omega = 0.0"),
])
def test_exudyn_refuses_what_its_hub_beam_does_not_build(tmp_path, scene, sets, named):
    with pytest.raises(PeerRefused, match=named.replace(".", r"\.").replace("(", r"\(")):
        base.run_peer(PEERS["exudyn-ga"], api.load_scene(scene, sets), [1e-3], tmp_path)
