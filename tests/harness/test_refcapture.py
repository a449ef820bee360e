"""The reference of nonsmooth and frictional cases (daebench.harness.references.capturing through
daebench.harness.references.reference): which scenes get a fine event-capturing reference, its
stated accuracy against the exact solution of the block on an incline, its storage and
its checks, and what `daebench reference` says about it.

Cost: three Moreau–Jean runs of a shortened block-incline (12 000 steps each) on the
rigid2d loop test_friction.py compiles too.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from daebench.harness.references import capturing as refcapture, reference as references
from daebench.models.rigid2d_exact import incline_motion
from daebench.models.scenes import load_scene

SHORT = {"t_end": 0.6, "output.dt": 1e-2}   # the stop (0.4025 s) inside, reference step 5e-5 s


def test_reference_kind_follows_friction_complementarity_and_the_model():
    """Friction (μ > 0), complementarity contacts and the slider-crank's declared chattering get a
    capturing reference, each with its reason; frictionless impact-law scenes stay with IDA."""
    kind, why = refcapture.reference_kind(load_scene("rocking-block"))
    assert kind == "capturing" and "friction" in why and "μ = 1" in why
    kind, why = refcapture.reference_kind(load_scene("falling-rod", {"contact.law": "complementarity"}))
    assert kind == "capturing" and "complementarity" in why
    kind, why = refcapture.reference_kind(load_scene("slider-crank-clearance"))
    assert kind == "capturing" and "chattering" in why
    assert refcapture.reference_kind(load_scene("falling-rod")) == ("ida", "")
    assert refcapture.reference_kind(load_scene("pendulum")) == ("ida", "")
    sc = load_scene("block-incline", SHORT)
    assert refcapture.reference_step(sc, references.REF_OVERSAMPLE) == pytest.approx(5e-5)
    assert refcapture.reference_step(sc, references.REF_OVERSAMPLE, tightest_h=1e-4) == pytest.approx(1e-5)


@pytest.fixture(scope="module")
def incline_reference(tmp_path_factory):
    import os

    old = os.environ.get("DAEBENCH_RESULTS")
    os.environ["DAEBENCH_RESULTS"] = str(tmp_path_factory.mktemp("results"))
    try:
        sc = load_scene("block-incline", SHORT)
        yield sc, references.load_reference(sc, mode="compute")
    finally:
        if old is None:
            os.environ.pop("DAEBENCH_RESULTS", None)
        else:
            os.environ["DAEBENCH_RESULTS"] = old


def test_capturing_reference_states_its_accuracy_honestly(incline_reference):
    """The stored reference is moreau at h = 5e-5 s; its accuracy record (coarse run at 2.1 h,
    perturbed start) estimates digits of vx within 0.5 of its true ones against the closed
    form (slide up exact, stop, slide back: first order after the stop: 5.0 digits), x within
    a factor 2; the whole run is trusted (the constant θ, y, gap columns limit nothing)."""
    sc, ref = incline_reference
    assert ref.kind == "capturing" and ref.meta["integrator"] == "moreau"
    assert ref.meta["settings"]["h"] == pytest.approx(5e-5) and math.isnan(ref.rtol)
    assert "friction" in ref.meta["why"] and ref.describe() == "moreau h 5e-05 (event capturing)"
    acc = ref.meta["accuracy"]
    assert acc["loose_factor"] == pytest.approx(1.1) and acc["coarse_h"] == pytest.approx(1.05e-4)
    assert acc["trust_t"] == sc.t_end and acc["trust_impacts"] == len(ref.impacts)   # θ ≡ 0 limits nothing
    H = ref.history
    x, v = incline_motion(3.0, math.radians(30.0), 0.3, 9.81, H.t.values)
    true_err = np.abs(H.vx.values - v).max()
    rng = acc["ranges"]["vx"]
    true_digits = -math.log10(true_err / rng)
    est_digits = min(acc["digits"]["vx"])
    assert true_err > 0 and abs(est_digits - true_digits) < 0.5, (est_digits, true_digits)
    assert np.abs(H.x.values - x).max() < 2 * 10 ** -min(acc["digits"]["x"]) * acc["ranges"]["x"]


def test_capturing_reference_is_validated_and_refused_as_the_wrong_kind(incline_reference):
    """Read back, it passes every check; a sidecar claiming IDA for this frictional scene is
    refused as damaged, naming both kinds and the reason."""
    sc, ref = incline_reference
    again = references.validate(sc, ref.path)
    assert again.kind == "capturing" and len(again.history) == len(ref.history)
    side = ref.path.with_suffix(".json")
    meta = json.loads(side.read_text())
    meta["kind"] = "ida"
    references.write_sidecar(side, meta)  # sealed again: the kind check itself is tested
    try:
        with pytest.raises(references.ReferenceDamaged,
                           match="'ida' reference, this scene needs a 'capturing' one \\(Coulomb friction"):
            references.validate(sc, ref.path)
    finally:
        meta["kind"] = "capturing"
        references.write_sidecar(side, meta)
    assert references.validate(sc, ref.path).kind == "capturing"


def test_compare_protocols_plan_both_families_and_refuse_with_reasons():
    """`daebench compare rocking-block` plans moreau, nsgenalpha and the event-driven integrators
    that declare friction at three steps each, and refuses IDA (and every integrator without
    friction) before running, each with the reason; the slider-crank plan runs IDA (μ = 0)."""
    from daebench.workflows import compare

    sc = load_scene("rocking-block")
    specs, refused = compare.plan(sc, compare.protocol_for(sc))
    ran = {s.integrator for s in specs}
    assert {"moreau", "nsgenalpha"} <= ran and sum(s.integrator == "moreau" for s in specs) == 3
    assert "ida" in refused and "friction" in refused["ida"] and "ida" not in ran
    crank = load_scene("slider-crank-clearance")
    specs, refused = compare.plan(crank, compare.protocol_for(crank))
    assert {"moreau", "nsgenalpha", "hht", "ida"} <= {s.integrator for s in specs}
    assert "lcp" in refused and "complementarity" in refused["lcp"]


def test_ida_tolerances_are_refused_for_a_capturing_reference():
    """--rtol/--atol name IDA's tolerances: asked of a scene whose reference is a capturing run,
    they are refused with the reason, not silently ignored."""
    from daebench.core.params import ParamError

    with pytest.raises(ParamError, match="event-capturing reference.*do not apply"):
        references.compute_reference(load_scene("rocking-block"), rtol=1e-9)
