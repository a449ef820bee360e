"""A reference's accuracy record (digits over time, trusted span) and the references of the
IVP test-set mechanisms against their published solutions.

Truth: synthetic histories with a known error (the trusted span and the digits follow in
closed form), the constraints (a perturbed start stays consistent), and the published
final values of F. Mazzia, C. Magherini, *Test Set for IVP Solvers* 2.4 (andrews.f,
crank.f, caraxis.f ``solut``; copied in :data:`daebench.studies.ivptest.REFERENCES`).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from daebench.harness.references import accuracy, reference as references
from daebench.harness.scoring import metrics
from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.studies import ivptest as ivptest


def _hist(t, y):
    return pd.DataFrame({"t": t, "y": y})


def test_trusted_span_and_digits_of_known_spreads():
    """ref y = sin t on [0, 20]; the loose run errs by 1e-6 t (estimated error 1e-7 t after
    the tolerance ratio 10), the perturbed one by 1e-8 eᵗ. Range 2: 1e-8 eᵗ passes
    TRUST_REL·2 = 2e-4 at t = ln 2e4 = 9.903; trust_t is the sample before."""
    t = np.linspace(0.0, 20.0, 20001)
    y = np.sin(t)
    acc = accuracy.assess(_hist(t, y), [1.0, 5.0, 9.5, 9.95, 15.0], _hist(t, y + 1e-6 * t),
                          _hist(t, y + 1e-8 * np.exp(t)), ["y"], 20.0)
    cross = math.log(accuracy.TRUST_REL * 2.0 / 1e-8)
    assert acc["trust_t"] == pytest.approx(cross, abs=1.5e-3)
    assert acc["trust_t"] <= cross
    assert acc["trust_impacts"] == 3 and acc["trust_limited_by"] == "y"
    assert acc["ranges"]["y"] == pytest.approx(2.0, rel=1e-6)
    # first window [0, 2]: max(1e-7·2, 1e-8·e²) = 2e-7 → −log10(2e-7 / 2) = 7
    assert acc["digits"]["windows"][0] == [0.0, 2.0]
    assert acc["digits"]["y"][0] == pytest.approx(7.0, abs=0.01)
    # last window [18, 20]: the estimate 1e-7·20 / 2; the sensitivity 1e-8 e²⁰ / 2
    assert acc["digits"]["y"][-1] == pytest.approx(6.0, abs=0.01)
    assert acc["digits_perturbed"]["y"][-1] == pytest.approx(-math.log10(1e-8 * math.exp(20.0) / 2.0), abs=0.01)


def test_runs_that_agree_trust_the_whole_run_and_a_stopped_run_ends_it():
    t = np.linspace(0.0, 1.0, 101)
    y = t**2
    acc = accuracy.assess(_hist(t, y), [], _hist(t, y), _hist(t, y + 1e-12), ["y"], 1.0)
    assert acc["trust_t"] == 1.0 and acc["trust_impacts"] == 0 and acc["trust_limited_by"] is None
    assert acc["digits_final"]["y"] == accuracy.DIGITS_CAP          # the loose run agrees exactly
    assert acc["digits_perturbed"]["y"][-1] == pytest.approx(12.0, abs=0.01)
    stopped = accuracy.assess(_hist(t, y), [0.2, 0.9], _hist(t, y), _hist(t[:51], y[:51]), ["y"], 1.0)
    assert stopped["trust_t"] == pytest.approx(0.5) and stopped["trust_impacts"] == 1


def test_perturbed_start_is_consistent_and_at_the_roundoff_of_rtol():
    sysm = build_system(load_scene("andrews"))
    q0, v0 = sysm.initial_state()
    q, v = accuracy.perturbed_start(sysm, 1e-11)
    assert np.abs(sysm.constraint(0.0, q)).max() < 1e-15
    assert np.abs(sysm.constraint_jacobian(0.0, q) @ v).max() < 1e-12
    dq = np.abs(q - q0)
    # moved by ≈ 10·rtol of each angle's scale, never more than a few times that
    assert 1e-12 < dq.max() < 1e-9


def test_reference_sidecar_holds_the_accuracy_record(tmp_path, monkeypatch):
    """A short reference (andrews, 5 ms): the sidecar holds trust_t, trust_impacts and the
    digits; the reference of a smooth run is trusted to its end, with ≥ 8 digits."""
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    sc = load_scene("andrews", ["t_end=0.005"])
    ref = references.compute_reference(sc)
    meta = json.loads(ref.path.with_suffix(".json").read_text())
    acc = meta["accuracy"]
    assert acc["trust_t"] == pytest.approx(0.005) and acc["trust_impacts"] == 0
    assert ref.trust_span == (acc["trust_t"], 0)
    assert references.trust_span(sc) == ref.trust_span
    assert set(acc["digits"]) == {"windows", *sc["output.observables"]}
    assert min(min(v) for k, v in acc["digits"].items() if k != "windows") >= 8.0
    assert meta["integrator"] == "ode-index1" and meta["agreement"]["status"] == "completed"


# -- the IVP test-set references against the published digits -------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("case", ["andrews", "crank", "caraxis"])
def test_reference_matches_the_published_solution_to_nine_digits(case, tmp_path, monkeypatch):
    """`daebench reference CASE` with its defaults (DOP853 rtol 1e-11 on the index-1 ODE, its
    loose and perturbed runs, the IDA check): ≥ 9 significant digits in every position
    component at t_end against the published solution, and its own digit estimate within
    one digit of its true digits — measured against the same solver 100× tighter, because
    the published values are themselves the limit beyond ~10 digits (andrews: DOP853 at
    rtol 1e-11, 1e-12, 1e-13 all give γ 9.56–9.68 against them, 10.18 against each other).
    Beyond 12 true digits the comparison resolves nothing (the tighter run's own accuracy):
    there the estimate need only be ≥ 11. Measured against the published values: andrews
    ≥ 9.68 (γ), crank ≥ 9.83 (q4), caraxis ≥ 11.11 (yr); estimate − truth below 12 digits:
    andrews ≤ +0.55 (γ), crank ≤ +0.11, caraxis ≤ 0.19 (2–6 min each on a loaded machine)."""
    from daebench.harness.running.runner import run_scene
    from daebench.integrators.odeint import IndexOneODE

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    sc = load_scene(case)
    ref = references.compute_reference(sc)
    published = ivptest.reference_digits(case, ref.history)
    _, tight = run_scene(sc, IndexOneODE(rtol=1e-13), write=False, force=True)
    a, b = ref.history.iloc[-1], tight.history.iloc[-1]
    true = {c: float(-np.log10(max(abs(a[c] - b[c]) / abs(b[c]), 1e-17))) for c in published}
    est = ref.meta["accuracy"]["digits_final"]
    print(f"\n{case}: published", {k: round(v, 2) for k, v in published.items()},
          "\n  true", {k: round(v, 2) for k, v in true.items()}, "\n  estimated", est)
    assert min(published.values()) >= 9.0
    for c, d in true.items():
        assert (abs(est[c] - d) <= 1.0) if d < 12.0 else (est[c] >= 11.0), (c, est[c], d)


def test_andrews_reference_reaches_nine_digits_fast():
    """The fast variant: the reference solver (DOP853 on the index-1 ODE, rtol 1e-11, atol
    rtol × the declared scales) alone, no check runs, over andrews' whole 0.03 s: ≥ 9 digits
    in all seven angles against the published solution (measured ≥ 9.68)."""
    from daebench.harness.running.runner import run_scene
    from daebench.integrators.odeint import IndexOneODE

    _, res = run_scene(load_scene("andrews"), IndexOneODE(rtol=1e-11), write=False, force=True)
    assert res.status == "completed"
    assert min(ivptest.reference_digits("andrews", res.history).values()) >= 9.0


def test_errors_on_the_trusted_span_stop_at_trust_t():
    """A run off by 1e-3 up to t = 5 and by 1 after it: on [0, trust_t = 5] its max error is
    1e-3, over the whole run 1."""
    tr = np.linspace(0.0, 10.0, 2001)
    t = np.linspace(0.0, 10.0, 101)
    ref = pd.DataFrame({"t": tr, "y": np.sin(tr)})
    run = pd.DataFrame({"t": t, "y": np.sin(t) + np.where(t <= 5.0, 1e-3, 1.0)})
    on = metrics.trusted_errors(run, ref, [], 5.0, ["y"])
    assert on["err_y_max"] == pytest.approx(1e-3, rel=1e-6) and on["err_y_final"] == pytest.approx(1e-3, rel=1e-6)
    stopped = metrics.trusted_errors(run[run.t <= 3.0], ref, [], 5.0, ["y"])
    assert math.isnan(stopped["err_y_max"])


def test_every_scored_row_carries_the_trusted_span():
    """scoring.score against a reference with trust_t = 5 (of 10): the row has trust_t,
    trust_impacts and the errors on [0, 5] (1e-3) beside the whole-run ones (1)."""
    from types import SimpleNamespace

    from daebench.harness.scoring import pipeline as scoring

    tr_t = np.linspace(0.0, 10.0, 2001)
    t = np.linspace(0.0, 10.0, 101)
    ref = pd.DataFrame({"t": tr_t, "y": np.sin(tr_t)})
    hist = pd.DataFrame({"t": t, "y": np.sin(t) + np.where(t <= 5.0, 1e-3, 1.0)})
    scene = SimpleNamespace(get=lambda key, default=None: ["y"] if key == "output.observables" else default)
    run = scoring.Run(scene, None, hist)
    truth = scoring.Truth(ref, (), "reference", 1e-11, trust_t=5.0, trust_impacts=0)
    row = scoring.score(run, truth, (scoring.accuracy, scoring.trusted))
    assert row["trust_t"] == 5.0 and row["trust_impacts"] == 0
    assert row["err_y_max_trusted"] == pytest.approx(1e-3, rel=1e-6)
    assert row["err_y_max"] == pytest.approx(1.0, rel=1e-6)


def test_conditioning_amplification_of_known_differences():
    """Synthetic perturbed runs whose difference from the reference is A·δ·R·sin(t) (R the
    reference's range): the record gives A back for each δ, per observable, with the impacts."""
    import numpy as np
    import pandas as pd

    from daebench.harness.references.accuracy import conditioning

    t = np.linspace(0.0, 3.0, 301)
    ref = pd.DataFrame({"t": t, "a": 2.0 * np.cos(t), "b": 0.5 * t})
    R = {"a": float(ref["a"].max() - ref["a"].min()), "b": 1.5}
    runs = {}
    for d, A in ((1e-8, 3.0), (1e-4, 40.0)):
        runs[d] = (pd.DataFrame({"t": t, "a": ref["a"] + A * d * R["a"] * np.sin(t),
                                 "b": ref["b"] + 2.0 * d * R["b"] * np.sin(t)}), 7)
    rec = conditioning(ref, runs, ["a", "b"])
    assert rec["perturbations"] == [1e-8, 1e-4] and rec["impacts"] == [7, 7]
    np.testing.assert_allclose(rec["amplification"]["a"], [3.0, 40.0], rtol=1e-6)
    np.testing.assert_allclose(rec["amplification"]["b"], [2.0, 2.0], rtol=1e-6)
