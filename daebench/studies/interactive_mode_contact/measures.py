"""The interactive-mode paper reproduced (Wang, Liu, Hong: dynamic modelling of flexible
bodies with contact/impact based on the interactive mode, Acta Physica Sinica 2017): the
three contact treatments — ACM (constraints + impact map, driver), PFM (penalty) and IMM
(interactive mode) — on the planar FE cases ``rod-wall``, ``slider-slot`` and
``rod-plate``, scored from ordinary run records.

Every run goes through :func:`daebench.harness.running.runner.run_scene` (the harness's path: history,
impacts, energy residual, constraint residuals); this module only reads the records:

* :func:`contact_window` — first touch to last release, from the run's contact
  episodes (PFM: the driver's separations; IMM: the integrator's episodes) or, for ACM
  (whose openings are not booked as episodes), from the history: the first output row
  after the last closed one, its gap extrapolated back to zero;
* :func:`rod_wall_scores` — T / (2L/c), mean reaction ∫F dt / T against Z v₀, the
  post-impact velocity and the residual vibration energy, against Saint-Venant;
* :func:`contact_force` — the total normal contact force of a history, whatever the
  treatment (ACM λ columns, PFM contact_force columns, IMM F_imm);
* :func:`impact_events` — contact episodes grouped into impacts (episodes of nearby
  nodes on one master surface that overlap in time), with where and when.

Contact-phase cost: :class:`PhaseTimer` wraps an integrator's ``advance`` and sums the
process CPU time of the calls that end in contact (ACM: a closed constraint; PFM: a
penetrating contact; IMM: a held force), the analog of the paper's "contact phase".
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from daebench.core.scene import Scene
from daebench.harness.running.runner import make_integrator, run_scene
from daebench.integrators.base import Integrator
from daebench.models.rodwall import exact
from daebench.models.scenes import load_scene

#: the treatments: (contact.law, default integrator)
TREATMENTS = {"ACM": ("constraint", "hht"), "PFM": ("penalty", "central"), "IMM": ("complementarity", "imm")}


def contact_window(res: Any) -> tuple[float, float]:
    """(first touch, last release) of a run [s]; NaN when there was no contact."""
    if not res.impacts:
        return math.nan, math.nan
    t0 = min(i.t for i in res.impacts)
    ends = [i.t_end for i in res.impacts if math.isfinite(i.t_end)]
    h = res.history
    if any(c.startswith("lambda_") for c in h.columns):      # ACM
        act = h["n_active"].to_numpy() > 0
        last = np.flatnonzero(act)
        if last.size and last[-1] + 2 < len(h):
            j = last[-1] + 1
            g1, g2 = h["gap_min"].iloc[j], h["gap_min"].iloc[j + 1]
            ta, tb = h["t"].iloc[j], h["t"].iloc[j + 1]
            return t0, float(ta - g1 * (tb - ta) / (g2 - g1)) if g2 != g1 else float(ta)
        return t0, math.nan
    return t0, (max(ends) if ends else math.nan)


def contact_force(hist: pd.DataFrame) -> np.ndarray:
    """Total normal contact force at each output row [N] (0 where open)."""
    cols = [c for c in hist.columns if c.startswith(("lambda_", "contact_force_"))]
    F = hist[cols].fillna(0.0).to_numpy().sum(axis=1) if cols else np.zeros(len(hist))
    if "F_imm" in hist:
        F = F + hist["F_imm"].fillna(0.0).to_numpy()
    return F


def rod_wall_scores(res: Any, scene: Scene) -> dict[str, float]:
    """Saint-Venant's numbers for a rod-wall run (docs/sources.md §A.2/A.3 conventions: mean
    reaction = ∫λ dt / T without the impulse of the impact map)."""
    ex = exact(scene)
    t0, t1 = contact_window(res)
    T = t1 - t0
    h = res.history
    v_after = float(h["v_cm"].iloc[-1])
    m = ex["mass"]
    impulse = m * (v_after + ex["v0"])                   # momentum balance over the run
    map_impulse = sum(i.impulse for i in res.impacts if math.isfinite(i.impulse) and i.closed)
    E0 = 0.5 * m * ex["v0"] ** 2
    E_after = float(h["E"].iloc[-1])
    return {"T_ratio": T / ex["T"], "F_mean_ratio": (impulse - map_impulse) / T / ex["F"],
            "v_after_ratio": v_after / ex["v0"], "E_after_ratio": E_after / E0,
            "vibration_ratio": (E_after - 0.5 * m * v_after ** 2) / E0, "t_touch": t0, "t_release": t1}


@dataclass
class Impact:
    """One impact: overlapping contact episodes of one master surface."""

    t_start: float
    t_end: float
    surface: int
    nodes: list[int]
    impulse: float
    x: float      # where on the striking body: mean reference position of its nodes in
    y: float      # its floating frame (relative to the frame origin) [m]


def impact_events(res: Any, system: Any, join: float = 5e-6) -> list[Impact]:
    """Group a run's contact episodes into impacts: same master surface, starting within
    ``join`` seconds of the group's last end; placed by the slave nodes' reference positions."""
    surface = system.data.surface
    eps = sorted(res.impacts, key=lambda i: i.t)
    groups: list[list[Any]] = []
    for e in eps:
        g = next((g for g in groups if surface[g[0].contact] == surface[e.contact]
                  and e.t <= max((x.t_end if math.isfinite(x.t_end) else x.t) for x in g) + join), None)
        if g is None:
            groups.append([e])
        else:
            g.append(e)
    out = []
    for g in groups:
        t0 = min(x.t for x in g)
        t1 = max((x.t_end if math.isfinite(x.t_end) else x.t) for x in g)
        nodes = sorted({int(system.slaves[x.contact]) for x in g})
        imp = sum(x.impulse for x in g if math.isfinite(x.impulse))
        X = system.data.Xref.reshape(-1, 2)[nodes]
        xy = X.mean(axis=0)
        out.append(Impact(t0, t1, int(surface[g[0].contact]), nodes, imp, float(xy[0]), float(xy[1])))
    return sorted(out, key=lambda i: i.t_start)


class PhaseTimer:
    """Wraps ``integ.advance`` to sum the process CPU time of calls that end in contact."""

    def __init__(self, integ: Integrator):
        self.integ = integ
        self.contact_s = 0.0
        self.total_s = 0.0
        self.contact_steps = 0
        inner = integ.advance

        def advance(t_stop, watch=None, **kw):
            c0 = time.process_time()
            adv = inner(t_stop, watch, **kw)
            dt = time.process_time() - c0
            self.total_s += dt
            if self._in_contact():
                self.contact_s += dt
                self.contact_steps += adv.steps
            return adv

        integ.advance = advance

    def _in_contact(self) -> bool:
        p = self.integ.problem
        if p is None:
            return False
        if p.active or (p.engaged != 0).any():
            return True
        md = p.system.kernel_data()
        return bool(getattr(md, "lam", np.zeros(0)).any())


def run(case: str, treatment: str, overrides: dict | None = None, integrator: str | None = None,
        **settings: Any) -> tuple[Any, Any, Integrator, PhaseTimer, Scene]:
    """One run of a treatment (``ACM`` | ``PFM`` | ``IMM``) on a case through the harness;
    returns (record, result, integrator, phase timer, scene)."""
    law, default = TREATMENTS[treatment]
    sc = load_scene(case, {"contact.law": law, **(overrides or {})})
    integ = make_integrator(integrator or default, settings)
    timer = PhaseTimer(integ)
    rec, res = run_scene(sc, integ, write=False, force=True)
    if rec.settings.get("h") != integ.settings.get("h"):   # h = auto resolved: another integrator ran, untimed
        raise ValueError(f"the phase timer needs the step given (h = {integ.settings.get('h')!r} was resolved to "
                         f"{rec.settings.get('h')!r}): pass h explicitly")
    return rec, res, integ, timer, sc
