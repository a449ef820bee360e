"""The time-averaged-gap LCP paper reproduced (Zhang, Qi, Wang, Guo, Wu: a flexible double
pendulum and a chain with contact, solved by a linear complementarity problem on the gap
averaged over a time window): its two examples with its own scheme (``lcp-avg``) beside the
continuous contact laws and the event-driven driver (``daebench averaged-gap``).

* :func:`chain_table` — Example 1 (``chain-impact``): the time-averaged-gap LCP at several
  windows h of the order of the ≈ 1.5 ms Hertz contact, and Hertz with Flores (and
  Lankarani–Nikravesh) damping over the restitutions, run by IDA. Per run: first contact,
  duration, approach speed, computed restitution, energy lost, peak force, the *unclipped*
  Flores force (the law clips at 0 — :func:`daebench.core.phase.law_force` — so the recorded
  ``contact_force_0`` can never show the negative force the source reports), m3's largest
  distance from the LCP run at h = 1 ms, and the energy balance.
* :func:`pendulum_table` — Example 2 (``double-pendulum``): event-driven IDA (constraint
  law, e = 0), ``lcp-avg`` at two windows, and Hertz under IDA; the outcome of
  :func:`daebench.models.doublependulum.contact_outcome` per run.
* :func:`pendulum_figure` — tip gap and tip normal force against time, one curve per run.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from daebench.core.problem import Problem
from daebench.harness.running import provenance
from daebench.integrators.lcp_avg import contact_forces
from daebench.models import build_system
from daebench.models.doublependulum import contact_outcome
from daebench.models.scenes import load_scene
from daebench.workflows.run import RunOutput, run


def _run(case: str, integrator: str, overrides: dict[str, Any], progress: bool, **settings: Any) -> RunOutput:
    return run(load_scene(case, overrides), integrator, settings, progress=progress)

CHAIN_WINDOWS = (1e-4, 5e-4, 1e-3, 2e-3)
CHAIN_RESTITUTIONS = (0.1, 0.2, 0.3, 0.5, 0.8, 1.0)
IDA_TIGHT = {"rtol": 1e-9, "atol": 1e-12}


def unclipped_hertz_force(history: pd.DataFrame, system: Any, impacts: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """(F, 1 + χ δ̇) of the chain's Hertz law *before* the clip at 0 at the history's rows:
    F = K δⁿ (1 + χ δ̇), δ = −gap, δ̇ = v3 − v4, χ from the approach speed of the episode the
    row lies in (as the driver sets it); 0 and 1 where the contact is open."""
    law = system.contact_law
    t = history["t"].to_numpy()
    chi = np.zeros(t.size)
    for imp in impacts:
        if imp["contact"] == 0 and math.isfinite(imp["vn_minus"]):
            end = imp["t_end"] if math.isfinite(imp["t_end"]) else np.inf
            chi[(t >= imp["t"]) & (t <= end)] = law.chi(np.array([-imp["vn_minus"]]))[0]
    delta = np.maximum(-history["gap"].to_numpy(), 0.0)
    factor = np.where(delta > 0.0, 1.0 + chi * (history["v3"] - history["v4"]).to_numpy(), 1.0)
    return np.where(delta > 0.0, law.stiffness * delta**law.exponent * factor, 0.0), factor


def lcp_force_history(run: Any, h_avg: float, contact: int = 0) -> np.ndarray:
    """The force ``lcp-avg`` applied at each recorded state of a run (API RunOutput)."""
    p = Problem(build_system(run.scene))
    return np.array([contact_forces(p, h_avg, t, q, v)[contact] for t, q, v in zip(run.t, run.q, run.v)])


def _chain_row(label: str, run: Any, force: np.ndarray, raw: np.ndarray, factor: np.ndarray,
               ref_x3: np.ndarray | None) -> dict:
    imp = [i for i in run.impacts if i["contact"] == 0]
    first = imp[0] if imp else {}
    H = run.observables
    e = first.get("vn_plus", math.nan) / -first["vn_minus"] if imp else math.nan
    return {"run": label, "status": run.status, "episodes": len(imp), "first_contact_s": first.get("t", math.nan),
            "duration_s": first.get("t_end", math.nan) - first.get("t", math.nan),
            "approach_speed": -first.get("vn_minus", math.nan), "restitution": e,
            "energy_lost_J": first.get("energy_loss", math.nan), "peak_force_N": float(np.max(force)),
            "min_force_recorded_N": float(np.min(force)), "min_force_unclipped_N": float(np.min(raw)),
            "min_damping_factor": float(np.min(factor)),
            "dx3_vs_lcp_m": float(np.max(np.abs(H["x3"].to_numpy() - ref_x3))) if ref_x3 is not None else math.nan,
            "energy_residual_J": run.energy_residual, "steps": run.counters["steps"]}


def chain_table(windows=CHAIN_WINDOWS, restitutions=CHAIN_RESTITUTIONS, rtol: float = 1e-4, atol: float = 1e-6,
                t_end: float = 0.1, output_dt: float = 1e-5, overrides: dict | None = None,
                progress: bool = False) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The chain-impact comparison (see the module docstring). ``rtol``/``atol``: lcp-avg's
    tolerances (the source's ode45 defaults); the continuous laws run under tight IDA.
    ``overrides``: scene keys for every run (e.g. two free masses: chain.stiffness = 0);
    ``progress``: a bar per run on stderr."""
    base = {"t_end": t_end, "output.dt": output_dt, **(overrides or {})}
    runs: dict[str, Any] = {}
    for h in windows:
        runs[f"lcp-avg h_avg={h:g}"] = _run("chain-impact", "lcp-avg",
                                            overrides={**base, "contact.law": "complementarity"},
                                            h_avg=h, rtol=rtol, atol=atol, progress=progress)
    for law in ("flores", "lankarani-nikravesh"):
        for e in restitutions if law == "flores" else (0.3,):
            runs[f"{law} e={e:g}"] = _run("chain-impact", "ida", overrides={
                **base, "contact.hertz_damping": law, "contact.restitution": e}, progress=progress, **IDA_TIGHT)
    ref_key = f"lcp-avg h_avg={1e-3:g}"
    ref = runs[ref_key].observables["x3"].to_numpy() if ref_key in runs else None
    rows = []
    for label, r in runs.items():
        if label.startswith("lcp-avg"):
            f = lcp_force_history(r, float(label.split("=")[1]))
            raw, factor = f, np.ones_like(f)
        else:
            f = r.observables["contact_force_0"].fillna(0.0).to_numpy()
            raw, factor = unclipped_hertz_force(r.observables, build_system(r.scene), r.impacts)
        rows.append(_chain_row(label, r, f, raw, factor, ref))
    return pd.DataFrame(rows), runs


def pendulum_table(windows=(1e-3, 1e-2), ida_rtol: float = 1e-6, hertz: bool = True,
                   overrides: dict | None = None, progress: bool = False) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The double-pendulum comparison: the outcome per run (see the module docstring);
    ``progress``: a bar per run on stderr."""
    over = dict(overrides or {})
    runs: dict[str, Any] = {"ida, constraint e=0": _run("double-pendulum", "ida", overrides=over, rtol=ida_rtol,
                                                        progress=progress)}
    for h in windows:
        runs[f"lcp-avg h_avg={h:g}"] = _run("double-pendulum", "lcp-avg", progress=progress,
                                            overrides={**over, "contact.law": "complementarity"}, h_avg=h)
    if hertz:
        runs["ida, hertz LN e=0"] = _run("double-pendulum", "ida", progress=progress,
                                         overrides={**over, "contact.law": "hertz"}, rtol=ida_rtol)
    rows = []
    for label, r in runs.items():
        o = contact_outcome(r.observables, r.impacts).as_dict()
        E0 = float(r.observables["E"].iloc[0])
        rows.append({"run": label, "status": r.status, **o, "E0_J": E0, "energy_residual_J": r.energy_residual,
                     "final_residual_J": float(r.observables["energy_residual"].iloc[-1]),
                     "steps": r.counters["steps"], "wall_s": r.wall_s})
    return pd.DataFrame(rows), runs


def tip_force(label: str, run: Any) -> np.ndarray:
    """The tip's normal force at the recorded states: λ₀ (constraint law), the law's force
    (continuous), the LCP force (lcp-avg)."""
    H = run.observables
    if label.startswith("lcp-avg"):
        return lcp_force_history(run, float(label.split("=")[1]))
    col = "lambda_0" if "lambda_0" in H else "contact_force_0"
    return H[col].fillna(0.0).to_numpy() if col in H else np.zeros(len(H))


def pendulum_figure(runs: dict[str, Any], path: str, window: tuple[float, float] = (0.6, 1.5),
                    fmt: str | None = None) -> None:
    """Tip gap [m] and tip normal force [N] against time [s], one curve per run."""
    import matplotlib  # lazy: matplotlib (heavy) only when the figure is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # lazy: as above

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7.5, 5.5), sharex=True)
    for label, r in runs.items():
        H = r.observables
        ax1.plot(H["t"], H["gap"], lw=1.0, label=label)
        ax2.plot(H["t"], tip_force(label, r), lw=0.8, label=label)
    ax1.set_ylabel("tip gap above the foundation [m]")
    ax1.set_ylim(-0.01, 0.3)
    ax2.set_ylabel("tip normal force [N]")
    ax2.set_yscale("symlog", linthresh=10.0)
    ax2.set_ylim(bottom=0.0)
    ax2.set_xlabel("time [s]")
    ax2.set_xlim(*window)
    ax1.legend(fontsize=7, loc="upper right")
    sc = next(iter(runs.values())).scene
    ax1.set_title(f"double-pendulum: link-2 end on the foundation (E = {sc['links.modulus']:.2g} Pa, "
                  f"{sc['links.elements']} elements/link, h_s = {sc['damping.hs'] * 1e3:g} ms)", fontsize=8)
    fig.tight_layout(rect=(0, 0.02, 1, 1))   # room for the provenance footer
    provenance.write_figure(fig, path, prov=provenance.collect([r.scene for r in runs.values()]), dpi=110, fmt=fmt)
    plt.close(fig)
