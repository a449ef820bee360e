"""Everything a cached reference carries is verified: a tampered, out-of-range or unreadable
sidecar field is damage, a damaged reference is recomputed or refused, a reference is
trusted only for what it assessed."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from daebench.harness.references import stored
from _cli import cli


@pytest.fixture()
def pendulum_reference(tmp_path, monkeypatch):
    """A small cached reference (pendulum, 0.2 s, no check runs)."""
    from daebench.harness.references import reference as references
    from daebench.models.scenes import load_scene

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    sc = load_scene("pendulum", ["t_end=0.2"])
    return sc, references.compute_reference(sc, rtol=1e-9, atol=1e-11, check=False)


def _edit(path: Path, change, reseal: bool = False) -> None:
    from daebench.harness.references.reference import write_sidecar

    side = path.with_suffix(".json")
    meta = json.loads(side.read_text())
    change(meta)
    if reseal:  # as if whoever edited it also knew to recompute the checksum
        write_sidecar(side, meta)
    else:
        side.write_text(json.dumps(meta, indent=1))


def _set(key: str, value):
    def change(meta):
        d = meta
        *head, last = key.split(".")
        for k in head:
            d = d.setdefault(k, {})
        d[last] = value
    return change


@pytest.mark.parametrize("key, value", [("impacts", [0.1]), ("accuracy.trust_t", 0.05), ("settings.rtol", 1e-12),
                                        ("agreement", {"err_theta_max": 0.0}), ("rows", 3)])
def test_a_tampered_sidecar_field_is_refused_as_damaged(pendulum_reference, key, value):
    """Editing a scored field of the sidecar (impacts, trust_t, settings…) changed the scores
    with exit 0: the sidecar's own checksum now covers every field."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    _edit(ref.path, _set(key, value))
    with pytest.raises(references.ReferenceDamaged, match="checksum mismatch: a field of the sidecar changed"):
        references.load_reference(sc, mode="require")
    assert "is damaged" in stored.why_no_reference(sc)


@pytest.mark.parametrize("key, value, why", [
    ("impacts", [math.nan], "not a finite time"),
    ("impacts", [0.15, 0.1], "not in time order"),
    ("impacts", [5.0], "outside \\[0, 0.2\\] s"),
    ("accuracy", [], "'accuracy' is not a mapping"),
    ("accuracy", {"trust_t": 10 ** 400, "trust_impacts": 0}, "trust_t .* is not a time"),
    ("accuracy", {"trust_t": math.inf, "trust_impacts": 0}, "trust_t .* is not a time"),
    ("accuracy", {"trust_t": 0.1, "trust_impacts": 4}, "trust_impacts 4 is not a count"),
    ("settings", [], "'settings' has the wrong type"),
    ("wall_s", "x", "'wall_s' 'x' is not a finite number"),
])
def test_a_sealed_sidecar_with_a_field_out_of_range_is_damaged(pendulum_reference, key, value, why):
    """Even with a matching checksum, every scored field is checked for type and range:
    "impacts": [NaN] gave 'error … nan' and exit 0; 10**400 an OverflowError."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    _edit(ref.path, _set(key, value), reseal=True)
    with pytest.raises(references.ReferenceDamaged, match=why):
        references.load_reference(sc, mode="require")


@pytest.mark.parametrize("text, why", [("[" * 5000 + "]" * 5000, "nested too deeply"),
                                       ('{"rows": ' + "9" * 5000 + "}", "not valid JSON"),
                                       ('{"a": 1e999999}', "checksum"),
                                       ("\xff\xfe", "not valid JSON|not UTF-8")])
def test_a_sidecar_that_breaks_the_json_reader_is_damaged_not_a_crash(pendulum_reference, text, why):
    """A sidecar that raised while read (deep JSON, 10**400 digits, bytes) was blamed on the
    integrator; it is a damaged reference, and `compute` replaces it."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    ref.path.with_suffix(".json").write_text(text)
    with pytest.raises(references.ReferenceDamaged, match=why):
        references.load_reference(sc, mode="require")
    again = references.load_reference(sc, mode="compute", rtol=1e-9, atol=1e-11, check=False)
    assert references.validate(sc, again.path).impacts == again.impacts


def test_a_damaged_reference_is_recomputed_in_a_bench_and_refused_under_require(pendulum_reference):
    """The bench's row is never charged with a damaged reference: `auto` recomputes it, `require`
    refuses the input naming the damage (exit 2)."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    _edit(ref.path, _set("impacts", [0.1]))
    r = cli(["reference", "pendulum", "--set", "t_end=0.2", "--rtol", "1e-9", "--atol", "1e-11"])
    assert r.exit_code == 0, r.output
    assert references.validate(sc, ref.path).impacts == []  # recomputed, sealed again
    _edit(ref.path, _set("impacts", [0.1]))
    r = cli(["bench", "pendulum", "-i", "hht", "--steps", "1e-2", "--set", "t_end=0.2", "--reference", "require",
             "--repeats", "1"])
    assert r.exit_code == 2 and "damaged" in r.output and "checksum mismatch" in r.output, r.output


def test_a_requested_tolerance_the_cache_does_not_meet_recomputes(pendulum_reference):
    """A reference asked for at rtol 1e-11 returned the cached 1e-9 one without a word."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    with pytest.raises(references.ReferenceDamaged, match="computed at rtol 1e-09, looser than the requested 1e-11"):
        references.load_reference(sc, mode="require", rtol=1e-11)
    tighter = references.load_reference(sc, mode="compute", rtol=1e-11, atol=1e-13, check=False)
    assert tighter.rtol == 1e-11
    assert references.load_reference(sc, mode="require", rtol=1e-10).rtol == 1e-11   # a tighter one serves


def test_output_only_keys_leave_the_scene_hash():
    """output.format and output.observables changed the hash, so the shipped reference was not
    used; the sweep's manifest names the observables it scores instead."""
    from daebench.harness.sweeps.sweep import manifest
    from daebench.models.scenes import load_scene

    sc = load_scene("beam-impact")
    other = sc.with_overrides({"output.format": "parquet", "output.observables": ["theta"]})
    assert other.hash == sc.hash
    assert sc.with_overrides({"t_end": 0.5}).hash != sc.hash
    assert manifest(other, [], "auto", 1)["observables"] == ["theta"] != manifest(sc, [], "auto", 1)["observables"]


def test_a_reference_assessed_on_fewer_observables_is_not_trusted_for_more(pendulum_reference, monkeypatch):
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    few = sc.with_overrides({"output.observables": ["theta"]})
    calls = []
    monkeypatch.setattr(references, "compute_reference", lambda scene, **kw: calls.append(scene) or "computed")
    _edit(ref.path, lambda m: m["scene_values"].update({"output.observables": ["theta"]}), reseal=True)
    assert references.load_reference(few, mode="require").path == ref.path
    assert references.load_reference(sc, mode="auto") == "computed" and calls == [sc]


def test_the_reference_is_described_by_what_computed_it():
    """A Moreau reference was labelled 'IDA rtol nan', the crank's DOP853 one 'IDA rtol 1e-11'."""
    import pandas as pd

    from daebench.harness.references.reference import Reference
    from daebench.harness.scoring.pipeline import reference_truth

    hist = pd.DataFrame({"t": [0.0, 1.0]})
    cap = Reference(hist, [], {"kind": "capturing", "integrator": "moreau", "settings": {"h": 5e-6}}, Path("x"))
    ode = Reference(hist, [], {"integrator": "ode-index1", "settings": {"rtol": 1e-11, "method": "dop853"}},
                    Path("x"))
    assert reference_truth(cap).description == "cached reference (moreau h 5e-06 (event capturing))"
    assert reference_truth(ode).description == "cached reference (DOP853 rtol 1e-11)"


def test_a_reference_larger_than_its_rows_can_be_is_refused_before_hashing(pendulum_reference, monkeypatch):
    """A symlink in the cache to a huge file made every run hash it first (41 s for 8 GB)."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    big = ref.path.parent / "big.bin"
    with open(big, "wb") as fh:
        fh.truncate(1 << 32)  # sparse: 4 GiB on paper
    ref.path.unlink()
    ref.path.symlink_to(big)
    hashed = []
    monkeypatch.setattr(references, "sha256", lambda p: hashed.append(p) or "")
    with pytest.raises(references.ReferenceDamaged, match="bytes, more than .* it was not read"):
        references.load_reference(sc, mode="require")
    assert hashed == []
