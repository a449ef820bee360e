"""A cached reference computed under another revision of the driver's contact law is refused
(daebench.harness.references.stored.validate) and so recomputed: continuous laws are at their
own revision since a contact touching at the start closes at g = 0 (the touching balls of
hertz-chain), constraint-law and contact-free scenes — the shipped beam-impact reference —
stay at theirs."""

from __future__ import annotations

import json

import pytest

from daebench.driver.contact_state import CONTACT_LAW_REVISION, CONTINUOUS_LAW_REVISION, contact_law_revision
from daebench.harness.references import reference as references
from daebench.harness.references.stored import write_sidecar
from daebench.models import build_system
from daebench.models.scenes import load_scene


def test_each_law_has_its_revision():
    assert contact_law_revision(build_system(load_scene("hertz-chain"))) == CONTINUOUS_LAW_REVISION
    assert contact_law_revision(build_system(load_scene("ball", {"contact.law": "penalty"}))) == CONTINUOUS_LAW_REVISION
    for case in ("beam-impact", "ball", "pendulum"):
        assert contact_law_revision(build_system(load_scene(case))) == CONTACT_LAW_REVISION
    assert CONTINUOUS_LAW_REVISION != CONTACT_LAW_REVISION


def test_a_continuous_law_reference_of_the_last_revision_is_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    scene = load_scene("ball", {"contact.law": "penalty", "t_end": 0.5})
    ref = references.compute_reference(scene, rtol=1e-8, atol=1e-10, check=False)
    assert ref.meta["contact_law_revision"] == CONTINUOUS_LAW_REVISION
    references.validate(scene, ref.path)   # today's: accepted
    side = ref.path.with_suffix(".json")
    meta = json.loads(side.read_text())
    write_sidecar(side, {**meta, "contact_law_revision": CONTACT_LAW_REVISION})   # as the last revision wrote it
    with pytest.raises(references.ReferenceDamaged, match="contact law revision 2, today's is 3"):
        references.validate(scene, ref.path)
