"""Hostile and careless input: every one is refused before anything runs, with exit code 2,
a message that names what is wrong (and how to fix it), and no traceback — or, where the
input is legitimate but the run cannot finish, a clean non-zero outcome, never a hang."""

from __future__ import annotations

from typing import ClassVar

import pytest
from typer.testing import CliRunner

from daebench.harness import executors
from daebench.cli.app import app
from daebench.integrators import base
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator, Registered, State

runner = CliRunner()


class RaisesInInit(Integrator):
    """A plugin whose constructor has a bug."""

    name: ClassVar[str] = "initbug"
    description: ClassVar[str] = "test only: raises in __init__"
    capabilities: ClassVar[Capabilities] = Capabilities(order=1, constraints=True, index=3)
    settings_spec = STEP_SETTINGS

    def __init__(self, **settings):
        raise KeyError("deliberate bug in __init__")


class Hang(Integrator):
    name: ClassVar[str] = "hang"
    description: ClassVar[str] = "test only: never finishes a step"
    capabilities: ClassVar[Capabilities] = Capabilities(order=1, constraints=True, index=3)
    settings_spec = STEP_SETTINGS

    def _start(self) -> None:
        pass

    def _step_impl(self, t_stop: float) -> State:
        import time
        while True:
            time.sleep(0.01)


@pytest.fixture(autouse=True)
def isolated(monkeypatch, tmp_path):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    monkeypatch.chdir(tmp_path)
    reg = {**base.registry(), "initbug": Registered("initbug", RaisesInInit, "tests"),
           "hang": Registered("hang", Hang, "tests")}
    monkeypatch.setattr(base, "registry", lambda refresh=False: dict(reg))
    monkeypatch.setattr(executors, "DASK_CONNECT_TIMEOUT", 1.0)


def refused(args: list[str], fragment: str, code: int = 2) -> None:
    r = runner.invoke(app, args)
    assert r.exit_code == code, (args, r.output)
    assert fragment in r.output, (args, r.output)
    assert "Traceback" not in r.output
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)


@pytest.fixture()
def files(tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    (d / "a-file").write_text("x")
    (d / "binary.toml").write_bytes(b"\x00\xff\xfe\x80" * 50)
    (d / "obs-string.toml").write_text('model = "pendulum"\n[output]\nobservables = "theta_deg"\n')
    (d / "model-list.toml").write_text('model = ["pendulum", "hub-beam"]\n')
    (d / "quoted.toml").write_text('model = "pendulum"\nt_end = "1.0"\n')
    (d / "truncated.parquet").write_bytes(b"PAR1\x00\x01")
    import pandas as pd
    pd.DataFrame({"t": [0.0, 1.0], "theta_deg": [1.0, 2.0]}).to_csv(d / "history.csv", index=False)
    pd.DataFrame({"label": ["hht"], "status": ["completed"], "wall_s": [1.0]}).to_csv(d / "table.csv", index=False)
    return d


P = ["run", "pendulum", "-i", "hht"]
B = ["bench", "pendulum", "-i", "hht", "--steps", "1e-2", "--set", "t_end=0.05", "--reference", "none"]


@pytest.mark.parametrize("args, fragment", [
    (P + ["--opt", "rtol=nan"], "'rtol' must be a finite number"),
    (P + ["--opt", "h=inf"], "'h' must be a finite number"),
    (P + ["--opt", "h=abc"], "must be a number"),
    (P + ["--opt", "alpha=0.5"], "out of range"),
    (P + ["--opt", "h=1e-12"], "beyond the limit"),
    (P + ["--opt", "alpah=0"], "did you mean 'alpha'"),
    (P + ["--opt", "h"], "must look like key=value"),
    (P + ["--set", "t_end=nan"], "'t_end' must be a finite number"),
    (P + ["--set", "t_end=inf"], "'t_end' must be a finite number"),
    (P + ["--set", "output.dt=nan"], "'output.dt' must be a finite number"),
    (P + ["--set", "t_end=1e9"], "out of range"),
    (P + ["--set", "output.dt=1e-9"], "history rows"),
    (P + ["--set", "model=hub-beam"], "'model' cannot be overridden"),
    (P + ["--set", "output.observables=theta,bogus"], "is not an observable of model 'pendulum'"),
    (P + ["--set", "pendulum.length=-1"], "out of range"),
    (P + ["--run-cap", "-1"], "run cap must be a finite number of seconds > 0"),
    (P + ["--run-cap", "nan"], "run cap must be a finite number"),
    (["run", "beam-impact", "-i", "hht", "--set", "contact.restitution=nan"], "must be a finite number"),
    (["run", "beam-impact", "-i", "hht", "--set", "discretization.n=inf"], "must be a finite number"),
    (["run", "beam-impact", "-i", "hht", "--set", "contact.law=complementarity"], "must be one of"),
    (["run", "beam-impact", "-i", "lcp"], "chain-impact"),
    (["run", "pendulum", "-i", "hhtt"], "did you mean 'hht'"),
    (["run", "pendulum", "-i", "initbug"], "raised while being configured"),
    (["run", "pendulm"], "did you mean 'pendulum'"),
    (["show", "hhtt"], "did you mean"),
    (["reference", "pendulum", "--rtol", "nan"], "finite"),
    (["reference", "pendulum", "--set", "t_end=nan"], "finite"),
    (B[:3] + ["HHT,bogus"] + B[4:], "unknown integrator 'bogus'"),
    (B + ["-j", "0"], "jobs must be a whole number from 1"),
    (B + ["-j", "-3"], "jobs must be a whole number from 1"),
    (B + ["--repeats", "0"], "repeats must be a whole number from 1"),
    (B + ["--run-cap", "-1"], "run cap must be a finite number"),
    (B + ["--name", "a/b/c"], "must be a plain file name"),
    (B + ["--name", ".."], "must be a plain file name"),
    (B + ["--steps", "nan"], "must be a finite number"),
    (B[:5] + ["1e-2,abc"] + B[6:], "must be a number"),
    (B[:5] + ["1e-13"] + B[6:], "out of range"),
    (B + ["--tols", "1e-4"], "not both"),
    (B + ["--reference", "bogus"], "unknown reference mode"),
    (B + ["--scheduler", "nowhere"], "must be 'local' or an address"),
    (B + ["--scheduler", "tcp://127.0.0.1:9"], "cannot reach the Dask scheduler"),
    (B + ["--name", "x", "--resume"], "nothing to resume"),
    (B + ["--resume", "--overwrite", "--name", "x"], "not both"),
    (B + ["--grid", "alpha="], "has no values"),
    (B + ["--grid", "alpha=0", "--grid", "alpha=-0.1"], "given twice"),
    (B + ["--grid", "alpah=0"], "did you mean 'alpha'"),
    (B + ["--grid", "alpha=nan"], "finite"),
    (B[:5] + ["1e-12"] + B[6:], "beyond the limit"),
    (B[:3] + ["initbug"] + B[4:], "raised while being configured"),
])
def test_refused_cleanly_with_exit_code_2(args, fragment):
    refused(args, fragment)


def test_bad_files_and_folders_are_refused(files, monkeypatch):
    refused(["run", str(files)], "is a folder")
    refused(["run", str(files / "binary.toml")], "not a text file")
    refused(["run", str(files / "obs-string.toml")], "must be a list of names")
    refused(["run", str(files / "model-list.toml")], "must be one model name")
    refused(["run", str(files / "quoted.toml")], "write the number without quotes")
    refused(P + ["--out", str(files / "a-file")], "is a file, not a folder")
    refused(P + ["--out", str(files / "a-file" / "sub")], "cannot write to history folder")
    refused(["plot", "wp", str(files)], "is a folder")
    refused(["plot", "wp", str(files / "truncated.parquet")], "cannot read table")
    refused(["plot", "wp", str(files / "history.csv")], "not a sweep table")
    refused(["plot", "wp", str(files / "nope.parquet")], "does not exist")
    refused(["plot", "history", str(files / "table.csv")], "plot it with `daebench plot wp`")
    refused(["plot", "history", str(files / "nope.csv")], "does not exist")
    refused(["plot", "history", str(files / "truncated.parquet")], "cannot read")
    # a results folder that cannot be written is found before any run, not after the sweep
    monkeypatch.setenv("DAEBENCH_RESULTS", str(files / "a-file" / "results"))
    refused(B, "cannot write to table folder")


def test_existing_table_is_never_replaced_without_being_asked(tmp_path):
    r = runner.invoke(app, B + ["--name", "t"])
    assert r.exit_code == 0, r.output
    before = (tmp_path / "results" / "bench" / "t.parquet").read_bytes()
    refused(B + ["--name", "t"], "already exists")
    assert (tmp_path / "results" / "bench" / "t.parquet").read_bytes() == before
    refused(B + ["--steps", "5e-3", "--name", "t", "--resume"], "planned with other arguments")
    r = runner.invoke(app, B + ["--name", "t", "--overwrite"])
    assert r.exit_code == 0, r.output


def test_case_insensitive_names_run():
    r = runner.invoke(app, ["run", "PENDULUM", "-i", "HHT", "--opt", "h=1e-2", "--set", "t_end=0.05"])
    assert r.exit_code == 0, r.output
    assert "pendulum with integrator hht" in r.output


def test_a_run_over_its_cap_stops_cleanly():
    """`run --run-cap`: a hanging integrator ends with exit code 1 and a message, no hang."""
    refused(["run", "pendulum", "-i", "hang", "--opt", "h=1e-2", "--run-cap", "0.3"], "wall-time cap of 0.3 s", 1)


def test_baumgarte_energy_blow_up_is_diverged():
    """3 J → ~460 J used to end 'completed'; the driver's energy-balance threshold now says diverged."""
    from daebench.harness.runner import run_scene
    from daebench.models.scenes import load_scene

    sc = load_scene("beam-impact", ["t_end=0.45", "discretization.n=5"])
    rec, res = run_scene(sc, "baumgarte", {"h": 5e-5}, write=False)
    assert rec.status == "diverged", (rec.status, rec.energy_residual)
