"""References shipped inside the package (maintainers' side).

The README's main job, ``daebench compare beam-impact``, needs beam-impact's reference; on a
fresh install computing it is the longest part of the first hour. So the package ships
it: ``daebench/data/references/<scene>-<hash>.parquet`` and ``.json``, the same pair
:mod:`daebench.harness.references` caches (zstd, byte-stream-split floats: the values are
the computed ones, bit for bit). When a scene has no cached reference,
:func:`daebench.harness.references.load_reference` installs the shipped one
(:func:`daebench.harness.references.install_shipped`: a copy into ``results/references/``)
— only after it passes every check a cached reference passes
(:func:`daebench.harness.references.validate`: sidecar, SHA-256, rows, columns, time
span, scene hash, kind, and the model probe of :mod:`daebench.harness.modelprobe`, which
a shipped reference must carry). One that fails is refused (``require``:
:class:`daebench.harness.references.ReferenceDamaged` saying why) or recomputed
(``compute``, ``auto``), never trusted. A changed scene has another hash: the shipped
file is not even looked at; a changed model fails the probe.

Maintainers: after a change of beam-impact's scene or model (the shipped reference is then
refused, and tests/test_refship.py fails saying so), ``python -m daebench.harness.refship
beam-impact`` recomputes its reference and ships it.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

from daebench.core.scene import Scene
from daebench.harness.references import (SHIPPED_DIR, Reference, ReferenceDamaged, reference_path, shipped_path,
                                         validate)


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
    shutil.copyfile(ref.path, dest)
    meta = json.loads(ref.path.with_suffix(".json").read_text())  # the sidecar as written (provenance too)
    meta.pop("installed_from", None)
    dest.with_suffix(".json").write_text(json.dumps(meta, indent=1) + "\n")
    return dest


def main(argv: list[str]) -> int:
    """``python -m daebench.harness.refship SCENE [--cached]``: recompute SCENE's reference (or
    take the cached one) and ship it."""
    from daebench.harness.references import compute_reference
    from daebench.models.scenes import load_scene

    if len(argv) not in (1, 2) or (len(argv) == 2 and argv[1] != "--cached"):
        print("usage: python -m daebench.harness.refship SCENE [--cached]  (--cached: ship the cached "
              "reference, do not recompute)", file=sys.stderr)
        return 2
    scene = load_scene(argv[0])
    ref = validate(scene, reference_path(scene)) if argv[1:] else compute_reference(scene)
    dest = ship(scene, ref)
    print(f"shipped {dest} ({dest.stat().st_size / 1e6:.2f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
