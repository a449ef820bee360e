"""The hub–beam's output rows in one compiled pass (HubBeam.output_rows, the driver's rows
of many output times) against independent formulas written here with NumPy over the
model's shape tables, and the driver's rows with and without the batch path; the native
IDA callbacks load from the kernel cache (daebench.stepping.sundials_c.type_key)."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from daebench import api
from daebench.driver import simulate
from daebench.models import build_system
from daebench.models.hubbeam import HubBeam
from daebench.models.scenes import load_scene

RNG = np.random.default_rng(20261125)
CASES = [("beam-impact", []), ("beam-impact", ["contact.law=hertz"]),
         ("hub-beam", ["effects.axial=true", "hub.radius=0.05", "discretization.n=4"]),
         ("hub-beam", ["discretization.kind=fem", "discretization.n=3", "effects.axial=true", "hub.radius=0.05"])]


def _states(s: HubBeam, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = 0.03 * RNG.standard_normal((k, s.n))
    v = RNG.standard_normal((k, s.n))
    q[:, 0] = RNG.uniform(-math.pi, math.pi, k)
    q[0, s.iB] = 0.0  # a straight beam: the modal participations' 0/0 case
    return np.linspace(0.0, 0.3, k), q, v


def _independent(s: HubBeam, t: float, q: np.ndarray, v: np.ndarray) -> tuple[dict, dict]:
    """Observables and energy terms from the scene and the shape tables, with NumPy."""
    sc, tab = s.scene, s.tables
    A, B = q[s.iA], q[s.iB]
    a = sc["hub.radius"]
    rhoS = sc["beam.density"] * sc["beam.area"]
    fore = sc["effects.foreshortening"]
    th = q[0]
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])

    def point(i: int) -> np.ndarray:  # inertial position of material point i (0 tip, 1 contact)
        ap = tab.at_points
        p1 = a + tab.points[i] + ap.phx[i] @ A - (0.5 * B @ tab.H_points[i] @ B if fore else 0.0)
        return R @ np.array([p1, ap.phy[i] @ B])

    tip = point(0)
    part = tab.at_points.phy[0] * B
    obs = {"theta_deg": math.degrees(th), "omega": v[0], "tip_x": tip[0], "tip_y": tip[1], "tip_w2": part.sum()}
    if s.n_contacts:
        obs["gap"] = point(1)[1] + sc["contact.plane_height"]
    if s.kind == "modes":
        tot = np.abs(part).sum()
        obs.update({f"W{i + 1}": (p / tot if tot > 0 else 0.0) for i, p in enumerate(part)})
    for j, c in enumerate(s.coordinate_names):   # the state itself, recorded for the modal measures
        obs[f"q_{c}"], obs[f"v_{c}"] = q[j], v[j]
    # gravity: g ∫ρS Y dx over the quadrature points, Y the inertial height of each point
    at = tab.at
    p1 = a + tab.x + at.phx @ A - (0.5 * np.einsum("i,kij,j->k", B, tab.H, B) if fore else 0.0)
    Y = math.sin(th) * p1 + math.cos(th) * (at.phy @ B)
    g = sc["gravity.g"] if sc["effects.gravity"] else 0.0
    law = s.contact_law
    contact = float(law.potential(np.array([obs["gap"]]))) if law is not None and law.continuous else 0.0
    E = {"kinetic": 0.5 * v @ s.mass(q) @ v, "elastic": 0.5 * (A @ s.K1 @ A + B @ s.K2 @ B),
         "gravity": g * rhoS * float(tab.w @ Y), "contact": contact}
    return obs, E


@pytest.mark.parametrize("name,overrides", CASES)
def test_rows_equal_independent_formulas_and_one_row_at_a_time(name, overrides):
    """Every observable and energy term of 6 states to 1e-12 of its size (the kinetic energy
    through the model's mass matrix; gravity as g Σ wρS Y over the quadrature points), and
    energy()/observables() are one row of output_rows to the last bit."""
    s = build_system(load_scene(name, overrides))
    t, q, v = _states(s, 6)
    if s.n_contacts and s.contact_law.continuous:  # one state pressed into the plane
        q[1, 0] = -math.radians(0.5)
    obs, E = s.output_rows(t, q, v)
    assert list(obs) == list(s.observables(t[0], q[0], v[0])) and list(E) == ["kinetic", "elastic", "gravity",
                                                                              "contact"]
    for r in range(len(t)):
        want_obs, want_E = _independent(s, t[r], q[r], v[r])
        assert set(want_obs) == set(obs)
        for k, x in want_obs.items():
            assert obs[k][r] == pytest.approx(x, rel=1e-12, abs=1e-12 * (1 + abs(x))), (r, k)
        scale = sum(abs(x) for x in want_E.values())
        for k, x in want_E.items():
            assert abs(E[k][r] - x) <= 1e-12 * scale, (r, k)
        assert s.observables(t[r], q[r], v[r]) == {k: c[r] for k, c in obs.items()}
        assert s.energy(q[r], v[r]) == {k: c[r] for k, c in E.items()}
    if name == "beam-impact" and not overrides:
        assert all(obs[f"W{i}"][0] == 0.0 for i in range(1, 6))  # straight beam
        assert s.tip_position(q[2]) == (obs["tip_x"][2], obs["tip_y"][2])


def test_driver_rows_equal_with_and_without_the_batch_path(monkeypatch):
    """A short beam-impact IDA run (its rows from the compiled loop, passed to output_rows in
    batches) writes the same history to the last bit as the row-by-row path."""
    kw = dict(overrides={"t_end": 0.02, "output.dt": 5e-5}, rtol=1e-8, atol=1e-10)
    batch = api.run("beam-impact", "ida", **kw)
    calls = []
    real = HubBeam.output_rows

    def counting(self, *a):
        calls.append(len(a[0]))
        return real(self, *a)

    monkeypatch.setattr(HubBeam, "output_rows", counting)
    api.run("beam-impact", "ida", **kw)
    assert max(calls) > 100  # the compiled loop's rows went through in batches
    monkeypatch.setattr(HubBeam, "output_rows", real)
    one = simulate.Driver._rows  # one output at a time: the row-by-row path (observables(), energy())

    def row_by_row(self, outs, problem, work=None):
        work = self._output_work(problem, len(outs)) if work is None else work
        for i, o in enumerate(outs):
            one(self, [o], problem, {k: (w[i:i + 1] if isinstance(w, np.ndarray) else w) for k, w in work.items()})

    monkeypatch.setattr(simulate.Driver, "_rows", row_by_row)
    rows = api.run("beam-impact", "ida", **kw)
    assert batch.status == rows.status == "completed" and len(batch.observables) == 401
    assert list(batch.observables.columns) == list(rows.observables.columns)
    assert np.array_equal(batch.observables.to_numpy(), rows.observables.to_numpy(), equal_nan=True)


def test_native_ida_callbacks_close_over_text_only():
    """numba keys a cached closure by the pickle of its closure variables; a numba type
    pickles differently in every process, text does not."""
    from numba import typeof

    from daebench.core.problem import Problem
    from daebench.stepping import ida_native

    s = build_system(load_scene("pendulum"))
    cx = ida_native.make_context(Problem(s).kernel, s.n, 1, np.zeros(9, np.int64))
    for cb in ida_native.callbacks(typeof(cx)):
        assert all(isinstance(c.cell_contents, str) for c in cb._pyfunc.__closure__)


@pytest.mark.slow
def test_native_ida_callbacks_load_from_the_cache_in_a_new_process():
    """The second of two fresh processes loads both callbacks from the kernel cache (before:
    each process compiled them again, 1.9 s each, and appended them to the cache file)."""
    code = ("from numba import typeof; import numpy as np; from daebench.core.problem import Problem; "
            "from daebench.models import build_system; from daebench.models.scenes import load_scene; "
            "from daebench.stepping import ida_native as N; s = build_system(load_scene('pendulum')); "
            "cx = N.make_context(Problem(s).kernel, s.n, 1, np.zeros(9, np.int64)); "
            "print(sum(cb._cache_hits for cb in N.callbacks(typeof(cx))))")
    hits = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                           env=os.environ.copy()).stdout.split()[-1] for _ in range(2)]
    assert hits[1] == "2"
