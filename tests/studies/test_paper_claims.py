"""The beam-impact paper's claims judged on planted run data: a claim whose mechanism
cannot act in the model reads "not testable here" with the measured reason, and a
pattern the data contradict is "not supported"."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from daebench.studies.hht_beam_impact import claims
from daebench.studies.hht_beam_impact.study import Protocol
from daebench.studies.hht_beam_impact.table import BAUMGARTE, HHT_ALPHAS


@pytest.fixture(autouse=True)
def _no_figures(monkeypatch):
    for name in ("fig_difference", "fig_series"):
        monkeypatch.setattr(claims, name, lambda *a, **k: [])


def _settings():
    from daebench.studies.hht_beam_impact.study import setting_name
    return ([("hht", setting_name("hht", {"alpha": a})) for a in HHT_ALPHAS]
            + [("baumgarte", setting_name("baumgarte", {"delta": d, "epsilon": e})) for d, e in BAUMGARTE])


def _runs(theta_shift: dict[str, float], N: int = 5, sets=("table", "rebound"), status=None):
    """Rows and histories: θ(t) = 30 sin(t) + the setting's planted shift."""
    t = np.linspace(0.0, 1.0, 201)
    rows, hists = [], {}
    for tag in sets:
        for integ, name in _settings():
            run = len(rows)
            rows.append({"run": run, "set": tag, "N": N, "e": 0.0, "integrator": integ, "setting": name,
                         "status": (status or {}).get(name, "completed"), "law": "constraint",
                         "impact_times": "[0.4, 0.7]"})
            hists[run] = pd.DataFrame({"t": t, "theta_deg": 30 * np.sin(t) + theta_shift.get(name, 0.0),
                                       "gap": np.abs(np.cos(3 * t))})
    return pd.DataFrame(rows), hists


def test_claim1_is_not_testable_when_delta_epsilon_change_theta_only_at_roundoff():
    shifts = {"HHT α=-0.15": 0.05, "HHT α=-1/3": 0.1, "Baumgarte (10,50)": 4e-11}
    df, hists = _runs(shifts)
    text, _ = claims.claim1(df, hists, Protocol(Ns=(5,)), None, {})
    assert text.endswith("→ not testable here"), text
    assert "round-off" in text and "4e-11°" in text and "nothing" not in text.split("→")[1]


def test_claim1_is_judged_when_delta_epsilon_act():
    shifts = {"HHT α=-0.15": 0.01, "Baumgarte (10,50)": 0.3, "Baumgarte (1000,5000)": 0.6}
    df, hists = _runs(shifts)
    text, _ = claims.claim1(df, hists, Protocol(Ns=(5,)), None, {})
    assert text.endswith("→ supported"), text        # 0.01° across α < 0.2 × 0.6° across (δ, ε)


def test_claim4_baumgarte_diverging_below_n9_is_not_supported():
    frames = []
    for N in (3, 5, 7, 9):
        status = {n: "diverged" for _, n in _settings() if n.startswith("Baum") and N >= 5}
        df, _ = _runs({}, N=N, sets=("table",), status=status)
        frames.append(df)
    df = pd.concat(frames, ignore_index=True)
    df["run"] = range(len(df))
    text, _ = claims.claim4(df, {}, Protocol(), None, {})
    assert "N = 5: diverged" in text and text.endswith("→ not supported"), text


def test_claim6_baumgarte_half_not_testable_at_roundoff_residuals():
    df, hists = _runs({}, N=7, sets=("table",))
    cdot = {"HHT α=-0.15": 2.6e-10, "Baumgarte (1000,5000)": 3.3e-12, "Baumgarte (10,50)": 5.6e-13}
    df["Cdot_max"] = df["setting"].map(cdot).fillna(1e-10)
    df["Cddot_max"] = 5.6e-3
    text, _ = claims.claim6(df, hists, Protocol(), None, {})
    assert "at round-off" in text, text
    assert text.endswith("→ supported by the 1 testable part(s); 1 part(s) not testable here"), text


def test_claim3_baumgarte_gain_shared_by_hht_is_not_supported():
    df, hists = _runs({}, sets=("rebound",))
    t = hists[0]["t"].to_numpy()
    for run, name in zip(df["run"], df["setting"]):
        drain = {"HHT α=0": -1e-9, "HHT α=-0.15": -5e-9, "HHT α=-1/3": -6e-9}.get(name, 0.0)
        # every method, HHT included, gains 5e-5 J across the first impact at t = 0.4 s
        hists[run]["energy_residual"] = drain * t / 0.4 + np.where(t > 0.4, 5e-5, 0.0)
    text, _ = claims.claim3(df, hists, Protocol(), None, {})
    assert "HHT over the same window" in text and "ABM4 step's" in text
    assert text.endswith("→ not supported"), text
