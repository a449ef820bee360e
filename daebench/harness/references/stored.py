"""A reference's files: where they live (``results/references/<scene>-<hash>.parquet`` and
its ``.json`` sidecar), how the sidecar is sealed, and every check a reference passes before
it is trusted (:func:`validate`; :mod:`daebench.harness.references.reference` computes, caches
and loads them — its module docstring tells the whole story).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene, cases_dir
from daebench.driver.contact_state import contact_law_revision
from daebench.harness.files import DamagedFile, read_json, results_dir
from daebench.harness.references import accuracy, capturing, modelprobe
from daebench.models import build_system


class ReferenceMissing(ParamError):
    """No cached reference for a scene; the message says which command makes one."""


class ReferenceDamaged(ParamError):
    """A cached reference that fails its checks; the message says what failed and the fix."""


@dataclass
class Reference:
    """A reference solution: its history, impact times and the JSON sidecar."""

    history: pd.DataFrame
    impacts: list[float]
    meta: dict[str, Any]
    path: Path
    notes: list[str] = field(default_factory=list)   # what a caller adds (e.g. digits against a test set)
    shipped: Path | None = None                       # where it was shipped, when it was

    @property
    def rtol(self) -> float:
        """IDA's rtol (NaN for a capturing reference: it has a step instead)."""
        return float(self.meta["settings"].get("rtol", math.nan))

    @property
    def kind(self) -> str:
        """'ida' or 'capturing' (:mod:`daebench.harness.references.capturing`)."""
        return str(self.meta.get("kind", "ida"))

    def describe(self) -> str:
        """What computed it, in a few words: 'ida rtol 1e-11' or 'moreau h 5e-06 (event capturing)'."""
        if self.kind == "capturing":
            return f"{self.meta.get('integrator', '?')} h {float(self.meta['settings']['h']):g} (event capturing)"
        method = self.meta["settings"].get("method")  # the index-1 ODE's solver (DOP853, Radau)
        return f"{str(method).upper() if method else self.meta.get('integrator', 'ida')} rtol {self.rtol:g}"

    def summary_lines(self, t_end: float) -> list[str]:
        """What `daebench reference` says about it: what computed it and how long it took,
        its agreement with the looser check run, its accuracy record
        (:func:`daebench.harness.references.accuracy.summary_lines`) and its ``notes``."""
        lines = [f"reference: {self.path}",
                 f"{self.describe()}, {self.meta['wall_s']:.3g} s, {len(self.impacts)} impacts"
                 + (f" — a fine event-capturing run: {self.meta.get('why')}" if self.kind == "capturing" else "")]
        agr = self.meta.get("agreement", {})
        worst = [f"{k} {v:.2e}" for k, v in agr.items() if k.startswith("err_") and k.endswith("_max") and v == v]
        if worst:
            lines.append(f"agreement with the 10× looser check run ({agr.get('check', '')}): " + ", ".join(worst))
        return lines + accuracy.summary_lines(self.meta, self.impacts, t_end) + list(self.notes)

    @property
    def trust_span(self) -> tuple[float, int]:
        """(trust_t, trust_impacts) from the sidecar's accuracy record
        (:mod:`daebench.harness.references.accuracy`); ReferenceDamaged when it has none."""
        acc = self.meta.get("accuracy") or {}
        if "trust_t" not in acc:
            raise ReferenceDamaged(f"the reference {self.path} has no accuracy record (computed without the check "
                                   f"runs, or by an older daebench); recompute it with "
                                   f"`daebench reference {self.meta.get('scene', 'NAME')} --force`")
        return float(acc["trust_t"]), int(acc["trust_impacts"])


def reference_path(scene: Scene) -> Path:
    """results/references/<scene-name>-<scene.hash>.parquet"""
    return results_dir() / "references" / f"{scene.name}-{scene.hash}.parquet"


def reference_command(scene: Scene, force: bool = False) -> str:
    """The command that makes the reference of *this* scene: its case name (or its file)
    and every --set override in effect (a command without them makes another scene's)."""
    src = Path(scene.source) if scene.source else None
    try:
        case = src is not None and src.parent.resolve() == cases_dir().resolve()
    except (OSError, ParamError):
        case = False
    target = src.stem if case else (str(src) if src is not None else scene.name)
    words = ["daebench", "reference", target] + (["--force"] if force else [])
    for k, v in scene.changes().items():
        text = ",".join(map(str, v)) if isinstance(v, list) else (str(v).lower() if isinstance(v, bool) else repr(v)
                                                                    if isinstance(v, float) else str(v))
        words += ["--set", f"{k}={text}"]
    return shlex.join(words)


def fix_command(scene: Scene) -> str:
    """The command that recomputes the reference of ``scene``, as messages quote it."""
    return f"`{reference_command(scene, force=True)}` (or --reference compute / auto in `daebench bench`)"


def why_no_reference(scene: Scene) -> str:
    """Why ``scene`` has no usable cached reference ('' when it has one): missing, with the
    command that makes it, or damaged, with what failed and the fix."""
    path = reference_path(scene)
    if not (path.exists() and path.with_suffix(".json").exists()):
        return (f"no cached reference for scene '{scene.name}' (hash {scene.hash}); "
                f"`{reference_command(scene)}` makes one")
    try:
        validate(scene, path)
    except ReferenceDamaged as exc:
        return str(exc)
    return ""


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


#: the sidecar field that holds the SHA-256 of the rest of the sidecar (:func:`seal`)
SEAL_KEY = "sidecar_sha256"
#: the largest sidecar read (a reference's sidecar is tens of kilobytes; a long impact list a few MB)
MAX_SIDECAR_BYTES = 32 << 20


def _canonical(meta: dict[str, Any]) -> bytes:
    return json.dumps({k: v for k, v in meta.items() if k != SEAL_KEY}, sort_keys=True,
                      separators=(",", ":")).encode()


def seal(meta: dict[str, Any]) -> dict[str, Any]:
    """``meta`` as it will read back from JSON, with :data:`SEAL_KEY`: the SHA-256 of the
    canonical JSON of every other field (sorted keys, no spaces). Together with the
    sidecar's ``sha256`` of the history this covers everything a score depends on: the
    impact times, the accuracy record (``trust_t``), the settings and the scene's values."""
    plain = json.loads(json.dumps(meta, default=str))
    plain[SEAL_KEY] = hashlib.sha256(_canonical(plain)).hexdigest()
    return plain


def write_sidecar(path: Path, meta: dict[str, Any]) -> None:
    """Write a reference's sidecar, sealed (:func:`seal`)."""
    path.write_text(json.dumps(seal(meta), indent=1) + "\n")


def _finite(x: Any) -> bool:
    """A JSON number that is a finite float (an integer of 400 digits is not)."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return False
    try:
        return math.isfinite(float(x))
    except OverflowError:
        return False


def _check_fields(meta: dict[str, Any], t_end: float) -> str:
    """What is wrong with the fields a score depends on ('' when nothing): types and ranges
    of the impact times, the accuracy record, the time span, the row count and columns."""
    kinds = {"sha256": str, "rows": int, "columns": list, "t_span": list, "settings": dict, "impacts": list}
    wrong = [k for k, typ in kinds.items() if not isinstance(meta[k], typ) or isinstance(meta[k], bool)]
    if wrong:
        return (f"sidecar field {', '.join(repr(k) for k in wrong)} has the wrong type "
                f"({', '.join(f'{k} = {meta[k]!r:.40}' for k in wrong)})")
    imp = meta["impacts"]
    if not all(_finite(t) for t in imp):
        bad = next(t for t in imp if not _finite(t))
        return f"sidecar field 'impacts' holds {bad!r:.40}, not a finite time"
    span = 1e-9 * max(1.0, t_end)
    if imp and (imp[0] < -span or imp[-1] > t_end + span):
        return f"sidecar field 'impacts' has a time outside [0, {t_end:g}] s ({min(imp)!r}, {max(imp)!r})"
    if any(b < a for a, b in zip(imp, imp[1:])):
        return "sidecar field 'impacts' is not in time order"
    if meta["rows"] < 2 or not all(isinstance(c, str) for c in meta["columns"]):
        return f"sidecar fields 'rows' ({meta['rows']}) or 'columns' are not those of a history"
    if len(meta["t_span"]) != 2 or not all(_finite(t) for t in meta["t_span"]):
        return f"sidecar field 't_span' {meta['t_span']!r:.60} is not two finite times"
    for k in ("accuracy", "agreement", "counters"):
        if k in meta and not isinstance(meta[k], dict):
            return f"sidecar field {k!r} is not a mapping"
    acc = meta.get("accuracy") or {}
    if "trust_t" in acc or "trust_impacts" in acc:
        tt, ti = acc.get("trust_t"), acc.get("trust_impacts")
        if not _finite(tt) or not 0 <= tt <= t_end + span:
            return f"accuracy.trust_t {tt!r:.40} is not a time in [0, {t_end:g}] s"
        if isinstance(ti, bool) or not isinstance(ti, int) or not 0 <= ti <= len(imp):
            return f"accuracy.trust_impacts {ti!r:.40} is not a count from 0 to {len(imp)} (the impacts)"
    if "wall_s" in meta and not _finite(meta["wall_s"]):
        return f"sidecar field 'wall_s' {meta['wall_s']!r:.40} is not a finite number"
    return ""


def _plausible_bytes(meta: dict[str, Any]) -> int:
    """The largest size the history file can have for the sidecar's rows and columns (its
    values uncompressed, twice over, plus a megabyte of Parquet metadata)."""
    return 16 * max(1, int(meta["rows"])) * max(1, len(meta["columns"])) + (1 << 20)


def validate(scene: Scene, path: Path) -> Reference:
    """Read and check a cached reference; :class:`ReferenceDamaged` says what is wrong.

    The sidecar is read safely (its size first; deep or huge JSON is damage, not a crash),
    its seal checked (:func:`seal`: any edited field is damage), its fields' types and
    ranges checked, the history's size checked against its rows and columns with ``stat``
    before it is hashed, then its checksum, columns, span, kind, contact-law revision and
    model probe."""
    side = path.with_suffix(".json")

    def damaged(why: str) -> ReferenceDamaged:
        return ReferenceDamaged(f"the cached reference {path} is damaged ({why}); recompute it with {fix_command(scene)}")

    for f, what in ((path, "the history"), (side, "the sidecar")):
        if not f.is_file():
            raise damaged(f"{what} {f.name} is {'a folder' if f.is_dir() else 'not a regular file'}")
    try:
        meta = read_json(side, "the sidecar", MAX_SIDECAR_BYTES)
    except DamagedFile as exc:
        raise damaged(f"sidecar unreadable: {exc}") from None
    if not isinstance(meta, dict):
        raise damaged("sidecar is not a JSON object")
    if not isinstance(meta.get(SEAL_KEY), str):
        raise damaged("the sidecar carries no checksum of its own fields (written by an older daebench?)")
    if hashlib.sha256(_canonical(meta)).hexdigest() != meta[SEAL_KEY]:
        raise damaged("checksum mismatch: a field of the sidecar changed after it was written")
    need = ("sha256", "rows", "columns", "t_span", "settings", "scene_hash", "impacts")
    missing = [k for k in need if k not in meta]
    if missing:
        raise damaged(f"sidecar lacks {', '.join(missing)} (written by an older daebench?)")
    wrong = _check_fields(meta, scene.t_end)
    if wrong:
        raise damaged(wrong)
    if meta["scene_hash"] != scene.hash:
        raise damaged(f"sidecar is for scene hash {meta['scene_hash']}, not {scene.hash}")
    try:
        size = os.stat(path).st_size
    except OSError as exc:
        raise damaged(f"the history cannot be read: {exc.strerror or exc}") from None
    if size > _plausible_bytes(meta):
        raise damaged(f"the history is {size} bytes, more than {meta['rows']} rows × {len(meta['columns'])} "
                      f"columns can take ({_plausible_bytes(meta)} bytes); it was not read")
    if sha256(path) != meta["sha256"]:
        raise damaged("checksum mismatch: the parquet file changed after it was written")
    try:
        hist = pd.read_parquet(path)
    except Exception as exc:  # pyarrow raises several types for a corrupt file
        raise damaged(f"parquet unreadable: {type(exc).__name__}") from None
    if list(hist.columns) != list(meta["columns"]) or len(hist) != int(meta["rows"]):
        raise damaged(f"{len(hist)} rows × {len(hist.columns)} columns, the sidecar says "
                      f"{meta['rows']} × {len(meta['columns'])}")
    if len(hist) < 2 or "t" not in hist:
        raise damaged("fewer than two output times")
    t0, t1 = float(hist["t"].iloc[0]), float(hist["t"].iloc[-1])
    if abs(t0) > 1e-12 or abs(t1 - scene.t_end) > 1e-9 * max(1.0, scene.t_end):
        raise damaged(f"time span [{t0:g}, {t1:g}] s does not cover the scene's [0, {scene.t_end:g}] s")
    want, why = capturing.reference_kind(scene)
    if meta.get("kind", "ida") != want:
        raise damaged(f"it is a '{meta.get('kind', 'ida')}' reference, this scene needs a '{want}' one"
                      + (f" ({why})" if why else ""))
    key = "h" if want == "capturing" else "rtol"
    try:
        tol = float(meta["settings"][key])
    except (KeyError, TypeError, ValueError, OverflowError):
        raise damaged(f"sidecar settings lack {key}") from None
    if not 0 < tol < 1:
        raise damaged(f"{key} {tol!r} in the sidecar")
    rev, system = meta.get("contact_law_revision", 1), build_system(scene)
    if rev != contact_law_revision(system):
        raise damaged(f"computed under the driver's contact law revision {rev!r}, today's is "
                      f"{contact_law_revision(system)} (its impacts and releases were decided otherwise)")
    probe = meta.get("model_probe")
    diff = [] if probe is None else modelprobe.differences(probe, modelprobe.probe(system)) \
        if isinstance(probe, dict) else ["the model probe is not a mapping"]
    if diff:
        raise damaged(f"computed with another model '{scene.model}' than today's: {'; '.join(diff[:3])}"
                      + (" …" if len(diff) > 3 else ""))
    return Reference(hist, [float(t) for t in meta["impacts"]], meta, path)
