"""Reference solutions: IDA far tighter than anything scored, checked against an
independent looser run, cached by scene hash — and never trusted blindly.

A reference is two files, ``results/references/<scene>-<hash>.parquet`` (the history)
and ``.json`` (the sidecar: settings, impact times, agreement with the check run,
provenance, and what makes the pair verifiable: the SHA-256 of the parquet file, its row
count, columns and time span). Both are written atomically (temporary file, then
``os.replace``), the parquet first, so a reader sees either the old pair, or a new
parquet whose checksum does not match the old sidecar — which :func:`load_reference`
reports as damaged. Every read checks the sidecar, the checksum, the columns, the time
span against the scene's ``t_end``, the scene hash and the kind of reference the scene
needs (IDA, or a fine event-capturing run for friction and complementarity contacts:
:mod:`daebench.harness.references.capturing`), and the model probe (the model's physics at a few
states, recorded in the sidecar: :mod:`daebench.harness.references.modelprobe`); a damaged reference is
recomputed (``compute`` and ``auto`` modes) or refused with the command that fixes it
(``require``). A scene without a cached reference gets the one the package ships, if any,
after the same checks (:mod:`daebench.harness.references.shipped`).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shlex
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene, cases_dir
from daebench.driver.contact_state import CONTACT_LAW_REVISION
from daebench.driver.simulate import simulate
from daebench.harness.files import DamagedFile, atomic_write, read_json, results_dir, write_error
from daebench.harness.references import accuracy, capturing, modelprobe, packed, side_runs
from daebench.harness.running import provenance
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.integrators.registry import get_integrator
from daebench.harness.scoring import metrics
from daebench.harness.scoring.pipeline import declared
from daebench.integrators.odeint import IndexOneODE
from daebench.models import build_system

REF_RTOL = 1e-11        # default reference tolerances (IDA)
REF_ATOL = 1e-13
REF_MARGIN = 100.0      # the reference is at least this much tighter than any scored rtol
CHECK_FACTOR = 10.0     # the independent check runs this much looser
REF_INTEGRATOR = "ida"
#: a reference stores its history at the scene's output.dt / this: runs are scored at their
#: own output times against the reference interpolated there (metrics.dense), so its rows
#: must resolve what the runs' rows alias (beam-impact: an 11 131 rad/s tone, period
#: 0.56 ms, sampled every 1 ms by a run; at 50 µs the Hermite interpolation of θ with ω
#: errs by ≈ 3e-4 of the tone's amplitude)
REF_OVERSAMPLE = 20
MODES = ("auto", "require", "compute", "none")
#: references shipped inside the package (:mod:`daebench.harness.references.shipped`)
SHIPPED_DIR = Path(__file__).resolve().parents[2] / "data" / "references"


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


def _fix(scene: Scene) -> str:
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
        return ReferenceDamaged(f"the cached reference {path} is damaged ({why}); recompute it with {_fix(scene)}")

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
    rev = meta.get("contact_law_revision", 1)
    if rev != CONTACT_LAW_REVISION:
        raise damaged(f"computed under the driver's contact law revision {rev!r}, today's is {CONTACT_LAW_REVISION} "
                      f"(its impacts and releases were decided otherwise)")
    probe = meta.get("model_probe")
    diff = [] if probe is None else modelprobe.differences(probe, modelprobe.probe(build_system(scene))) \
        if isinstance(probe, dict) else ["the model probe is not a mapping"]
    if diff:
        raise damaged(f"computed with another model '{scene.model}' than today's: {'; '.join(diff[:3])}"
                      + (" …" if len(diff) > 3 else ""))
    return Reference(hist, [float(t) for t in meta["impacts"]], meta, path)


def shipped_path(scene: Scene) -> Path:
    """Where the package keeps a shipped reference of ``scene`` (it may not exist)."""
    return SHIPPED_DIR / reference_path(scene).name


def install_shipped(scene: Scene) -> Path | None:
    """Copy the reference the package ships for ``scene`` into the cache after every check
    of :func:`validate` (a model probe required); None when it ships none for this scene
    hash (:mod:`daebench.harness.references.shipped`).

    Raises
    ------
    ReferenceDamaged
        It fails a check (damaged; stale: another model).
    """
    src = shipped_path(scene)
    if not (src.is_file() and src.with_suffix(".json").is_file()):
        return None
    try:
        ref = validate(scene, src)
        if not isinstance(ref.meta.get("model_probe"), dict):
            raise ReferenceDamaged("it has no model probe")
    except ReferenceDamaged as exc:
        raise ReferenceDamaged(f"the reference shipped for '{scene.name}' is refused: {exc}") from None
    dest = reference_path(scene)
    kept = "nothing was cached; the shipped reference stays where it is"
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, "the reference folder", dest.parent, kept) from None
    hist, meta = ref.history, {k: v for k, v in ref.meta.items() if k not in (packed.DERIVED_KEY, packed.ORDER_KEY)}
    if ref.meta.get(packed.DERIVED_KEY):   # shipped thin: the columns the states determine rebuilt, to the bit
        try:
            hist = packed.rebuild(build_system(scene), hist, ref.meta[packed.DERIVED_KEY], ref.meta[packed.ORDER_KEY])
        except (ValueError, KeyError, TypeError) as exc:
            raise ReferenceDamaged(f"the reference shipped for '{scene.name}' is refused: {exc}") from None
    atomic_write(dest, lambda p: write_history(p, hist), "the reference", kept)
    meta.update({"installed_from": f"shipped with daebench ({src.name})", "sha256": sha256(dest),
                 "columns": list(hist.columns)})
    atomic_write(dest.with_suffix(".json"), lambda p: write_sidecar(p, meta), "the reference's sidecar", kept)
    return dest


def load_reference(scene: Scene, compute: bool = False, mode: str | None = None, **kwargs: Any) -> Reference:
    """The cached reference of ``scene``, checked.

    Parameters
    ----------
    scene : the scene (its hash names the file)
    compute : compute it when missing or damaged (same as ``mode='compute'``)
    mode : 'require' (missing or damaged: an error with the fix), 'compute' or 'auto'
        (missing: :class:`ReferenceMissing`; damaged: recomputed). Default: 'compute'
        if ``compute`` else 'require'.
    kwargs : go to :func:`compute_reference`

    Raises
    ------
    ReferenceMissing, ReferenceDamaged
    """
    mode = mode or ("compute" if compute else "require")
    path = reference_path(scene)
    if not (path.exists() and path.with_suffix(".json").exists()):
        try:
            if install_shipped(scene) is not None:
                return _meets(scene, validate(scene, path), mode, kwargs)
        except ReferenceDamaged:
            if mode not in ("compute", "auto"):
                raise
            return compute_reference(scene, **kwargs)
        if mode == "compute":
            return compute_reference(scene, **kwargs)
        raise ReferenceMissing(
            f"no reference for scene '{scene.name}' (hash {scene.hash}) at {path}. "
            f"Make it with `{reference_command(scene)}` "
            f"(or pass --reference compute / --reference none to `daebench bench`).")
    try:
        ref = validate(scene, path)
    except ReferenceDamaged:
        if mode in ("compute", "auto"):
            return compute_reference(scene, **kwargs)
        raise
    return _meets(scene, ref, mode, kwargs)


def _meets(scene: Scene, ref: Reference, mode: str, kwargs: dict[str, Any]) -> Reference:
    """``ref`` when it is at least as tight as an explicitly requested ``rtol``; otherwise
    recomputed at that rtol (modes 'compute', 'auto') or refused with the reason."""
    assessed = list((ref.meta.get("scene_values") or {}).get("output.observables") or [])
    scored = list(scene["output.observables"])
    if assessed and not (scored and set(scored) <= set(assessed)):
        # its accuracy record (trust_t) covers only the observables its scene named
        if mode in ("compute", "auto"):
            return compute_reference(scene, **kwargs)
        raise ReferenceDamaged(f"the cached reference {ref.path} assessed its accuracy on {', '.join(assessed)} only, "
                               f"this scene scores {', '.join(scored) or 'every observable'}; recompute it with "
                               f"{_fix(scene)}")
    want = kwargs.get("rtol")
    if want is None or ref.kind != "ida" or not ref.rtol > float(want) * (1 + 1e-9):
        return ref
    if mode in ("compute", "auto"):
        return compute_reference(scene, **kwargs)
    raise ReferenceDamaged(f"the cached reference {ref.path} was computed at rtol {ref.rtol:g}, looser than the "
                           f"requested {float(want):g}; recompute it with {_fix(scene)} --rtol {float(want):g}")


def _ida_setting(name: str) -> Any:
    """The reference solver's declared setting ``name``: its range is the one bound of a
    reference's tolerance (a value outside it is refused, never raised silently)."""
    return next(s for s in get_integrator(REF_INTEGRATOR).settings_spec if s.name == name)


def reference_tolerances(tightest_rtol: float | None = None, rtol: float | None = None,
                         atol: float | None = None) -> tuple[float, float]:
    """rtol/atol of a reference: the given ones, checked against the reference solver's
    declared ranges (:class:`ParamError` outside them); else the defaults, tightened to
    REF_MARGIN below the tightest scored rtol but not below the solver's lowest rtol."""
    if rtol is not None:
        r = float(_ida_setting("rtol").validate(rtol, "reference"))
    else:
        r = REF_RTOL if tightest_rtol is None else min(REF_RTOL, float(tightest_rtol) / REF_MARGIN)
        r = max(r, float(_ida_setting("rtol").low))
    a = (REF_ATOL * r / REF_RTOL) if atol is None else float(_ida_setting("atol").validate(atol, "reference"))
    return r, max(a, float(_ida_setting("atol").low))


def compute_reference(scene: Scene, tightest_rtol: float | None = None, rtol: float | None = None,
                      atol: float | None = None, check: bool = True,
                      progress: Callable[[str, float], Any] | None = None,
                      tightest_h: float | None = None, parallel: bool = True) -> Reference:
    """Compute, check and cache the reference of ``scene``, with its accuracy record.

    A scene with friction, with contacts left to an integrator, or whose model asks for it
    gets a fine event-capturing reference instead of IDA's
    (:func:`daebench.harness.references.capturing.reference_kind`): Moreau–Jean at a fixed step
    (at most ``tightest_h`` / STEP_MARGIN), checked by a 2× coarser run and a perturbed
    start, its accuracy record built the same way; ``rtol``/``atol`` do not apply to it.
    Otherwise the reference solver is IDA, or — for a model that declares ``reference_solver``
    (the IVP test-set mechanisms) — that solver on the index-1 ODE with per-component
    absolute tolerances rtol × the model's ``state_scale()``
    (:mod:`daebench.integrators.odeint`). It runs at (rtol, atol) (defaults 1e-11 /
    1e-13, or REF_MARGIN tighter than ``tightest_rtol``); with ``check``, again
    CHECK_FACTOR looser and again at (rtol, atol) from a start perturbed at the round-off
    level of rtol (:mod:`daebench.harness.references.accuracy`): their spread gives the digits per
    observable over time, ``trust_t`` and ``trust_impacts`` (sidecar ``accuracy``). A
    reference by the ODE solver is also checked by IDA CHECK_FACTOR looser (another method
    family; sidecar ``agreement``). All runs write REF_OVERSAMPLE× denser output than the
    scene's. With ``parallel`` the check runs run in forked processes beside the reference
    run (:mod:`daebench.harness.references.side_runs`: same numbers, about the time of the two longer
    runs on two cores). ``progress(label, t_end)`` is a context manager factory whose value
    receives the simulated time of the reference run
    (:class:`daebench.harness.running.progress.RunProgress`).

    Raises
    ------
    RuntimeError
        If the reference run does not complete.
    """
    dense_scene = scene.with_overrides({"output.dt": scene["output.dt"] / REF_OVERSAMPLE})
    system = build_system(scene)
    kind, why = capturing.reference_kind(scene, system)
    if kind == "capturing":
        if rtol is not None or atol is not None:
            raise ParamError(f"scene '{scene.name}' has an event-capturing reference ({why}); IDA's --rtol/--atol "
                             f"do not apply to it: leave them out")
        h = capturing.reference_step(scene, REF_OVERSAMPLE, tightest_h)
        integ, res, acc_meta = capturing.capture_runs(scene, dense_scene, h, check, progress)
        return _store(scene, dense_scene, integ, res, {}, acc_meta, {"kind": kind, "why": why})
    r, a = reference_tolerances(tightest_rtol, rtol, atol)
    solver = getattr(system, "reference_solver", REF_INTEGRATOR)

    def run(rt: float, at: float, label: str | None, method: str = solver, start: Any = None,
            tick: Callable[[float], Any] | None = None) -> tuple[Any, Any]:
        integ = (make_integrator(REF_INTEGRATOR, {"rtol": rt, "atol": at}) if method == REF_INTEGRATOR
                 else IndexOneODE(rtol=rt, atol=at, method=method))
        with progress(label, scene.t_end) if progress is not None and label else nullcontext() as bar:
            cb = bar if tick is None else (lambda t: (tick(t), bar(t) if bar is not None else None))
            if start is None:
                return integ, run_scene(dense_scene, integ, write=False, force=True, progress=cb)[1]
            system = accuracy.with_start(build_system(dense_scene), *start)
            return integ, simulate(system, integ, scene.t_end, dense_scene["output.dt"], progress=cb)

    def side(rt: float, at: float, method: str = solver, start: Any = None) -> Callable[[], side_runs.RunSummary]:
        return lambda: side_runs.RunSummary.of(run(rt, at, None, method, start)[1])

    jobs: dict[str, Callable[[], side_runs.RunSummary]] = {}
    if check:
        # the independent check: IDA CHECK_FACTOR looser (for an ODE reference, also its loose run);
        # the perturbed start; beside the reference run once it has stepped (refside: forked processes)
        jobs["check"] = side(r * CHECK_FACTOR, a * CHECK_FACTOR, REF_INTEGRATOR)
        if solver != REF_INTEGRATOR:
            jobs["loose"] = side(r * accuracy.LOOSE_FACTOR, a * accuracy.LOOSE_FACTOR)
        jobs["perturbed"] = side(r, a, start=accuracy.perturbed_start(build_system(scene), r))
        for d in accuracy.CONDITIONING_PERTURBATIONS:  # the problem's own amplification of a start error
            tol = accuracy.conditioning_tolerance(d, r)
            jobs[f"conditioning {d:g}"] = side(tol, a * tol / r, start=accuracy.perturbed_start(build_system(scene),
                                                                                              d, 1.0))
    with side_runs.SideRuns(jobs, parallel=parallel) as runs:
        integ, res = run(r, a, f"reference of {scene.name}: {solver} rtol {r:g}", tick=runs.start)
        if res.status != "completed":
            raise RuntimeError(f"reference run of '{scene.name}' {res.status}: {res.message}")
        impacts = [float(i.t) for i in res.impacts]
        agreement: dict[str, Any] = {}
        acc_meta: dict[str, Any] = {}
        if check:
            got = runs.results()
            chk = got["check"]
            agreement = {"check": f"{REF_INTEGRATOR} rtol={r * CHECK_FACTOR:g} atol={a * CHECK_FACTOR:g}",
                         "status": chk.status}
            if chk.status == "completed":
                acc = metrics.accuracy(chk.history, res.history, ref_impacts=impacts, declared=declared(scene.model))
                agreement.update({k: v for k, v in acc.items() if k.endswith("_max")})
                agreement.update(metrics.impact_time_errors(chk.impacts, impacts))
            loose, f = (got["loose"], accuracy.LOOSE_FACTOR) if "loose" in got else (chk, CHECK_FACTOR)
            pert = got["perturbed"]
            cols = list(scene["output.observables"]) or metrics.observable_columns(res.history)
            acc_meta = accuracy.assess(res.history, impacts, loose.history, pert.history, cols, scene.t_end,
                                       loose_factor=f)
            acc_meta.update({"loose": loose.status, "perturbed": pert.status,
                             "perturbed_impacts": len(pert.impacts), "loose_impacts": len(loose.impacts)})
            cond = {d: got[f"conditioning {d:g}"] for d in accuracy.CONDITIONING_PERTURBATIONS}
            acc_meta["conditioning"] = accuracy.conditioning(
                res.history, {d: (c.history, len(c.impacts)) for d, c in cond.items() if c.status == "completed"},
                cols)
    return _store(scene, dense_scene, integ, res, agreement, acc_meta, {"kind": "ida"})


def write_history(path: Path, hist: pd.DataFrame) -> None:
    """Write a reference's history as the cache keeps it (zstd, byte-stream-split floats:
    the values bit for bit)."""
    floats = [c for c in hist.columns if hist[c].dtype.kind == "f"]
    hist.to_parquet(path, index=False, compression="zstd", compression_level=9, use_dictionary=False,
                    use_byte_stream_split=floats)


def _store(scene: Scene, dense_scene: Scene, integ: Any, res: Any, agreement: dict[str, Any],
           acc_meta: dict[str, Any], extra: dict[str, Any]) -> Reference:
    """Write the reference's history and sidecar atomically (module docstring), with the
    model probe (:mod:`daebench.harness.references.modelprobe`)."""
    impacts = [float(i.t) for i in res.impacts]
    path = reference_path(scene)
    hist = res.history
    kept = (f"the reference was computed ({res.wall_s:.3g} s) but is not cached; the runs scored against it "
            f"need it cached")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, "the reference folder", path.parent, kept) from None
    for f in (path, path.with_suffix(".json")):
        if f.is_dir():
            raise ReferenceDamaged(f"the cached reference {f} is a folder, not a file; remove it (`rm -r {f}`) "
                                   f"and run {_fix(scene)}")
    atomic_write(path, lambda p: write_history(p, hist), "the reference", kept)
    meta = {"scene": scene.name, "scene_hash": scene.hash, "scene_values": scene.values,
            "integrator": integ.name, "settings": integ.to_config(), "wall_s": res.wall_s,
            "counters": res.counters, "impacts": impacts,
            "impulses": [float(i.impulse) for i in res.impacts],   # the impulse measure's truth
            "output_dt": dense_scene["output.dt"], "agreement": agreement,
            "accuracy": acc_meta, "contact_law_revision": CONTACT_LAW_REVISION,
            "energy_residual_max": res.energy_residual, "model_probe": modelprobe.record(build_system(scene)),
            **extra, "sha256": sha256(path), "rows": len(hist),
            "columns": list(hist.columns), "t_span": [float(hist["t"].iloc[0]), float(hist["t"].iloc[-1])]}
    meta = {**meta, "provenance": provenance.collect([scene])}
    atomic_write(path.with_suffix(".json"), lambda p: write_sidecar(p, meta), "the reference's sidecar", kept)
    return Reference(hist, impacts, meta, path)


def trust_span(scene: Scene) -> tuple[float, int]:
    """(trust_t, trust_impacts) of the cached reference of ``scene`` (module docstring).

    Raises
    ------
    ReferenceMissing, ReferenceDamaged
        No cached reference, or one without an accuracy record (computed by an older
        daebench: recompute it with ``daebench reference NAME --force``).
    """
    return load_reference(scene, mode="require").trust_span
