"""Peer codes run on daebench's cases (daebench.peers, through daebench.api.peers): the refusals, and
the real peers' runs — Exudyn (daebench.peers.exudyn) and Siconos (daebench.peers.workers.siconos_worker,
the slider-crank in compiled plugins: daebench.peers.workers.siconos_slidercrank,
daebench.peers.workers.siconos_plugins, with daebench.peers.workers.common) — held to independent truth — the ball's closed forms (impact times, jumps, positions),
orders measured from step sweeps, the pendulum's exact solution. A test whose peer is not
installed is skipped with the reason."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from daebench import api
from daebench.models.ball import ball_impacts
from daebench.peers import PEERS, PeerRefused, PeerUnavailable, base
from _peers import needs_exudyn, needs_siconos

H0, E, G = 1.0, 0.8, 9.81   # the ball case's values (cases/ball.toml)


def test_a_missing_peer_is_refused_with_its_install_command(monkeypatch, tmp_path):
    monkeypatch.setenv("DAEBENCH_SYSTEM_PYTHON", str(tmp_path / "no-python"))
    with pytest.raises(PeerUnavailable, match=r"apt-get install python3-siconos"):
        api.peer("ball", "siconos-mj", [1e-3], write=False, out=tmp_path)
    assert not list(tmp_path.iterdir())


def test_an_interpreter_without_the_code_is_refused(tmp_path):
    peer = base.Peer("nope", "Nothing", "x", "siconos_worker.py", "no_such_module_here", "pip install nothing",
                     base.this_python)
    with pytest.raises(PeerUnavailable, match="pip install nothing"):
        peer.python()


def test_an_unknown_peer_names_the_choices():
    with pytest.raises(PeerRefused, match="siconos-mj, siconos-ed, exudyn-ga"):
        api.peer("ball", "siconos", [1e-3], write=False)


@pytest.mark.parametrize("h", ["abc", -1e-3, math.inf])
def test_a_bad_step_is_refused(h):
    with pytest.raises(PeerRefused, match="step"):
        base.check_step(h)


@needs_siconos
def test_a_step_that_does_not_divide_t_end_is_refused(tmp_path):
    with pytest.raises(PeerRefused, match="does not divide t_end"):
        api.peer("ball", "siconos-mj", [3e-3 / 7], write=False, out=tmp_path)


@needs_exudyn
def test_exudyn_refuses_the_rigid_ball_and_names_the_shared_law(tmp_path):
    with pytest.raises(PeerRefused, match="contact.law=penalty"):
        api.peer("ball", "exudyn-ga", [1e-3], write=False, out=tmp_path)


@needs_siconos
def test_siconos_moreau_jean_converges_at_order_one_in_position(tmp_path):
    res = api.peer("ball", "siconos-mj", [1e-3, 5e-4, 2.5e-4], write=False, out=tmp_path)
    err = [r["err_x_max"] for r in res.rows()]
    ratios = [a / b for a, b in zip(err, err[1:])]
    assert all(1.7 < q < 2.2 for q in ratios), ratios      # measured: 1.87, 1.90
    assert [r.steps for r in res.runs] == [2500, 5000, 10000]
    assert all(r.cpu_s > 0 for r in res.runs)
    assert all(r["impacts_matched"] == 4 for r in res.rows()[1:])


@needs_siconos
def test_siconos_lsodar_hits_the_closed_form_impacts_and_jumps(tmp_path):
    (run,) = base.run_peer(PEERS["siconos-ed"], api.load_scene("ball"), [1e-2], tmp_path)
    times, _ = ball_impacts(H0, E, G, 4)
    found = pd.read_csv(run.impacts)["t"].to_numpy()
    assert found.size == 4
    assert np.max(np.abs(found - times)) <= 1e-12
    data = pd.read_csv(run.file, comment="#")
    v1 = math.sqrt(2 * G * H0)
    for k, tk in enumerate(times):   # two rows at each impact: v⁻ = −e^k v1, v⁺ = e^(k+1) v1
        at = data[data["t"] == found[k]]
        assert len(at) == 2
        assert abs(at["v"].iloc[0] + E ** k * v1) <= 1e-9 and abs(at["v"].iloc[1] - E ** (k + 1) * v1) <= 1e-9
        assert abs(at["x"].iloc[0]) <= 1e-12
    assert api.score("ball", run.file, impacts=str(run.impacts), write=False).row["err_x_max"] <= 1e-12


@needs_siconos
def test_siconos_lsodar_scores_a_velocity_error_below_1e_9(tmp_path):
    res = api.peer("ball", "siconos-ed", [1e-2], write=False, out=tmp_path)
    assert res.rows()[0]["err_v_max"] <= 1e-9


@needs_exudyn
def test_exudyn_generalized_alpha_converges_at_order_two_on_the_pendulum(tmp_path):
    res = api.peer("pendulum", "exudyn-ga", [1e-2, 5e-3, 2.5e-3], write=False, out=tmp_path)
    err = [r["err_theta_max"] for r in res.rows()]      # θ [deg] against the exact solution
    pairs, fitted = res.orders("err_theta_max")
    assert all(1.9 < p < 2.1 for p in pairs[1:]), (err, pairs)      # measured: 2.0001, 2.0001
    assert 1.9 < fitted < 2.1


@needs_siconos
@pytest.mark.slow
def test_compare_runs_the_peers_in_the_same_run_and_tables_them(tmp_path):
    opts = api.SweepOptions(execution=api.Execution(jobs=1, progress=False))
    res = api.compare("ball", opts, out=tmp_path / "cmp", peers=["siconos-mj", "siconos-ed"], peer_steps=[1e-3])
    ext = res.external
    assert sorted(ext["label"]) == ["siconos-ed", "siconos-mj"]
    assert (ext["steps"] > 0).all() and (ext["wall_s"] > 0).all()   # the peers' own CPU time, as the file says
    mj = ext[ext["label"] == "siconos-mj"].iloc[0]
    ed = ext[ext["label"] == "siconos-ed"].iloc[0]
    assert 1e-3 < mj["err_x_max"] < 2e-2 and ed["err_x_max"] < 1e-12


@needs_siconos
def test_the_perf_section_times_both_moreau_jeans_on_the_same_steps():
    from daebench.studies.perf import peer_cost

    (row,) = peer_cost.measure((("ball", "x", (1e-3,)),), repeats=1)
    assert row["steps"] == 2500
    assert row["moreau_us_per_step"] > 0 and row["siconos_mj_us_per_step"] > 0
    # the same scheme at the same step: the same first-order error (closed form), within 2×
    assert 0.5 < row["moreau_err_max"] / row["siconos_err_max"] < 2.0


@needs_siconos
def test_siconos_slider_crank_plugin_holds_the_energy_to_first_order_before_the_first_impact(tmp_path):
    """Free flight of the mechanism (no corner touches before 2.7 ms): the plugin's M, F_gyr
    and Jacobians, held to daebench's energy of the model — its drift halves with h (Moreau–Jean
    is first order), as it would not if a term of the plugin were wrong."""
    from daebench.models import build_system

    sc = api.load_scene("slider-crank-clearance")
    system = build_system(sc)
    drift = []
    for run in base.run_peer(PEERS["siconos-mj"], sc, [2e-5, 1e-5], tmp_path):
        d = pd.read_csv(run.file, comment="#")
        assert 2e-3 < pd.read_csv(run.impacts)["t"].min() < 4e-3
        free = d[d["t"] < 2.5e-3]
        w2 = (free["vy"] - 0.153 * np.cos(free["theta"]) * free["omega"]) / (0.306 * np.cos(free["rod"]))
        E = np.array([sum(system.energy(np.array([a, b, c]), np.array([w, u, z])).values()) for a, b, c, w, u, z in
                      zip(free["theta"], free["rod"], free["psi"], free["omega"], w2, free["psidot"])])
        drift.append(np.max(np.abs(E - E[0])) / E[0])
    assert drift[1] < 1e-3 and 1.8 < drift[0] / drift[1] < 2.2, drift     # measured: 1.7e-3, 8.6e-4


@needs_siconos
@pytest.mark.slow
def test_siconos_slider_crank_agrees_with_daebench_moreau_at_the_same_step(tmp_path):
    sc = api.load_scene("slider-crank-clearance")
    (run,) = base.run_peer(PEERS["siconos-mj"], sc, [1e-5], tmp_path)
    d = pd.read_csv(run.file, comment="#")
    ours = api.run(sc, "moreau", h=1e-5, write=False).observables
    for col, tol in (("theta", 0.02), ("y", 1e-4)):     # measured: 6.1e-3 rad, 4.6e-5 m (chattering)
        assert np.max(np.abs(np.interp(ours["t"], d["t"], d[col]) - ours[col])) < tol, col


@needs_exudyn
def test_exudyn_on_the_penalty_ball_follows_an_independent_integration_of_the_same_law(tmp_path):
    from _penalty_ball import penalty_ball_height as _truth

    sc = api.load_scene("ball", ["contact.law=penalty"])
    (run,) = base.run_peer(PEERS["exudyn-ga"], sc, [5e-5], tmp_path)
    d = pd.read_csv(run.file, comment="#").iloc[::20]
    assert np.max(np.abs(d["x"].to_numpy() - _truth(d["t"].to_numpy()))) < 5e-3    # measured: 1.7e-3
    assert len(pd.read_csv(run.impacts)) == 4


@needs_exudyn
def test_exudyn_on_the_penalty_ball_converges_where_the_law_has_no_jump_at_the_onset(tmp_path):
    """The default dashpot (c = 45) switches c·v⁻ ≈ 199 N on at the contact's onset: a fixed step
    that does not locate it misses part of that force, a velocity error of order Δa·h whose
    factor is where the onset falls in the step, so the error does not fall steadily with h
    (measured over one bounce: 1.0e-3, 5.8e-5, 4.2e-4, 1.9e-4 m at h = 1e-4 … 1.25e-5 s;
    daebench's genalpha alike). Without the dashpot the force is continuous and the error falls
    with h."""
    from _penalty_ball import penalty_ball_height as _truth

    sc = api.load_scene("ball", ["contact.law=penalty", "contact.penalty_damping=0", "t_end=0.7"])
    err = []
    for run in base.run_peer(PEERS["exudyn-ga"], sc, [1e-4, 1.25e-5], tmp_path):
        d = pd.read_csv(run.file, comment="#")
        err.append(np.max(np.abs(d["x"].to_numpy() - _truth(d["t"].to_numpy(), damping=0.0))))
    assert err[1] < err[0] / 30.0, err          # measured: 8.0e-5 → 5.1e-7 (×158 for 8× the steps)


@needs_siconos
@pytest.mark.slow
def test_siconos_slider_crank_is_scored_over_the_trusted_span_at_three_steps(tmp_path):
    res = api.peer("slider-crank-clearance", "siconos-mj", [2e-5, 1e-5, 5e-6], write=False, out=tmp_path)
    rows = res.rows()
    assert all(r["status"] == "completed" and r["trust_t"] > 0 for r in rows)
    err = [r["err_theta_max_trusted"] for r in rows]
    assert all(math.isfinite(e) and e > 0 for e in err)
    pairs, fitted = res.orders("err_theta_max_trusted")
    assert all(0.8 < p < 1.2 for p in pairs[1:]), (err, pairs)     # measured: 1.00, 0.98 (span 0 – 3.27 ms)
