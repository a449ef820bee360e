"""Claim 7 of the beam-impact study — cost grows steeply with N, and at the fixed steps HHT
is slower than Baumgarte — judged on what each run did, not only on how long it took.

At the paper's sizes (n = N + 1 ≤ 10 unknowns) a run's CPU time is mostly call overhead,
so it cannot say how cost grows with size nor which method does more work. Two measures
that can:

- **operation counts** of every Table 1 run (the integrator's counters: residual and
  Jacobian evaluations, LU factorizations, Newton iterations), priced by a stated model of
  dense linear algebra in the n unknowns (:func:`operation_cost`);
- **CPU time per step where it is not overhead**: HHT on the same beam discretized by
  finite elements (``discretization.kind = fem``, n = 2·elements + 1 up to 1 001,
  foreshortening off: its tables grow as n³ in memory), each size run over two horizons:
  their CPU times' difference over their steps' difference excludes the set-up. The
  explicit ABM4 of Baumgarte's method cannot take the paper's step on these meshes (its
  step must stay below ~1/ω_max, which grows as n²); the runs say so.
"""

from __future__ import annotations

import json
import math
from functools import lru_cache
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from daebench.harness.analysis import plots
from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.studies.hht_beam_impact.claims import _num, _verdict
from daebench.studies.hht_beam_impact.figures import fig_cost
from daebench.studies.hht_beam_impact.table import PUBLISHED_TABLE1, table1

#: a growth exponent above this is "steep" (cost growing faster than the size itself)
STEEP = 1.0
#: the FE sizes of the per-step fit start here: from n ≈ 100 on, a step costs far more than
#: the call overhead that dominates the modal beam's (HHT α=−0.15, h = 1e-4 s, CPU time per
#: step from 50 and 150 steps: 3.1e-4 s on the FE beam at n = 101, 9.3e-6 s on the modal
#: beam at N = 9, 4.2e-7 s at N = 3)
MIN_FIT_UNKNOWNS = 100


def operation_cost(n: float, residual_evals: float, jacobian_evals: float, lu_factorizations: float,
                   newton_iterations: float) -> float:
    """Floating-point operations of a run by a dense model in its n unknowns.

    An LU factorization costs (2/3) n³, a pair of triangular solves 2 n² (one per Newton
    iteration, or one per factorization where a method solves without iterating, as the
    ABM4 of Baumgarte's method does for each derivative), a residual evaluation 2 n² (its
    mass-matrix product, a lower bound), a Jacobian evaluation 2 n³ (n residual columns).
    A model, stated so that counts of different methods can be added; it prices the
    algorithm, not an implementation's overhead."""
    solves = max(newton_iterations, lu_factorizations)
    return ((2.0 / 3.0) * n ** 3 * lu_factorizations + 2.0 * n ** 2 * (solves + residual_evals)
            + 2.0 * n ** 3 * jacobian_evals)


def power_fit(n: np.ndarray, cost: np.ndarray) -> tuple[float, float]:
    """k and log c of cost ≈ c n^k, least squares in log–log."""
    k, c0 = np.polyfit(np.log(n), np.log(cost), 1)
    return float(k), float(c0)


def growth(n: np.ndarray, cost: np.ndarray) -> tuple[float, float]:
    """Exponent k of cost ∝ n^k (:func:`power_fit`) and the largest |log residual|."""
    k, c0 = power_fit(n, cost)
    return k, float(np.max(np.abs(np.log(cost) - (k * np.log(n) + c0))))


#: the integrator counters a row carries (:class:`daebench.integrators.base.Counters`)
COUNTS = ("steps", "residual_evals", "jacobian_evals", "lu_factorizations", "newton_iterations")


@lru_cache(maxsize=32)
def _unknowns(scene: str, overrides: str) -> int:
    """A run's number of unknowns, from its model built with the run's scene overrides (JSON)."""
    return int(build_system(load_scene(scene, json.loads(overrides))).n)


def _counted(rows: pd.DataFrame, scene: str) -> pd.DataFrame:
    """The completed rows with their unknowns n and modelled operations per step."""
    out = []
    for _, r in rows[rows["status"] == "completed"].iterrows():
        c = {k: float(pd.to_numeric(r.get(k), errors="coerce")) for k in (*COUNTS, "cpu_s")}
        if not all(math.isfinite(v) for v in c.values()) or c["steps"] <= 0:
            continue
        n = _unknowns(scene, r["overrides"])
        ops = operation_cost(n, c["residual_evals"], c["jacobian_evals"], c["lu_factorizations"],
                             c["newton_iterations"])
        out.append({"N": int(r["N"]), "n": n, "setting": str(r["setting"]), "ops_step": ops / c["steps"],
                    "ops": ops, **c})
    return pd.DataFrame(out, columns=["N", "n", "setting", "ops_step", "ops", *COUNTS, "cpu_s"])


def per_step_cpu(rows: pd.DataFrame, scene: str) -> pd.DataFrame:
    """CPU time, modelled operations and Newton iterations per step of each FE size: (the
    long horizon's − the short's) / (their steps' difference), from completed rows of one
    setting — the set-up, and the one factorization and Jacobian of a run, cancel."""
    out = []
    c = _counted(rows, scene)
    for n, g in c.groupby("n"):
        g = g.sort_values("steps")
        if len(g) < 2 or g["steps"].iloc[-1] <= g["steps"].iloc[0]:
            continue
        a, b = g.iloc[0], g.iloc[-1]
        d = b["steps"] - a["steps"]
        out.append({"n": int(n), "cpu_step": (b["cpu_s"] - a["cpu_s"]) / d, "ops_step": (b["ops"] - a["ops"]) / d,
                    "newton_step": (b["newton_iterations"] - a["newton_iterations"]) / d})
    return pd.DataFrame(out, columns=["n", "cpu_step", "ops_step", "newton_step"])


def claim7(df, hists, p, stem, prov):
    """Cost grows steeply with N; at these fixed steps HHT is slower than Baumgarte (module
    docstring: judged on operation counts at the paper's sizes and on CPU time per step on
    FE meshes where it is not overhead; CPU time at the paper's sizes is reported beside)."""
    scene = p.scene
    figs = fig_cost(table1(df), stem, prov) if stem is not None else []
    table = _counted(df[df["set"] == "table"], scene)
    parts: list[tuple[str, bool | None]] = []
    # HHT against Baumgarte, N by N, in operations (the verdict) and CPU time (beside)
    pairs = []
    for N in sorted(set(table["N"])):
        m = table[table["N"] == N]
        hv, bv = m[m.setting.str.startswith("HHT")], m[m.setting.str.startswith("Baum")]
        if len(hv) and len(bv):
            pairs.append((N, hv["ops"].mean() / bv["ops"].mean(), hv["cpu_s"].mean() / bv["cpu_s"].mean()))
    parts.append(("HHT/Baumgarte operations (CPU time) " + ", ".join(f"N={N}: {o:.3g} ({c:.3g})" for N, o, c in pairs),
                  all(o > 1.0 for _, o, _ in pairs)) if pairs else ("no completed HHT/Baumgarte pair", None))
    # growth at the paper's sizes: operations per run (the model) and CPU time (overhead)
    fits = []
    for family, word in (("HHT", "HHT"), ("Baum", "Baumgarte")):
        g = table[table.setting.str.startswith(family)].groupby("N")[["ops", "cpu_s"]].median()
        if len(g) > 1:
            N = g.index.to_numpy(float)
            fits.append((word, N, growth(N, g["ops"].to_numpy()), growth(N, g["cpu_s"].to_numpy())))
    pub = growth(PUBLISHED_TABLE1.index.to_numpy(float), PUBLISHED_TABLE1.median(axis=1).to_numpy(float))[0]
    parts.append(("; ".join(f"{w} median operations ∝ N^{ko:.2g} (median CPU time ∝ N^{kc:.2g}, call overhead at "
                            f"these sizes; fit over N = {N.min():g}…{N.max():g}, {len(N)} points, log residual "
                            f"{so:.2g})" for w, N, (ko, so), (kc, _) in fits) + f" (published wall time N^{pub:.2g})",
                  None) if fits else ("one N only, so no growth with N", None))
    # growth where it is not overhead: HHT's CPU time per step on FE meshes
    size = df[df["set"] == "size"] if "set" in df else df.iloc[:0]
    hs = per_step_cpu(size[size["setting"].astype(str).str.startswith("HHT")], scene)
    fit = hs[hs["n"] >= MIN_FIT_UNKNOWNS]
    if len(fit) >= 3:
        k, spread = growth(fit["n"].to_numpy(float), fit["cpu_step"].to_numpy())
        ko = growth(fit["n"].to_numpy(float), fit["ops_step"].to_numpy())[0]
        pts = ", ".join(f"{_num(c, '.2g')} s at n = {n}" for n, c in zip(hs["n"], hs["cpu_step"]))
        parts.append((f"HHT CPU time per step on the FE beam ∝ n^{k:.2g} (fit over n = {fit['n'].min()}…"
                      f"{fit['n'].max()}, {len(fit)} sizes, log residual {spread:.2g}; {pts}; operations per step "
                      f"n^{ko:.2g}, Newton iterations per step {_num(hs['newton_step'].median(), '.3g')})", k > STEEP))
    else:
        parts.append((f"{len(fit)} FE size(s) with n ≥ {MIN_FIT_UNKNOWNS} completed over two horizons: no growth "
                      "where cost is not overhead", None))
    bad = size[size["setting"].astype(str).str.startswith("Baum") & (size["status"] != "completed")]
    if len(bad):
        el = sorted(set(int(x) for x in bad["N"]))
        parts.append((f"Baumgarte on the FE beam: {bad['status'].iloc[0]} at every size tried ({len(el)}: "
                      f"{el[0]}…{el[-1]} elements; at {el[0]}: {bad['message'].iloc[0]}), so HHT against Baumgarte "
                      "where cost is not overhead is not testable at this step", None))
    if stem is not None and len(hs):
        figs += fig_size(table, hs, fit, Path(str(stem) + "-size"), prov)
    return _verdict(parts), figs


def fig_size(table: pd.DataFrame, hs: pd.DataFrame, fit: pd.DataFrame, stem: Path, prov: dict[str, Any]) -> list[Path]:
    """CPU time per step (left) and modelled operations per step (right) against the
    number of unknowns, log–log, every point labelled by its n; the fitted power law over
    the rows of ``fit`` dashed."""
    fig, (a, b) = plt.subplots(1, 2, figsize=(9.0, 4.0))
    for family, colour, word in (("HHT", "C0", "HHT α-family"), ("Baum", "C1", "Baumgarte")):
        m = table[table.setting.str.startswith(family)].groupby("n")[["cpu_s", "steps", "ops_step"]].median()
        if len(m):
            a.plot(m.index, m["cpu_s"] / m["steps"], "o", color=colour, label=f"{word}, modal beam (whole run / steps)")
            b.plot(m.index, m["ops_step"], "o", color=colour, label=f"{word}, modal beam")
    a.plot(hs["n"], hs["cpu_step"], "s-", color="C2", label="HHT α=−0.15, FE beam (two-horizon difference)")
    b.plot(hs["n"], hs["ops_step"], "s-", color="C2", label="HHT α=−0.15, FE beam")
    for ax, col in ((a, "cpu_step"), (b, "ops_step")):
        if len(fit) >= 2:
            n = fit["n"].to_numpy(float)
            k, c0 = power_fit(n, fit[col].to_numpy())
            ax.plot(n, np.exp(c0) * n ** k, "k--", lw=0.8, label=f"fit ∝ n^{k:.2g} (n = {n.min():g}…{n.max():g})")
    for _, r in hs.iterrows():
        a.annotate(f"n={int(r['n'])}", (r["n"], r["cpu_step"]), fontsize=6, xytext=(3, 3), textcoords="offset points")
    for ax, ylab in ((a, "CPU time per step [s]"), (b, "modelled operations per step [flop]")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("unknowns n (θ and the beam's coordinates)")
        ax.set_ylabel(ylab)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6)
    a.set_title("claim 7: measured cost per step", fontsize=9)
    b.set_title("claim 7: dense operation model (cost.operation_cost)", fontsize=9)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return plots.save(fig, stem, prov)
