"""The reference the package ships for the main case (beam-impact): loaded on an empty
results folder after every check a cached one passes, refused when the scene or the model
changed (daebench.harness.references.shipped, daebench.harness.references.modelprobe)."""

import shutil

import numpy as np
import pandas as pd
import pytest

from daebench.harness.references import accuracy, fingerprints, modelprobe, reference as references
from daebench.models.scenes import load_scene

REGENERATE = "daebench reference beam-impact --force --ship"


@pytest.fixture
def empty_results(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    return tmp_path / "results"


@pytest.fixture
def no_compute(monkeypatch):
    """compute_reference replaced by a recorder: a test sees that a refused reference is
    recomputed without paying for it."""
    calls = []

    def fake(scene, **kw):
        calls.append(scene.hash)
        return "computed"

    monkeypatch.setattr(references, "compute_reference", fake)
    return calls


def test_the_shipped_reference_loads_with_require_on_an_empty_results_folder(empty_results):
    scene = load_scene("beam-impact")
    src = references.shipped_path(scene)
    assert src.is_file(), f"no shipped reference for beam-impact's scene hash {scene.hash}; run `{REGENERATE}`"
    assert src.stat().st_size < 4e6  # measured 3.5 MB (zstd, byte-stream-split floats; 1.9 MB before the state columns)
    ref = references.load_reference(scene, mode="require")
    assert ref.path == empty_results / "references" / src.name and ref.path.is_file()
    assert ref.kind == "ida" and ref.rtol == 1e-11
    assert len(ref.history) == 20001 and len(ref.impacts) == 13
    assert ref.trust_span == (1.0, 13)
    assert ref.meta["installed_from"].startswith("shipped")
    assert fingerprints.differences(scene, ref) == []  # and it is fingerprinted: the numbers the project measured
    assert scene.hash in fingerprints._load()
    # the first impact near t ≈ 0.37 s (cases/beam-impact.toml), θ starts at 45°
    assert 0.36 < ref.impacts[0] < 0.39 and ref.history["theta_deg"].iloc[0] == 45.0
    # from now on it is an ordinary cached reference
    assert references.why_no_reference(scene) == ""
    from daebench.harness.sweeps import sweep as bench

    bench.prepare_references([], scene, "require")


def test_a_changed_scene_does_not_get_the_shipped_reference(empty_results, no_compute):
    scene = load_scene("beam-impact", ["start.theta_deg=44"])
    with pytest.raises(references.ReferenceMissing, match="daebench reference beam-impact --set start.theta_deg=44"):
        references.load_reference(scene, mode="require")
    assert references.load_reference(scene, mode="compute") == "computed" and no_compute == [scene.hash]
    assert not (empty_results / "references").exists() or not any((empty_results / "references").iterdir())


def test_a_shipped_reference_of_another_scene_hash_is_refused(empty_results, no_compute, tmp_path, monkeypatch):
    """A shipped pair under the changed scene's file name (as if copied there by mistake):
    its sidecar names the old scene hash, so it is refused and recomputed, never installed."""
    scene = load_scene("beam-impact")
    changed = load_scene("beam-impact", ["beam.modulus=7e10"])
    fake = tmp_path / "shipped"
    fake.mkdir()
    src = references.shipped_path(scene)
    for suffix in (".parquet", ".json"):
        shutil.copyfile(src.with_suffix(suffix), fake / f"beam-impact-{changed.hash}{suffix}")
    monkeypatch.setattr(references, "SHIPPED_DIR", fake)
    with pytest.raises(references.ReferenceDamaged, match=f"refused.*scene hash {scene.hash}, not {changed.hash}"):
        references.load_reference(changed, mode="require")
    assert references.load_reference(changed, mode="auto") == "computed" and no_compute == [changed.hash]
    assert not references.reference_path(changed).exists()


def test_a_changed_model_refuses_the_shipped_reference(empty_results, no_compute, monkeypatch):
    """Same scene, a model whose elastic energy changed by 1e-6 (a formula or constant in the
    code): the model probe in the sidecar differs, the shipped reference is refused."""
    from daebench.models.hubbeam import HubBeam

    scene = load_scene("beam-impact")
    real = HubBeam.energy

    def changed(self, q, v):
        out = real(self, q, v)
        return {**out, "elastic": out["elastic"] * (1 + 1e-6)}

    monkeypatch.setattr(HubBeam, "energy", changed)
    with pytest.raises(references.ReferenceDamaged, match="refused.*another model 'hub-beam'.*E.elastic"):
        references.load_reference(scene, mode="require")
    assert references.load_reference(scene, mode="compute") == "computed" and no_compute == [scene.hash]
    assert not references.reference_path(scene).exists()


def test_probe_passes_round_off_and_catches_a_parameter():
    from daebench.models import build_system

    scene = load_scene("beam-impact")
    p = modelprobe.probe(build_system(scene))
    jitter = {k: [x * (1 + 1e-13) for x in v] for k, v in p.items()}
    assert modelprobe.differences(jitter, p) == []
    other = modelprobe.probe(build_system(scene.with_overrides({"beam.density": 2.7e3})))
    diff = modelprobe.differences(p, other)
    assert any(d.startswith("E.kinetic") for d in diff) and any(d.startswith("M[") for d in diff)
    assert modelprobe.differences({**p, "extra": [1.0]}, p) == ["extra vanished"]


@pytest.mark.slow
def test_the_shipped_reference_is_what_the_code_computes_today(empty_results):
    """Recompute beam-impact's reference (3 IDA runs, ~30 s CPU) and compare it with the
    shipped one: every scored observable within TRUST_REL of its range (the reference's own
    stated tolerance; measured: identical to the last bit), the same impacts to 1e-9 s."""
    scene = load_scene("beam-impact")
    new = references.compute_reference(scene)
    old = pd.read_parquet(references.shipped_path(scene))
    assert list(new.history.columns) == list(old.columns) and len(new.history) == len(old)
    for c in scene["output.observables"]:
        rng = float(old[c].max() - old[c].min())
        assert np.max(np.abs(new.history[c].to_numpy() - old[c].to_numpy())) <= accuracy.TRUST_REL * rng, c
    shipped = references.validate(scene, references.shipped_path(scene))
    assert np.max(np.abs(np.subtract(new.impacts, shipped.impacts))) <= 1e-9
