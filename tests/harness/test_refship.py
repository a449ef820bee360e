"""The reference the package ships for the main case (beam-impact): loaded on an empty
results folder after every check a cached one passes, refused when the scene or the model
changed (daebench.harness.references.shipped, daebench.harness.references.modelprobe)."""

import json
import shutil

import numpy as np
import pandas as pd
import pytest

from daebench.harness.references import accuracy, fingerprints, modelprobe, packed, reference as references
from daebench.models.scenes import load_scene
from daebench.harness.references import stored

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
    assert src.stat().st_size < 2e6  # stored thin (daebench.harness.references.packed); 3.5 MB whole
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
    assert stored.why_no_reference(scene) == ""
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
    old = references.load_reference(scene, mode="require").history   # the shipped one, installed whole
    assert list(new.history.columns) == list(old.columns) and len(new.history) == len(old)
    for c in scene["output.observables"]:
        rng = float(old[c].max() - old[c].min())
        assert np.max(np.abs(new.history[c].to_numpy() - old[c].to_numpy())) <= accuracy.TRUST_REL * rng, c
    shipped = references.validate(scene, references.shipped_path(scene))
    assert np.max(np.abs(np.subtract(new.impacts, shipped.impacts))) <= 1e-9


def test_the_shipped_reference_is_thin_and_installs_whole(empty_results):
    """The package stores the states, the time, the work, the energy residual and the
    contact columns; the observables and energy terms are rebuilt on install and must be
    the computed ones. Checked here by formulas independent of the model's kernel: θ in
    degrees is q_theta, E is the sum of its terms, and the energy residual is
    E − E(0) − ΣW + D_impacts row by row."""
    scene = load_scene("beam-impact")
    src = references.shipped_path(scene)
    stored = pd.read_parquet(src)
    assert {"t", "q_theta", "v_theta", "energy_residual", "D_impacts"} <= set(stored.columns)
    assert not {"theta_deg", "tip_x", "E", "E_kinetic"} & set(stored.columns)
    hist = references.load_reference(scene, mode="require").history
    meta = json.loads(src.with_suffix(".json").read_text())
    assert list(hist.columns) == meta[packed.ORDER_KEY] and len(hist) == len(stored)
    assert set(hist.columns) - set(stored.columns) == set(meta[packed.DERIVED_KEY])
    np.testing.assert_allclose(hist["theta_deg"], np.degrees(hist["q_theta"]), rtol=1e-15, atol=0)
    terms = [c for c in hist.columns if c.startswith("E_")]
    assert {"E_kinetic", "E_elastic", "E_gravity"} <= set(terms)
    np.testing.assert_allclose(hist["E"], hist[terms].sum(axis=1), rtol=1e-14, atol=1e-15)
    works = [c for c in hist.columns if c.startswith("W_") and c[2:].isalpha() and len(c) > 3]
    resid = hist["E"] - hist["E"].iloc[0] - hist[works].sum(axis=1) + hist["D_impacts"]
    assert np.max(np.abs(resid - hist["energy_residual"])) < 1e-12


def _planted(tmp_path, monkeypatch, edit):
    """The shipped pair copied into a fake package folder, its sidecar edited by ``edit`` and
    sealed again (as a maintainer's mistake would be: the seal does not catch it)."""
    scene = load_scene("beam-impact")
    fake = tmp_path / "shipped"
    fake.mkdir()
    src = references.shipped_path(scene)
    shutil.copyfile(src, fake / src.name)
    meta = json.loads(src.with_suffix(".json").read_text())
    edit(meta)
    references.write_sidecar(fake / src.with_suffix(".json").name, meta)
    monkeypatch.setattr(references, "SHIPPED_DIR", fake)
    return scene


def test_a_derived_column_that_does_not_rebuild_is_refused(empty_results, no_compute, tmp_path, monkeypatch):
    """tip_x's fingerprint moved by 1e-9 of its scale at one sampled row (1 000× the
    tolerance: another model's value, not arithmetic): refused, nothing installed, and
    `auto` computes the reference instead."""
    def moved(meta):
        fp = meta[packed.DERIVED_KEY]["tip_x"]
        fp["samples"][7] += 1e-9 * fp["scale"]

    scene = _planted(tmp_path, monkeypatch, moved)
    with pytest.raises(references.ReferenceDamaged, match="refused.*tip_x: at a sampled row it differs by"):
        references.load_reference(scene, mode="require")
    assert not references.reference_path(scene).exists()
    assert references.load_reference(scene, mode="auto") == "computed" and no_compute == [scene.hash]


def test_another_cpus_last_bits_are_accepted(empty_results, no_compute, tmp_path, monkeypatch):
    """Every sampled value of every rebuilt column two ulps away and the sums of magnitudes
    moved by 1e-14 (what another CPU's vector width or math library gives): installed, and
    the installed columns are this machine's rebuilt values (θ in degrees = q_theta)."""
    def last_bits(meta):
        for fp in meta[packed.DERIVED_KEY].values():
            fp["samples"] = [None if x is None else float(np.nextafter(np.nextafter(x, np.inf), np.inf))
                             for x in fp["samples"]]
            fp["sum_abs"] *= 1 + 1e-14

    scene = _planted(tmp_path, monkeypatch, last_bits)
    hist = references.load_reference(scene, mode="require").history
    assert no_compute == []
    np.testing.assert_allclose(hist["theta_deg"], np.degrees(hist["q_theta"]), rtol=1e-15, atol=0)


def test_thin_drops_only_what_the_states_rebuild():
    """A column 1e-9 off its formula at one row (not round-off: another quantity) is kept; one
    an ulp off is dropped, rebuilt to the formula's value, its difference recorded."""
    from daebench.models import build_system

    scene = load_scene("beam-impact")
    system = build_system(scene)
    q0, v0 = system.initial_state()
    t = np.linspace(0.0, 1e-3, 4)
    obs, terms = system.output_rows(t, np.tile(q0, (4, 1)), np.tile(v0 + 0.1, (4, 1)))
    hist = pd.DataFrame({"t": t, **obs, **{f"E_{k}": x for k, x in terms.items()},
                         "E": sum(terms.values()), "energy_residual": np.zeros(4)})
    exact = hist.copy()
    hist.loc[2, "tip_y"] *= 1 + 1e-9
    hist.loc[1, "tip_x"] = np.nextafter(hist.loc[1, "tip_x"], np.inf)
    kept, derived = packed.thin(system, hist)
    assert "tip_y" in kept.columns and "tip_y" not in derived
    assert {"theta_deg", "tip_x", "E", "E_kinetic"} <= set(derived) and "energy_residual" in kept.columns
    assert derived["tip_x"]["max_difference"] == pytest.approx(abs(np.spacing(exact.loc[1, "tip_x"])), rel=1e-12)
    whole = packed.rebuild(system, kept, derived, list(hist.columns))
    assert list(whole.columns) == list(hist.columns)
    pd.testing.assert_frame_equal(whole.drop(columns="tip_y"), exact.drop(columns="tip_y"), check_exact=True)
    assert whole.loc[2, "tip_y"] == hist.loc[2, "tip_y"]   # kept as stored
