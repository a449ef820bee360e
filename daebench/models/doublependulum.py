"""Flexible double pendulum falling onto a smooth rigid foundation (case ``double-pendulum``).

Source: seed 003, Example 2 (docs/sources.md §E): two flexible links (L, A, ρ, E given; the
section's I, element count, pivot height and time span not), released at rest from the
horizontal under gravity; link 2 strikes a smooth (frictionless) rigid foundation,
deforms greatly, does not rebound, stays in contact, slides and lifts off.

Model: co-rotational Euler–Bernoulli beams (:mod:`daebench.models.corotational`), lumped
mass, ``links.elements`` elements per link. Link 1 runs from the pivot (node 0, at the
origin, translations held — a revolute joint) to the joint node; link 2 from the joint
node to the tip. The joint node's position is shared by both links and each link has
its own end rotation there (the revolute joint between the links is built into the
coordinates). So the model is an ODE in independent coordinates, as the source's
eq. (16) assumes, and the explicit scheme ``lcp-avg`` runs on it directly.

Contact points: the nodes of link 2 (``contact.points = "link2"``: tip first, then towards
the joint, the joint node last) or the tip alone (``"tip"``); contact 0 is always the tip.
Gap g = y + h0 against the foundation y = −h0, g_q = e_y, γ_g = 0. Laws:
``constraint`` (the event-driven driver: a closed node keeps g = 0 and slides freely
along the plane; the impact map with ``contact.restitution``), ``hertz`` and ``penalty``
(continuous), ``complementarity`` (left to an integrator that resolves contacts:
``lcp-avg``, the source's scheme, or ``lcp``).

Damping (``effects.damping``): the source's time-averaged element stress
F_e = K_e (u_e + (h_s/2) u̇_e) with h_s = ``damping.hs``.

:func:`contact_outcome` extracts the published qualitative outcome from a run.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Iterable

import numpy as np
import pandas as pd

from daebench.core.contact import contact_schema
from daebench.models.corotational import Frame
from daebench.core.observables import Observable, Position
from daebench.core.params import Param
from daebench.core.scene import Scene, SceneError

DESCRIPTION = "flexible double pendulum (co-rotational beams) falling onto a smooth rigid foundation"

#: the history's columns as the scorer reads them (daebench.core.observables)
OBSERVABLES = (
    Observable("gap", "m", "tip gap", height=True),
    Observable("tip_x", "m", "tip x"),
    Observable("tip_y", "m", "tip y", height=True, summary=True),
    Position("tip", "tip_x", "tip_y", label="tip position", impact_windows=True),
)

POISSON = 0.3  # for the default Hertz stiffness only
CONTACT = contact_schema(("constraint", "hertz", "penalty", "complementarity"),
                         hertz_rule="(4/3) E/(1−ν²) √r, r the section radius, ν = 0.3")

SCHEMA: dict[str, Param] = {
    p.name: p
    for p in (
        Param("links.length", float, 2.0, "length L of each link", low=1e-3, high=1e3, unit="m"),
        Param("links.area", float, 3e-4, "cross-section area A", low=1e-10, high=10.0, unit="m^2"),
        Param("links.inertia", float, 0.0, "second moment of area I (0: solid round section, A²/4π)",
              low=0.0, high=10.0, unit="m^4"),
        Param("links.density", float, 7850.0, "density ρ", low=1.0, high=1e5, unit="kg/m^3"),
        Param("links.modulus", float, 2.1e9, "Young's modulus E", low=1e3, high=1e13, unit="Pa"),
        Param("links.elements", int, 8, "co-rotational elements per link", low=1, high=200),
        Param("pivot.height", float, 3.0, "height h0 of the pivot above the foundation y = −h0", low=0.0,
              high=1e3, unit="m"),
        Param("start.angle_deg", float, 0.0, "initial angle of both (straight) links below the horizontal",
              low=-90.0, high=90.0, unit="deg"),
        Param("gravity.g", float, 9.81, "gravitational acceleration (along −y)", low=0.0, high=1e3, unit="m/s^2"),
        Param("effects.gravity", bool, True, "gravity"),
        Param("effects.damping", bool, False, "time-averaged element stress K_e (u_e + (h_s/2) u̇_e)"),
        Param("effects.contact", bool, True, "contact of link 2 with the foundation"),
        Param("damping.hs", float, 0.0, "averaging time h_s of the element stress (β_d = h_s/2)", low=0.0,
              high=10.0, unit="s"),
        *CONTACT.params,
        Param("contact.points", str, "link2", "which nodes can touch: every node of link 2, or its tip",
              choices=("link2", "tip")),
    )
}


def check_scene(scene: Scene) -> None:
    """Cross-key checks; raise :class:`SceneError` naming the key and the fix."""
    if scene["effects.damping"] and scene["damping.hs"] <= 0.0:
        raise SceneError("scene key 'damping.hs' must be > 0 with effects.damping = true")
    CONTACT.check(scene)
    if scene["effects.contact"]:
        if scene["pivot.height"] >= 2.0 * scene["links.length"]:
            raise SceneError(f"scene key 'pivot.height' = {scene['pivot.height']} m: the links "
                             f"(2 × {scene['links.length']} m) can never reach the foundation; choose less "
                             f"than {2.0 * scene['links.length']} m or effects.contact = false")


def build(scene: Scene) -> "DoublePendulum":
    check_scene(scene)
    return DoublePendulum(scene)


def section_inertia(area: float, inertia: float = 0.0) -> float:
    """I of the section: the given value, or the solid round section's A²/(4π)."""
    return inertia if inertia > 0.0 else area * area / (4.0 * math.pi)


class DoublePendulum(Frame):
    """Two co-rotational beam links, pinned at the origin, hinged to each other."""

    def __init__(self, scene: Scene) -> None:
        s = scene
        self.scene = s
        L, A, rho, E = s["links.length"], s["links.area"], s["links.density"], s["links.modulus"]
        I = section_inertia(A, s["links.inertia"])
        ne = s["links.elements"]
        ang = math.radians(s["start.angle_deg"])
        d = np.array([math.cos(ang), -math.sin(ang)])
        nodes = np.outer(np.linspace(0.0, 2.0 * L, 2 * ne + 1), d)
        elements = np.c_[np.arange(2 * ne), np.arange(1, 2 * ne + 1)]
        rot = elements.copy()
        rot[ne, 0] = 2 * ne + 1  # link 2's first end: its own rotation at the joint (a hinge)
        self.joint, self.tip = ne, 2 * ne
        on = s["effects.contact"]
        contact_nodes = () if not on else ((self.tip,) if s["contact.points"] == "tip"
                                           else tuple(range(self.tip, ne - 1, -1)))
        super().__init__(nodes, elements, E * A, E * I, rho * A, rho * I, rot_ids=rot, pinned=[0],
                         g=s["gravity.g"] if s["effects.gravity"] else 0.0, contact_nodes=contact_nodes,
                         h0=s["pivot.height"], gravity_datum=-s["pivot.height"], damping_beta=0.5 * s["damping.hs"] if s["effects.damping"] else 0.0)
        self.length = L
        self.radius = math.sqrt(A / math.pi)
        law = s["contact.law"]
        self.contact_model = "none" if not on else law
        self.contact_restitution = float(s["contact.restitution"])
        if on and law != "complementarity":
            self.hertz_stiffness = s["contact.hertz_stiffness"] or 4.0 / 3.0 * E / (1.0 - POISSON**2) * math.sqrt(self.radius)
            self.contact_law = CONTACT.law(s, self.n_contacts, self.hertz_stiffness)

    def observables(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, float]:
        """Tip and joint positions, tip velocity, the tip's gap and the smallest gap of the
        contact nodes, and the chord angles of both links [deg, from +x]."""
        xt, yt = self.node_position(q, self.tip)
        xj, yj = self.node_position(q, self.joint)
        kt = self._trans[self.tip]
        h0 = self.data.h0
        gaps = [self.node_position(q, a)[1] + h0 for a in self.contact_nodes]
        return {"tip_x": xt, "tip_y": yt, "tip_vx": float(v[kt]), "tip_vy": float(v[kt + 1]),
                "joint_x": xj, "joint_y": yj, "gap": yt + h0, "min_gap": min(gaps) if gaps else math.nan,
                "link1_deg": math.degrees(math.atan2(yj, xj)),
                "link2_deg": math.degrees(math.atan2(yt - yj, xt - xj))}


# -- the published outcome, extracted from a run -------------------------------------------------
@dataclass
class ContactOutcome:
    """The link-2 end (tip) on the foundation in one run (NaN where it did not happen).

    first_contact : first time the tip gap reaches 0 (interpolated in the history) [s]
    episode_start : start of the tip's first contact episode as the run reports it (the
        impact for the constraint law, first touch for continuous laws, the force onset —
        before the gap closes — for ``lcp-avg``) [s]
    approach_speed, rebound_speed : −ġ and ġ⁺ of that first episode [m/s] (ġ⁺ after the
        impact map, at separation, or at the end of the first force episode)
    rebounds : whether the tip leaves the foundation (gap > ``tol``) within
        ``rebound_window`` of the first contact
    lift_off : the end of the last contact (gap ≤ ``tol``) before the tip leaves for good,
        i.e. before its gap first exceeds ``away`` after the first contact [s]
    contact_fraction : fraction of [first_contact, lift_off] with the tip on the foundation
    max_hop : largest tip gap within [first_contact, lift_off] [m]
    slide : tip x at lift-off − tip x at first contact [m]
    max_penetration : −(smallest tip gap of the run) [m]
    """

    first_contact: float
    episode_start: float
    approach_speed: float
    rebound_speed: float
    rebounds: bool
    lift_off: float
    contact_fraction: float
    max_hop: float
    slide: float
    max_penetration: float

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def _crossing(t: np.ndarray, g: np.ndarray, k: int, level: float) -> float:
    """Time where g crosses ``level`` between samples k − 1 and k (linear)."""
    if k == 0 or g[k - 1] == g[k]:
        return float(t[k])
    return float(t[k - 1] + (t[k] - t[k - 1]) * (g[k - 1] - level) / (g[k - 1] - g[k]))


def contact_outcome(history: pd.DataFrame, impacts: Iterable = (), tol: float = 1e-3, away: float = 0.2,
                    rebound_window: float = 0.02, contact: int = 0) -> ContactOutcome:
    """The outcome the source reports (no rebound, persistent contact, sliding, lift-off) as
    numbers, from a run's history (columns t, gap, tip_x) and its impacts or contact
    episodes (objects or the API's dicts).

    ``tol`` [m]: the tip counts as on the foundation while its gap is ≤ tol (the constraint
    law keeps it at 0, the continuous laws and ``lcp-avg`` at a small penetration);
    ``away`` [m]: a gap beyond it means the tip has left for good.
    """
    t = history["t"].to_numpy()
    g = history["gap"].to_numpy()
    x = history["tip_x"].to_numpy()
    nan = math.nan
    imps = [i if isinstance(i, dict) else i.as_dict() for i in impacts]
    imps = [i for i in imps if i["contact"] == contact]
    start = float(imps[0]["t"]) if imps else nan
    v_in = -float(imps[0]["vn_minus"]) if imps else nan
    v_out = float(imps[0]["vn_plus"]) if imps else nan
    pen = max(0.0, -float(np.min(g)))
    below = np.flatnonzero(g <= 0.0)
    if below.size == 0:
        return ContactOutcome(nan, start, v_in, v_out, False, nan, nan, nan, nan, pen)
    k = int(below[0])
    t0 = _crossing(t, g, k, 0.0)
    if k > 0 and "tip_vy" in history and history["tip_vy"].iloc[k - 1] < 0.0:
        # from the last free sample at its approach speed: a closed constraint holds g at 0,
        # so interpolating towards the next sample would place the contact late
        t0 = min(t0, float(t[k - 1] + g[k - 1] / -history["tip_vy"].iloc[k - 1]))
    gone = np.flatnonzero(g[k:] > away)
    last = k + int(gone[0]) if gone.size else len(t)
    on = np.flatnonzero(g[k:last] <= tol)
    j = k + int(on[-1])
    t_off = _crossing(t, g, j + 1, tol) if gone.size and j + 1 < len(t) else nan
    left = np.flatnonzero(g[k:] > tol)
    bounce = bool(left.size and t[k + int(left[0])] - t0 < rebound_window)
    span = slice(k, j + 1)
    frac = float(np.mean(g[span] <= tol))
    x0 = float(np.interp(t0, t, x))
    slide = float(np.interp(t_off, t, x)) - x0 if math.isfinite(t_off) else nan
    return ContactOutcome(t0, start, v_in, v_out, bounce, t_off, frac, float(np.max(g[span])), slide, pen)
