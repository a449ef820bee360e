"""`daebench run` (one scene with one integrator: a summary, or the run record as JSON) and
`daebench reference` (the cached reference of a scene) (:mod:`daebench.api.runs`)."""

from __future__ import annotations

import sys
import traceback
from typing import Any, Optional

import typer

from daebench.cli import textout
from daebench.cli.common import fail, load_scene_or_exit, out


def register(app: typer.Typer) -> None:
    """Add `daebench run` and `daebench reference` to ``app``."""
    app.command("run")(run)
    app.command("reference")(reference)


def run(scene: str = typer.Argument(..., help="scene name or path to a .toml file"),
        integrator: str = typer.Option("ida", "--integrator", "-i",
                                       help="integrator name (see `daebench list`; settings: `daebench show NAME`)"),
        set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
        opt: list[str] = typer.Option([], "--opt", help="integrator setting: name=value (e.g. h=1e-4)"),
        out_dir: Optional[str] = typer.Option(None, "--out", help="folder for the history file (default results/runs)"),
        as_json: bool = typer.Option(False, "--json", help="print one JSON record (stdout holds nothing else)"),
        run_cap: Optional[float] = typer.Option(None, "--run-cap", help="wall-time cap of the run [s]"),
        force: bool = typer.Option(False, "--force", help="run even beyond the step-count / history-size limits"),
        show_traceback: bool = typer.Option(False, "--traceback",
                                            help="when an exception ends the run, print where it was raised "
                                                 "(the integrator's frames included) on stderr")) -> None:
    """Run a scene with one integrator; write the time history; print a summary."""
    from daebench import api

    sc = load_scene_or_exit(scene, set_)
    try:
        settings = api.parse_pairs(opt, "--opt", "h=1e-4")
        r = api.run(sc, integrator, settings=settings, writing=api.Writing(True, out_dir, run_cap, force),
                    progress=True)
    except api.OutputWriteError as exc:  # the run finished; its file could not be written
        fail(str(exc), 1)
    except api.ParamError as exc:
        fail(str(exc))
    except api.RunTimeout as exc:
        fail(f"{exc}; nothing was written (raise --run-cap, or use a larger step)", 1)
    except KeyboardInterrupt:
        fail("interrupted; nothing was written", 130)
    except Exception as exc:  # a plugin's bug during the run: say so; the traceback on request
        if show_traceback:
            sys.stderr.write(traceback.format_exc())
        fail(f"the run raised {type(exc).__name__}: {exc} (a bug in integrator '{integrator}' or the model?"
             + ("" if show_traceback else " `--traceback` shows where") + ")", 1)
    if show_traceback and r.traceback:
        sys.stderr.write(r.traceback)
    if as_json:
        sys.stdout.write(r.record.to_json() + "\n")
    else:
        for line in textout.kv_lines(run_summary(r)):
            out(line)
    if r.status != "completed":
        raise typer.Exit(1)


def _settings_text(settings: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in settings.items())


def run_summary(r: Any) -> list[tuple[str, str]]:
    """(label, text) lines of a run's summary: what ran, how it ended, what the numbers mean."""
    pairs = [("run", f"{r.scene.name} with integrator {r.integrator}"),
             ("settings", _settings_text(r.settings) or "(none)"),
             ("status", f"{r.status}{' — ' + r.message if r.message else ''} ({r.wall_s:.3g} s wall)")]
    pairs += [("warning", w) for w in getattr(r.record, "warnings", [])]
    declared = r.declared
    obs = r.record.observables
    finals = [("t", "s")] + [(o.name, o.unit) for o in declared.declared if o.summary]
    stopped = r.status != "completed"
    t_kept = obs.get("t")
    for k, unit in finals:
        if k in obs:
            pairs.append(((f"last kept {k}" if stopped else f"final {k}") + (f" [{unit}]" if unit else ""),
                          f"{obs[k]:.10g}"))
    t_final = getattr(r.record, "t_final", None)
    if stopped and t_final is not None and t_kept is not None and t_final != t_kept:
        pairs.append(("stopped at", f"t = {t_final:.10g} s (the history keeps the output rows before it)"))
    pairs.append(("energy balance", f"max |E − E0 − W_nc + D_impacts| = {r.energy_residual:.3e} J "
                  + ("over the rows kept (the residual where the run stopped is in its status)" if stopped
                     else "(bookkeeping error of the run; 0 is exact)")))
    if r.impacts:
        law = getattr(r.record, "impact_law", "")
        pairs.append(("impacts", f"{len(r.impacts)}; first at t = {r.impacts[0]['t']:.12g} s"
                                 + (f"; impact law: {law}" if law else "")))
    c = r.constraint_max
    if any(c.values()):
        pairs.append(("constraints", f"max while closed |C| {c['C']:.2e} m, |Ċ| {c['Cdot']:.2e} m/s, "
                                     f"|C̈| {c['Cddot']:.2e} m/s²"))
    pairs.append(("work", ", ".join(f"{k} {v}" for k, v in r.counters.items())))
    if r.error.get("against"):
        names = [k.removeprefix("err_").removesuffix("_max") for k in r.error
                 if k.startswith("err_") and k.endswith("_max")]
        points = [p for p in declared.positions if p.score_name in names]
        parts = {c for p in points for c in (declared.get(p.x).score_name, declared.get(p.y).score_name)}
        names = [n for n in names if n not in parts]  # a point's coordinates: its one error says it
        errs = [f"{n} {r.error[f'err_{n}_max']:.3e}" for n in names]
        units = _units_text(declared, names)
        pairs.append((f"error vs {r.error['against']} (max over the run{'; ' + units if units else ''})",
                      ", ".join(errs)))
    else:
        pairs.append(("error", f"no exact solution, and {r.error.get('why') or 'no cached reference'}"))
    absent = [o for o in r.scene.get("output.observables") or [] if o not in r.observables.columns]
    if absent:
        pairs.append(("not recorded", f"{', '.join(absent)} (scored observables of the scene that an effect "
                                      f"switched off removes)"))
    if r.history_path:
        pairs.append(("history", r.history_path))
    return pairs


def _units_text(declared: Any, names: list[str]) -> str:
    """'theta in deg, x, y, pos in m': the declared units of the scored names, grouped."""
    by_unit: dict[str, list[str]] = {}
    for n in names:
        d = declared.by_score_name(n)
        if d is not None and d.unit:
            by_unit.setdefault(d.unit, []).append(n)
    return ", ".join(f"{', '.join(ns)} in {u}" for u, ns in by_unit.items())


def reference(scene: str = typer.Argument(..., help="scene name or path to a .toml file"),
              set_: list[str] = typer.Option([], "--set", help="override a scene key: dotted.key=value"),
              rtol: Optional[float] = typer.Option(None, "--rtol", help="IDA rtol (default 1e-11)"),
              atol: Optional[float] = typer.Option(None, "--atol", help="IDA atol (default rtol·1e-2)"),
              force: bool = typer.Option(False, "--force", help="recompute even if cached"),
              ship: bool = typer.Option(False, "--ship", hidden=True,
                                        help="maintainers: copy the reference into the package")) -> None:
    """Compute (or show) the cached reference of a scene: its trusted span, digits and check run."""
    from daebench import api

    sc = load_scene_or_exit(scene, set_)
    try:
        with api.sigterm_as_interrupt():  # SIGTERM ends it as Ctrl-C does: said, not silent
            ref = api.reference(sc, rtol=rtol, atol=atol, force=force, progress=True, ship=ship)
    except KeyboardInterrupt:
        fail("interrupted (Ctrl-C or SIGTERM) before the reference was complete; nothing was cached (a reference "
             "is written only whole): run the command again", 130)
    except api.OutputWriteError as exc:
        fail(str(exc), 1)
    except api.ParamError as exc:
        fail(str(exc))
    except RuntimeError as exc:
        fail(str(exc), 1)
    for line in ref.summary_lines(sc.t_end):
        out(line)
    if ref.shipped is not None:
        out(f"shipped {ref.shipped} ({ref.shipped.stat().st_size / 1e6:.2f} MB)")
