"""The studies: the source papers reproduced (`daebench paper`, `daebench averaged-gap`,
`daebench interactive-mode`), event capturing against event-driven contact
(`daebench capture`) and the speed figures (`daebench perf`, `daebench compile-report`)."""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import pandas as pd

from daebench.core.params import Param, ParamError
from daebench.harness.files import (OutputWriteError, atomic_write, describe_os_error, ensure_writable_dir,
                                    results_dir, under_root, write_error)
from daebench.studies import averaged_gap_lcp, event_capturing
from daebench.studies.hht_beam_impact import study as beam_study
from daebench.studies.interactive_mode_contact import runs as interactive_runs
from daebench.studies.perf import compile_census, suite
from daebench.studies.perf.settings import PerfSettings


# ---- the HHT-α beam-impact paper ---------------------------------------------------------------
def hht_beam_impact(variant: str = "both", quick: bool = False, jobs: int = 1, out: str | Path | None = None,
                    run_cap: float | None = None) -> list[tuple[str, beam_study.PaperResult]]:
    """The beam-impact study (HHT-α vs Baumgarte, Acta Physica Sinica 2017): Table 1 beside
    the published seconds, one figure and one computed verdict per claim, for each
    ``variant`` ('published', 'calibrated' or 'both'; ``quick``: the reduced grid for CI).
    Returns (heading, result) per variant, in ``out`` (or ``out``/<variant> for several)."""
    names = ["quick"] if quick else (list(beam_study.VARIANTS) if variant == "both" else [variant])
    if not quick and any(v not in beam_study.VARIANTS for v in names):
        raise ParamError(f"unknown --variant '{variant}'; choose one of {', '.join(beam_study.VARIANTS)} or both")
    done = []
    for name in names:
        folder = None if out is None else (Path(out) if len(names) == 1 else Path(out) / name)
        res = beam_study.run_paper(quick=quick, jobs=jobs, out=folder, run_cap=run_cap, variant=name)
        setting = beam_study.VARIANTS[name]().setting() if name in beam_study.VARIANTS else "quick grid"
        done.append((f"{name} variant: {setting}", res))
    return done


# ---- the time-averaged-gap LCP paper ---------------------------------------------------------------
def numbers(text: str, what: str = "a list value", low: float = 0.0) -> tuple[float, ...]:
    """Comma-separated finite numbers ≥ ``low`` (the package's one number rule).

    Raises
    ------
    ParamError
    """
    vals = [x.strip() for x in text.split(",") if x.strip()]
    if not vals:
        raise ParamError(f"'{text}' is not a comma-separated list of numbers (e.g. 1e-3,1e-2)")
    try:
        return tuple(Param("value", float, low, what, low=low, high=1e5).validate(v, "a") for v in vals)
    except ParamError as exc:
        raise ParamError(f"{exc} (in '{text}')") from None


@dataclass
class StudyTable:
    """A study's table and the files it wrote."""

    table: pd.DataFrame
    files: list[Path] = field(default_factory=list)


def _out(out: str | Path | None, sub: str) -> Path:
    """The study's output folder (``out``, default ``<results>/<sub>``), proved writable
    before any run."""
    return ensure_writable_dir(Path(out) if out is not None else results_dir() / sub, "output folder (--out)")


def averaged_gap_chain(windows: Sequence[float], restitutions: Sequence[float],
                       out: str | Path | None = None) -> StudyTable:
    """The chain example: lcp-avg at several windows beside Hertz–Flores/LN under IDA
    (:func:`daebench.studies.averaged_gap_lcp.chain_table`); chain.csv in ``out`` (default
    results/averaged-gap)."""
    folder = _out(out, "averaged-gap")
    df, _ = averaged_gap_lcp.chain_table(tuple(windows), tuple(restitutions), progress=True)
    return StudyTable(df, [_csv(df, folder / "chain.csv")])


def averaged_gap_pendulum(windows: Sequence[float], hertz: bool = True,
                          out: str | Path | None = None) -> StudyTable:
    """The flexible double pendulum: event-driven IDA, lcp-avg and Hertz; the outcome table
    and the tip gap/force figure (pendulum.csv, double-pendulum.png in ``out``, default
    results/averaged-gap)."""
    folder = _out(out, "averaged-gap")
    df, runs = averaged_gap_lcp.pendulum_table(tuple(windows), hertz=hertz, progress=True)
    files = [_csv(df, folder / "pendulum.csv")]
    fig = folder / "double-pendulum.png"
    atomic_write(fig, lambda p: averaged_gap_lcp.pendulum_figure(runs, str(p), fmt="png"), "the figure",
                 "the table is printed below")
    return StudyTable(df, files + [fig])


def _csv(df: pd.DataFrame, path: Path) -> Path:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, "the study's folder", path.parent, "the table is printed below") from None
    atomic_write(path, lambda p: df.to_csv(p, index=False), "the study's table", "the table is printed below")
    return path


# ---- the interactive-mode paper -------------------------------------------------------------------------
def interactive_mode(part: str, out: str | Path | None = None) -> Path:
    """One part of the interactive-mode reproduction's runs (rodwall, slider, rodplate, cost,
    figure: :data:`daebench.studies.interactive_mode_contact.runs.PARTS`) in ``out`` (default
    results/flexcontact); its folder."""
    if part not in interactive_runs.PARTS:
        raise ParamError(f"unknown part '{part}'; choose one of {', '.join(interactive_runs.PARTS)}")
    folder = _out(out, "flexcontact")
    interactive_runs.run_part(part, folder)
    return folder


# ---- event capturing against event-driven contact ----------------------------------------------------
@dataclass(frozen=True)
class CapturePage:
    """What `daebench capture page` compares: the ``scene`` at ``restitution``, the fixed
    ``steps`` of hht, moreau and nsgenalpha and the ``tols`` of ida, one history run each
    at ``h``, an optional ``t_end``; the sweeps' ``jobs`` and ``repeats``, whether they
    ``resume`` or ``overwrite`` earlier tables."""

    scene: str = "beam-impact"
    restitution: float = 0.3
    steps: tuple[float, ...] = (4e-4, 2e-4, 1e-4, 5e-5, 2.5e-5)
    tols: tuple[float, ...] = (1e-5, 1e-6, 1e-7, 1e-8)
    h: float = 1e-4
    t_end: float | None = None
    jobs: int = 1
    repeats: int = 3
    resume: bool = False
    overwrite: bool = False


def capture_page(page: CapturePage, out: str | Path | None = None) -> tuple[pd.DataFrame, list[Path]]:
    """The comparison page: the sweeps scored against the IDA reference, one work–precision
    figure per error measure, and penetration and energy over time, in ``out`` (default
    results/capture); (summary, files)."""
    folder = Path(out) if out is not None else results_dir() / "capture"
    ensure_writable_dir(folder, "--out folder")
    ov = {} if page.t_end is None else {"t_end": page.t_end}
    df = event_capturing.compare(page.scene, page.restitution, list(page.steps), list(page.tols), overrides=ov,
                                 jobs=page.jobs, repeats=page.repeats, progress=True, resume=page.resume,
                                 overwrite=page.overwrite)
    title = f"{page.scene}, e = {page.restitution:g}"
    tag = event_capturing.tag(page.restitution)
    try:
        files = event_capturing.work_precision_figures(df, folder / tag, title=title)
        hists = event_capturing.capture_histories(page.scene, page.restitution, page.h, overrides=ov, progress=True)
        files += event_capturing.penetration_energy_figure(hists, folder / f"penetration-energy-{tag}", title)[1]
    except OSError as exc:
        raise OutputWriteError(f"cannot write to '{folder}': {describe_os_error(exc)}; the sweep tables are kept in "
                               f"results/bench/ (run again with --resume to redraw without running)") from None
    return event_capturing.summary(df), files


def capture_rates(n_modes: int = 5, h: float = 1e-4, repeats: int = 3) -> pd.DataFrame:
    """Steps per second of moreau, nsgenalpha and hht on beam-impact, measured in one process."""
    return event_capturing.step_rates(n_modes=n_modes, h=h, repeats=repeats)


# ---- speed --------------------------------------------------------------------------------------
def perf(settings: PerfSettings | None = None, out: str | Path | None = None,
         section: str | None = None) -> tuple[str, dict[str, Any] | None]:
    """The speed figures (:mod:`daebench.studies.perf`): all of them (Markdown and the
    result, written to results/perf/perf.json and perf.md), or one ``section`` of
    :data:`daebench.studies.perf.suite.SECTIONS` (its Markdown, no result)."""
    if section is not None:
        return suite.run_section(section, out), None
    res = suite.run_perf(settings or PerfSettings(), out)
    return suite.markdown(res), res


def compile_report(args: Sequence[str], opt: int | None = None, top: int = 20,
                   out: str | Path | None = None) -> tuple[str, Path]:
    """What a cold run of ``daebench ARGS`` compiles (run twice in a fresh process, first
    from an empty kernel cache): the Markdown table and the file it is written to
    (results/perf/compile-<command>-opt<N>-<UTC time>.md; an earlier report is never replaced).

    Raises
    ------
    ParamError
        No command, or compile-report itself.
    RuntimeError
        The command's process ended without a census.
    """
    args = list(args)
    if not args:
        raise ParamError("give the command to measure after `--`, e.g. "
                         "`daebench compile-report -- run beam-impact --integrator hht`")
    if args[0] == "compile-report":
        raise ParamError("compile-report cannot measure itself; give another daebench command after `--`")
    res = compile_census.census(args, opt=None if opt is None else str(opt))
    text = compile_census.markdown(res, top=top)
    folder = Path(out) if out else results_dir() / "perf"
    stamp = time.strftime("%Y%m%dT%H%M%S", time.gmtime())
    words = "-".join(a.strip("-") for a in args if a.strip("-"))
    name = ("compile-" + re.sub(r"[^A-Za-z0-9._-]+", "_", words)[:80] + f"-opt{res.opt[0]}-{stamp}.md")
    path = under_root(folder, name, what="the compile report")  # the command's words never make a path
    folder.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda p: Path(p).write_text(text), "the compile report", "printed above")
    return text, path
