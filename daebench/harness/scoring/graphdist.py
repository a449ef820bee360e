"""A distance that survives impacts: the Hausdorff distance between the graphs of a run and
of its reference in (t, q) and (t, v).

After an impact a pointwise error |y_run(t) − y_ref(t)| does not converge: a velocity that
jumps a step early differs by the whole jump over that step, however small the step, and a
position's error inherits the shifted phase. The distance between the *graphs* does: a jump
located δt early is δt away in time (Monteiro Marques 1987; Acary 2012, "Higher order event
capturing time-stepping schemes for nonsmooth multibody systems with unilateral constraints
and impacts", Appl. Numer. Math. 62; cardillo's convergence analysis computes the same
distance, unscaled, by brute force). For a Moreau–Jean scheme it falls like h (Acary 2012);
the nonsmooth generalized-α scheme keeps first order across impacts as well (its second
order is on the smooth parts; Capobianco et al. 2020).

Definition (per observable y)
-----------------------------
Each history is a polyline through its rows (t_k, y_k) — two rows at one time, as an
exact reference may hold at an impact, make a vertical segment. Points are scaled,
(t / T, y / Y), with the **time scale T = the reference's horizon** (its last time minus
its first) and the **value scale Y = the reference's range of y** (max − min; max |y| for a
constant, 1 for an identically zero one). The distance of two points is the Euclidean
distance of the scaled points, √((Δt/T)² + (Δy/Y)²): dimensionless, per observable, and
within a factor √2 of the metric of Acary's graph distance, max(|Δt|, ‖Δy‖) (which
cardillo uses); the Euclidean one is chosen because a nearest-neighbour search in the
max-norm meets exact ties all along two parallel flat stretches, and slows down by orders of
magnitude. The Hausdorff distance of two polylines A, B is max(sup_a d(a, B), sup_b d(b, A)); a
jump moved by δt is δt/T away, a constant offset c is c/Y away, in either metric.

Computation (:func:`polyline_distance`, compiled): the directed distance sup_a d(a, B) by
branch and bound along each segment of A — d(·, B) is 1-Lipschitz, so a piece of length ℓ
whose ends lie d₀ and d₁ from B holds no point farther than (d₀ + d₁ + ℓ)/2, and the
distance to one segment of B is convex along the piece, so no point is farther from the
segment nearest to one end than that segment is from the piece's ends; a piece whose bound
cannot beat the largest distance found by more than δ/2 is left, the others are halved —
with d(a, B) exact (point to segment) over the segments of B within d of a in time, d
bounded by the point of B at a's own time (B is a graph over time). The result is within δ/2
of the polylines' distance, δ = the larger of :data:`RESOLUTION` and :data:`RELATIVE` of the
distance (reported as ``graph_resolution``); the work follows the pieces near the maximum,
not the graphs' length over δ.

A history resolves a jump only to its output interval (a jump between two output rows is a
segment across that interval) and a vibration only to its output rate. A sweep row
(:func:`measure`) therefore compares the run's graph with the reference's **sampled at the
run's output times** (``at_run_times``): both graphs then have the same resolution, and
what remains is the run's error, not the output's. (Against the reference's own rows,
beam-impact's run histories at 1 ms would sit ≥ 0.06 from it for any integrator: the
reference itself sampled at 1 ms and moved by 0.1 ms is 0.064 (the tip deflection) and 0.145 (the hub's angular velocity)
away from its 50 µs rows: its 11 131 rad/s tone, period 0.56 ms, is not resolved at 1 ms.)
Against an exact solution with its impacts as vertical segments (the tests), set
``output.dt`` ≤ h.

Columns: ``err_graph_q`` (max over the observables of position level), ``err_graph_v``
(max over those of velocity level: the observables that change with v at fixed q,
:func:`velocity_columns`), the worst observable of each (``graph_q_worst``,
``graph_v_worst``), ``graph_time_scale`` [s] and ``graph_resolution``.
"""

from __future__ import annotations

import math
from typing import Any, Iterable, Sequence

import numpy as np
import pandas as pd
from numba import njit

from daebench.core.params import ParamError
from daebench.harness.scoring.metrics import interpolate

RESOLUTION = 1e-5        #: the distance is resolved to this, in scaled units, at least
RELATIVE = 1e-2          #: … and to this fraction of itself
STACK = 128              #: pieces a segment is split into at most at once (depth-first: ≥ log2 of length/δ)


def value_scale(y: np.ndarray) -> float:
    """Y of an observable from the reference's values: range, else max |y|, else 1."""
    y = np.asarray(y, float)
    y = y[np.isfinite(y)]
    if not y.size:
        return 1.0
    r = float(y.max() - y.min())
    if r > 0.0:
        return r
    m = float(np.max(np.abs(y)))
    return m if m > 0.0 else 1.0


@njit(cache=True)
def _segment(px, py, ax, ay, bx, by):
    """Distance from (px, py) to the segment (ax, ay)–(bx, by)."""
    dx, dy = bx - ax, by - ay
    l2 = dx * dx + dy * dy
    u = 0.0
    if l2 > 0.0:
        u = min(1.0, max(0.0, ((px - ax) * dx + (py - ay) * dy) / l2))
    return math.hypot(ax + u * dx - px, ay + u * dy - py)


@njit(cache=True)
def _to_graph(px, py, tb, yb):
    """(exact distance from (px, py) to the polyline B (time-ordered), its nearest segment):
    the point of B at time px (its end outside B's span) bounds it, and only the segments
    within that bound in time can be nearer."""
    nb = tb.shape[0]
    if nb == 1:
        return math.hypot(px - tb[0], py - yb[0]), 0
    j = min(max(np.searchsorted(tb, px, "right"), 1), nb - 1)     # segment j − 1 holds time px
    w = min(max((px - tb[j - 1]) / (tb[j] - tb[j - 1]), 0.0), 1.0) if tb[j] > tb[j - 1] else 1.0
    bound = math.hypot(px - (tb[j - 1] + w * (tb[j] - tb[j - 1])), py - (yb[j - 1] + w * (yb[j] - yb[j - 1])))
    lo = max(np.searchsorted(tb, px - bound, "left") - 1, 0)
    hi = min(np.searchsorted(tb, px + bound, "right"), nb - 1)
    d, near = bound, j - 1
    for i in range(lo, hi):
        di = _segment(px, py, tb[i], yb[i], tb[i + 1], yb[i + 1])
        if di < d:
            d, near = di, i
    return d, near


@njit(cache=True)
def _to_segment(px, py, tb, yb, i):
    """Distance from (px, py) to segment i of B (its one point when B has one)."""
    if tb.shape[0] == 1:
        return math.hypot(px - tb[0], py - yb[0])
    return _segment(px, py, tb[i], yb[i], tb[i + 1], yb[i + 1])


@njit(cache=True)
def _piece_bound(x0, y0, x1, y1, d0, d1, s0, s1, tb, yb):
    """An upper bound of the distance to B over the piece (x0, y0)–(x1, y1) whose ends lie d0,
    d1 from B, nearest to its segments s0, s1: the 1-Lipschitz cone, and the distance to
    either end's nearest segment — convex along the piece, so its larger end value."""
    cone = 0.5 * (d0 + d1 + math.hypot(x1 - x0, y1 - y0))
    via0 = max(d0, _to_segment(x1, y1, tb, yb, s0))
    via1 = max(d1, _to_segment(x0, y0, tb, yb, s1))
    return min(cone, via0, via1)


@njit(cache=True)
def _directed(ta, ya, tb, yb, resolution, relative):
    """sup over the polyline A of the distance to the polyline B, to δ/2 with δ = max(resolution,
    relative × the result) (module docstring: branch and bound on the 1-Lipschitz distance)."""
    na = ta.shape[0]
    dv = np.empty(na)
    sv = np.empty(na, np.int64)
    best = 0.0
    for k in range(na):
        dv[k], sv[k] = _to_graph(ta[k], ya[k], tb, yb)
        best = max(best, dv[k])
    st = np.empty((STACK, 4))   # pieces (u0, u1, d(u0), d(u1)) of the segment, depth first
    si = np.empty((STACK, 2), np.int64)   # … and the nearest segments of B at their ends
    for k in range(na - 1):
        x0, y0 = ta[k], ya[k]
        dx, dy = ta[k + 1] - x0, ya[k + 1] - y0
        st[0, 0], st[0, 1], st[0, 2], st[0, 3] = 0.0, 1.0, dv[k], dv[k + 1]
        si[0, 0], si[0, 1] = sv[k], sv[k + 1]
        top = 1
        while top:
            top -= 1
            u0, u1, d0, d1 = st[top, 0], st[top, 1], st[top, 2], st[top, 3]
            s0, s1 = si[top, 0], si[top, 1]
            bound = _piece_bound(x0 + u0 * dx, y0 + u0 * dy, x0 + u1 * dx, y0 + u1 * dy, d0, d1, s0, s1, tb, yb)
            if bound <= best + 0.5 * max(resolution, relative * best) or top + 2 > STACK:
                continue
            um = 0.5 * (u0 + u1)
            dm, sm = _to_graph(x0 + um * dx, y0 + um * dy, tb, yb)
            best = max(best, dm)
            st[top, 0], st[top, 1], st[top, 2], st[top, 3] = um, u1, dm, d1
            si[top, 0], si[top, 1] = sm, s1
            st[top + 1, 0], st[top + 1, 1], st[top + 1, 2], st[top + 1, 3] = u0, um, d0, dm
            si[top + 1, 0], si[top + 1, 1] = s0, sm
            top += 2
    return best


def polyline_distance(t_a: np.ndarray, y_a: np.ndarray, t_b: np.ndarray, y_b: np.ndarray,
                      resolution: float = RESOLUTION, relative: float = RELATIVE) -> float:
    """Hausdorff distance of two time-ordered polylines (scaled coordinates), to δ/2 with
    δ = max(resolution, relative × the distance); NaN when one is empty. Rows with a
    non-finite t or y are dropped."""
    pts = []
    for t, y in ((t_a, y_a), (t_b, y_b)):
        t, y = np.asarray(t, float), np.asarray(y, float)
        ok = np.isfinite(t) & np.isfinite(y)
        pts.append((np.ascontiguousarray(t[ok]), np.ascontiguousarray(y[ok])))
    (ta, ya), (tb, yb) = pts
    if not ta.size or not tb.size:
        return math.nan
    return max(float(_directed(ta, ya, tb, yb, resolution, relative)),
               float(_directed(tb, yb, ta, ya, resolution, relative)))


def graph_distance(t_run: np.ndarray, y_run: np.ndarray, t_ref: np.ndarray, y_ref: np.ndarray,
                   time_scale: float, y_scale: float, resolution: float = RESOLUTION) -> tuple[float, float]:
    """Scaled Hausdorff distance of the graphs of (t_run, y_run) and (t_ref, y_ref) (module
    docstring); returns (distance, the resolution δ it is accurate to: within δ/2, δ the larger
    of ``resolution`` and :data:`RELATIVE` of the distance)."""
    for name, val in (("time scale", time_scale), ("value scale", y_scale), ("resolution", resolution)):
        if not (math.isfinite(float(val)) and float(val) > 0.0):
            raise ParamError(f"the graph distance needs a positive finite {name}, got {val!r}")
    T, Y = float(time_scale), float(y_scale)
    d = polyline_distance(np.asarray(t_run, float) / T, np.asarray(y_run, float) / Y,
                          np.asarray(t_ref, float) / T, np.asarray(y_ref, float) / Y, float(resolution), RELATIVE)
    return d, max(float(resolution), RELATIVE * d) if math.isfinite(d) else float(resolution)


def velocity_columns(system: Any, columns: Iterable[str], t: float = 0.0) -> set[str]:
    """The columns among ``columns`` that are of velocity level: the model's observables at
    its initial state that change when v changes at fixed q (a probe, no declaration
    needed: ω of a rotating hinge is a velocity, the angle ω of Andrews' squeezer is not)."""
    q0, v0 = system.initial_state()
    q0, v0 = np.asarray(q0, float), np.asarray(v0, float)
    a = system.observables(t, q0, v0)
    b = system.observables(t, q0, v0 + 1.0 + np.abs(v0))
    out = set()
    for c in columns:
        if c in a and c in b and abs(float(b[c]) - float(a[c])) > 1e-12 * (1.0 + abs(float(a[c]))):
            out.add(c)
    return out


def graph_errors(run: pd.DataFrame, ref: pd.DataFrame, q_columns: Sequence[str], v_columns: Sequence[str] = (),
                 time_scale: float | None = None, resolution: float = RESOLUTION,
                 at_run_times: bool = False) -> dict[str, Any]:
    """The row's graph-distance columns (module docstring) for the observables both
    histories hold; ``time_scale`` defaults to the reference's horizon. With
    ``at_run_times`` the reference's graph is the polyline through its values at the run's
    output times (linear interpolation of its rows), so that both graphs have the same time
    resolution (the value scale stays the full reference's)."""
    t_ref = ref["t"].to_numpy(float)
    T = float(time_scale) if time_scale is not None else float(t_ref[-1] - t_ref[0])
    if not (math.isfinite(T) and T > 0.0):
        raise ParamError(f"the graph distance needs a reference spanning a positive time, got T = {T!r}")
    t_run = run["t"].to_numpy(float)
    out: dict[str, Any] = {"graph_time_scale": T}
    res_used = 0.0
    for level, cols in (("q", q_columns), ("v", v_columns)):
        worst, name = math.nan, ""
        for c in cols:
            if c not in run.columns or c not in ref.columns:
                continue
            y_ref = ref[c].to_numpy(float)
            tg, yg = (t_run, interpolate(ref, c, t_run)) if at_run_times else (t_ref, y_ref)
            d, delta = graph_distance(t_run, run[c].to_numpy(float), tg, yg, T, value_scale(y_ref), resolution)
            res_used = max(res_used, delta)
            if math.isfinite(d) and not d <= worst:
                worst, name = d, c
        out[f"err_graph_{level}"], out[f"graph_{level}_worst"] = worst, name
    out["graph_resolution"] = res_used if res_used > 0.0 else math.nan
    return out


def measure(run: Any, truth: Any) -> dict[str, Any]:
    """The scoring pipeline's measure (:data:`daebench.harness.scoring.pipeline.MEASURES`): the
    scene's scored observables that the truth holds, split into position and velocity
    level by :func:`velocity_columns`, against the truth's history sampled at the run's
    output times (``at_run_times``: both graphs at one time resolution)."""
    t = truth.history["t"].to_numpy(float)
    if len(run.history) < 2 or len(t) < 2 or not t[-1] > t[0]:  # a run that stopped at its start has no graph
        return {"graph_time_scale": math.nan, "err_graph_q": math.nan, "graph_q_worst": "",
                "err_graph_v": math.nan, "graph_v_worst": "", "graph_resolution": math.nan}
    cols = [c for c in run.scene.get("output.observables") or []
            if c in run.history.columns and c in truth.history.columns]
    vel = velocity_columns(run.system, cols)
    return graph_errors(run.history, truth.history, [c for c in cols if c not in vel], [c for c in cols if c in vel],
                        at_run_times=True)
