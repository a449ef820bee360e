"""Siconos' Moreau–Jean with Coulomb friction (daebench.peers.workers.siconos_rigid2d) on
block-incline, held to the closed form of daebench.models.rigid2d_exact: the block slides
up at −g (sin φ + μ cos φ), stops at t_s after x_s, slides back at −g (sin φ − μ cos φ);
with μ = 0.7 > tan φ it sticks. The steps are the peer's own for the case
(daebench.peers.siconos.BLOCK_INCLINE_STEPS: t_s half a step before the next grid point at
each). A test whose peer is not installed is skipped with the reason."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from daebench import api
from daebench.models.rigid2d_exact import incline_motion, incline_stop
from daebench.peers import PEERS, PeerRefused, base
from _peers import needs_siconos
from daebench.peers.siconos import BLOCK_INCLINE_STEPS

G, PHI, V0 = 9.81, math.radians(30.0), 3.0     # cases/block-incline.toml


def _runs(tmp_path, steps, overrides=()):
    sc = api.load_scene("block-incline", list(overrides))
    return [(r, pd.read_csv(r.file, comment="#")) for r in base.run_peer(PEERS["siconos-mj"], sc, steps, tmp_path)]


def _slope(t: np.ndarray, v: np.ndarray) -> float:
    return float(np.polyfit(t, v, 1)[0])


@pytest.fixture(scope="module")
def sliding(tmp_path_factory):
    return _runs(tmp_path_factory.mktemp("incline"), BLOCK_INCLINE_STEPS)


@needs_siconos
def test_siconos_block_incline_stops_where_and_when_the_closed_form_says(sliding):
    mu = 0.3
    ts, xs = incline_stop(V0, PHI, mu, G)
    assert abs(ts - 0.4025) < 1e-4 and abs(xs - 0.6037) < 1e-4
    for run, d in sliding:
        h = run.h
        t, x, vx = d["t"].to_numpy(), d["x"].to_numpy(), d["vx"].to_numpy()
        stop = t[np.argmax(vx <= 1e-12)]        # the first step at rest (to rounding) or sliding back
        assert 0.0 <= stop - ts < h, (h, stop)   # measured: 0.50 h at each step
        assert abs(x.max() - xs) < G * h * h, (h, x.max())     # measured: 0.93 h²
        # held on the ground: the corners neither lift nor sink, the block does not tip
        assert np.max(np.abs(d["y"] - 0.1)) < 1e-12 and np.max(np.abs(d["theta"])) < 1e-12
        assert d["gap"].min() > -1e-12


@needs_siconos
def test_siconos_block_incline_decelerates_then_slides_back_at_the_exact_rates(sliding):
    mu = 0.3
    a_up, a_back = G * (math.sin(PHI) + mu * math.cos(PHI)), G * (math.sin(PHI) - mu * math.cos(PHI))
    assert abs(a_up - 7.454) < 1e-3 and abs(a_back - 2.356) < 1e-3
    ts, _ = incline_stop(V0, PHI, mu, G)
    for run, d in sliding:
        h = run.h
        t, vx = d["t"].to_numpy(), d["vx"].to_numpy()
        up, back = (t > 0.0) & (t < ts - h), t > ts + 2 * h
        assert abs(-_slope(t[up], vx[up]) - a_up) < 1e-9, h     # constant forces: the fits are exact
        assert abs(-_slope(t[back], vx[back]) - a_back) < 1e-9, h


@needs_siconos
def test_siconos_block_incline_converges_at_order_one(sliding):
    mu = 0.3
    err_x, err_v = [], []
    for run, d in sliding:
        t = d["t"].to_numpy()
        x, v = incline_motion(V0, PHI, mu, G, t)
        err_x.append(np.max(np.abs(d["x"].to_numpy() - x)))
        err_v.append(np.max(np.abs(d["vx"].to_numpy() - v)))
    for err in (err_x, err_v):
        orders = [math.log(a / b) / math.log(ha / hb) for a, b, ha, hb in
                  zip(err, err[1:], BLOCK_INCLINE_STEPS, BLOCK_INCLINE_STEPS[1:])]
        assert all(0.9 < p < 1.1 for p in orders), (err, orders)    # measured: x 1.00, 1.00; vx 1.00, 1.00
    assert err_x[0] < 1e-3    # measured: 7.1e-4 m at h = 1/1005 s


@needs_siconos
def test_siconos_block_incline_sticks_with_friction_above_tan_phi(tmp_path):
    mu = 0.7
    assert mu > math.tan(PHI)
    ts, xs = incline_stop(V0, PHI, mu, G)
    for run, d in _runs(tmp_path, [1e-3, 5e-4], [f"contact.friction={mu}"]):
        h = run.h
        t, x, vx = d["t"].to_numpy(), d["x"].to_numpy(), d["vx"].to_numpy()
        rest = t >= ts + h
        # at rest from the step after t_s to t_end: measured |ẋ| ≤ 5e-18 m/s, x still to 1e-16 m
        assert np.max(np.abs(vx[rest])) < 1e-12 and np.ptp(x[rest]) < 1e-12, h
        assert np.all(vx[t < ts - h] > 0.0)
        assert abs(x[rest][0] - xs) < G * h * h, (h, x[rest][0] - xs)
        up = (t > 0.0) & (t < ts - h)
        assert abs(-_slope(t[up], vx[up]) - G * (math.sin(PHI) + mu * math.cos(PHI))) < 1e-9


@needs_siconos
def test_siconos_refuses_the_compliant_law_and_the_event_driven_scheme_on_rigid2d(tmp_path):
    with pytest.raises(PeerRefused, match="contact.law = constraint"):
        api.peer("block-incline", "siconos-mj", [1e-3], overrides=["contact.law=penalty",
                                                                   "contact.penalty_stiffness=1e6"],
                 write=False, out=tmp_path)
    with pytest.raises(PeerRefused, match="siconos-mj"):
        api.peer("block-incline", "siconos-ed", [1e-3], write=False, out=tmp_path)
