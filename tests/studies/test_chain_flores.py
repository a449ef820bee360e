"""Seed 003's Example 1 (chain-impact) with its own scheme beside the Flores law.

Independent truth: the Flores law's formula written out (F = K δ^1.5 (1 + χ δ̇),
χ = 8(1 − e)/(5 e v₀)) evaluated on IDA's history; the rigid closed form of lcp-avg
(e = 0.0877, test_lcp_avg.py), which the chain's first contact approaches because it lasts
≈ 1.7 ms ≪ the chain's 63 ms period; the energy balance shrinking with the tolerance.
"""

import numpy as np
import pytest

import daebench
from daebench.models import build_system
from daebench.studies.averaged_gap_lcp import lcp_force_history, unclipped_hertz_force


def test_flores_force_goes_negative_before_the_clip_at_low_restitution():
    r = daebench.run("chain-impact", integrator="ida", overrides={
        "output.dt": 1e-5, "contact.hertz_damping": "flores", "contact.restitution": 0.1}, rtol=1e-9, atol=1e-12)
    assert r.status == "completed", r.message
    raw, factor = unclipped_hertz_force(r.observables, build_system(r.scene), r.impacts)
    recorded = r.observables["contact_force_0"].fillna(0.0).to_numpy()
    on = recorded > 0.0
    assert np.allclose(raw[on], recorded[on], rtol=1e-9)   # where it pushes, the formula is the law
    assert recorded.min() >= 0.0                            # the clip hides ...
    assert raw.min() < -10.0 and factor.min() < -1.0        # ... a pulling force at separation
    i = int(np.argmin(raw))
    ep = [e for e in r.impacts if e["t"] <= r.observables["t"][i] <= e["t_end"]][0]
    assert r.observables["t"][i] > 0.5 * (ep["t"] + ep["t_end"])   # in the separating half


@pytest.mark.slow
def test_chain_with_the_source_scheme():
    runs = {tol: daebench.run("chain-impact", integrator="lcp-avg",
                              overrides={"contact.law": "complementarity", "output.dt": 1e-4},
                              h_avg=1e-3, rtol=tol, atol=tol * 1e-2) for tol in (1e-4, 1e-8)}
    r = runs[1e-8]
    first = r.impacts[0]
    assert first["vn_plus"] / -first["vn_minus"] == pytest.approx(0.0877, rel=0.05)
    assert first["t_end"] - first["t"] == pytest.approx(1.622e-3, rel=0.05)
    assert lcp_force_history(r, 1e-3).min() >= 0.0
    res = {tol: abs(x.observables["energy_residual"].iloc[-1]) for tol, x in runs.items()}
    print("final energy residual by tolerance:", res)
    assert res[1e-8] < 0.05 * res[1e-4] and res[1e-8] < 1e-4 * r.observables["E"].iloc[0]
