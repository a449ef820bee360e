"""Sweeps never lose a row; grids are classified before running; references cache and load."""

from __future__ import annotations

import json
import math
from typing import ClassVar

import numpy as np
import pandas as pd
import pytest

from daebench.harness.sweeps import options, sweep as bench
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator, State
from daebench.integrators.registry import Registered
from daebench.harness.references.reference import ReferenceMissing, compute_reference, load_reference, reference_tolerances
from daebench.harness.running.runner import run_scene
from daebench.harness.sweeps.options import Execution, SweepError, SweepOptions
from daebench.harness.sweeps.plan import RunSpec, plan_sweep

# the exploding test integrator overflows on purpose
pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


def sweep(scene, integrators, **keywords):
    """A sweep with the API's keyword names (:func:`daebench.harness.sweeps.options.from_keywords`)."""
    return bench.run_sweep(scene, *options.from_keywords(integrators, keywords))


class Boom(Integrator):
    """Raises an ordinary exception (a bug, not a StepFailure) on its third step."""

    name: ClassVar[str] = "boom"
    description: ClassVar[str] = "test only: raises"
    capabilities: ClassVar[Capabilities] = Capabilities(order=1, constraints=True, index=3)
    settings_spec = STEP_SETTINGS

    def _start(self) -> None:
        pass

    def _step_impl(self, t_stop: float) -> State:
        if self.counters.steps >= 2:
            raise KeyError("deliberate bug in _step_impl")
        s = self.state
        return State(min(s.t + self.h, t_stop), s.q.copy(), s.v.copy(), s.a.copy(), s.lam.copy())


class Explode(Integrator):
    """Multiplies the state by 1e100 every step (overflow after a few): the driver must call it diverged."""

    name: ClassVar[str] = "explode"
    description: ClassVar[str] = "test only: diverges"
    capabilities: ClassVar[Capabilities] = Capabilities(order=1, constraints=True, index=3)
    settings_spec = STEP_SETTINGS

    def _start(self) -> None:
        pass

    def _step_impl(self, t_stop: float) -> State:
        s = self.state
        return State(min(s.t + self.h, t_stop), 1e100 * s.q, 1e100 * s.v + 1.0, s.a.copy(), s.lam.copy())


@pytest.fixture()
def registry(monkeypatch, tmp_path):
    real = integrator_registry.registry()
    reg = {**real, "boom": Registered("boom", Boom, "tests"), "explode": Registered("explode", Explode, "tests")}
    monkeypatch.setattr(integrator_registry, "registry", lambda: dict(reg))
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    return reg


@pytest.fixture()
def pendulum():
    from daebench.models.scenes import load_scene

    return load_scene("pendulum", ["t_end=0.2", "output.dt=1e-2"])


@pytest.mark.parametrize("jobs", [1, 2])
def test_raise_diverge_succeed_give_three_rows(registry, pendulum, tmp_path, jobs):
    df = sweep(pendulum, ["boom", "explode", "hht"], steps=[1e-2], jobs=jobs,
               reference="none", progress=False, name="three")
    assert len(df) == 3
    by = df.set_index("integrator")
    assert by.loc["boom", "status"] == "failed" and "deliberate bug" in by.loc["boom", "message"]
    assert by.loc["explode", "status"] == "diverged" and by.loc["explode", "verdict"] == "diverged"
    assert by.loc["hht", "status"] == "completed"
    assert by.loc["hht", "verdict_t"] == pytest.approx(0.2)
    assert by.loc["hht", "steps"] == 20
    assert (tmp_path / "bench" / "three.parquet").exists() and (tmp_path / "bench" / "three.csv").exists()
    side = json.loads((tmp_path / "bench" / "three.json").read_text())
    assert side["rows"] == 3 and "numpy" in side["provenance"]["versions"]


def test_scored_against_the_exact_solution_and_nan_for_diverged(registry, pendulum):
    """The pendulum has an exact solution: a sweep scores against it (as `daebench.run`
    does), not against the reference it also requires."""
    ref = compute_reference(pendulum, rtol=1e-10, atol=1e-12)
    assert ref.path.exists() and ref.meta["agreement"]["err_theta_max"] < 1e-5
    again = load_reference(pendulum)
    pd.testing.assert_frame_equal(again.history, ref.history)
    df = sweep(pendulum, ["explode", "hht"], steps=[1e-2, 5e-3], jobs=1, reference="require",
               progress=False, write=False)
    ok = df[df.integrator == "hht"].sort_values("h")
    assert ok["err_theta_max"].notna().all() and (ok["against"] == "exact solution").all()
    e_big, e_small = ok["err_theta_max"].iloc[1], ok["err_theta_max"].iloc[0]
    assert 3.0 < e_big / e_small < 5.0  # order 2
    assert df[df.integrator == "explode"]["err_theta_max"].isna().all()


def test_grid_keys_classified_and_unknown_refused(registry, pendulum):
    specs = plan_sweep(pendulum, ["hht", "ida"], grid={"alpha": [0.0, -0.1], "pendulum.length": [1, 2]},
                             steps=[1e-2])
    # alpha varies only for hht (2 × 2 lengths); ida has no fixed step → skipped rows (2 lengths)
    hht = [s for s in specs if s.integrator == "hht"]
    assert len(hht) == 4 and {s.options["alpha"] for s in hht} == {0.0, -0.1}
    assert all(s.scene_overrides["pendulum.length"] in (1, 2) for s in specs)
    assert all(s.skip for s in specs if s.integrator == "ida")
    with pytest.raises(SweepError, match="unknown grid key 'alpah'.*alpha"):
        plan_sweep(pendulum, ["hht"], grid={"alpah": [0.0]})
    with pytest.raises(SweepError, match="unknown integrator 'hhtt'"):
        plan_sweep(pendulum, ["hhtt"])
    with pytest.raises(ReferenceMissing, match="daebench reference pendulum"):
        sweep(pendulum, ["hht"], steps=[1e-2], reference="require", progress=False)


def test_tols_skip_fixed_step_only(registry, pendulum):
    specs = plan_sweep(pendulum, ["hht", "boom"], tols=[1e-4])
    hht, boom = specs
    assert hht.options["adaptive"] is True and hht.options["rtol"] == 1e-4
    assert "no adaptive" in boom.skip
    df = bench.run_specs(specs, pendulum, SweepOptions(reference="none", execution=Execution(progress=False)))
    assert list(df.status) == ["completed", "skipped"]


def test_reference_tolerance_margin():
    assert reference_tolerances() == (1e-11, 1e-13)
    r, a = reference_tolerances(tightest_rtol=1e-10)
    assert r == pytest.approx(1e-12) and a == pytest.approx(1e-14)


class Hang(Boom):
    """Never finishes a step (like a driver stuck on repeated events)."""

    name: ClassVar[str] = "hang"

    def _step_impl(self, t_stop: float) -> State:
        import time
        while True:
            time.sleep(0.01)


def test_hanging_run_is_a_failed_row(registry, pendulum, monkeypatch):
    reg = {**integrator_registry.registry(), "hang": Registered("hang", Hang, "tests")}
    monkeypatch.setattr(integrator_registry, "registry", lambda: dict(reg))
    run_scene(pendulum, "hht", {"h": 1e-2}, write=False)  # kernels loaded (workers fork from here)
    df = sweep(pendulum, ["hang", "hht"], steps=[1e-2], reference="none", progress=False,
               write=False, run_cap=2.0)
    by = df.set_index("integrator")
    assert by.loc["hang", "status"] == "timeout" and "wall-time cap" in by.loc["hang", "message"]
    assert by.loc["hht", "status"] == "completed"


def test_cli_bench_reference_plot_and_clear_errors(registry, tmp_path):
    from typer.testing import CliRunner

    from daebench.cli.app import app

    run = CliRunner().invoke
    r = run(app, ["bench", "pendulum", "-i", "hht,bogus", "--steps", "1e-2"])
    assert r.exit_code == 2 and "unknown integrator 'bogus'" in r.output
    r = run(app, ["bench", "pendulum", "-i", "hht", "--grid", "alpah=0", "--steps", "1e-2"])
    assert r.exit_code == 2 and "did you mean 'alpha'" in r.output
    sets = ["--set", "t_end=0.2", "--set", "output.dt=1e-2"]
    r = run(app, ["bench", "pendulum", "-i", "hht", "--steps", "1e-2", *sets])
    assert r.exit_code == 2 and "daebench reference pendulum" in r.output
    r = run(app, ["reference", "pendulum", *sets, "--rtol", "1e-9"])
    assert r.exit_code == 0, r.output
    r = run(app, ["bench", "pendulum", "-i", "hht", "--steps", "2e-2,1e-2", "--name", "t", *sets])
    assert r.exit_code == 0, r.output
    r = run(app, ["plot", "wp", str(tmp_path / "bench" / "t.parquet"), "--out", str(tmp_path / "wp")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "wp.png").exists() and (tmp_path / "wp.svg").exists()
    r = run(app, ["plot", "wp", str(tmp_path / "bench" / "t.parquet"), "--y", "nope"])
    assert r.exit_code == 2 and "column 'nope'" in r.output


def test_dask_executor_gives_the_rows_of_the_process_pool(registry, pendulum):
    """The scale-out executor: a local Dask cluster of worker processes returns the same
    scored rows as the process pool (same steps, same errors to round-off), and a run
    that raises or diverges is still a row with its reason (in-process threaded cluster,
    where the test-only integrators are registered)."""
    pytest.importorskip("dask.distributed")
    from dask.distributed import Client, LocalCluster

    compute_reference(pendulum, rtol=1e-10, atol=1e-12)
    kw = dict(steps=[1e-2, 5e-3], reference="require", progress=False, write=False)
    local = sweep(pendulum, ["hht", "newmark"], jobs=2, **kw)
    dask = sweep(pendulum, ["hht", "newmark"], jobs=2, scheduler="local", **kw)
    assert list(dask["label"]) == list(local["label"]) and (dask["status"] == "completed").all()
    assert list(dask["steps"]) == list(local["steps"])
    np.testing.assert_allclose(dask["err_theta_max"], local["err_theta_max"], rtol=1e-9)

    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        df = sweep(pendulum, ["boom", "explode", "hht"], steps=[1e-2], scheduler=client,
                   reference="none", progress=False, write=False)
    by = df.set_index("integrator")
    assert by.loc["boom", "status"] == "failed" and "deliberate bug" in by.loc["boom", "message"]
    assert by.loc["explode", "status"] == "diverged" and by.loc["hht", "steps"] == 20


def test_observable_of_a_switched_off_effect_is_reported_not_scored(registry):
    """beam-impact lists 'gap'; with effects.contact=false the model does not compute it: the
    run is scored on the rest and the row says which observable was left out (a typo is
    refused instead: tests/integrators/test_hostile_inputs.py)."""
    from daebench.models.scenes import load_scene

    sc = load_scene("beam-impact", ["effects.contact=false", "discretization.n=3", "t_end=0.05"])
    df = sweep(sc, ["hht"], steps=[1e-4], reference="compute", progress=False, write=False)
    row = df.iloc[0]
    assert row["status"] == "completed" and row["unscored_observables"] == "gap"
    assert math.isfinite(row["err_theta_max"]) and "err_gap_max" not in df.columns


def test_a_reference_too_loose_for_the_sweep_is_recomputed_under_compute(tmp_path, monkeypatch, capsys):
    """survey/compare with --reference compute: a cached reference not REF_MARGIN tighter than
    the tightest scored rtol is replaced by one that is (said on stderr); 'require' refuses it."""
    from daebench.harness.references.reference import load_reference
    from daebench.models.scenes import load_scene

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    sc = load_scene("pendulum").with_overrides({"t_end": 0.2})
    compute_reference(sc, rtol=1e-8, check=False)
    specs = [RunSpec(0, "ida", {"rtol": 1e-10}, {}, {"rtol": 1e-10})]
    with pytest.raises(SweepError, match="not 100× tighter"):
        bench.prepare_references(specs, sc, "require")
    bench.prepare_references(specs, sc, "compute")
    assert "computing one at rtol 1e-12 in its place" in capsys.readouterr().err
    assert load_reference(sc, mode="require").rtol == pytest.approx(1e-12)
    bench.prepare_references(specs, sc, "require")  # now tight enough: accepted as it is
