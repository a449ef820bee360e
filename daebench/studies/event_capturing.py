"""Event-capturing against event-driven contact on one case: the comparison page.

* :func:`step_rates` — steps per second of ``moreau``, ``nsgenalpha`` and ``hht`` on
  beam-impact (N modes) measured in one process, interleaved, the minimum of several
  repeats: the per-step cost beside hht's (for ``daebench perf``).
* :func:`compare` — the sweep ``daebench bench beam-impact -i hht,moreau,nsgenalpha
  --steps … --grid projection=false,true`` plus ``-i ida --tols …``, one scored table;
* :func:`work_precision_figures` — one work–precision figure per error measure;
* :func:`capture_histories` and :func:`penetration_energy_figure` — penetration
  max(−g, 0) and total energy E over time, one run per integrator at one step.

Runs go through the harness's run and sweep (:func:`daebench.harness.running.runner.run_scene`,
:func:`daebench.harness.sweeps.sweep.run_sweep`): the same driver, scoring and reference as
every other row.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from daebench.driver.simulate import simulate  # noqa: E402
from daebench.harness.analysis import plots  # noqa: E402
from daebench.harness.running.progress import RunProgress  # noqa: E402
from daebench.harness.running.runner import make_integrator, run_scene  # noqa: E402
from daebench.harness.sweeps import options, sweep  # noqa: E402
from daebench.integrators.registry import get_integrator  # noqa: E402
from daebench.models import build_system  # noqa: E402
from daebench.models.scenes import load_scene  # noqa: E402

#: the line-up: label → (integrator, settings)
LINEUP: dict[str, tuple[str, dict[str, Any]]] = {
    "hht (event-driven)": ("hht", {}),
    "moreau": ("moreau", {}),
    "moreau (projection)": ("moreau", {"projection": True}),
    "nsgenalpha": ("nsgenalpha", {}),
    "ida (event-driven)": ("ida", {}),
}
#: error measures with a work–precision figure (those the table has)
ERROR_MEASURES = ("err_theta_max", "err_tip_max", "err_tip_w2_max", "err_theta_l2", "err_impact1_t",
                  "energy_resid_max")
#: axis labels with units for the measures plots.label_of does not know
MEASURE_LABELS = {"err_theta_max": "max error of θ [deg]", "err_theta_l2": "L2 error of θ [deg]",
                  "err_tip_max": "max error of the tip position [m]",
                  "err_tip_w2_max": "max error of the tip deflection w2(L) [m]",
                  "err_impact1_t": "error of the first impact time [s]",
                  "energy_resid_max": "max |energy-balance residual| [J]"}
STEPS = (4e-4, 2e-4, 1e-4, 5e-5, 2.5e-5)
TOLS = (1e-5, 1e-6, 1e-7, 1e-8)


def tag(restitution: float) -> str:
    """A file-name tag for a restitution with no dot (Path.with_suffix would cut it): e0p3."""
    return f"e{restitution:g}".replace(".", "p")


# -- per-step cost ---------------------------------------------------------------------------------
def step_rates(n_modes: int = 5, h: float = 1e-4, t_end: float = 1.0, restitution: float = 0.0,
               repeats: int = 3) -> pd.DataFrame:
    """Steps per second on beam-impact with ``n_modes`` modes, every integrator at the fixed
    step h (hht also at the paper's protocol, 1e-6 s in contact), measured in this process:
    one warm-up run each (compilation, caches), then ``repeats`` interleaved rounds, the
    minimum wall time kept. Through the driver with output every 1 ms, as ``daebench run``.

    Returns
    -------
    DataFrame: label, integrator, settings, status, steps, wall_s, steps_per_s,
    newton_per_step (Newton iterations per step).
    """
    sc = load_scene("beam-impact", {"discretization.n": int(n_modes), "t_end": float(t_end),
                                    "contact.restitution": float(restitution)})
    lineup = {"hht": ("hht", {"h": h}), "hht (h_contact 1e-6)": ("hht", {"h": h, "h_contact": 1e-6}),
              "moreau": ("moreau", {"h": h}), "moreau (projection)": ("moreau", {"h": h, "projection": True}),
              "nsgenalpha": ("nsgenalpha", {"h": h})}

    def once(name: str, settings: dict[str, Any]):
        system = build_system(sc)
        integ = get_integrator(name)(**settings)
        t0 = time.perf_counter()
        res = simulate(system, integ, sc.t_end, sc["output.dt"])
        return time.perf_counter() - t0, res

    for spec in lineup.values():  # warm-up: compilation, caches
        once(*spec)
    best: dict[str, tuple[float, Any]] = {label: (np.inf, None) for label in lineup}
    for _ in range(max(int(repeats), 1)):
        for label, spec in lineup.items():
            wall, res = once(*spec)
            if wall < best[label][0]:
                best[label] = (wall, res)
    rows = []
    for label, (wall, res) in best.items():
        name, settings = lineup[label]
        steps = int(res.counters["steps"])
        rows.append({"label": label, "integrator": name, "settings": json.dumps(settings), "status": res.status,
                     "steps": steps, "wall_s": wall, "steps_per_s": steps / wall,
                     "newton_per_step": res.counters["newton_iterations"] / max(steps, 1)})
    return pd.DataFrame(rows)


# -- the sweep -------------------------------------------------------------------------------------
def compare(scene: str = "beam-impact", restitution: float = 0.3, steps: Sequence[float] = STEPS,
            tols: Sequence[float] = TOLS, overrides: Mapping[str, Any] | None = None, jobs: int = 1,
            name: str | None = None, reference: str = "compute", repeats: int = 3,
            **bench_kw: Any) -> pd.DataFrame:
    """hht, moreau (with and without projection) and nsgenalpha at fixed steps, ida at
    tolerances, scored against the scene's IDA reference; one table (rows of both sweeps).
    Wall times: the minimum of ``repeats`` runs after a warm-up (short runs are noisy)."""
    ov = {"contact.restitution": float(restitution), **dict(overrides or {})}
    sc = load_scene(scene, ov)
    stem = name or f"{scene}-capture-{tag(restitution)}"
    fixed = sweep.run_sweep(sc, *options.from_keywords(
        ["hht", "moreau", "nsgenalpha"], dict(steps=list(steps), grid={"projection": [False, True]}, jobs=jobs,
                                              name=f"{stem}-fixed", reference=reference, repeats=repeats, **bench_kw)))
    adaptive = sweep.run_sweep(sc, *options.from_keywords(
        ["ida"], dict(tols=list(tols), jobs=jobs, name=f"{stem}-ida", reference=reference, repeats=repeats,
                      **bench_kw)))
    return pd.concat([fixed, adaptive], ignore_index=True)


def work_precision_figures(df: pd.DataFrame, out_dir: str | Path, measures: Sequence[str] = ERROR_MEASURES,
                           x: str = "wall_s", title: str = "") -> list[Path]:
    """One work–precision figure (error against wall time, Pareto front) per error measure
    the table has; written as <out_dir>/wp-<measure>.png/.svg."""
    out = []
    for m in measures:
        if m not in df.columns or not np.isfinite(pd.to_numeric(df[m], errors="coerce")).any():
            continue
        label = MEASURE_LABELS.get(m, plots.label_of(m))
        fig, _ = plots.work_precision(df, x=x, y=m, title=f"{title}: {label}" if title else label)
        fig.axes[0].set_ylabel(label)
        out += plots.save(fig, Path(out_dir) / f"wp-{m}")
    return out


# -- histories: penetration and energy -----------------------------------------------------------
def capture_histories(scene: str = "beam-impact", restitution: float = 0.3, h: float = 1e-4,
                      lineup: Mapping[str, tuple[str, dict[str, Any]]] = LINEUP, rtol: float = 1e-8,
                      overrides: Mapping[str, Any] | None = None, progress: bool = False) -> dict[str, pd.DataFrame]:
    """One run per line-up entry (fixed-step integrators at h, ida at rtol): label → history.
    Labels carry the step or tolerance; ``progress``: a bar per run on stderr."""
    sc = load_scene(scene, {"contact.restitution": float(restitution), **dict(overrides or {})})
    out = {}
    for label, (name, settings) in lineup.items():
        s = dict(settings)
        if name == "ida":
            s.setdefault("rtol", rtol)
            tag = f"{label}, rtol {s['rtol']:g}"
        else:
            s.setdefault("h", h)
            tag = f"{label}, h = {s['h']:g} s"
        integ = make_integrator(name, s)
        bar = RunProgress(f"{sc.name} with {integ.name}", sc.t_end) if progress else None
        if bar is not None:
            bar.start()
        try:
            out[tag] = run_scene(sc, integ, write=False, progress=bar)[1].history
        finally:
            if bar is not None:
                bar.stop()
    return out


def penetration_energy_figure(hists: Mapping[str, pd.DataFrame], stem: str | Path | None = None,
                              title: str = "", window: tuple[float, float] | None = None) -> tuple[Any, list[Path]]:
    """Two axes over time: penetration max(−g, 0) [m] of contact 0 and total energy E [J],
    one line per run (``window``: a time interval to show)."""
    fig, (ax_p, ax_e) = plt.subplots(2, 1, figsize=(8.0, 6.5), sharex=True)
    for label, hist in hists.items():
        t = hist["t"].to_numpy(float)
        sel = np.ones(t.size, bool) if window is None else (t >= window[0]) & (t <= window[1])
        if "gap" in hist.columns:
            ax_p.plot(t[sel], np.maximum(-hist["gap"].to_numpy(float)[sel], 0.0), lw=1.0, label=label)
        ax_e.plot(t[sel], hist["E"].to_numpy(float)[sel], lw=1.0, label=label)
    ax_p.set_ylabel("penetration max(−g, 0) [m]")
    ax_e.set_ylabel("total energy E [J]")
    ax_e.set_xlabel("t [s]")
    for ax in (ax_p, ax_e):
        ax.grid(True, alpha=0.3)
    ax_p.legend(fontsize=7)
    ax_p.set_title(title or "event-capturing vs event-driven: penetration and energy")
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig, (plots.save(fig, stem) if stem is not None else [])


def summary(df: pd.DataFrame, measures: Sequence[str] = ERROR_MEASURES) -> pd.DataFrame:
    """The table's columns that the figures show, one row per run (for printing)."""
    cols = [c for c in ("label", "h", "tol", "status", "steps", "wall_s", *measures) if c in df.columns]
    return df[cols]
