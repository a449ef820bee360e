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

Computation: both polylines are resampled so that consecutive points lie at most δ apart
(δ = the larger of :data:`RESOLUTION` and 1 % of the distance, :func:`graph_distance`;
coarser only when a graph would need more than :data:`MAX_POINTS` points; the δ used is
reported as ``graph_resolution``), and the point sets' Hausdorff distance is found with
:class:`scipy.spatial.cKDTree` nearest neighbours, O(n log n). It differs from the
polylines' distance by at most δ.

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
from typing import TYPE_CHECKING, Any, Iterable, Sequence

import numpy as np
import pandas as pd

from daebench.core.params import ParamError
from daebench.harness.scoring.metrics import interpolate

if TYPE_CHECKING:  # pragma: no cover
    from scipy.spatial import cKDTree

RESOLUTION = 1e-5        #: largest spacing of the resampled polylines, in scaled units
MAX_POINTS = 1_000_000   #: at most this many points per resampled graph (δ grows to fit)
STRIDE = 32              #: :func:`directed` queries every STRIDE-th point first
COARSE = 1e-3            #: the first pass's resolution (:func:`graph_distance`)
RELATIVE = 1e-2          #: the second pass resolves the distance to this fraction of itself


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


def resample(t: np.ndarray, y: np.ndarray, time_scale: float, y_scale: float,
             resolution: float = RESOLUTION) -> tuple[np.ndarray, float]:
    """Points (N × 2, scaled) along the polyline through (t, y) no more than the resolution
    apart; the resolution is raised when N would exceed :data:`MAX_POINTS`.
    Rows with a non-finite t or y are dropped. Returns (points, resolution used)."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    ok = np.isfinite(t) & np.isfinite(y)
    p = np.column_stack([t[ok] / time_scale, y[ok] / y_scale])
    if len(p) < 2:
        return p, float(resolution)
    d = np.hypot(*np.diff(p, axis=0).T)
    delta = float(resolution)
    total = float(np.sum(np.ceil(d / delta))) + 1.0
    if total > MAX_POINTS:
        delta *= total / MAX_POINTS * 1.01
    k = np.maximum(np.ceil(d / delta).astype(np.int64), 1)
    seg = np.repeat(np.arange(k.size), k)
    s = (np.arange(seg.size) - np.repeat(np.cumsum(k) - k, k)) / k[seg]
    pts = p[seg] + s[:, None] * (p[seg + 1] - p[seg])
    return np.vstack([pts, p[-1:]]), delta


def directed(a: np.ndarray, b: np.ndarray, tree: cKDTree | None = None) -> float:
    """sup over the points a of their distance to the point set b, as if every point
    were queried, querying every :data:`STRIDE`-th point first: a point lies within
    STRIDE/2 spacings of a queried one and the distance to b is 1-Lipschitz, so only the
    neighbourhoods of queried points within (STRIDE/2)·(largest spacing) of the maximum
    can hold a larger one; those are queried in full."""
    if len(a) == 0 or len(b) == 0:
        return math.nan
    if tree is None:
        from scipy.spatial import cKDTree  # lazy: importing scipy.spatial costs ~0.5 s of every start

        tree = cKDTree(b)
    if len(a) <= 4 * STRIDE:
        return float(np.max(tree.query(a, k=1)[0]))
    spacing = float(np.max(np.linalg.norm(np.diff(a, axis=0), axis=1)))
    idx = np.arange(0, len(a), STRIDE)
    d = tree.query(a[idx], k=1)[0]
    m = float(d.max())
    cand = idx[d >= m - 0.5 * STRIDE * spacing]
    near = np.unique(np.clip(cand[:, None] + np.arange(-STRIDE, STRIDE + 1)[None, :], 0, len(a) - 1))
    return max(m, float(np.max(tree.query(a[near], k=1)[0])))


def hausdorff(a: np.ndarray, b: np.ndarray) -> float:
    """Hausdorff distance of two point sets (N × d, M × d), Euclidean (cKDTree)."""
    if len(a) == 0 or len(b) == 0:
        return math.nan
    return max(directed(a, b), directed(b, a))


def graph_distance(t_run: np.ndarray, y_run: np.ndarray, t_ref: np.ndarray, y_ref: np.ndarray,
                   time_scale: float, y_scale: float, resolution: float = RESOLUTION) -> tuple[float, float]:
    """Scaled Hausdorff distance of the graphs of (t_run, y_run) and (t_ref, y_ref) (module
    docstring); returns (distance, the resolution δ it is accurate to).

    Two passes: at δ = max(resolution, :data:`COARSE`), then, unless that δ is already within
    :data:`RELATIVE` of the distance found, at δ = max(resolution, RELATIVE × that distance).
    A far graph is so measured to 1 % at little cost (a nearest-neighbour search from far
    away meets a near-tie at every point of the other polyline within √(2 d δ)); a near
    one to the resolution."""
    for name, val in (("time scale", time_scale), ("value scale", y_scale), ("resolution", resolution)):
        if not (math.isfinite(float(val)) and float(val) > 0.0):
            raise ParamError(f"the graph distance needs a positive finite {name}, got {val!r}")
    delta = max(float(resolution), COARSE)
    for second in (False, True):
        a, da = resample(t_run, y_run, time_scale, y_scale, delta)
        b, db = resample(t_ref, y_ref, time_scale, y_scale, delta)
        d, used = hausdorff(a, b), max(da, db)
        finer = max(float(resolution), RELATIVE * d) if math.isfinite(d) else used
        if second or used <= finer * 1.0000001:
            break
        delta = finer
    return d, used


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
