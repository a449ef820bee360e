"""The runs behind the interactive-mode reproduction's tables: ``daebench interactive-mode
rodwall|slider|rodplate|cost|figure [--out OUT_DIR]`` (default results/flexcontact). Each
part writes a JSON of rows (and the slider part an .npz of histories for the figure); all
runs go through :func:`daebench.studies.interactive_mode_contact.measures.run` (the
harness's run path)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from daebench.harness.running import provenance
from daebench.harness.running.progress import SweepProgress
from daebench.models import build_system
from daebench.studies.interactive_mode_contact import measures as fc

SLIDER_RUNS = [("ACM", "hht", dict(h=1e-6, h_contact=1e-7, alpha=-0.05), {}),
               ("IMM", "imm", dict(h=1e-7), {}),
               ("IMM", "imm", dict(h=2e-8), {}),
               ("IMM", "imm", dict(h=1e-7, global_method="hht", alpha=-0.05), {}),
               ("PFM", "central", dict(h=2e-8), {"contact.penalty_stiffness": 1e6}),
               ("PFM", "central", dict(h=2e-8), {"contact.penalty_stiffness": 1e7}),
               ("PFM", "central", dict(h=2e-8), {"contact.penalty_stiffness": 1e8})]
ROD_PLATE_RUNS = [("ACM", "hht", dict(h=1e-6, h_contact=1e-7, alpha=-0.05), {}),
                  ("PFM", "central", dict(h=5e-8), {"contact.penalty_stiffness": 1e8}),
                  ("PFM", "central", dict(h=2e-8), {"contact.penalty_stiffness": 1e9}),
                  ("PFM", "central", dict(h=1e-8), {"contact.penalty_stiffness": 1e10}),
                  ("IMM", "imm", dict(h=1e-8), {})]


#: mass redistribution (rod.contact_mass = redistributed) under the constraint law, at two steps per mesh
REDISTRIBUTED = {"rod.contact_mass": "redistributed"}


def _rod_wall_runs(N: int) -> list[tuple]:
    h = min(1e-7, 1e-5 / N)
    return [(N, "ACM", "ACM", dict(h=1e-6, h_contact=min(1e-7, 2e-5 / N), alpha=0.0), {}),
            (N, "ACM+MR", "ACM", dict(h=h, alpha=0.0), REDISTRIBUTED),
            (N, "ACM+MR", "ACM", dict(h=h / 4, alpha=0.0), REDISTRIBUTED),
            (N, "IMM", "IMM", dict(h=h), {}), (N, "PFM", "PFM", dict(h=h), {"contact.penalty_stiffness": 1e10})]


ROD_WALL_RUNS = [run for N in (10, 50, 200) for run in _rod_wall_runs(N)]
COST_RUNS = [(N, tr, name, opts) for N in (10, 50, 200, 800)
             for tr, name, opts in (("IMM", "imm", dict(h=1e-8)), ("PFM", "central", dict(h=1e-8)),
                                    ("ACM", "hht", dict(h=1e-7, h_contact=1e-8, alpha=-0.05)))
             if not (tr == "ACM" and N > 200)]


def _each(part: str, runs: list[tuple], label: Callable[[tuple], str]) -> Iterator[tuple]:
    """The runs of a part, one after another, with progress on stderr (each takes seconds)."""
    with SweepProgress(f"interactive-mode {part}", len(runs)) as progress:
        for run in runs:
            progress.running([label(run)])
            yield run
            progress.update({"label": label(run), "status": "done"})


def rod_wall(out: Path) -> list[dict]:
    rows = []
    for N, label, tr, opts, ov in _each("rodwall", ROD_WALL_RUNS, lambda r: f"N={r[0]} {r[1]} h={r[3]['h']:g}"):
        c0 = time.process_time()
        rec, res, integ, timer, sc = fc.run("rod-wall", tr, {"rod.elements": N, "output.dt": 5e-7, **ov}, **opts)
        rows.append(dict(N=N, treatment=label, settings=opts, status=res.status, cpu_s=time.process_time() - c0,
                         contact_cpu_s=timer.contact_s, steps=res.counters["steps"],
                         energy_residual=res.energy_residual, C_max=res.constraint_max.get("C"),
                         **fc.rod_wall_scores(res, sc)))
        _dump(out / "rod-wall.json", rows)
    return rows


def slider(out: Path) -> list[dict]:
    rows, hist, scenes = [], {}, []
    for k, (tr, name, opts, ov) in enumerate(_each("slider", SLIDER_RUNS, lambda r: f"{r[1]} h={r[2]['h']:g}")):
        c0 = time.process_time()
        rec, res, integ, timer, sc = fc.run("slider-slot", tr, {"output.dt": 1e-6, **ov}, integrator=name, **opts)
        h = res.history
        scenes.append(sc)
        imps = fc.impact_events(res, build_system(sc), join=20e-6)
        rows.append(dict(run=k, treatment=tr, integrator=name, settings=opts, overrides=ov, status=res.status,
                         cpu_s=time.process_time() - c0, integ_cpu_s=timer.total_s, contact_cpu_s=timer.contact_s,
                         contact_steps=timer.contact_steps, E0=float(h.E.iloc[0]), E_end=float(h.E.iloc[-1]),
                         stats=getattr(integ, "stats", {}),
                         impacts=[dict(t0=i.t_start, t1=i.t_end, wall="upper" if i.surface == 0 else "lower",
                                       x_body=i.x, y_body=i.y) for i in imps]))
        for key, col in (("t", h.t.to_numpy()), ("Px", h.P_x.to_numpy()), ("Py", h.P_y.to_numpy()),
                         ("F", fc.contact_force(h))):
            hist[f"{k}_{key}"] = col
        _dump(out / "slider-slot.json", rows)
        np.savez(out / "slider-slot.npz", **hist)
        # the runs' provenance, for the figure drawn from them later
        (out / "slider-slot.provenance.json").write_text(json.dumps(provenance.collect(scenes), default=str))
    return rows


def rod_plate(out: Path) -> list[dict]:
    rows = []
    for tr, name, opts, ov in _each("rodplate", ROD_PLATE_RUNS, lambda r: f"{r[1]} h={r[2]['h']:g}"):
        c0 = time.process_time()
        rec, res, integ, timer, sc = fc.run("rod-plate", tr, {"t_end": 4e-4, "output.dt": 1e-6, **ov},
                                            integrator=name, **opts)
        t0, t1 = fc.contact_window(res)
        h = res.history
        rows.append(dict(treatment=tr, integrator=name, settings=opts, overrides=ov, status=res.status,
                         cpu_s=time.process_time() - c0, duration=t1 - t0, E_ratio=float(h.E.iloc[-1] / h.E.iloc[0])))
        _dump(out / "rod-plate.json", rows)
    return rows


def cost(out: Path) -> list[dict]:
    rows = []
    for N, tr, name, opts in _each("cost", COST_RUNS, lambda r: f"N={r[0]} {r[1]}"):
        rec, res, integ, timer, sc = fc.run("rod-wall", tr, {"rod.elements": N, "output.dt": 1e-4, "t_end": 1e-4,
                                                             "contact.penalty_stiffness": 1e10},
                                            integrator=name, **opts)
        rows.append(dict(N=N, n=2 * (N + 1) * 2, treatment=tr, steps=res.counters["steps"],
                         us_per_step=1e6 * timer.total_s / res.counters["steps"]))
        _dump(out / "cost.json", rows)
    return rows


def figure(out: Path, dest: Path | None = None) -> None:
    """The slider figure from the slider part's rows in ``out``, written to ``dest`` (default
    ``out``/slider-slot.png: under the chosen output folder, like every output; the curated
    copy is results/curated/slider-slot.png)."""
    import matplotlib  # lazy: matplotlib (heavy) only when the figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # lazy: as above

    rows = json.loads((out / "slider-slot.json").read_text())
    H = np.load(out / "slider-slot.npz")
    fig, ax = plt.subplots(2, 1, figsize=(7.5, 6.2))
    for k in (0, 2, 6):
        r, s = rows[k], rows[k]["settings"]
        lab = (f"{r['treatment']} ({r['integrator']}, h={s['h']:g} s"
               + (f", h_contact={s['h_contact']:g} s" if "h_contact" in s else "")
               + (f", εN={r['overrides']['contact.penalty_stiffness']:g} N/m" if r["overrides"] else "") + ")"
               + ("" if r["status"] == "completed"
                  else f" — {r['status']}: E {r['E0']:.4g} → {r['E_end']:.4g} J"))
        ax[0].plot(1e3 * H[f"{k}_Px"], 1e3 * H[f"{k}_Py"], lw=1, label=lab)
        ax[1].plot(1e3 * H[f"{k}_t"], H[f"{k}_F"], lw=0.8, label=lab)
    for y in (3.5, -3.5):
        ax[0].axhline(y, color="k", lw=2)
    ax[0].set_xlabel("head tip P: x [mm]")
    ax[0].set_ylabel("head tip P: y [mm]")
    ax[0].set_title("slider-slot: trajectory of the slider's end point P (walls at y = ±3.5 mm)", fontsize=9)
    ax[1].set_xlabel("t [ms]")
    ax[1].set_ylabel("total contact force [N]")
    ax[0].legend(fontsize=7, loc="lower right")
    ax[1].legend(fontsize=7)
    fig.tight_layout(rect=(0, 0.02, 1, 1))   # room for the provenance footer
    prov = json.loads((out / "slider-slot.provenance.json").read_text())
    provenance.write_figure(fig, dest if dest is not None else out / "slider-slot.png", prov=prov, dpi=120)
    plt.close(fig)


def _dump(path: Path, rows: list[dict]) -> None:
    path.write_text(json.dumps(rows, indent=1, default=float))


#: the parts, by the name `daebench interactive-mode PART` takes
PARTS = {"rodwall": rod_wall, "slider": slider, "rodplate": rod_plate, "cost": cost, "figure": figure}


def run_part(part: str, out: Path) -> None:
    """One part of :data:`PARTS`, its files written under ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    PARTS[part](out)
