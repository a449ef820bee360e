"""`daebench compare CASE`: every applicable integrator at the case's protocol, each run
scored against the reference, one table and one work-precision figure.

**Where a protocol is declared.** In the case's scene file (its ``[compare]`` table:
methods, steps, contact step, tolerances, measures, targets, tags), or by an integrator
for the case; :mod:`daebench.workflows.protocol` reads both (:func:`protocol_for`). The
table's heading says what was run (:func:`heading`).

**Applicable.** An integrator the scene's contact law and constraints allow
(:func:`daebench.harness.running.checks.check_applicable`, the driver's own rule, checked before anything
runs). An integrator that refuses the model only in its own start (e.g. ``imm`` outside
the planar FE models) comes back as a run that stopped at t = 0 without a step; it is
listed as not applicable too, with its message.

**Scored.** Every row is an ordinary sweep row (:func:`daebench.harness.sweeps.row.execute`): the
verdict, the timing rule of :data:`daebench.harness.running.timing.REPEATS`, the whole-run errors, the
impact-aware measures of :mod:`daebench.harness.scoring.impact_metrics`, energy and constraint residuals.
The reference is the cached one, computed first (with a progress bar) when missing, and
checked against a shipped fingerprint (:mod:`daebench.harness.references.fingerprints`) where one exists.

**Other codes beside daebench's runs.** Trajectories from other codes (``include``:
:class:`daebench.workflows.score.Source`) are read and checked before anything runs, checked
for unit errors against the truth before the first run, and scored after the runs by the
same pipeline against the same truth (:func:`daebench.workflows.score.external_row`). Their
rows join the table with ``integrator`` = ``external``, are marked ``[external]`` in the
printed table, the figure and the report, stand on the work–precision figure when their
metadata give a cost, and take no part in the recommendation or the determinism check.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene
from daebench.harness.analysis import evidence, plots, recommend
from daebench.harness.files import ensure_writable_dir, jsonable, results_dir, write_error
from daebench.harness.references import fingerprints
from daebench.harness.references.reference import ReferenceMissing, load_reference
from daebench.harness.running import checks, provenance, timing
from daebench.harness.running.progress import run_progress_factory
from daebench.harness.scoring import glossary, pipeline
from daebench.harness.sweeps import digest, sweep
from daebench.harness.sweeps.options import Execution, SweepOptions
from daebench.harness.sweeps.sweep import HARNESS_FAILURES
from daebench.harness.sweeps.plan import RunSpec, plan_sweep
from daebench.integrators import registry as integrator_registry
from daebench.workflows import converge
from daebench.workflows import score as external
from daebench.workflows.protocol import Entry, Protocol, declared_entries, default_protocol, protocol_for

__all__ = ["Entry", "Protocol", "declared_entries", "default_protocol", "protocol_for", "run_compare"]


@dataclass
class CompareResult:
    """The scored table, the integrators not applicable (name → why), written files, the
    protocol (measures resolved), the headline observable's declaration, the folder, and
    the determinism check: a line per run whose history digest differs from the previous
    comparison in the same folder."""

    table: pd.DataFrame
    not_applicable: dict[str, str]
    files: list[Path]
    protocol: Protocol
    reference: Any = None
    headline: Any = None
    folder: Path | None = None
    changed: list[str] = field(default_factory=list)
    page: Path | None = None          # the HTML page, when one was written
    recommendations: list[dict[str, Any]] = field(default_factory=list)   # one record per target
    convergence: dict[str, Any] = field(default_factory=dict)             # budget, stopping rule, runs added
    paragraphs: dict[str, str] = field(default_factory=dict)              # the same in words, per case
    model: str | None = None                                              # the case's model (labels, units)

    @property
    def external(self) -> pd.DataFrame:
        """The rows scored from other codes' files."""
        return self.table[external.is_external(self.table)]

    @property
    def failures(self) -> pd.DataFrame:
        """The rows of runs that gave no verdict (error, timeout, crashed)."""
        return self.table[self.table["status"].isin(HARNESS_FAILURES)] if len(self.table) else self.table

    @property
    def ok(self) -> bool:
        """Every run gave a verdict and every history equals its previous one (the exit rule)."""
        return not len(self.failures) and not self.changed

    def table_rows(self) -> tuple[list[str], list[list[Any]]]:
        """The printed table (:func:`table_rows`)."""
        return table_rows(self.table, self.protocol.measures, self.model)

    def recommendation_rows(self) -> tuple[list[str], list[list[Any]]]:
        """The recommendation as a small table (:func:`daebench.harness.analysis.recommend.table_rows`)."""
        return recommend.table_rows(self.recommendations, self.model)

    def heading(self, case: str) -> str:
        """What was run, in words (:func:`heading`)."""
        return heading(self, case)

    def summary_lines(self) -> list[str]:
        """What the table does not say (:func:`summary_lines`)."""
        return summary_lines(self)

    def as_json(self) -> str:
        """The table as JSON records (for --json)."""
        return as_json(self)


def plan(scene: Scene, protocol: Protocol) -> tuple[list[RunSpec], dict[str, str]]:
    """The runs of the protocol that apply to ``scene``, numbered in order, and the
    integrators refused before running (name → the refusal)."""
    specs: list[RunSpec] = []
    refused: dict[str, str] = {}
    for e in protocol.entries:
        try:
            cls = integrator_registry.get_integrator(e.integrator)
            checks.check_applicable(scene, cls)
            part = plan_sweep(scene, [cls.name], steps=list(e.steps) or None, tols=list(e.tols) or None,
                              options=dict(e.options))
        except ParamError as exc:
            refused[e.integrator] = str(exc)
            continue
        for s in part:
            s.index = len(specs)
            specs.append(s)
    return specs, refused


def _refused_at_start(row: pd.Series) -> bool:
    """The integrator refused the model before its first step (the row's ``refused``, from
    :attr:`daebench.driver.simulate.RunResult.refused`); any other failure stays a row."""
    return bool(row.get("refused") == True)  # noqa: E712  a missing or NaN flag is no refusal


#: what `daebench compare` runs with unless told otherwise: two workers, the reference
#: computed when missing (with a progress bar)
DEFAULT_OPTIONS = SweepOptions(reference="compute", execution=Execution(jobs=2))


def run_compare(scene: Scene, options: SweepOptions = DEFAULT_OPTIONS, out: str | Path | None = None,
                protocol: Protocol | None = None, include: Sequence[external.Source] = (),
                budget_s: float = 0.0) -> CompareResult:
    """Run the protocol of ``scene``, score every run, write the table and the figure, and
    compare each run's history digest with the previous comparison in the same folder.

    Parameters
    ----------
    scene : the case (overrides applied)
    options : ``reference`` 'compute' (compute the reference when missing, with a progress
        bar), 'require' (refuse without one) or 'auto'; ``execution`` (worker processes,
        progress bars) and ``timing`` (its ``run_cap``: wall-time cap of one run [s])
    out : output folder (default results/compare/<scene>-<hash>)
    protocol : instead of the case's own
    include : trajectories of other codes, scored beside the runs (module docstring)
    budget_s : wall time [s] for extending the series until each target is decided
        (:mod:`daebench.workflows.converge`); 0: the protocol's runs only

    Raises
    ------
    ParamError
        Before any run: no applicable integrator, a missing reference under 'require', a
        cached reference that disagrees with the shipped fingerprint, an included file that
        is refused (:class:`daebench.harness.scoring.external.ExternalDataError`).
    OutputWriteError
        The runs finished but the files could not be written; ``.result`` holds the table.
    """
    head = pipeline.headline(scene)
    proto = (protocol or protocol_for(scene)).resolved(head.score_name)
    folder = Path(out) if out is not None else default_folder(scene)
    others = [external.prepare(scene, src, "--include") for src in include]   # refused before the folder is made
    ensure_writable_dir(folder, "compare folder (--out)",  # before any run: /dev/null, too long, read-only
                        longest_name=f".wp-{scene.name}-{proto.measures[0] if proto.measures else 'e'}"
                                     f".svg.{'9' * 7}.tmp")
    previous = digest.previous_table(folder / "table.parquet")   # the last comparison: its digests
    if previous is not None:
        previous = previous[~external.is_external(previous)]
    specs, refused = plan(scene, proto)
    if not specs:
        raise ParamError(f"no integrator applies to scene '{scene.name}': "
                         + "; ".join(f"{k}: {v}" for k, v in refused.items()))
    sweep.prepare_references(specs, scene, options.reference, run_progress_factory(options.execution.progress))
    ref = None
    if options.reference != "none":
        try:
            ref = load_reference(scene, mode="require")
            fingerprints.check(scene, ref)
        except ReferenceMissing:
            ref = None
    truths = [external.truth_for(scene, e, lambda: ref) for e in others]   # a unit error refuses before any run
    scored = options.scored_against("require" if ref is not None else "none")
    t0 = time.perf_counter()
    df = sweep.run_specs(specs, scene, scored, description=f"compare {scene.name}")
    took = time.perf_counter() - t0
    gone = df.apply(_refused_at_start, axis=1) if len(df) else pd.Series([], dtype=bool)
    for _, r in df[gone].iterrows():
        refused.setdefault(r["integrator"], str(r["message"]))
    df = df[~gone].reset_index(drop=True)
    cpu = float(pd.to_numeric(df.get(evidence.COST, pd.Series(dtype=float)), errors="coerce").sum())
    df, prog = converge.compare_extend(df, scene, proto.entries, targets_of(df, proto), scored, budget_s,
                                       len(specs), took / cpu if cpu > 0 else 1.0)
    changed = digest.mismatch_lines(previous, df)   # a run whose history differs from its last time
    if others:
        rows = [external.external_row(scene, e, tr, len(df) + k) for k, (e, tr) in enumerate(zip(others, truths))]
        df = pd.concat([df, pd.DataFrame(rows)], ignore_index=True)
    df = with_orders(df, measures_present(df, proto.measures))
    recs, paras = recommendation(df, proto, scene.model, prog)
    conv = {"budget_s": prog.budget_s, "spent_s": prog.spent_s, "stopping_rule": converge.stopping_rule(prog.budget_s),
            "stopped": prog.stopped, "added": [f"{lab} {x}" for lab, x in prog.added]}
    done = CompareResult(df, refused, [], proto, ref, head, folder, changed, recommendations=recs, paragraphs=paras,
                         model=scene.model, convergence=conv)
    try:
        done.files = write(df, scene, proto, folder, refused, ref, recs, conv)
    except OSError as exc:  # a full disk after the work: the table still reaches the caller
        err = write_error(exc, "the comparison to", folder, "every run finished: the table is printed, "
                          "not saved (run again to save it)")
        err.result = done
        raise err from None
    return done


def with_orders(df: pd.DataFrame, measures: Sequence[str]) -> pd.DataFrame:
    """``df`` with the observed order of each run on the first of ``measures`` and why a
    run is outside the asymptotic regime (:func:`daebench.harness.analysis.evidence.observed_orders`;
    columns ``order`` and ``regime``)."""
    if not measures or not len(df):
        return df
    o = evidence.observed_orders(df, measures[0])
    return df.assign(order=o["order"], regime=o["regime"])


def targets_of(df: pd.DataFrame, proto: Protocol) -> dict[str, tuple[float, ...]]:
    """The targets per measure: the case's, else round decades of daebench's own runs' errors."""
    own = df[~external.is_external(df)]
    ms = measures_present(own, proto.measures)
    return {**recommend.default_targets(own, ms), **{m: t for m, t in proto.targets.items() if m in ms}}


def recommendation(df: pd.DataFrame, proto: Protocol, model: str | None, prog: converge.Progress | None = None
                   ) -> tuple[list[dict[str, Any]], dict[str, str]]:
    """The recommendation records over the protocol's measures (:func:`targets_of`) and the
    paragraph, from daebench's own runs (never an external row); a target without a pick
    says what the extension found (:func:`daebench.workflows.converge.answer_text`)."""
    own = df[~external.is_external(df)]
    ms = measures_present(own, proto.measures)
    if not ms or not len(own):
        return [], {}
    _, recs, paras = recommend.for_table(own, ms, targets_of(df, proto), model_of=lambda case: model)
    out = [r for rs in recs.values() for r in rs]
    if prog is not None:
        for r in out:
            if not r["pick"]:
                why = converge.answer_text(prog.predictions.get((r["measure"], float(r["target"]))), prog.budget_s)
                r["missing"] = f"{why}; {r['missing']}" if r["missing"] else why
    return out, paras


def default_folder(scene: Scene) -> Path:
    """results/compare/<scene>-<first 8 digits of its hash>"""
    return results_dir() / "compare" / f"{scene.name}-{scene.hash[:8]}"


def marked(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with the labels of external rows marked ``[external]`` (figures, pages)."""
    ext = external.is_external(df)
    if not ext.any():
        return df
    out = df.copy()
    out.loc[ext, "label"] = out.loc[ext, "label"].astype(str) + " [external]"
    return out


def measures_present(df: pd.DataFrame, measures: Sequence[str]) -> list[str]:
    """The protocol's measures that at least one row has a finite value for."""
    return [m for m in measures if m in df.columns and pd.to_numeric(df[m], errors="coerce").notna().any()]


def scene_label(scene: Scene) -> str:
    """The scene's name with the values its answers depend on: ``beam-impact (N = 5, e = 0, 1 s)``."""
    return f"{scene.name} ({', '.join(plots.title_values(scene) + [f'{scene.t_end:g} s'])})"


def write(df: pd.DataFrame, scene: Scene, proto: Protocol, folder: Path, refused: Mapping[str, str],
          ref: Any, recs: Sequence[Mapping[str, Any]] = (), convergence: Mapping[str, Any] | None = None
          ) -> list[Path]:
    """table.csv/.parquet, the work-precision figure (one panel per measure, against CPU
    time) and a JSON sidecar (protocol, the recommendation records, not-applicable
    integrators, reference, provenance)."""
    folder.mkdir(parents=True, exist_ok=True)
    prov = provenance.collect([scene])
    files = [folder / "table.csv", folder / "table.parquet"]
    df.to_csv(files[0], index=False)
    df.to_parquet(files[1], index=False)
    ms = measures_present(df, proto.measures)
    if ms:
        title = (f"{scene_label(scene)}: work–precision ({len(df)} runs, reference {ref.describe()})" if ref is not None
                 else f"{scene_label(scene)}: work–precision")
        files += plots.work_precision(marked(df), evidence.COST, ms, "label", folder / f"wp-{scene.name}", prov,
                                      title=title)[1]
    side = folder / "compare.json"
    ext = df[external.is_external(df)]
    provenance.write_sidecar(side, prov, scene=scene.name, scene_hash=scene.hash, why=proto.why,
                             measures=list(proto.measures), not_applicable=dict(refused),
                             recommendations=jsonable([{k: r[k] for k in (*recommend.RECORD, "missing")} for r in recs]),
                             order_measure=ms[0] if ms else None,
                             external=jsonable([{"label": r["label"], "settings": r["settings"], "cost_s": r["wall_s"],
                                                 "steps": r["steps"]} for _, r in ext.iterrows()]),
                             reference=None if ref is None else str(ref.path),
                             convergence=jsonable(dict(convergence or {})),
                             timing={"repeats": timing.REPEATS, "short_run_s": timing.SHORT_RUN_S,
                                     "warmup_cap_s": timing.WARMUP_CAP_S})
    return files + [side]


def _setting(r: pd.Series) -> str:
    h, tol = r.get("h"), r.get("tol")
    if isinstance(tol, float) and math.isfinite(tol):
        return f"tol={tol:g}"
    return f"h={h:g}" if isinstance(h, float) and math.isfinite(h) else ""


def _values(xs: Sequence[Any]) -> str:
    return ", ".join(f"{x:g}" for x in dict.fromkeys(x for x in xs if isinstance(x, float) and math.isfinite(x)))


def heading(res: CompareResult, case: str) -> str:
    """What was run, in words, from the table: each integrator's steps or tolerances as run
    (integrators run alike grouped), whose declaration they are, and how many runs."""
    df = res.table
    if not len(df):
        return f"{case}: no run"
    entries = {e.integrator: e for e in res.protocol.entries}
    groups: list[tuple[str, bool, list[str]]] = []   # (what, declared, integrators)
    for name in dict.fromkeys(df["integrator"]):
        rows = df[df["integrator"] == name]
        e = entries.get(name, Entry(name))
        steps = _values(rows["h"]) if "h" in rows and e.steps else ""
        tols = _values(rows["tol"]) if "tol" in rows and e.tols else ""
        what = f"h = {steps} s" if steps else f"tol = {tols}" if tols else "one run at its defaults"
        if e.options:
            what += " with " + ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}"
                                         for k, v in e.options.items())
        if groups and groups[-1][:2] == (what, e.declared):
            groups[-1][2].append(name)
        else:
            groups.append((what, e.declared, [name]))
    defaults = "one run at its defaults"
    parts = [f"{', '.join(names)}: " + (what.replace(defaults, "one run each at their defaults") if len(names) > 1
                                        else what) for what, _, names in groups]
    given = [g for g in groups if not g[1] and not g[0].startswith(defaults)]
    rest = [g for g in groups if not g[1] and g not in given]
    sources = (["the runs declared for this case"] if any(g[1] for g in groups) else []) \
        + (["runs given to compare"] if given else [])
    if rest:
        sources.append("the others once at their defaults: nothing declared for this case" if sources
                       else "every integrator once at its defaults: no runs declared for this case")
    return f"{case}: {len(df)} runs ({'; '.join(sources)}) — " + "; ".join(parts)


def table_rows(df: pd.DataFrame, measures: Sequence[str], model: str | None = None
               ) -> tuple[list[str], list[list[Any]]]:
    """The printed table: one row per run — integrator, settings (step or tolerance),
    status, steps, CPU time (minimum of the timed repeats), the protocol's ``measures``
    (headers in words and units, :mod:`daebench.harness.scoring.glossary`), the observed
    order on the first measure (``*``: outside the asymptotic regime) and the impacts
    matched / spurious against the truth. Every other column stays in the written table."""
    ms = [m for m in measures if m in df.columns]
    heads = []
    for m in ms:
        d = glossary.describe(m, model)
        words = two_lines(d.short)
        heads.append(f"{words}\n[{d.unit}]" if d.unit else words)
    cols = ["integrator", "settings", "status", "steps", "CPU\n[s]", *heads, "order", "impacts\nok/spur"]
    rows = []
    for _, r in df.iterrows():
        ext = r["integrator"] == external.EXTERNAL
        who = f"{r['label']} [external]" if ext else str(r["integrator"])
        order = r.get("order", math.nan)
        o = f"{order:.2g}" + ("*" if r.get("regime") else "") if isinstance(order, float) and math.isfinite(order) \
            else "-"
        imp = f"{_int(r.get('impacts_matched'))}/{_int(r.get('impacts_spurious'))}"
        rows.append([who, _setting(r) or ("-" if ext else "defaults"), r["status"],   # external: h = t_end/steps
                     _int(r.get("steps")),
                     r.get("cpu_s"), *[r.get(m) for m in ms], o, imp])
    return cols, rows


def two_lines(words: str) -> str:
    """``words`` broken at the space nearest their middle ('θ max\\ntrusted'): a narrow
    column header."""
    spaces = [i for i, ch in enumerate(words) if ch == " "]
    if not spaces:
        return words
    i = min(spaces, key=lambda k: abs(k - len(words) / 2))
    return words[:i] + "\n" + words[i + 1:]


def _int(x: Any) -> Any:
    return int(x) if isinstance(x, (int, float)) and math.isfinite(x) else "-"


def summary_lines(res: CompareResult) -> list[str]:
    """What the table does not say: scoring coverage, integrators not applicable."""
    ext = external.is_external(res.table)
    df = res.table[~ext]
    lines = []
    first = f"err_{res.headline.score_name}_max_trusted" if res.headline is not None else ""
    scored = df[df[first].notna()] if first in df else df.iloc[:0]
    verdicts = df["status"].value_counts().to_dict() if len(df) else {}
    against = ", ".join(f"{n} against the {w}" for w, n in (scored["against"].value_counts().items()
                                                             if "against" in scored else ()))
    lines.append(f"{len(df)} runs: " + ", ".join(f"{v} {k}" for k, v in verdicts.items())
                 + f"; {len(scored)} scored" + (f" ({against})" if against else "")
                 + " (a run that did not complete has no error)")
    for _, r in res.table[ext].iterrows():
        cost = f"cost {r['wall_s']:.4g} s (as its file says)" if math.isfinite(float(r["wall_s"])) else \
            "no cost given: not on the work–precision figure"
        lines.append(f"external: {r['label']} ({json.loads(r['settings']).get('source', '?')}), scored against the "
                     f"{r['against']}; {cost}")
    conv = res.convergence
    if conv:
        added = f"{len(conv['added'])} run(s) added ({', '.join(conv['added'])})" if conv["added"] else "no run added"
        lines.append(f"series extended within a budget of {conv['budget_s']:g} s ({conv['spent_s']:.3g} s spent): "
                     f"{added}; stopped: {conv['stopped']}")
        lines.append(f"stopping rule: {conv['stopping_rule']}")
    for k, v in res.not_applicable.items():
        lines.append(f"not applicable: {k} — {v}")
    return lines


def as_json(res: CompareResult) -> str:
    """The table as JSON records (for --json)."""
    return res.table.to_json(orient="records", default_handler=str)
