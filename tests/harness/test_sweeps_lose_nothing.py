"""Sweeps lose nothing: Ctrl-C keeps finished rows and resume completes the table with
bit-identical rows; a crashing plugin costs only its own row (its run in a forked child,
daebench.harness.running.isolated); a damaged reference is
caught in every mode; concurrent sweeps keep every row; the run cap works under Dask."""

from __future__ import annotations

import ctypes
import faulthandler
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import ClassVar

import numpy as np
import pandas as pd
import pytest

from daebench.harness.references import reference as references
from daebench.harness.sweeps import options, sweep as bench
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator, State
from daebench.integrators.registry import Registered
from daebench.models.scenes import load_scene

from _closed_forms import pendulum_theta_deg  # noqa: E402

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


def sweep(scene, integrators, **keywords):
    """A sweep with the API's keyword names (:func:`daebench.harness.sweeps.options.from_keywords`)."""
    return bench.run_sweep(scene, *options.from_keywords(integrators, keywords))


class _Stepper(Integrator):
    description: ClassVar[str] = "test only"
    capabilities: ClassVar[Capabilities] = Capabilities(order=1, constraints=True, index=3)
    settings_spec = STEP_SETTINGS

    def _start(self) -> None:
        pass

    def _step_impl(self, t_stop: float) -> State:
        self.misbehave()
        s = self.state
        return State(min(s.t + self.h, t_stop), s.q.copy(), s.v.copy(), s.a.copy(), s.lam.copy())


class Segv(_Stepper):
    name: ClassVar[str] = "segv"

    def misbehave(self) -> None:
        faulthandler.disable()  # the crash is the test's: no traceback dump in the suite's output
        ctypes.string_at(0)  # reads address 0: SIGSEGV


class Exit3(_Stepper):
    name: ClassVar[str] = "exit3"

    def misbehave(self) -> None:
        os._exit(3)


class CtrlC(_Stepper):
    name: ClassVar[str] = "ctrlc"

    def misbehave(self) -> None:
        raise KeyboardInterrupt


class Hang(_Stepper):
    name: ClassVar[str] = "hang"

    def misbehave(self) -> None:
        while True:
            time.sleep(0.01)


@pytest.fixture()
def plugins(monkeypatch, tmp_path):
    reg = {**integrator_registry.registry(), **{c.name: Registered(c.name, c, "tests") for c in (Segv, Exit3, CtrlC, Hang)}}
    monkeypatch.setattr(integrator_registry, "registry", lambda refresh=False: dict(reg))
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    return tmp_path


@pytest.fixture()
def pendulum():
    return load_scene("pendulum", ["t_end=0.2", "output.dt=1e-2"])


@pytest.mark.parametrize("jobs", [1, 2])
def test_crashing_plugins_cost_only_their_own_rows(plugins, pendulum, jobs):
    df = sweep(pendulum, ["segv", "hht", "exit3", "ctrlc"], steps=[1e-2, 5e-3], jobs=jobs,
               reference="none", progress=False, name="crash")
    by = {(r.integrator, r.h): r for r in df.itertuples()}
    for h, steps in ((1e-2, 20), (5e-3, 40)):
        assert by["hht", h].status == "completed" and by["hht", h].steps == steps
        assert by["segv", h].status == "crashed" and "SIGSEGV" in by["segv", h].message
        assert by["exit3", h].status == "crashed" and "exited with code 3" in by["exit3", h].message
        assert by["ctrlc", h].status == "failed" and "KeyboardInterrupt" in by["ctrlc", h].message
    # every row is on disk, and the command reports the failures with a non-zero exit code
    assert len(pd.read_parquet(plugins / "bench" / "crash.parquet")) == 8
    if jobs == 1:
        return
    from typer.testing import CliRunner

    from daebench.cli.app import app

    r = CliRunner().invoke(app, ["bench", "pendulum", "-i", "segv,hht", "--steps", "1e-2", "--set", "t_end=0.2",
                                 "--reference", "none", "-j", "2"])
    assert r.exit_code == 1 and "gave no verdict (crashed)" in r.output


def test_run_cap_under_dask_leaves_a_timeout_row_and_the_sweep_goes_on(plugins, pendulum):
    pytest.importorskip("dask.distributed")
    from dask.distributed import Client, LocalCluster

    from daebench.harness.running.runner import run_scene

    run_scene(pendulum, "hht", {"h": 1e-2}, write=False)  # kernels loaded: the cap measures the run alone
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        df = sweep(pendulum, ["hang", "hht"], steps=[1e-2], scheduler=client, reference="none",
                   progress=False, write=False, run_cap=2.0)
    by = df.set_index("integrator")
    assert by.loc["hang", "status"] == "timeout" and "wall-time cap of 2 s" in by.loc["hang", "message"]
    assert by.loc["hht", "status"] == "completed"


def _damage_truncate_rows(path: Path) -> None:
    pd.read_parquet(path).head(10).to_parquet(path, index=False)


def _damage_truncate_bytes(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _damage_empty_sidecar(path: Path) -> None:
    path.with_suffix(".json").write_text("")


def _damage_drop_column(path: Path) -> None:
    pd.read_parquet(path).drop(columns=["x"]).to_parquet(path, index=False)


def _hht_theta_error(scene) -> float:
    """max |θ − θ_exact| [deg] of hht at h = 1e-2 on the scene, θ_exact the pendulum's closed
    form (tests/_closed_forms.py: Jacobi elliptic functions)."""
    from daebench.driver.simulate import simulate
    from daebench.integrators.registry import get_integrator
    from daebench.models import build_system

    h = simulate(build_system(scene), get_integrator("hht")(h=1e-2), scene.t_end, scene["output.dt"]).history
    return float(np.max(np.abs(h["theta_deg"] - pendulum_theta_deg(h["t"]))))


@pytest.mark.parametrize("damage", [_damage_truncate_rows, _damage_truncate_bytes, _damage_empty_sidecar,
                                    _damage_drop_column])
def test_damaged_reference_is_caught_in_every_mode(plugins, pendulum, damage):
    good = references.compute_reference(pendulum, rtol=1e-9, atol=1e-11, check=False)
    truth = _hht_theta_error(pendulum)
    assert sweep(pendulum, ["hht"], steps=[1e-2], reference="require", progress=False,
                 write=False)["err_theta_max"].iloc[0] == pytest.approx(truth, rel=1e-3)
    damage(good.path)
    with pytest.raises(references.ReferenceDamaged, match="daebench reference pendulum --force"):
        sweep(pendulum, ["hht"], steps=[1e-2], reference="require", progress=False, write=False)
    for i, mode in enumerate(("auto", "compute")):  # recomputed (default tolerance), then scored as before
        if i:
            damage(references.reference_path(pendulum))
        df = sweep(pendulum, ["hht"], steps=[1e-2], reference=mode, progress=False, write=False)
        assert df["err_theta_max"].iloc[0] == pytest.approx(truth, rel=1e-3)
        references.validate(pendulum, references.reference_path(pendulum))  # valid again
    damage(references.reference_path(pendulum))
    df = sweep(pendulum, ["hht"], steps=[1e-2], reference="none", progress=False, write=False)
    # the damaged reference is not read; the pendulum is scored against its exact solution
    assert df["against"].iloc[0] == "exact solution" and df["err_theta_max"].iloc[0] == pytest.approx(truth, rel=1e-3)


# ---- the command line, in real processes ------------------------------------------------------
# slow enough that a signal sent after the first rows lands while later ones run (2e5 steps a
# row, timed as a warm-up and the best of 3). Run the suite in the foreground: a shell's
# background job starts with SIGINT ignored, and these tests then fail for want of a Ctrl-C.
SLOW_SWEEP = ["bench", "pendulum", "-i", "hht", "--steps", "1e-5", "--grid", "alpha=0,-0.05,-0.1,-0.15,-0.2",
              "--set", "t_end=2", "--reference", "none"]


def daebench(*args: str, results: Path) -> subprocess.Popen:
    env = dict(os.environ, DAEBENCH_RESULTS=str(results), COLUMNS="100")
    # SIGINT at its default in the child: a shell's background job (the suite run with `&`)
    # hands its children SIGINT ignored, and Python then never sees the Ctrl-C these tests send
    return subprocess.Popen([sys.executable, "-m", "daebench.cli.app", *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def stored_rows(results: Path, name: str) -> int:
    db = results / "bench" / f"{name}.rows.sqlite"
    if not db.exists():
        return 0
    try:
        with sqlite3.connect(db, timeout=5) as con:
            return con.execute("SELECT COUNT(*) FROM rows").fetchone()[0]
    except sqlite3.OperationalError:  # the table is being created
        return 0


def wait_for(cond, proc: subprocess.Popen, what: str, limit: float = 300.0) -> None:
    """Poll until ``cond()``; fail (not hang) if the process ends first or after ``limit`` s."""
    t0 = time.monotonic()
    while not cond():
        assert proc.poll() is None, f"process ended before {what}: {proc.communicate()}"
        assert time.monotonic() - t0 < limit, f"no {what} after {limit} s"
        time.sleep(0.05)


def test_sigint_keeps_finished_rows_and_resume_completes_them_bit_identically(tmp_path):
    res = tmp_path / "results"
    p = daebench(*SLOW_SWEEP, "--name", "s", "-j", "2", results=res)  # -j 2: workers stop at once too
    wait_for(lambda: stored_rows(res, "s") >= 2, p, "two finished rows")
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "continue with: daebench bench" in err and "--resume" in err
    partial = pd.read_parquet(res / "bench" / "s.parquet")
    kept = partial[partial.status == "completed"]
    assert len(partial) == 5 and len(kept) >= 2
    assert set(partial.status) <= {"completed", "interrupted"}

    p = daebench(*SLOW_SWEEP, "--name", "s", "-j", "2", "--resume", results=res)
    out, err = p.communicate(timeout=300)
    assert p.returncode == 0, err
    full = pd.read_parquet(res / "bench" / "s.parquet")
    assert len(full) == 5 and (full.status == "completed").all()
    # the rows finished before Ctrl-C are the stored ones, bit for bit (timings included; the
    # partial table's integer columns are float there, padded with NaN for the unfinished runs)
    pd.testing.assert_frame_equal(full.loc[kept.index, kept.columns].reset_index(drop=True),
                                  kept.reset_index(drop=True), check_exact=True, check_dtype=False)
    # and the whole table equals an uninterrupted sweep's, but for the timings
    p = daebench(*SLOW_SWEEP, "--name", "whole", results=res)
    assert p.wait(timeout=300) == 0
    whole = pd.read_parquet(res / "bench" / "whole.parquet")
    drop = [c for c in bench.TIMING_COLUMNS if c in whole.columns]
    pd.testing.assert_frame_equal(full.drop(columns=drop), whole.drop(columns=drop), check_exact=True)


def test_concurrent_sweeps_lose_no_row(tmp_path):
    res = tmp_path / "results"
    quick = ["bench", "pendulum", "-i", "hht,newmark", "--steps", "1e-2,5e-3", "--set", "t_end=0.2",
             "--reference", "none", "-j", "1"]
    a, b = daebench(*quick, results=res), daebench(*quick, results=res)
    assert a.wait(timeout=300) == 0 and b.wait(timeout=300) == 0, (a.communicate(), b.communicate())
    tables = sorted((res / "bench").glob("pendulum-*.parquet"))
    assert len(tables) == 2  # unique default names: neither replaced the other
    for t in tables:
        assert (pd.read_parquet(t).status == "completed").sum() == 4
    # one name, two sweeps at once: the second is refused while the first writes
    first = daebench(*SLOW_SWEEP, "--name", "same", "-j", "1", results=res)
    wait_for(lambda: stored_rows(res, "same") >= 1, first, "a first row")
    second = daebench(*quick, "--name", "same", results=res)
    _, err = second.communicate(timeout=120)
    assert second.returncode == 2 and "being written by another sweep" in err
    first.send_signal(signal.SIGINT)
    first.communicate(timeout=60)
    assert first.returncode == 130 and stored_rows(res, "same") >= 1


def test_wall_time_cap_waits_for_numba_compilation():
    """A cap that falls inside a numba compilation takes effect after it: an exception
    raised inside the compiler (LLVM calls back into Python) killed workers on a cold cache
    when the 1-s warm-up cap fired there."""
    import time

    import numba

    from daebench.harness.running.compile_events import COMPILE_DEPTH
    from daebench.harness.running.deadline import RunTimeout, deadline

    @numba.njit
    def fresh(x):                       # a new dispatcher: its first call compiles (≫ 10 ms)
        s = 0.0
        for i in range(10):
            s += np.sin(x * i) / (1.0 + i)
        return s

    done = []
    with pytest.raises(RunTimeout):
        with deadline(0.01):
            fresh(1.0)
            done.append(time.perf_counter())
            time.sleep(2.0)             # the cap lands here, after the compilation
    assert done and fresh.signatures and not COMPILE_DEPTH.compiling(threading.get_ident())
