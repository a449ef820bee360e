"""A plugin's mistakes said where they happen: a wrong shape or a step that does not advance
ends the run at that step with the array, its shape and the expected one; `--traceback`
shows the plugin's own frames; a refused sweep leaves no file behind."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

import daebench
from daebench.cli.app import app
from daebench.core.system import State
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator

runner = CliRunner()


class Euler(Integrator):
    name = "t-euler"
    description = "explicit Euler at acceleration level (test)"
    capabilities = Capabilities(order=1, constraints=True, index=1)
    settings_spec = STEP_SETTINGS
    calls = 0

    def _start(self) -> None:
        pass

    def _step_impl(self, t_stop: float) -> State:
        type(self).calls += 1
        s, p = self.state, self.problem
        h = min(self.h, t_stop - s.t)
        q, v = s.q + h * s.v, s.v + h * s.a
        a, lam = p.acceleration(s.t + h, q, v)
        return State(s.t + h, q, v, a, lam)


class WrongShape(Euler):
    name = "t-wrongshape"

    def _step_impl(self, t_stop: float) -> State:
        s = super()._step_impl(t_stop)
        return State(s.t, s.q, s.v, s.a, np.zeros(3))


class Stuck(Euler):
    name = "t-stuck"

    def _step_impl(self, t_stop: float) -> State:
        s = super()._step_impl(t_stop)
        return State(self.state.t, s.q, s.v, s.a, s.lam)


class Buggy(Euler):
    name = "t-buggy"
    error = ValueError

    def _step_impl(self, t_stop: float) -> State:
        return plugin_helper(self.state, self.error)


def plugin_helper(state: State, error: type) -> State:
    raise error("a bug two frames inside the plugin")


@pytest.fixture
def plugins():
    for c in (Euler, WrongShape, Stuck, Buggy):
        daebench.register(c)
    yield
    for c in (Euler, WrongShape, Stuck, Buggy):
        integrator_registry.unregister(c.name)


def test_a_wrong_shape_ends_the_run_at_that_step_naming_the_array(plugins):
    r = daebench.run("pendulum", "t-wrongshape", h=1e-3)
    assert r.status == "failed"
    assert ("integrator 't-wrongshape' broke the step contract in the step from t = 0 s: lam has shape (3,), "
            "expected (1,) (1 active constraints in this phase)") in r.message


def test_a_step_that_does_not_advance_ends_the_run_at_once(plugins):
    Stuck.calls = 0
    r = daebench.run("pendulum", "t-stuck", h=1e-3)
    assert r.status == "failed" and "does not advance t" in r.message and Stuck.calls == 1


def test_traceback_of_run_shows_the_plugins_frames(plugins, tmp_path, monkeypatch):
    """Any exception of the plugin ends the run as a failure (the driver's verdict), and
    `--traceback` shows where the plugin raised it."""
    r = daebench.run("pendulum", "t-buggy", h=1e-3)
    assert r.status == "failed" and "ValueError: a bug two frames inside the plugin" in r.message
    assert "plugin_helper" in r.traceback and "test_contract.py" in r.traceback
    for error in (ValueError, IndexError):
        monkeypatch.setattr(Buggy, "error", error)
        args = ["run", "pendulum", "-i", "t-buggy", "--opt", "h=1e-3", "--out", str(tmp_path)]
        out = runner.invoke(app, args + ["--traceback"])
        assert out.exit_code == 1 and 'raise error("a bug two frames inside the plugin")' in out.stderr, error
        plain = runner.invoke(app, args)
        assert plain.exit_code == 1 and "plugin_helper" not in plain.stderr


def test_an_error_rows_traceback_reaches_the_plugins_frames(plugins, monkeypatch):
    def explode(*args, **kwargs):
        return plugin_helper(None, RuntimeError)

    monkeypatch.setattr(Euler, "_start", explode)
    df = daebench.bench("pendulum", ["t-euler"], steps=[1e-3], overrides={"t_end": 0.01}, reference="none",
                        write=False, executor="inline")
    assert df["status"].iloc[0] == "failed" and "RuntimeError" in df["message"].iloc[0]
    assert "plugin_helper" in df["traceback"].iloc[0]


def test_a_refused_sweep_leaves_nothing_behind(tmp_path):
    folder = tmp_path / "bench"
    with pytest.raises(daebench.ParamError, match="no reference"):
        daebench.bench("beam-impact", ["hht"], steps=[1e-3], overrides={"t_end": 0.01, "contact.restitution": 0.123},
                       reference="require", name="refused", folder=folder)
    assert list(folder.iterdir()) == []
    with pytest.raises(daebench.ParamError, match="nothing to resume"):
        daebench.bench("pendulum", ["hht"], steps=[1e-3], reference="none", name="absent", folder=folder, resume=True)
    assert list(folder.iterdir()) == []


def test_the_ball_is_scored_against_its_exact_solution():
    """`daebench list` says the ball's impact times and apex heights are exact: `run` uses them."""
    r = daebench.run("ball", "hht", h=1e-3, overrides={"t_end": 1.0})
    assert r.error["against"] == "exact solution" and r.error["err_x_max"] < 1e-9
    out = runner.invoke(app, ["run", "ball", "-i", "hht", "--opt", "h=1e-3", "--set", "t_end=1", "--out", "/tmp"])
    assert "error vs exact solution" in out.stdout and "no exact solution" not in out.stdout
    for cmd in ("bench", "compare", "survey"):
        help_text = " ".join(runner.invoke(app, [cmd, "--help"], env={"COLUMNS": "200"}).stdout.split())
        assert "none (no reference: runs are scored only against a model's exact solution)" in help_text, cmd
