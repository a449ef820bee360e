"""Reproduce the beam-impact study (HHT-α vs Baumgarte for a contact-constraint DAE, Acta
Physica Sinica 2017): Table 1 beside the published seconds,
and one figure plus one computed verdict per claim 1–7.

The runs are ordinary sweep rows (:func:`daebench.harness.sweeps.row.execute`), so they are scored
and never lost; their histories are kept under ``<out>/runs/`` for the figures. Each
verdict is a sentence with the number it rests on, computed from this run's data —
"supported", "not supported" or "not testable here" (e.g. N = 9 is not in --quick), or
supported by the parts that could be tested, naming how many could not
(:mod:`daebench.studies.hht_beam_impact.claims`).
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from daebench.core.params import ParamError
from daebench.core.scene import Scene
from daebench.harness.files import ensure_writable_dir, results_dir
from daebench.harness.running import provenance
from daebench.harness.running.history_io import read_history
from daebench.harness.sweeps import sweep
from daebench.harness.sweeps.options import Execution, Storage, SweepOptions, Timing
from daebench.harness.sweeps.plan import RunSpec
from daebench.models.scenes import load_scene
from daebench.studies.hht_beam_impact import claims, cost
from daebench.studies.hht_beam_impact.table import (BAUMGARTE, BASE_OBSERVABLES, HHT_ALPHAS, PUBLISHED_TABLE1,  # noqa: F401
                                           QUICK_RUN_CAP, SCENE, observables, table1)

#: the seven claims, in the paper's order
CLAIMS = (*claims.CLAIMS, cost.claim7)

@dataclass(frozen=True)
class Protocol:
    """The grid and step protocol of one reproduction.

    Two variants: ``published`` — beam-impact (J_h = 0) at the paper's
    h = 1e-4 s, where Baumgarte + ABM4 diverges for N ≥ 5 so claims resting on it cannot
    be judged; ``calibrated`` — beam-impact-hub (J_h = 0.03 kg m²) at h = 2.5e-5 s, the
    step at which this model shows the published pattern (Baumgarte completes N = 3, 5, 7
    and diverges at N = 9; the reasoning and the numbers are in cases/beam-impact-hub.toml).
    """

    Ns: tuple[int, ...] = (3, 5, 7, 9)
    n_main: int = 5                 # N of the e = 0.3 and Hertz comparisons (claims 1–3)
    n_modal: int = 7                # N of the modal and constraint-residual claims (5, 6)
    t_end: float = 1.0
    h: float = 1e-4
    h_contact: float = 1e-6
    e_table: float = 0.0            # restitution of the Table 1 runs
    e_rebound: float = 0.3
    #: claim 7's FE beam sizes (elements; n = 2·elements + 1 unknowns) and the two horizons,
    #: in steps, whose difference gives the CPU time per step without the set-up
    size_elements: tuple[int, ...] = (50, 100, 150, 250, 350, 500)
    size_steps: tuple[int, int] = (100, 400)
    scene: str = SCENE
    name: str = "published"

    @classmethod
    def full(cls) -> "Protocol":
        return cls()

    @classmethod
    def calibrated(cls) -> "Protocol":
        return cls(scene="beam-impact-hub", h=2.5e-5, name="calibrated")

    @classmethod
    def quick(cls) -> "Protocol":
        # no FE sizes: their first runs compile the FE kernels (~70 s CPU), which --quick exists to avoid
        return cls(Ns=(3,), n_main=3, n_modal=3, t_end=0.5, h_contact=1e-5, size_elements=(), name="quick")

    def setting(self) -> str:
        """The setting every verdict of this protocol rests on, in words."""
        return (f"{self.scene}, fixed h = {self.h:g} s ({self.h_contact:g} s in contact), t_end = {self.t_end:g} s")


VARIANTS = {"published": Protocol.full, "calibrated": Protocol.calibrated}


def setting_name(integrator: str, opts: dict[str, Any]) -> str:
    """Column name of Table 1 for a run's settings."""
    if integrator == "hht":
        a = opts["alpha"]
        return {0.0: "HHT α=0", -0.15: "HHT α=-0.15"}.get(a, "HHT α=-1/3" if abs(a + 1 / 3) < 1e-12 else f"HHT α={a:g}")
    if integrator == "baumgarte":
        return f"Baumgarte ({opts['delta']:g},{opts['epsilon']:g})"
    return integrator


def plan(p: Protocol) -> list[RunSpec]:
    """Every run of the reproduction, tagged by purpose in ``varied['set']``."""
    specs: list[RunSpec] = []

    def add(tag: str, integ: str, opts: dict[str, Any], N: int, e: float, law: str = "constraint",
            **scene_keys: Any) -> None:
        over = {"discretization.n": N, "contact.restitution": e, "contact.law": law,
                "output.observables": observables(N), **scene_keys}
        o = {"h": p.h, "h_contact": p.h_contact, **opts}
        varied = {"set": tag, "N": N, "e": e, "law": law, "setting": setting_name(integ, opts)}
        specs.append(RunSpec(len(specs), integ, o, over, varied))

    methods = [("hht", {"alpha": a}) for a in HHT_ALPHAS] + \
              [("baumgarte", {"delta": d, "epsilon": ep}) for d, ep in BAUMGARTE]
    for N in p.Ns:
        for integ, o in methods:
            add("table", integ, o, N, p.e_table)
    for integ, o in methods:
        add("rebound", integ, o, p.n_main, p.e_rebound)
    add("hertz", "newmark", {}, p.n_main, p.e_rebound, "hertz")
    # claim 7 where cost is not overhead: the FE beam (foreshortening off: its tables grow as
    # n³ in memory), N = its elements; Baumgarte's explicit ABM4 once, at the short horizon
    fe = {"discretization.kind": "fem", "effects.foreshortening": False, "output.observables": BASE_OBSERVABLES}
    for el in p.size_elements:
        for k, steps in enumerate(p.size_steps):
            sized = [("hht", {"alpha": -0.15})] + ([("baumgarte", {"delta": 0.0, "epsilon": 0.0})] if k == 0 else [])
            for integ, o in sized:
                add("size", integ, o, el, p.e_table, **fe, t_end=steps * p.h)
    return specs


def base_scene(p: Protocol) -> Scene:
    return load_scene(p.scene, {"t_end": p.t_end, "output.observables": observables(min(p.Ns))})


# ==== running =================================================================
@dataclass
class PaperResult:
    folder: Path
    runs: pd.DataFrame
    table: pd.DataFrame
    table_md: str
    verdicts: list[str]
    figures: list[Path] = field(default_factory=list)


def run_paper(quick: bool = False, jobs: int = 1, out: str | Path | None = None,
              progress: bool = True, run_cap: float | None = None, variant: str = "published") -> PaperResult:
    """Run the study's grid, then write the table, the claim figures and verdicts.

    ``variant`` is a key of :data:`VARIANTS` (ignored with ``quick``); the outputs go to
    ``out`` (default results/paper/<variant>). ``run_cap`` bounds each run's wall time
    (default: QUICK_RUN_CAP with ``quick``, none otherwise); a run over it is a 'failed'
    row, never a hang."""
    if run_cap is None and quick:
        run_cap = QUICK_RUN_CAP
    if not quick and variant not in VARIANTS:
        raise ParamError(f"unknown paper variant '{variant}'; choose one of {', '.join(VARIANTS)}")
    p = Protocol.quick() if quick else VARIANTS[variant]()
    folder = Path(out) if out is not None else results_dir() / "paper" / p.name
    ensure_writable_dir(folder, "output folder (--out)")  # before the runs, not after them
    scene = base_scene(p)
    specs = plan(p)
    options = SweepOptions(reference="auto", timing=Timing(run_cap=run_cap),
                           execution=Execution(jobs=jobs, progress=progress),
                           storage=Storage(write=False, history_dir=folder / "runs"))
    df = sweep.run_specs(specs, scene, options, description="paper")
    return report(df, p, folder, scene, progress=progress)


def report(df: pd.DataFrame, p: Protocol, folder: Path, scene: Scene, progress: bool = False) -> PaperResult:
    """Table, figures and verdicts from the run rows (no running); ``progress``: a line on
    stderr per claim (drawing the seven claims' figures takes ~10 s)."""
    scenes = [(scene.name, h) for h in sorted(set(df["scene_hash"].dropna()))]
    prov = provenance.collect(scenes)
    prov["protocol"] = p.__dict__
    df.to_csv(folder / "runs.csv", index=False)
    table = table1(df)
    md = table1_markdown(table, p) + provenance.markdown_footer(prov)
    table.to_csv(folder / "table1.csv", index=False)
    (folder / "table1.md").write_text(md)
    hists = _load_histories(df)
    verdicts, figs = [], []
    for k, fn in enumerate(CLAIMS, start=1):
        if progress:
            print(f"paper: claim {k} of {len(CLAIMS)}: verdict and figure", file=sys.stderr, flush=True)
        try:
            text, fig = fn(df, hists, p, folder / f"claim{k}", prov)
            figs += fig
        except Exception as exc:  # a claim that cannot be assessed still gets a line
            text = f"not testable here ({type(exc).__name__}: {exc})"
        verdicts.append(f"claim {k}: [{claim_setting(k, p)}] {text}")
    body = (f"# Verdicts ({p.name} variant, computed from this run)\n\n{p.setting()}.\n\n"
            + "\n".join(f"- {v}" for v in verdicts) + "\n")
    body += "\nProtocol: " + json.dumps(p.__dict__) + "\n" + provenance.markdown_footer(prov)
    (folder / "verdicts.md").write_text(body)
    provenance.write_sidecar(folder / "provenance.json", prov)
    return PaperResult(folder, df, table, md, verdicts, figs)


def claim_setting(k: int, p: Protocol) -> str:
    """The runs claim ``k`` is judged on."""
    return {1: f"N = {p.n_main}, e = {p.e_table:g} and {p.e_rebound:g}", 2: f"N = {p.n_main}, e = {p.e_rebound:g}",
            3: f"N = {p.n_main}, e = {p.e_rebound:g}", 4: f"N = {', '.join(map(str, p.Ns))}, e = {p.e_table:g}",
            5: f"N = {p.n_modal}, e = {p.e_table:g}", 6: f"N = {p.n_modal}, e = {p.e_table:g}",
            7: f"N = {', '.join(map(str, p.Ns))}, e = {p.e_table:g}; FE beam of {', '.join(map(str, p.size_elements))} "
               f"elements over {p.size_steps[0]} and {p.size_steps[1]} steps"}[k] + f"; {p.scene}, h = {p.h:g} s"


def _load_histories(df: pd.DataFrame) -> dict[int, pd.DataFrame]:
    out = {}
    for _, r in df.iterrows():
        path = r.get("history")
        if isinstance(path, str) and Path(path).exists():
            out[int(r["run"])] = read_history(path)
    return out


def table1_markdown(t: pd.DataFrame, p: Protocol) -> str:
    cols = list(PUBLISHED_TABLE1.columns)
    lines = ["# Table 1 — wall-clock seconds, measured here / published (2017)\n",
             f"{p.scene}, e = {p.e_table:g}, fixed steps h = {p.h:g} s, h_contact = {p.h_contact:g} s, "
             f"t_end = {p.t_end:g} s. 'published' is the paper's Table 1 (MATLAB-era code, t_end "
             f"not stated there), hard-coded as data.\n",
             "| N | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for N in sorted(set(t["N"])):
        cells = []
        for c in cols:
            m = t[(t["N"] == N) & (t["setting"] == c)]
            meas = m["measured"].iloc[0] if len(m) else "—"
            pub = PUBLISHED_TABLE1.loc[N, c] if N in PUBLISHED_TABLE1.index else math.nan
            cells.append(f"{meas} / {pub:g} published" if pub == pub else meas)
        lines.append(f"| {N} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


