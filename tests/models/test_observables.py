"""Declared observables: a model defined here, outside daebench (a plugin-like module
registered at test time), declares its own columns and is scored — against its exact
solution, or against a reference — with no change to the harness.

Independent truth: the pendulum's elliptic-function solution (:func:`exact_theta`). The
test model is the pendulum with other column names (φ in radians, the bob as a point
``bob``), so its scored errors must equal the built-in pendulum's, converted.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import daebench
from daebench import models
from daebench.core.observables import Observable, Observables, Position
from daebench.core.params import ParamError
from daebench.models import pendulum as P

# ---- the test model: a module with DESCRIPTION, SCHEMA, OBSERVABLES and build ------------------
DESCRIPTION = "test only: the rigid pendulum with its own column names"
SCHEMA = P.SCHEMA
OBSERVABLES = (
    Observable("phi", "rad", "φ", derivative="phi_dot", impact_windows=True, summary=True),
    Observable("phi_dot", "rad/s", "φ̇"),
    Observable("bob_y", "m", "bob height", height=True),
    Position("bob", "bob_x", "bob_y", label="bob position", impact_windows=True),
)


class Bob(P.Pendulum):
    """The pendulum (its compiled kernels), observed as φ [rad], φ̇ and the bob's (x, y)."""

    def observables(self, t, q, v):
        phi_dot = (q[0] * v[1] - q[1] * v[0]) / float(q @ q)
        return {"phi": math.atan2(q[0], -q[1]), "phi_dot": phi_dot, "bob_x": float(q[0]), "bob_y": float(q[1])}

    def exact_observables(self, t):
        th = self.exact_theta(t)
        return {"phi": th, "bob_x": self.l * np.sin(th), "bob_y": -self.l * np.cos(th)}


class BobNoExact(Bob):
    exact_observables = None  # scored against the reference


def build(scene):
    cls = BobNoExact if scene.name.endswith("-ref") else Bob
    return cls(mass=scene["pendulum.mass"], length=scene["pendulum.length"], g=scene["gravity.g"],
               theta0_deg=scene["start.theta_deg"], omega0=scene["start.omega"])


SCENE = """name = "{name}"
description = "test model"
model = "bob"
t_end = 0.2
[pendulum]
length = 1.0
[start]
theta_deg = 30.0
[output]
dt = 1e-3
observables = ["phi", "bob_x", "bob_y"]
"""


@pytest.fixture
def bob(monkeypatch, tmp_path):
    """Register this module as model 'bob' (as an entry point would) and write its scenes."""
    monkeypatch.setitem(models.MODELS, "bob", __name__)
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    paths = {}
    for name in ("bob-exact", "bob-ref"):
        paths[name] = tmp_path / f"{name}.toml"
        paths[name].write_text(SCENE.format(name=name))
    return paths


def test_declared_observables_are_scored_against_the_exact_solution(bob):
    r = daebench.run(str(bob["bob-exact"]), "hht", h=1e-3)
    assert r.error["against"] == "exact solution"
    # the declared short names and the declared point: err_phi_*, err_bob_* (not the column names)
    assert {"err_phi_max", "err_phi_l2", "err_phi_final", "err_bob_max"} <= set(r.error)
    t = r.observables["t"].to_numpy()
    direct = np.abs(r.observables["phi"].to_numpy() - P.exact_theta(t, math.radians(30.0), 0.0, 9.81, 1.0))
    assert r.error["err_phi_max"] == pytest.approx(direct.max(), rel=1e-12)
    # the same run of the built-in pendulum, scored in degrees: the same error
    same = daebench.run("pendulum", "hht", h=1e-3, overrides={"t_end": 0.2})
    assert same.error["err_theta_max"] == pytest.approx(math.degrees(r.error["err_phi_max"]), rel=1e-9)
    assert same.error["err_pos_max"] == pytest.approx(r.error["err_bob_max"], rel=1e-9)


def test_declared_observables_are_scored_in_a_sweep_against_the_reference(bob):
    df = daebench.bench(str(bob["bob-ref"]), ["hht"], steps=[1e-3], reference="compute", write=False,
                        executor="inline", repeats=1)
    row = df.iloc[0]
    assert row["status"] == "completed" and row["against"] == "reference"
    # whole-run, before the first impact (no impact: the whole run) — for the column and the point
    for k in ("err_phi_max", "err_bob_max", "err_pre_phi_max", "err_pre_bob_max"):
        assert math.isfinite(row[k]), k
    # against the IDA reference (rtol 1e-11) the error is the exact one to the reference's accuracy
    exact = daebench.run(str(bob["bob-exact"]), "hht", h=1e-3).error
    assert row["err_phi_max"] == pytest.approx(exact["err_phi_max"], abs=1e-10)  # rad; the error is 2e-7
    assert row["err_pre_phi_max"] == row["err_phi_max"]


def test_run_summary_prints_declared_finals_and_units(bob):
    from daebench.cli.runs import run_summary

    lines = dict(run_summary(daebench.run(str(bob["bob-exact"]), "hht", h=1e-3)))
    assert "final phi [rad]" in lines and "final bob_y [m]" not in lines  # only `summary` columns
    err = next(v for k, v in lines.items() if k.startswith("error vs exact solution"))
    key = next(k for k in lines if k.startswith("error vs exact solution"))
    assert "phi in rad" in key and "bob in m" in key
    assert err.startswith("phi ") and ", bob " in err and "bob_x" not in err  # the point, not its coordinates


def test_declarations_are_checked():
    with pytest.raises(ParamError, match="fingerprint_tol"):
        Observable("a", fingerprint_tol=-1.0)
    with pytest.raises(ParamError, match="non-empty"):
        Position("", "x", "y")
    with pytest.raises(ParamError, match="twice"):
        Observables([Observable("a", short="s"), Observable("b", short="s")])
    with pytest.raises(ParamError, match="Observable"):
        Observables(["theta"])
    d = Observables(OBSERVABLES)
    assert d.get("undeclared").score_name == "undeclared" and d.derivative("phi") == ("phi_dot", 1.0)
    assert d.height_column(["t", "phi", "bob_y"]) == "bob_y" and d.height_column(["t"]) is None
    obs, pos = d.windowed(["phi", "bob_x", "bob_y"])
    assert [o.name for o in obs] == ["phi"] and [p.name for p in pos] == ["bob"]
