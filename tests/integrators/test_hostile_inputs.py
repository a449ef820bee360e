"""Hostile and careless input: every one is refused before anything runs, with exit code 2,
a message that names what is wrong (and how to fix it), and no traceback — or, where the
input is legitimate but the run cannot finish, a clean non-zero outcome, never a hang."""

from __future__ import annotations

from typing import ClassVar

import pytest
from typer.testing import CliRunner

from daebench.harness.sweeps import dask_cluster
from daebench.cli.app import app
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator, State
from daebench.integrators.registry import Registered

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
    reg = {**integrator_registry.registry(), "initbug": Registered("initbug", RaisesInInit, "tests"),
           "hang": Registered("hang", Hang, "tests")}
    monkeypatch.setattr(integrator_registry, "registry", lambda refresh=False: dict(reg))
    monkeypatch.setattr(dask_cluster, "DASK_CONNECT_TIMEOUT", 1.0)


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
    from daebench.harness.running.runner import run_scene
    from daebench.models.scenes import load_scene

    sc = load_scene("beam-impact", ["t_end=0.45", "discretization.n=5"])
    rec, res = run_scene(sc, "baumgarte", {"h": 5e-5}, write=False)
    assert rec.status == "diverged", (rec.status, rec.energy_residual)


# ---- issue 24: names, numbers, files, environment, the Python API ------------------------------
def _scene_file(folder, name_line: str) -> str:
    p = folder / "x.toml"
    p.write_text(f'model = "pendulum"\n{name_line}\nt_end = 0.05\n')
    return str(p)


@pytest.mark.parametrize("name, fragment", [
    ("/etc/passwd", "contains a path"),
    ("../../escape", "contains a path"),
    ("a/b", "contains a path"),
    ("-rf", "starts with '.' or '-'"),
    (".hidden", "starts with '.' or '-'"),
    ("x" * 300, "300 characters long, more than 100"),
])
def test_a_scene_name_is_a_file_name_stem(tmp_path, name, fragment):
    """Item 1: `name` went unsanitised into file paths (`/etc/passwd-hht-….csv` was
    written). Refused from the file and from --set, before anything runs; nothing is written
    anywhere (the output folder stays empty, and no file appears outside it)."""
    out = tmp_path / "out"
    before = set(tmp_path.parent.iterdir())
    refused(["run", _scene_file(tmp_path, f'name = "{name}"'), "-i", "hht", "--opt", "h=1e-2", "--out", str(out)],
            fragment)
    refused(P + ["--opt", "h=1e-2", "--set", f"name={name}", "--out", str(out)], fragment)
    assert "a scene name is a plain file-name stem" in runner.invoke(app, P + ["--set", f"name={name}"]).output
    assert not out.exists() or not any(out.iterdir())
    assert set(tmp_path.parent.iterdir()) == before
    assert not (tmp_path.parent.parent / "escape-hht").exists()


def test_set_name_renames_the_history(tmp_path):
    """`--set name=…` was accepted and ignored; it now names the history file."""
    r = runner.invoke(app, P + ["--opt", "h=1e-2", "--set", "t_end=0.05", "--set", "name=renamed", "--out",
                                str(tmp_path / "out")])
    assert r.exit_code == 0, r.output
    files = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert len(files) == 2 and all(f.startswith("renamed-hht-") for f in files), files


@pytest.mark.parametrize("args, fragment", [
    (P + ["--opt", "h=1_0e-3"], "no '_' in numbers"),
    (P + ["--set", "t_end=1_0"], "no '_' in numbers"),
    (["run", "pendulum", "-i", "ida", "--opt", "h=1e-3"], "setting 'h' = 0.001 would be ignored"),
    (["run", "pendulum", "-i", "ida", "--opt", "h_contact=1e-6"], "would be ignored"),
    (["run", "/dev/zero"], "not a regular file"),
    (["show", "beam-impact", "--keys", "--set", "bogus=1"], "unknown scene key 'bogus'"),
])
def test_issue24_inputs_refused(args, fragment):
    """Items 9, 12, 15: '1_0e-3' was read as 0.01; `h` was accepted and shown for IDA, which
    ignores it; `run /dev/zero` read until memory ran out; `show SCENE --set bogus=1` said
    the scene was neither an integrator nor a scene."""
    refused(args, fragment)


def test_show_set_typo_names_the_key_not_the_scene():
    r = runner.invoke(app, ["show", "beam-impact", "--keys", "--set", "bogus=1"])
    assert "neither an integrator nor a scene" not in r.output


def test_a_utf8_bom_is_accepted(tmp_path):
    p = tmp_path / "bom.toml"
    p.write_bytes(b"\xef\xbb\xbf" + b'model = "pendulum"\nt_end = 0.05\n')
    r = runner.invoke(app, ["run", str(p), "-i", "hht", "--opt", "h=1e-2", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert "bom with integrator hht" in r.output


def test_cases_folder_that_does_not_exist_is_an_error(monkeypatch, tmp_path):
    """`DAEBENCH_CASES=/nonexistent daebench list` showed no cases and exited 0."""
    monkeypatch.setenv("DAEBENCH_CASES", str(tmp_path / "nonexistent"))
    refused(["list"], "is not a folder")
    refused(["run", "pendulum"], "is not a folder")


def test_an_oversized_scene_file_is_refused_without_reading_it(tmp_path):
    p = tmp_path / "big.toml"
    with open(p, "wb") as fh:
        fh.truncate(50 << 20)            # sparse: 50 MB of zeros
    refused(["run", str(p)], "more than such a file can plausibly be")


API_BAD = [
    ("run", (None,), {}), ("run", (123,), {}), ("run", ({"model": "pendulum"},), {}),
    ("run", ("pendulum", "hht"), {"overrides": {1: 2}}), ("run", ("pendulum", "hht"), {"settings": "h=1e-3"}),
    ("run", ("pendulum", "hht"), {"out_dir": 123, "write": True, "h": 1e-2}),
    ("bench", ("pendulum", None), {"steps": [1e-2], "write": False}),
    ("bench", ("pendulum", ["hht"]), {"grid": {"alpha": 0.0}, "write": False}),
    ("bench", ("pendulum", ["hht"]), {"options": "alpha=0", "write": False}),
    ("reference", (None,), {}),
    ("load_scene", (None,), {}), ("load_scene", ({"model": "pendulum"},), {}), ("load_scene", (b"",), {}),
    ("load_scene", (42,), {}), ("load_scene", ("pendulum", 42), {}),
]


@pytest.mark.parametrize("fn, args, kw", API_BAD)
def test_the_python_api_raises_param_error(fn, args, kw):
    """Item 12: the README promises ParamError (a message with the fix) for bad input; these
    raised plain TypeError/ValueError."""
    import daebench
    from daebench.core.params import ParamError

    with pytest.raises(ParamError) as exc:
        getattr(daebench, fn)(*args, **kw)
    msg = str(exc.value)
    assert any(w in msg for w in ("must", "e.g.", "Valid keys")), msg   # what is wrong and how to fix it


@pytest.mark.parametrize("args, fragment", [
    (["capture", "page", "-e", "nan"], "must be a finite number"),
    (["capture", "page", "-e", "1.5"], "out of range [0, 1]"),
    (["capture", "page", "--h", "inf"], "must be a finite number"),
    (["capture", "page", "--steps", "1e-4,nan"], "must be a finite number"),
    (["capture", "page", "--tols", "1_0e-6"], "no '_' in numbers"),
    (["seed003", "chain", "--windows", "1e-3,nan"], "must be a finite number"),
])
def test_study_commands_refuse_bad_numbers(args, fragment):
    """Item 15: `capture page -e nan` said 'should be ≤ 1' (NaN passed typer's range)."""
    refused(args, fragment)


def test_capture_page_shows_progress_and_can_run_again(monkeypatch, tmp_path):
    """Item 16: the page ran 258 s with no output and could not be run twice (its table
    existed). It now asks for progress bars and passes --resume/--overwrite to its sweeps."""
    from daebench.core.params import ParamError
    from daebench.studies import event_capturing as eventcapture

    seen = {}

    def fake(*args, **kw):
        seen.update(kw)
        raise ParamError("stop here")

    monkeypatch.setattr(eventcapture, "compare", fake)
    refused(["capture", "page", "--overwrite", "--out", str(tmp_path / "cap")], "stop here")
    assert seen["progress"] is True and seen["overwrite"] is True and seen["resume"] is False
    refused(["capture", "page", "--resume", "--out", str(tmp_path / "cap")], "stop here")
    assert seen["resume"] is True


def test_a_start_through_the_plane_is_refused(tmp_path):
    """Item 9: beam-impact from θ = -30° starts 0.5 m through the plane; it ran and diverged
    (9e5 J). Refused before the run, naming the gap and the fix; nothing written."""
    refused(["run", "beam-impact", "-i", "hht", "--set", "start.theta_deg=-30", "--out", str(tmp_path / "o")],
            "0.5 m through its surface")
    refused(["bench", "beam-impact", "-i", "hht", "--steps", "1e-4", "--set", "start.theta_deg=-30",
             "--reference", "none"], "a rigid contact cannot start violated")
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_contact_keys_with_contact_off_are_noted(tmp_path):
    """Item 9: `effects.contact=false` with a contact law and restitution set was accepted
    silently; the run goes ahead and a note says those keys change nothing."""
    r = runner.invoke(app, ["run", "beam-impact", "-i", "hht", "--opt", "h=1e-3", "--set", "effects.contact=false",
                            "--set", "contact.law=hertz", "--set", "contact.restitution=0.5", "--set", "t_end=0.01",
                            "--set", "discretization.n=3", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert ("note: effects.contact = false, so contact.law, contact.restitution have no effect in this run"
            in r.output), r.output


@pytest.mark.parametrize("extra, fragment", [
    (["--grid", "h=1e-3,2e-3"], "grid key 'h' is also set by --steps"),
])
def test_a_grid_key_that_steps_also_sets_is_refused(extra, fragment):
    """Item 8: `--steps 1e-2 --grid h=1e-3,2e-3` made two runs, both at h = 0.01."""
    refused(B + extra, fragment)
    refused(["bench", "pendulum", "-i", "hht", "--tols", "1e-4", "--grid", "rtol=1e-3,1e-5", "--reference", "none"],
            "grid key 'rtol' is also set by --tols")


def test_the_run_summary_says_why_there_is_no_error_and_how_to_get_one(tmp_path):
    """Items 13, 14: no reference → the exact command that makes one for *this* scene (with
    the run's --set); the API's .error says why it has no errors."""
    import daebench

    r = runner.invoke(app, ["run", "beam-impact", "-i", "hht", "--opt", "h=1e-3", "--set", "t_end=0.002",
                            "--set", "discretization.n=3", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    flat = " ".join(r.output.split())
    assert ("`daebench reference beam-impact --set t_end=0.002 --set discretization.n=3` makes one" in flat
            or "`daebench reference beam-impact --set discretization.n=3 --set t_end=0.002` makes one" in flat), flat
    out = daebench.run("beam-impact", "hht", h=1e-3, overrides={"t_end": 0.002, "discretization.n": 3})
    assert out.error["against"] is None and "no cached reference" in out.error["why"]
