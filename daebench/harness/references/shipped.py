"""References shipped inside the package (maintainers' side).

The README's main job, ``daebench compare beam-impact``, needs beam-impact's reference; on a
fresh install computing it is the longest part of the first hour. So the package ships
it: ``daebench/data/references/<scene>-<hash>.parquet`` and ``.json``, the pair
:mod:`daebench.harness.references.reference` caches, stored thin (:mod:`daebench.harness.references.packed`:
the columns the states determine are dropped and rebuilt on install, each checked to the bit
against its recorded digest). When a scene has no cached reference,
:func:`daebench.harness.references.reference.load_reference` installs the shipped one
(:func:`daebench.harness.references.reference.install_shipped`: a copy into ``results/references/``)
— only after it passes every check a cached reference passes
(:func:`daebench.harness.references.stored.validate`: sidecar, SHA-256, rows, columns, time
span, scene hash, kind, and the model probe of :mod:`daebench.harness.references.modelprobe`, which
a shipped reference must carry). One that fails is refused (``require``:
:class:`daebench.harness.references.stored.ReferenceDamaged` saying why) or recomputed
(``compute``, ``auto``), never trusted. A changed scene has another hash: the shipped
file is not even looked at; a changed model fails the probe.

Maintainers: after a change of beam-impact's scene or model (the shipped reference is then
refused, and tests/harness/test_refship.py fails saying so), ``daebench reference beam-impact --force
--ship`` recomputes its reference and ships it (without ``--force``: ships the cached one).
"""

from __future__ import annotations

import json
from pathlib import Path

from daebench.core.scene import Scene
from daebench.harness.references import packed
from daebench.harness.references.reference import (SHIPPED_DIR, Reference, ReferenceDamaged, sha256, shipped_path,
                                                    validate, write_history, write_sidecar)
from daebench.models import build_system


def ship(scene: Scene, ref: Reference) -> Path:
    """Maintainers: copy the cached reference ``ref`` of ``scene`` into the package (after
    its checks; it must carry a model probe)."""
    validate(scene, ref.path)  # the model probe too
    if not isinstance(ref.meta.get("model_probe"), dict):
        raise ReferenceDamaged(f"{ref.path} has no model probe; recompute it with "
                               f"`daebench reference {scene.name} --force`")
    SHIPPED_DIR.mkdir(parents=True, exist_ok=True)
    for old in SHIPPED_DIR.glob(f"{scene.name}-*"):
        old.unlink()  # the scene's earlier (other-hash) reference
    dest = shipped_path(scene)
    kept, derived = packed.thin(build_system(scene), ref.history)
    write_history(dest, kept)
    meta = json.loads(ref.path.with_suffix(".json").read_text())  # the sidecar as written (provenance too)
    meta.pop("installed_from", None)
    meta.update({"sha256": sha256(dest), "columns": list(kept.columns), packed.DERIVED_KEY: derived,
                 packed.ORDER_KEY: list(ref.history.columns)})
    write_sidecar(dest.with_suffix(".json"), meta)  # sealed anew without the cache's own note
    return dest
