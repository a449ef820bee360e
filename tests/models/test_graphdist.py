"""The graph (Hausdorff) distance (daebench.harness.scoring.graphdist): closed forms (a jump moved by
d is d away, a constant offset c is c away, simple polylines), the compiled search against a
brute-force dense resampling, the velocity-level probe, and the convergence order of Moreau–Jean and the nonsmooth
generalized-α scheme on the bouncing ball against its exact piecewise-parabolic motion,
where a pointwise error does not converge but the graph distance falls like h."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from daebench.core.params import ParamError
from daebench.driver.simulate import simulate
from daebench.harness.scoring import graphdist as gd
from daebench.integrators.registry import get_integrator
from daebench.models import build_system
from daebench.models.ball import exact_motion
from daebench.models.scenes import load_scene


def step(t_jump: float) -> pd.DataFrame:
    """y = 0 before t_jump, 1 after, on [0, 1]; the jump as two rows at one time."""
    return pd.DataFrame({"t": [0.0, t_jump, t_jump, 1.0], "y": [0.0, 0.0, 1.0, 1.0]})


@pytest.mark.parametrize("d", [0.1, 0.01, 1e-3])
def test_a_jump_moved_by_d_is_d_away(d):
    """T = 1 s, Y = 1: the vertical segments are d apart, the flat parts overlap."""
    out = gd.graph_errors(step(0.5 + d), step(0.5), ["y"])
    assert out["err_graph_q"] == pytest.approx(d, abs=out["graph_resolution"])
    assert out["graph_time_scale"] == 1.0 and out["graph_q_worst"] == "y"


def test_constant_offset_and_scales():
    """y_ref = 2 (Y = max|y| = 2 for a constant), y_run = 2.1 over [0, 4] s: 0.1 / 2 = 0.05;
    the time scale is the reference's horizon, 4 s; a sine delayed by τ is ≤ τ/T away
    (its graph moved by τ: the delayed one starts at τ)."""
    t = np.linspace(0.0, 4.0, 401)
    ref = pd.DataFrame({"t": t, "y": np.full(t.size, 2.0)})
    run = pd.DataFrame({"t": t, "y": np.full(t.size, 2.1)})
    out = gd.graph_errors(run, ref, ["y"])
    assert out["err_graph_q"] == pytest.approx(0.05, abs=1e-12) and out["graph_time_scale"] == 4.0
    tf = np.linspace(0.0, 4.0, 40001)
    sine = pd.DataFrame({"t": tf, "y": np.sin(5 * tf)})
    late = pd.DataFrame({"t": tf + 4e-3, "y": np.sin(5 * tf)})     # the same graph 4 ms later
    d = gd.graph_errors(late, sine, ["y"])["err_graph_q"]
    assert 0.0 < d <= 4e-3 / 4.0 + 1e-5


def test_bad_input_is_refused():
    with pytest.raises(ParamError, match="time scale"):
        gd.graph_distance(np.r_[0.0, 1.0], np.r_[0.0, 1.0], np.r_[0.0, 1.0], np.r_[0.0, 1.0], 0.0, 1.0)
    with pytest.raises(ParamError, match="positive time"):
        gd.graph_errors(step(0.5), pd.DataFrame({"t": [1.0, 1.0], "y": [0.0, 1.0]}), ["y"])


def test_polyline_closed_forms():
    """Simple polylines with known distances: a tent of height 1 over [0, 2] against the flat
    line (1: the apex; back, the flat line's middle is 1/√2 from the tent); a flat line over
    [0, 4] given by its ends only against a graph that leaves it at t = 1 and returns at t = 3
    (the directed distance is 1, at the line's midpoint, inside its one segment: the search
    must split the segment to find it; back, the plateau at height 5 is 5 away)."""
    tent_t, tent_y = np.r_[0.0, 1.0, 2.0], np.r_[0.0, 1.0, 0.0]
    flat_t, flat_y = np.r_[0.0, 2.0], np.r_[0.0, 0.0]
    assert gd.polyline_distance(tent_t, tent_y, flat_t, flat_y, 1e-9, 0.0) == pytest.approx(1.0, abs=1e-9)
    assert gd._directed(flat_t, flat_y, tent_t, tent_y, 1e-9, 0.0) == pytest.approx(1 / math.sqrt(2), abs=1e-9)
    line_t, line_y = np.r_[0.0, 4.0], np.r_[0.0, 0.0]
    box_t, box_y = np.r_[0.0, 1.0, 1.0, 3.0, 3.0, 4.0], np.r_[0.0, 0.0, 5.0, 5.0, 0.0, 0.0]
    assert gd._directed(line_t, line_y, box_t, box_y, 1e-9, 0.0) == pytest.approx(1.0, abs=1e-9)
    assert gd.polyline_distance(line_t, line_y, box_t, box_y, 1e-9, 0.0) == pytest.approx(5.0, abs=1e-9)
    # the stated resolution: a coarse δ = 0.1 finds the midpoint's 1 to within δ/2
    assert abs(gd._directed(line_t, line_y, box_t, box_y, 0.1, 0.0) - 1.0) <= 0.05


def dense_points(t: np.ndarray, y: np.ndarray, step: float) -> np.ndarray:
    """Points along the polyline through (t, y), no more than ``step`` apart."""
    p = np.column_stack([t, y])
    k = np.maximum(np.ceil(np.hypot(*np.diff(p, axis=0).T) / step).astype(int), 1)
    s = np.concatenate([np.arange(j) / j for j in k])
    seg = np.repeat(np.arange(k.size), k)
    return np.vstack([p[seg] + s[:, None] * (p[seg + 1] - p[seg]), p[-1:]])


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(2, 400), st.integers(2, 400))
def test_polyline_distance_equals_brute_force(seed, n, m):
    """:func:`polyline_distance` (branch and bound, exact point-to-segment distances) against
    a brute force: both polylines resampled 2e-4 apart and the point sets' Hausdorff distance
    by k-d tree (within 2e-4 of the polylines'): equal within the two resolutions."""
    rng = np.random.default_rng(seed)
    ta, tb = np.sort(rng.uniform(0.0, 1.0, n)), np.sort(rng.uniform(0.0, 1.0, m))
    ya = np.cumsum(rng.normal(scale=2e-2, size=n))
    yb = np.cumsum(rng.normal(scale=2e-2, size=m)) + rng.normal(scale=5e-2)
    d = gd.polyline_distance(ta, ya, tb, yb, resolution=1e-5, relative=0.0)
    a, b = dense_points(ta, ya, 2e-4), dense_points(tb, yb, 2e-4)
    brute = max(float(np.max(cKDTree(b).query(a)[0])), float(np.max(cKDTree(a).query(b)[0])))
    assert abs(d - brute) <= 2e-4 + 1e-5


def test_velocity_level_probe():
    """The ball's v changes with v at fixed x, its x does not."""
    ball = build_system(load_scene("ball", {}))
    assert gd.velocity_columns(ball, ["x", "v", "absent"]) == {"v"}


# -- convergence on the bouncing ball -----------------------------------------------------------
SWEEP = tuple(2e-3 * 1.5 ** -np.arange(6))     # 2e-3 … 2.6e-4: ratios that sample the impact phase
T_END = 1.3                                     # two impacts (0.4515 s, 1.1740 s)


def exact_history(system, t_end: float, dt: float = 1e-4) -> pd.DataFrame:
    """The exact motion at dt and at each impact twice (v⁻, then v⁺: the vertical segment)."""
    impacts, at = exact_motion(system, t_end)
    ti = np.array([i[0] for i in impacts])
    t = np.sort(np.concatenate([np.arange(0.0, t_end + dt / 2, dt), ti, ti]))
    x, v = at(t)
    for tk, vm, vp in impacts:
        k = np.flatnonzero(t == tk)
        x[k], v[k[0]], v[k[1]] = system.wall, vm, vp
    return pd.DataFrame({"t": t, "x": x, "v": v})


def slope(h, err) -> float:
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])


@pytest.mark.parametrize("integrator", ["moreau", "nsgenalpha"])
def test_ball_graph_distance_first_order(integrator):
    """err_graph_q (x) and err_graph_v (v) against the exact motion over two bounces, runs
    written at every step (output.dt = h): fitted order ≈ 1 (Acary 2012 for Moreau–Jean;
    first order across impacts for nonsmooth generalized-α, Capobianco et al. 2020); the
    pointwise max error of v, printed beside, is the size of the jump wherever an output
    time falls between the exact and the run's impact."""
    eq, ev, pointwise = [], [], []
    for h in SWEEP:
        sc = load_scene("ball", {"t_end": T_END, "output.dt": float(h)})
        system = build_system(sc)
        res = simulate(system, get_integrator(integrator)(h=float(h)), sc.t_end, sc["output.dt"])
        assert res.status == "completed" and len(res.impacts) == 2
        ref = exact_history(system, T_END)
        out = gd.graph_errors(res.history, ref, ["x"], ["v"], resolution=5e-5)
        eq.append(out["err_graph_q"])
        ev.append(out["err_graph_v"])
        _, v_exact = exact_motion(system, T_END)[1](res.history["t"].to_numpy())
        pointwise.append(float(np.max(np.abs(res.history["v"].to_numpy() - v_exact))))
    pq, pv = slope(SWEEP, eq), slope(SWEEP, ev)
    print(f"\n{integrator}: h {['%.2e' % h for h in SWEEP]}\n  err_graph_q {['%.2e' % e for e in eq]} "
          f"(order {pq:.2f})\n  err_graph_v {['%.2e' % e for e in ev]} (order {pv:.2f})\n"
          f"  pointwise max |v error| {['%.2f' % e for e in pointwise]} m/s")
    assert 0.7 <= pq <= 1.6 and 0.7 <= pv <= 1.6
    assert all(e < 10.0 * h / T_END for e, h in zip(eq + ev, SWEEP + SWEEP))


def test_pipeline_measure():
    """The measure of the scoring pipeline splits the ball's scored observables into x
    (position level) and v (velocity level) and scales time by the truth's horizon."""
    from types import SimpleNamespace
    sc = load_scene("ball", {"t_end": 1.0})
    system = build_system(sc)
    t = np.linspace(0.0, 1.0, 1001)
    truth = SimpleNamespace(history=pd.DataFrame({"t": t, "x": 1.0 - t, "v": -np.ones_like(t)}))
    run = SimpleNamespace(scene=sc, system=system,
                          history=pd.DataFrame({"t": t, "x": 1.0 - t + 0.01, "v": -np.ones_like(t) - 0.5}))
    out = gd.measure(run, truth)
    assert out["graph_q_worst"] == "x" and out["graph_v_worst"] == "v" and out["graph_time_scale"] == 1.0
    assert out["err_graph_q"] == pytest.approx(0.01, rel=1e-3)   # at the start: (0, 1.01) to the end point (0, 1)
    assert out["err_graph_v"] == pytest.approx(0.5, rel=1e-9)                        # constant: Y = max|v| = 1


def test_reference_sampled_at_the_run_times():
    """A tone the run's output rate does not resolve (1.8 kHz at 1 ms rows): the run equal to
    the reference at its own times is 0 from the reference sampled at its times (the
    comparison a sweep row makes), whatever the reference does between them."""
    tf = np.linspace(0.0, 0.1, 2001)                       # 50 µs rows
    ref = pd.DataFrame({"t": tf, "y": np.sin(2 * np.pi * 1800 * tf)})
    run = ref.iloc[::20].reset_index(drop=True)            # 1 ms rows
    assert gd.graph_errors(run, ref, ["y"], at_run_times=True)["err_graph_q"] < 1e-12
    late = run.assign(y=np.sin(2 * np.pi * 1800 * (run["t"] - 1e-5)))
    d = gd.graph_errors(late, ref, ["y"], at_run_times=True)["err_graph_q"]
    assert 0.0 < d < 2 * np.pi * 1800 * 1e-5 / 2.0 + 1e-6      # |Δy| / Y ≤ ω·τ / range
