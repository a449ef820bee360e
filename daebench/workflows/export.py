"""`daebench export CASE`: everything another code needs to set a case up and to hand its
trajectory back to `daebench score` — as JSON (:func:`case_sheet`) and as a short Markdown
sheet (:func:`markdown`), the page the documentation shows for each case.

What it holds, all read from the scene and the model (nothing here knows a model):

* every resolved scene key with its value, unit, meaning and allowed range (``parameters``;
  the values exactly: a scene file written from them with every key explicit is the same
  scene, hash included);
* the effects that are on;
* the initial state as the scene gives it (the ``start.*`` keys, physical quantities) and in
  the model's coordinates q0, v0 with their names, and the model's own description (its
  module docstring: equations, coordinates, conventions);
* the size (coordinates, bilateral constraints and their residual at the start, contact
  points), the contact law (name, restitution, whether continuous) and the contact keys,
  with the gaps at the start;
* the observables: name, unit, label (its meaning), the column of its time derivative, its
  role (a height, scored around impacts, scored at all) and its value at the start, which
  another code's set-up must reproduce; the positions scored as one point;
* the energy terms at the start; t_end, output.dt, the number of output times and their rule;
* what the case is scored against (the exact solution, or a reference) and the command that
  scores a file.

Written (atomically) to results/export/<case>-<hash8>/<case>.json and .md, or to ``out``.
"""

from __future__ import annotations

import inspect
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from daebench import __version__
from daebench.core.scene import Scene
from daebench.harness.files import atomic_write, ensure_writable_dir, results_dir
from daebench.harness.scoring import pipeline
from daebench.models import build_system, get_model
from daebench.models.scenes import load_scene

#: the keys every scene has, which are no physics (shown apart in the sheet)
META_KEYS = ("name", "description", "model")


def _plain(v: Any) -> Any:
    """A value as JSON takes it: numpy numbers as Python ones, a non-finite float as text
    ('inf', '-inf', 'nan': TOML reads them back)."""
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        f = float(v)
        return f if math.isfinite(f) else str(f)
    if isinstance(v, np.bool_):
        return bool(v)
    return v


def _floats(a: Any) -> list[Any]:
    return [_plain(x) for x in np.asarray(a, float).ravel()]


def has_exact_solution(system: Any, t_end: float) -> bool:
    """Whether the model gives an exact solution for this scene (scored against it)."""
    fn = getattr(system, "exact_observables", None)
    if fn is None:
        return False
    try:
        fn(np.array([0.0, t_end]))
    except ValueError:
        return False
    return True


def output_times_rule(t_end: float, dt: float) -> tuple[int, str]:
    """(number of output times, their rule in words)."""
    n = int(round(t_end / dt))
    if abs(n * dt - t_end) < 1e-9 * t_end:
        return n + 1, f"t_k = k·t_end/{n}, k = 0 … {n} (output.dt = {dt!r} s divides t_end)"
    m = int(math.ceil(t_end / dt - 1e-12))
    return m + 1, f"t_k = k·{dt!r} s for t_k < t_end, then t_end itself"


def case_sheet(scene: Scene) -> dict[str, Any]:
    """The case as another code needs it (module docstring), JSON-ready."""
    system = build_system(scene)
    module = get_model(scene.model)
    declared = pipeline.declared(scene.model)
    q0, v0 = (np.asarray(x, float) for x in system.initial_state())
    obs0 = system.observables(0.0, q0, v0)
    scored = list(scene.get("output.observables") or [])
    params = []
    for key, value in scene.values.items():
        p = scene.schema.get(key)
        params.append({"key": key, "value": _plain(value), "unit": getattr(p, "unit", ""),
                       "meaning": getattr(p, "doc", ""), "range": p.describe() if p is not None else ""})
    start = [r for r in params if r["key"].startswith("start.")]
    names = list(getattr(system, "coordinate_names", ()) or [f"q{i}" for i in range(q0.size)])
    coords = [{"name": n, "q0": _plain(q), "v0": _plain(v)} for n, q, v in zip(names, q0, v0)]
    contact: dict[str, Any] = {"points": int(system.n_contacts)}
    law = getattr(system, "contact_law", None)
    if system.n_contacts:
        contact.update(law=getattr(law, "name", "") if law is not None else "",
                       continuous=bool(getattr(law, "continuous", False)) if law is not None else False,
                       restitution=_plain(getattr(system, "contact_restitution", math.nan)),
                       gaps_at_start=_floats(system.gap(q0)))
    contact["keys"] = [r for r in params if r["key"].startswith("contact.")]
    observables = []
    for name, value in obs0.items():
        d = declared.get(name)
        role = [w for w, on in (("scored", name in scored), ("height above the contact surface", d.height),
                                ("scored before the first impact and per window after each", d.impact_windows))
                if on]
        observables.append({"name": name, "unit": d.unit, "meaning": d.label or name,
                            "derivative": ({"column": d.derivative, "factor": _plain(d.derivative_factor)}
                                           if d.derivative else None),
                            "role": role, "at_start": _plain(value)})
    positions = [{"name": p.name, "x": p.x, "y": p.y, "unit": p.unit, "meaning": p.label or p.name}
                 for p in declared.positions]
    n_out, rule = output_times_rule(scene.t_end, float(scene["output.dt"]))
    exact = has_exact_solution(system, scene.t_end)
    bil = int(system.n_bilateral)
    return {
        "case": scene.name, "description": description(scene), "model": scene.model, "scene_hash": scene.hash,
        "changed": {k: {"value": _plain(v), "case_file": _plain(scene.base.get(k))} for k, v in scene.changes().items()
                    if k != "description"},
        "daebench": __version__,
        "model_description": inspect.cleandoc(module.__doc__ or getattr(module, "DESCRIPTION", "")),
        "parameters": params,
        "effects": scene.effects(),
        "initial_state": {"physical": start, "coordinates": coords},
        "size": {"coordinates": int(q0.size), "bilateral_constraints": bil, "contact_points": int(system.n_contacts),
                 "constraint_residual_at_start": _floats(system.constraint(0.0, q0)) if bil else []},
        "contact": contact,
        "observables": observables, "positions": positions,
        "energy_at_start": {f"E_{k}": _plain(v) for k, v in system.energy(q0, v0).items()},
        "time": {"t_end": _plain(scene.t_end), "output_dt": _plain(scene["output.dt"]), "output_times": n_out,
                 "rule": rule},
        "scoring": {"truth": "the exact solution" if exact else
                    "a reference (IDA at rtol 1e-11, or a fine event-capturing run), over its trusted span",
                    "columns": ["t", *obs0], "scored": scored,
                    "command": f"daebench score {scene.name} FILE.csv"
                               + (" [--impacts IMPACTS.csv]" if system.n_contacts else "") + " [--json]"},
    }


def description(scene: Scene) -> str:
    """The scene's description, followed — when ``--set`` changed values the description may
    quote — by the values used: 'restitution 0.8 …' exported with contact.restitution = 0.5
    says so, so that the sheet never states a value the case does not use."""
    changed = {k: v for k, v in scene.changes().items() if k != "description"}
    if not changed:
        return scene.description
    used = "; ".join(f"{k} = {_md_value(_plain(v))} (the case file: {_md_value(_plain(scene.base.get(k)))})"
                     for k, v in changed.items())
    return f"{scene.description} — exported with {used}"


def _md_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    text = ", ".join(map(str, v)) if isinstance(v, list) else repr(v) if isinstance(v, float) else str(v)
    return text.replace("|", "\\|") or "—"


def _table(head: list[str], rows: list[list[Any]]) -> list[str]:
    if not rows:
        return ["(none)"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(_md_value(x) for x in r) + " |" for r in rows]
    return out


def markdown(sheet: dict[str, Any]) -> str:
    """The case sheet as a short Markdown page."""
    s = sheet
    first = s["model_description"].split("\n\n", 1)[0].replace("\n", " ")
    L = [f"# {s['case']}", "", s["description"], "",
         f"Model `{s['model']}` — {first}", "",
         f"Scene hash `{s['scene_hash']}` (daebench {s['daebench']}). The full description of the model (its "
         f"equations and coordinates) is `model_description` in the JSON export.", "",
         "## Parameters", ""]
    L += _table(["key", "value", "unit", "meaning"],
                [[r["key"], r["value"], r["unit"], r["meaning"]] for r in s["parameters"] if r["key"] not in META_KEYS])
    L += ["", "## Initial state", "", "As the scene gives it:", ""]
    L += _table(["key", "value", "unit", "meaning"], [[r["key"], r["value"], r["unit"], r["meaning"]]
                                                       for r in s["initial_state"]["physical"]])
    L += ["", "In the model's coordinates:", ""]
    L += _table(["coordinate", "q0", "v0"], [[c["name"], c["q0"], c["v0"]] for c in s["initial_state"]["coordinates"]])
    z = s["size"]
    L += ["", f"{z['coordinates']} coordinate(s), {z['bilateral_constraints']} bilateral constraint(s), "
              f"{z['contact_points']} contact point(s).", ""]
    c = s["contact"]
    if c["points"]:
        L += ["## Contact", "", f"Law `{c['law']}`" + (" (continuous force law)" if c["continuous"] else
                                                     " (impact law: Newton restitution, complementarity)")
              + f", restitution {c['restitution']!r}; gaps at the start: {_md_value(c['gaps_at_start'])} m.", ""]
        L += _table(["key", "value", "unit", "meaning"], [[r["key"], r["value"], r["unit"], r["meaning"]]
                                                           for r in c["keys"]])
        L += [""]
    L += ["## Observables", "", "Write these columns (with `t` in s) for `daebench score`; the value at the start "
                                "checks another code's set-up.", ""]
    rows = []
    for o in s["observables"]:
        der = f"{o['derivative']['factor']:.6g} × {o['derivative']['column']}" if o["derivative"] else ""
        rows.append([o["name"], o["unit"], o["meaning"], der, "; ".join(o["role"]), o["at_start"]])
    L += _table(["column", "unit", "meaning", "d/dt", "role", "at t = 0"], rows)
    if s["positions"]:
        L += ["", "Points scored as one Euclidean error: " + "; ".join(
            f"{p['name']} = ({p['x']}, {p['y']}) [{p['unit']}] ({p['meaning']})" for p in s["positions"]) + "."]
    tm = s["time"]
    L += ["", "## Time", "", f"t_end = {tm['t_end']!r} s; {tm['output_times']} output times, {tm['rule']}.", "",
          "## Scoring", "", f"Scored against {s['scoring']['truth']}:", "", "```",
          s["scoring"]["command"], "```", ""]
    return "\n".join(L)


@dataclass(frozen=True)
class ExportResult:
    """The sheet and the files written (JSON, Markdown)."""

    sheet: dict[str, Any]
    files: tuple[Path, ...]

    def as_json(self) -> str:
        return json.dumps(self.sheet, indent=2, ensure_ascii=False)


def export_case(scene: Scene, out: str | Path | None = None, write: bool = True) -> ExportResult:
    """The case sheet of ``scene``, written as <case>.json and <case>.md to ``out`` (default
    results/export/<case>-<hash8>)."""
    sheet = case_sheet(scene)
    if not write:
        return ExportResult(sheet, ())
    folder = ensure_writable_dir(out if out is not None else default_folder(scene), "export folder (--out)")
    text = {".json": json.dumps(sheet, indent=2, ensure_ascii=False) + "\n", ".md": markdown(sheet)}
    files = []
    for suffix, body in text.items():
        path = folder / f"{scene.name}{suffix}"
        atomic_write(path, lambda p, b=body: Path(p).write_text(b, encoding="utf-8"), "the case sheet")
        files.append(path)
    return ExportResult(sheet, tuple(files))


def default_folder(scene: Scene) -> Path:
    """results/export/<scene>-<first 8 digits of its hash>"""
    return results_dir() / "export" / f"{scene.name}-{scene.hash[:8]}"


def file_table(names: Sequence[str]) -> str:
    """What a file must hold for each case of ``names`` (the documentation's table, one row a
    case): the scored columns with their units, the other observables a file may give, the
    contact points and their law, how impacts are written, and the truth."""

    out = ["| case | scored columns [unit] | other observables | contact points | impacts | truth |",
           "|---|---|---|---|---|---|"]
    for name in names:
        scene = load_scene(name)
        sheet = case_sheet(scene)
        obs = {o["name"]: o for o in sheet["observables"]}
        scored = sheet["scoring"]["scored"]
        c = sheet["contact"]
        law = f" ({c['law'] or 'resolved by the integrator'})" if c["points"] else ""
        how = ("—" if not c["points"] else "none: a continuous force law" if c.get("continuous")
               else "two rows per impact, or an impacts file")
        out.append(f"| {name} | " + ", ".join(f"`{k}`" + (f" [{obs[k]['unit']}]" if obs[k]['unit'] else "") for k in scored if k in obs)
                   + f" | {', '.join(f'`{k}`' for k in obs if k not in scored) or '—'} | {c['points']}{law} | {how} | "
                   + ("exact solution" if sheet["scoring"]["truth"] == "the exact solution" else "reference") + " |")
    return "\n".join(out)
