"""Scene files (TOML) → a validated :class:`Scene`.

A scene names a model, its discretization, which physical effects are on, their
parameters, the start state, end time, output times and observables. Every key is
declared (:class:`~daebench.core.params.Param`) by the common schema below or by the
model's ``SCHEMA``; an unknown key is an error that names the closest valid key, a
bad value names the allowed type or range. Command-line overrides
(``--set dotted.key=value``) go through the same validation.

Keys are flat dotted names (``contact.law``); TOML tables are flattened to them.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable

from daebench.core.bounded_file import UnreadableFile, read_bounded
from daebench.core.comparison import TAGS, Comparison
from daebench.core.comparison import parse as parse_comparison
from daebench.core.params import Param, ParamError, did_you_mean, parse_pairs


class SceneError(ParamError):
    """A scene file or override that cannot be used; the message says how to fix it."""


COMMON_SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("name", str, "", "scene name"),
        Param("description", str, "", "one-line description"),
        Param("model", str, "", "model the scene runs"),
        Param("t_end", float, 1.0, "end time", low=1e-9, high=1e5, unit="s"),
        Param("output.dt", float, 1e-3, "spacing of the output times", low=1e-9, high=1e5, unit="s"),
        Param("output.observables", list, [], "observables scored against the reference (empty: all); "
              "the history records every observable"),
        Param("output.format", str, "csv", "history file format", choices=("csv", "parquet")),
    )
}


#: keys that change what is written or scored, not what is computed (left out of :attr:`Scene.hash`)
OUTPUT_ONLY = ("output.format", "output.observables")

#: a scene name is a file-name stem (histories are <name>-<integrator>-<id>.csv): no path
#: separator, no leading '.' or '-', at most NAME_MAX characters (the file system takes
#: 255 bytes per name; the rest is the integrator, the run id and the suffix)
NAME_MAX = 100
NAME_RE = re.compile(rf"[A-Za-z0-9][A-Za-z0-9._-]{{0,{NAME_MAX - 1}}}")
#: the largest scene file read (a scene is a few kB; /dev/zero or a wrong file is refused)
MAX_SCENE_BYTES = 1 << 20


class UnknownScene(SceneError):
    """A case name that is not in cases/ (nor a file)."""


def check_name(name: Any, where: str = "scene key 'name'") -> str:
    """A scene name, refused unless it is a plain file-name stem (see :data:`NAME_RE`).

    Raises
    ------
    SceneError
        For a path separator, '..', an absolute path, a leading '.' or '-', a character
        other than letters, digits, '.', '_' and '-', or more than NAME_MAX characters.
    """
    if not isinstance(name, str):
        raise SceneError(f"{where} must be a string, got {name!r}")
    if NAME_RE.fullmatch(name):
        return name
    if len(name) > NAME_MAX:
        why = f"is {len(name)} characters long, more than {NAME_MAX}"
    elif "/" in name or "\\" in name or name.startswith(".."):
        why = "contains a path ('/', '\\' or '..'): results are written under the output folder only"
    else:
        why = "has a character other than letters, digits, '.', '_' and '-' (or starts with '.' or '-')"
    raise SceneError(f"{where} {name[:60]!r}{'…' if len(name) > 60 else ''} {why}; a scene name is a plain "
                     f"file-name stem, e.g. name = \"my-pendulum\" (it names the history files)")


def read_toml(path: Path) -> dict[str, Any]:
    """A scene file's TOML (a UTF-8 byte-order mark is allowed), refused when it is not a
    regular file or larger than MAX_SCENE_BYTES.

    Raises
    ------
    SceneError
    """
    try:
        data = read_bounded(path, MAX_SCENE_BYTES)
    except UnreadableFile as exc:
        raise SceneError(f"{path}: {exc}; give a .toml scene file") from None
    try:
        return tomllib.loads(data.decode("utf-8").removeprefix("\ufeff"))
    except UnicodeDecodeError:
        raise SceneError(f"{path}: not a text file (a scene is a UTF-8 TOML file)") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise SceneError(f"{path}: nested too deeply to be a scene (a scene's keys are a few levels deep, "
                         f"e.g. [contact] restitution = 0.3)") from None


def cases_dir() -> Path:
    """Where named scenes live: $DAEBENCH_CASES, the installed copy, or the repo's cases/.

    Raises
    ------
    SceneError
        When $DAEBENCH_CASES is set to something that is not a folder.
    """
    env = os.environ.get("DAEBENCH_CASES")
    if env:
        if not Path(env).is_dir():
            raise SceneError(f"DAEBENCH_CASES={env} is not a folder; point it at a folder of scene .toml files "
                             f"(or unset it to use the installed cases)")
        return Path(env)
    here = Path(__file__).resolve().parents[1]  # the daebench package
    for cand in (here / "_cases", here.parent / "cases"):
        if cand.is_dir():
            return cand
    raise SceneError("cannot find the cases/ folder; set DAEBENCH_CASES to it")


def scene_names() -> list[str]:
    """The names of the scene files in :func:`cases_dir` (their stems; no file is read)."""
    return [p.stem for p in sorted(cases_dir().glob("*.toml"))]


def tagged(tag: str) -> list[str]:
    """The names of the scene files whose ``[compare]`` tags hold ``tag`` (the survey's sets:
    :data:`daebench.core.comparison.TAGS`), read from the files' tables alone.

    Raises
    ------
    SceneError
        For a scene file whose ``[compare]`` table cannot be read (it names the file).
    """
    if tag not in TAGS:
        raise SceneError(f"unknown case tag '{tag}'{did_you_mean(tag, TAGS)} (tags: {', '.join(TAGS)})")
    return [p.stem for p in sorted(cases_dir().glob("*.toml"))
            if tag in parse_comparison(read_toml(p).get("compare"), str(p)).tags]


def list_scenes() -> list[tuple[str, str]]:
    """(name, description) of every scene file in :func:`cases_dir`; a file that cannot be
    read has 'cannot be read: …' as its description (it affects only what names it)."""
    out = []
    for p in sorted(cases_dir().glob("*.toml")):
        try:
            desc = str(read_toml(p).get("description", ""))
        except SceneError as exc:
            desc = f"cannot be read: {exc}"
        out.append((p.stem, desc))
    return out


#: the deepest nesting of tables a scene file may have (its keys are two or three levels deep)
MAX_DEPTH = 16


def flatten(d: dict[str, Any], prefix: str = "", depth: int = 0) -> dict[str, Any]:
    """Tables as dotted keys; a key given twice (``"contact.restitution" = 0.3`` and
    ``[contact] restitution = 0.9``) or tables nested beyond MAX_DEPTH are refused.

    Raises
    ------
    SceneError
    """
    if depth > MAX_DEPTH:
        raise SceneError(f"tables nested more than {MAX_DEPTH} deep under '{prefix[:60]}…'; a scene's keys are a "
                         f"few levels deep, e.g. [contact] restitution = 0.3")
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        part = flatten(v, key + ".", depth + 1) if isinstance(v, dict) else {key: v}
        twice = sorted(set(part) & set(out))
        if twice:
            raise SceneError(f"scene key '{twice[0]}' is given twice (as a dotted key and in a table); keep one")
        out.update(part)
    return out


@dataclass
class Scene:
    """A validated scene: every declared key with its value (defaults filled in)."""

    name: str
    model: str
    values: dict[str, Any]
    schema: dict[str, Param] = field(repr=False)
    source: str = ""
    #: the model's cross-key check (``check_scene``), run on every copy with overrides
    check: Callable[["Scene"], None] | None = field(default=None, repr=False, compare=False)
    #: the values as the scene file gave them (before overrides); None when not read from a file
    base: dict[str, Any] | None = field(default=None, repr=False, compare=False)
    #: how the case is compared (its file's ``[compare]`` table): not physics, not in :attr:`hash`
    comparison: Comparison = field(default_factory=Comparison, repr=False, compare=False)

    def __post_init__(self) -> None:
        check_name(self.name)

    def __getitem__(self, key: str) -> Any:
        if key not in self.values:
            raise SceneError(f"scene '{self.name}' has no key '{key}'{did_you_mean(key, self.values)}")
        return self.values[key]

    def get(self, key: str, default: Any = None) -> Any:
        return self.values.get(key, default)

    @property
    def t_end(self) -> float:
        return float(self.values["t_end"])

    @property
    def description(self) -> str:
        return str(self.values.get("description", ""))

    @property
    def hash(self) -> str:
        """Content hash of the resolved physics: name, description and the output-only keys
        (:data:`OUTPUT_ONLY`) excluded, so a history format or a choice of scored observables
        uses the same cached reference; the ``[compare]`` table (:attr:`comparison`) is not a
        value and not in it."""
        body = {k: v for k, v in sorted(self.values.items()) if k not in ("name", "description", *OUTPUT_ONLY)}
        return hashlib.sha256(json.dumps(body, sort_keys=True, default=str).encode()).hexdigest()[:16]

    def with_overrides(self, overrides: Iterable[str] | dict[str, Any]) -> "Scene":
        """A copy with ``key=value`` overrides applied and validated.

        Strings are parsed as command-line text; other values (from Python) must have
        the key's type. ``model`` cannot be overridden: a scene's keys belong to its model.
        """
        if isinstance(overrides, (str, bytes)) or not isinstance(overrides, (dict, Iterable)):
            raise SceneError(f"scene overrides must be {{key: value}} or a list of \"key=value\" strings, "
                             f"e.g. {{\"t_end\": 0.5}}; got {overrides!r}")
        pairs = parse_overrides(overrides) if not isinstance(overrides, dict) else dict(overrides)
        values = dict(self.values)
        for key, raw in pairs.items():
            if key == "model" and raw != self.model:
                raise SceneError(
                    f"scene key 'model' cannot be overridden (scene '{self.name}' is a '{self.model}' scene and "
                    f"its keys belong to that model); pick a scene of the other model instead "
                    f"(`daebench list` shows the cases)")
            values[key] = validate_key(key, raw, self.schema, "--set")
        if "name" in pairs:
            check_name(values["name"], "--set name")
        return Scene(values.get("name") or self.name, self.model, values, self.schema, self.source, self.check,
                     self.base, self.comparison).checked()

    def revalidated(self) -> "Scene":
        """This scene after every value is checked again by its declared parameter, with the
        name and the model's cross-key checks: a ``Scene`` whose ``values`` or ``name`` were
        changed in place after loading (``scene.values["t_end"] = -1``) is refused here with
        the :class:`SceneError` an override would get, not with an error deep in a run.

        Raises
        ------
        SceneError
        """
        check_name(self.name)
        unknown = [k for k in self.values if k not in self.schema]
        if unknown:
            raise SceneError(f"unknown scene key '{unknown[0]}' in scene '{self.name}'"
                             f"{did_you_mean(unknown[0], self.schema)}")
        for key, value in self.values.items():
            if validate_key(key, value, self.schema, "scene value") != value:
                raise SceneError(f"scene key '{key}' holds {value!r}, which is not a value of its type "
                                 f"({self.schema[key].type.__name__})")
        return self.checked()

    def checked(self) -> "Scene":
        """Run the model's cross-key checks (e.g. a contact law needs effects.contact)."""
        if self.check is not None:
            self.check(self)
        return self

    def changes(self) -> dict[str, Any]:
        """The values that differ from the scene file's (the ``--set`` overrides in effect;
        empty for a scene not read from a file)."""
        if self.base is None:
            return {}
        return {k: v for k, v in self.values.items() if self.base.get(k) != v}

    def idle_keys(self) -> dict[str, list[str]]:
        """{effect: keys} of the keys set away from their default under an effect that is off
        (``effects.contact = false`` with ``contact.restitution = 0.3``): they change nothing,
        which the command line says in a note."""
        off = [k.split(".", 1)[1] for k, v in self.values.items() if k.startswith("effects.") and v is False]
        out: dict[str, list[str]] = {}
        changed = self.changes()
        for k, v in self.values.items():
            head = k.split(".", 1)[0]
            if head in off and "." in k and k in self.schema and (v != self.schema[k].default or k in changed):
                out.setdefault(head, []).append(k)
        return out

    def effects(self) -> dict[str, bool]:
        return {k.split(".", 1)[1]: bool(v) for k, v in self.values.items() if k.startswith("effects.")}


def parse_overrides(items: Iterable[str]) -> dict[str, str]:
    items = list(items)
    if not all(isinstance(i, str) for i in items):
        raise SceneError(f"scene overrides must be \"key=value\" strings, e.g. [\"t_end=0.5\"]; got {items!r}")
    try:
        return parse_pairs(items, "--set", "contact.restitution=0.3")
    except ParamError as exc:
        raise SceneError(str(exc)) from None


def validate_key(key: str, raw: Any, schema: dict[str, Param], where: str, strict: bool = False) -> Any:
    """One key's value, validated by its declared :class:`Param` (``strict``: typed source)."""
    if not isinstance(key, str) or key not in schema:
        raise SceneError(
            f"unknown scene key '{key}' ({where}){did_you_mean(key, schema)} "
            f"Valid keys are listed by `daebench show SCENE --keys`."
        )
    try:
        return schema[key].validate(raw, "scene key", strict=strict)
    except ParamError as exc:
        raise SceneError(str(exc)) from None


def resolve_path(name_or_path: str | os.PathLike) -> Path:
    """The scene file of a case name (case-insensitive) or a path to a .toml file."""
    if not isinstance(name_or_path, (str, os.PathLike)) or not str(name_or_path).strip():
        raise SceneError(f"a scene is a case name (e.g. \"pendulum\", see `daebench list`), a path to a .toml "
                         f"file or a Scene; got {name_or_path!r}")
    p = Path(name_or_path)
    if p.is_dir():
        raise SceneError(f"'{p}' is a folder, not a scene file; give a case name (`daebench list`) "
                         f"or a path to a .toml file")
    if p.suffix == ".toml" or p.exists():
        if not p.exists():
            raise SceneError(f"scene file '{p}' does not exist")
        return p
    names = scene_names()
    match = [n for n in names if n.lower() == p.name.lower()]
    if match:
        return cases_dir() / f"{match[0]}.toml"
    raise UnknownScene(
        f"unknown scene '{name_or_path}'{did_you_mean(str(name_or_path).lower(), names)} "
        f"Known scenes: {', '.join(names)} (see `daebench list`)."
    )
