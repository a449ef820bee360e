"""The third hostile round: no false "completed", no trusted field unchecked, nothing
written or executed outside its place, no traceback. One section per group of failures;
each test reproduces a failure that was found and holds its fix."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from daebench.cli.app import app
from daebench.harness.references import stored

runner = CliRunner()


def cli(args: list[str]):
    r = runner.invoke(app, args)
    assert "Traceback" not in r.output, r.output
    assert r.exception is None or isinstance(r.exception, SystemExit), (args, r.exception, r.output)
    return r


# ==== 2: everything a reference carries is verified ===========================================
@pytest.fixture()
def pendulum_reference(tmp_path, monkeypatch):
    """A small cached reference (pendulum, 0.2 s, no check runs)."""
    from daebench.harness.references import reference as references
    from daebench.models.scenes import load_scene

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    sc = load_scene("pendulum", ["t_end=0.2"])
    return sc, references.compute_reference(sc, rtol=1e-9, atol=1e-11, check=False)


def _edit(path: Path, change, reseal: bool = False) -> None:
    from daebench.harness.references.reference import write_sidecar

    side = path.with_suffix(".json")
    meta = json.loads(side.read_text())
    change(meta)
    if reseal:  # as if whoever edited it also knew to recompute the checksum
        write_sidecar(side, meta)
    else:
        side.write_text(json.dumps(meta, indent=1))


def _set(key: str, value):
    def change(meta):
        d = meta
        *head, last = key.split(".")
        for k in head:
            d = d.setdefault(k, {})
        d[last] = value
    return change


@pytest.mark.parametrize("key, value", [("impacts", [0.1]), ("accuracy.trust_t", 0.05), ("settings.rtol", 1e-12),
                                        ("agreement", {"err_theta_max": 0.0}), ("rows", 3)])
def test_a_tampered_sidecar_field_is_refused_as_damaged(pendulum_reference, key, value):
    """Editing a scored field of the sidecar (impacts, trust_t, settings…) changed the scores
    with exit 0: the sidecar's own checksum now covers every field."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    _edit(ref.path, _set(key, value))
    with pytest.raises(references.ReferenceDamaged, match="checksum mismatch: a field of the sidecar changed"):
        references.load_reference(sc, mode="require")
    assert "is damaged" in stored.why_no_reference(sc)


@pytest.mark.parametrize("key, value, why", [
    ("impacts", [math.nan], "not a finite time"),
    ("impacts", [0.15, 0.1], "not in time order"),
    ("impacts", [5.0], "outside \\[0, 0.2\\] s"),
    ("accuracy", [], "'accuracy' is not a mapping"),
    ("accuracy", {"trust_t": 10 ** 400, "trust_impacts": 0}, "trust_t .* is not a time"),
    ("accuracy", {"trust_t": math.inf, "trust_impacts": 0}, "trust_t .* is not a time"),
    ("accuracy", {"trust_t": 0.1, "trust_impacts": 4}, "trust_impacts 4 is not a count"),
    ("settings", [], "'settings' has the wrong type"),
    ("wall_s", "x", "'wall_s' 'x' is not a finite number"),
])
def test_a_sealed_sidecar_with_a_field_out_of_range_is_damaged(pendulum_reference, key, value, why):
    """Even with a matching checksum, every scored field is checked for type and range:
    "impacts": [NaN] gave 'error … nan' and exit 0; 10**400 an OverflowError."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    _edit(ref.path, _set(key, value), reseal=True)
    with pytest.raises(references.ReferenceDamaged, match=why):
        references.load_reference(sc, mode="require")


@pytest.mark.parametrize("text, why", [("[" * 5000 + "]" * 5000, "nested too deeply"),
                                       ('{"rows": ' + "9" * 5000 + "}", "not valid JSON"),
                                       ('{"a": 1e999999}', "checksum"),
                                       ("\xff\xfe", "not valid JSON|not UTF-8")])
def test_a_sidecar_that_breaks_the_json_reader_is_damaged_not_a_crash(pendulum_reference, text, why):
    """A sidecar that raised while read (deep JSON, 10**400 digits, bytes) was blamed on the
    integrator; it is a damaged reference, and `compute` replaces it."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    ref.path.with_suffix(".json").write_text(text)
    with pytest.raises(references.ReferenceDamaged, match=why):
        references.load_reference(sc, mode="require")
    again = references.load_reference(sc, mode="compute", rtol=1e-9, atol=1e-11, check=False)
    assert references.validate(sc, again.path).impacts == again.impacts


def test_a_damaged_reference_is_recomputed_in_a_bench_and_refused_under_require(pendulum_reference):
    """The bench's row is never charged with a damaged reference: `auto` recomputes it, `require`
    refuses the input naming the damage (exit 2)."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    _edit(ref.path, _set("impacts", [0.1]))
    r = cli(["reference", "pendulum", "--set", "t_end=0.2", "--rtol", "1e-9", "--atol", "1e-11"])
    assert r.exit_code == 0, r.output
    assert references.validate(sc, ref.path).impacts == []  # recomputed, sealed again
    _edit(ref.path, _set("impacts", [0.1]))
    r = cli(["bench", "pendulum", "-i", "hht", "--steps", "1e-2", "--set", "t_end=0.2", "--reference", "require",
             "--repeats", "1"])
    assert r.exit_code == 2 and "damaged" in r.output and "checksum mismatch" in r.output, r.output


def test_a_requested_tolerance_the_cache_does_not_meet_recomputes(pendulum_reference):
    """A reference asked for at rtol 1e-11 returned the cached 1e-9 one without a word."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    with pytest.raises(references.ReferenceDamaged, match="computed at rtol 1e-09, looser than the requested 1e-11"):
        references.load_reference(sc, mode="require", rtol=1e-11)
    tighter = references.load_reference(sc, mode="compute", rtol=1e-11, atol=1e-13, check=False)
    assert tighter.rtol == 1e-11
    assert references.load_reference(sc, mode="require", rtol=1e-10).rtol == 1e-11   # a tighter one serves


def test_output_only_keys_leave_the_scene_hash():
    """output.format and output.observables changed the hash, so the shipped reference was not
    used; the sweep's manifest names the observables it scores instead."""
    from daebench.harness.sweeps.sweep import manifest
    from daebench.models.scenes import load_scene

    sc = load_scene("beam-impact")
    other = sc.with_overrides({"output.format": "parquet", "output.observables": ["theta"]})
    assert other.hash == sc.hash
    assert sc.with_overrides({"t_end": 0.5}).hash != sc.hash
    assert manifest(other, [], "auto", 1)["observables"] == ["theta"] != manifest(sc, [], "auto", 1)["observables"]


def test_a_reference_assessed_on_fewer_observables_is_not_trusted_for_more(pendulum_reference, monkeypatch):
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    few = sc.with_overrides({"output.observables": ["theta"]})
    calls = []
    monkeypatch.setattr(references, "compute_reference", lambda scene, **kw: calls.append(scene) or "computed")
    _edit(ref.path, lambda m: m["scene_values"].update({"output.observables": ["theta"]}), reseal=True)
    assert references.load_reference(few, mode="require").path == ref.path
    assert references.load_reference(sc, mode="auto") == "computed" and calls == [sc]


def test_the_reference_is_described_by_what_computed_it():
    """A Moreau reference was labelled 'IDA rtol nan', the crank's DOP853 one 'IDA rtol 1e-11'."""
    import pandas as pd

    from daebench.harness.references.reference import Reference
    from daebench.harness.scoring.pipeline import reference_truth

    hist = pd.DataFrame({"t": [0.0, 1.0]})
    cap = Reference(hist, [], {"kind": "capturing", "integrator": "moreau", "settings": {"h": 5e-6}}, Path("x"))
    ode = Reference(hist, [], {"integrator": "ode-index1", "settings": {"rtol": 1e-11, "method": "dop853"}},
                    Path("x"))
    assert reference_truth(cap).description == "cached reference (moreau h 5e-06 (event capturing))"
    assert reference_truth(ode).description == "cached reference (DOP853 rtol 1e-11)"


def test_a_reference_larger_than_its_rows_can_be_is_refused_before_hashing(pendulum_reference, monkeypatch):
    """A symlink in the cache to a huge file made every run hash it first (41 s for 8 GB)."""
    from daebench.harness.references import reference as references

    sc, ref = pendulum_reference
    big = ref.path.parent / "big.bin"
    with open(big, "wb") as fh:
        fh.truncate(1 << 32)  # sparse: 4 GiB on paper
    ref.path.unlink()
    ref.path.symlink_to(big)
    hashed = []
    monkeypatch.setattr(references, "sha256", lambda p: hashed.append(p) or "")
    with pytest.raises(references.ReferenceDamaged, match="bytes, more than .* it was not read"):
        references.load_reference(sc, mode="require")
    assert hashed == []


# ==== 4: no executable cache ===================================================================
def _handle_module(name: str = "pendulum"):
    from daebench.api import load_scene
    from daebench.core import handles
    from daebench.models import build_system

    md = build_system(load_scene(name)).kernel_data()
    for k in [k for k in handles._MODULES if k[0] is type(md)]:
        handles._MODULES.pop(k)
    handles.handle(md)
    made = [k for k in handles._MODULES if k[0] is type(md)]
    assert len(made) == 1
    return md, Path(handles._MODULES[made[0]].__file__), made


def test_a_line_planted_in_a_generated_kernel_module_does_not_run(tmp_path):
    """A line appended to a module under daebench-handles/ ran on the next run: what runs is
    the text daebench generates, and the file is written anew when it differs."""
    from daebench.core import handles

    md, path, made = _handle_module()
    good = path.read_bytes()
    marker = tmp_path / "planted"
    path.write_bytes(good + f"\nopen({str(marker)!r}, 'w').write('ran')\nraise SystemExit('planted')\n".encode())
    for k in made:
        handles._MODULES.pop(k)
    h = handles.handle(md)
    assert not marker.exists() and path.read_bytes() == good
    assert h.fns.shape == (len(handles.SIGNATURES),) and (h.fns != 0).all()


def test_a_truncated_generated_kernel_module_is_regenerated():
    """A truncated module broke every later run ('a bug in integrator hht') and was never repaired."""
    from daebench.core import handles

    md, path, made = _handle_module()
    good = path.read_bytes()
    path.write_bytes(good[: len(good) // 2])
    for k in made:
        handles._MODULES.pop(k)
    handles.handle(md)
    assert path.read_bytes() == good


def test_a_kernel_folder_others_can_write_is_passed_over(tmp_path, monkeypatch):
    """With no writable home cache the fallback was a shared /tmp/daebench-numba/ whose .py files
    were imported with no owner or permission check."""
    import os

    import numba

    from daebench.core import handles

    shared = tmp_path / "shared"
    (shared / "daebench-handles").mkdir(parents=True)
    os.chmod(shared / "daebench-handles", 0o777)
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(shared))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "home-cache"))
    d = handles._directory()
    assert d == tmp_path / "home-cache" / "daebench" / "daebench-handles"
    assert not os.stat(d).st_mode & 0o022


# ==== 1: no false "completed" ==================================================================
def _over_the_rule(history) -> str:
    """'' when every row of a history passes the divergence rule, else its reason."""
    import numpy as np

    from daebench.driver.history import divergence

    works = {c[2:]: history[c].to_numpy() for c in history.columns if c.startswith("W_")}
    last = {k: float(np.nan_to_num(w[-1])) for k, w in works.items()}
    E = history["E"].to_numpy()
    scale = max(abs(float(x)) for c, x in history.iloc[0].items() if c.startswith("E_")) or 1.0
    return divergence(E, history["energy_residual"].to_numpy(), last, float(E[0]), scale,
                      float(history["D_impacts"].iloc[-1]))[1]


@pytest.mark.parametrize("integrator", ["moreau", "hht", "newmark", "genalpha"])
def test_no_stiff_spring_wall_run_completes_over_the_divergence_rule(integrator):
    """spring-wall at stiffness 1e4 … 1e10 × h 1e-2, 1e-3 (32 runs over the four integrators):
    Moreau said 'completed' at 534–865× the start energy where the others said diverged."""
    from daebench.harness.running.runner import run_scene
    from daebench.models.scenes import load_scene

    for k in (1e4, 1e6, 1e8, 1e10):
        for h in (1e-2, 1e-3):
            sc = load_scene("spring-wall", {"t_end": 0.5, "spring.stiffness": k})
            _, r = run_scene(sc, integrator, {"h": h}, write=False)
            assert r.status in ("completed", "diverged"), (k, h, r.status, r.message)
            if r.status == "completed":
                assert _over_the_rule(r.history) == "", (integrator, k, h, r.energy_residual)
            else:
                assert r.message, (k, h)


def test_the_moreau_spring_wall_command_ends_diverged_with_the_reason(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    r = cli(["run", "spring-wall", "-i", "moreau", "--opt", "h=1e-2", "--set", "t_end=0.5",
             "--set", "spring.stiffness=1e8"])
    assert r.exit_code == 1 and "diverged" in r.output and "inside its rigid obstacle" in r.output, r.output


def test_hht_at_extreme_values_is_not_completed():
    """ball.mass 1e-9, stiffness 1e12, start 1e6 m at 1e6 m/s: residual 1.4e35 J, 779 km through
    the wall, 'completed'."""
    import daebench

    r = daebench.run("spring-wall", "hht", overrides=["ball.mass=1e-9", "spring.stiffness=1e12", "start.x=1e6",
                                                      "start.v=1e6"], write=False).record
    assert r.status == "diverged" and "energy" in r.message


def test_a_capturing_step_through_a_rigid_obstacle_is_diverged(monkeypatch):
    """The penetration rule: a capturing run whose gap falls below −PENETRATION × the scene's
    length scale (the size of its start, here 1 m) is diverged with the reason; made strict, it
    catches the O(h v) penetration every Moreau step has."""
    import daebench
    from daebench.driver import history
    from daebench.models import build_system
    from daebench.models.scenes import load_scene

    assert build_system(load_scene("ball")).length_scale() == pytest.approx(1.0)
    ok = daebench.run("ball", "moreau", settings={"h": 1e-3}, overrides={"t_end": 1.0}, write=False).record
    assert ok.status == "completed"
    monkeypatch.setattr(history, "PENETRATION", 1e-9)
    r = daebench.run("ball", "moreau", settings={"h": 1e-3}, overrides={"t_end": 1.0}, write=False).record
    assert r.status == "diverged" and "inside its rigid obstacle, deeper than 1e-09 × the scene's length scale 1 m" \
        in r.message, r.message
    bad, why = history.penetration([[0.1, -0.6], [0.2, 0.0]], 1.0)
    assert bad.tolist() == [True, False] and why.startswith("contact 1 is 0.6 m inside")


# ==== 3, 5: one rule for every path written; outputs checked writable before the work ==========
@pytest.fixture()
def sandbox(tmp_path, monkeypatch):
    """cwd and the results root three levels down in tmp_path (so '../../x' stays inside tmp_path
    and can be looked for), a regular file to make unwritable folders under, a sweep table, a
    history and a written survey 'sv'."""
    import pandas as pd

    from daebench.workflows import survey
    from tests.test_report_browser import _survey

    cwd = tmp_path / "a" / "b" / "cwd"
    cwd.mkdir(parents=True)
    monkeypatch.chdir(cwd)
    monkeypatch.setenv("DAEBENCH_RESULTS", str(cwd / "results"))
    (tmp_path / "a-file").write_text("x")
    data = tmp_path / "data"
    data.mkdir()
    pd.DataFrame({"t": [0.0, 1.0], "theta": [1.0, 2.0], "energy_residual": [0.0, 0.0]}).to_csv(
        data / "history.csv", index=False)
    pd.DataFrame({"label": ["hht", "hht"], "status": ["completed"] * 2, "wall_s": [1.0, 2.0], "cpu_s": [0.9, 1.8], "h": [1e-2, 5e-3],
                  "err_theta_max_trusted": [1e-3, 2.5e-4], "err_pre_theta_max": [1e-3, 2.5e-4],
                  "case": ["pendulum"] * 2, "scene_set": ['{"t_end": 0.5'] * 2}).to_csv(data / "table.csv", index=False)
    (cwd / "results" / "survey" / "sv").mkdir(parents=True)
    res = _survey(cwd / "results" / "survey" / "sv")
    res.name = "sv"
    survey.write(res)
    return tmp_path, cwd


def _files(folder: Path) -> set[Path]:
    return {p for p in folder.rglob("*") if p.is_file()}


def _unwritable(tmp: Path) -> str:
    return str(tmp / "a-file" / "sub")  # a folder under a regular file: no one can create it, root neither


TRAVERSAL = [
    (["stability", "pendulum", "--name", "../../x"], "contains a path"),
    (["stability", "pendulum", "--name", "/tmp/x"], "contains a path"),
    (["report", "../../outside/x"], "contains a path"),
    (["report", "/tmp/outside-x"], "contains a path"),
    (["survey", "--name", "../../x", "--quick"], "must be a plain file name"),
    (["bench", "pendulum", "-i", "hht", "--steps", "1e-2", "--set", "t_end=0.05", "--reference", "none",
      "--name", "../../x"], "must be a plain file name"),
    (["run", "pendulum", "--set", "name=../../x"], "contains a path"),
]

UNWRITABLE = [
    ["run", "pendulum", "-i", "hht", "--set", "t_end=0.01"],
    ["stability", "pendulum"],
    ["effects", "beam-impact"],
    ["paper", "--quick"],
    ["interactive-mode", "rodwall"],
    ["averaged-gap", "chain"],
    ["averaged-gap", "pendulum"],
    ["seed003", "chain"],
    ["capture", "page", "ball"],
    ["export", "pendulum"],
    ["compare", "pendulum"],
    ["report", "sv"],
]


@pytest.mark.parametrize("args, fragment", TRAVERSAL)
def test_a_name_with_a_path_is_refused_and_nothing_is_written_outside(sandbox, args, fragment):
    """`report ../../outside/x` and `stability --name ../../x` wrote outside the results root."""
    tmp, cwd = sandbox
    before = _files(tmp)
    r = cli(args)
    assert r.exit_code == 2 and fragment in r.output, (args, r.output)
    assert {p for p in _files(tmp) - before if not p.is_relative_to(cwd / "results")} == set()


@pytest.mark.parametrize("args", UNWRITABLE, ids=lambda a: "-".join(a[:2]))
def test_an_unwritable_output_folder_is_refused_before_the_work(sandbox, args):
    """`stability`, `effects`, `seed003`, `report` with --out in an unwritable folder raised after
    all runs; every writing command refuses it up front (exit 2, no traceback, nothing written)."""
    tmp, cwd = sandbox
    before = _files(tmp)
    r = cli(args + ["--out", _unwritable(tmp) + ("/page.html" if args[0] == "report" else "")])
    assert r.exit_code == 2 and "cannot write to" in r.output, (args, r.output)
    assert {p for p in _files(tmp) - before if not p.is_relative_to(cwd / "results")} == set()


@pytest.mark.parametrize("sub", ["wp", "order", "history"])
def test_plot_refuses_an_unwritable_stem_and_honours_the_results_root(sandbox, sub):
    tmp, cwd = sandbox
    src = str(tmp / "data" / ("history.csv" if sub == "history" else "table.csv"))
    extra = ["--x", "h", "--y", "err_pre_theta_max"] if sub == "order" else []
    r = cli(["plot", sub, src, *extra, "--out", _unwritable(tmp) + "/fig"])
    assert r.exit_code == 2 and "cannot write to" in r.output, r.output
    if sub == "history":  # the default stem is under DAEBENCH_RESULTS, not ./results of the cwd
        r = cli(["plot", sub, src])
        assert r.exit_code == 0, r.output
        assert (cwd / "results" / "figures" / "history.png").exists()
    else:  # a damaged scene_set cell only leaves the title without it
        r = cli(["plot", sub, src, *extra])
        assert r.exit_code == 0, r.output


def test_the_report_page_refuses_dev_null_and_a_damaged_survey(sandbox):
    tmp, cwd = sandbox
    r = cli(["report", "sv", "--out", "/dev/null"])
    assert r.exit_code == 2 and "not a regular file" in r.output, r.output
    assert Path("/dev/null").exists() and not Path("/dev/null").is_file()
    folder = cwd / "results" / "survey" / "sv"
    side = (folder / "survey.json").read_text()
    for name, text in (("survey.json", side[: len(side) // 2]), ("survey.json", '{"cases": [{}]}'),
                       ("survey.json", "[" * 3000 + "]" * 3000)):
        (folder / name).write_text(text)
        r = cli(["report", "sv"])
        assert r.exit_code == 2 and "is damaged" in r.output, r.output
    (folder / "survey.json").write_text(side)
    (folder / "table.parquet").write_bytes((folder / "table.parquet").read_bytes()[:100])
    r = cli(["report", "sv"])
    assert r.exit_code == 2 and "is damaged" in r.output, r.output
    (folder / "table.parquet").unlink()
    (folder / "reach.csv").write_bytes(b"\x00garbage,\n\xff\xfe")
    r = cli(["report", "sv"])
    assert r.exit_code == 2 and "is damaged" in r.output, r.output


def test_a_scene_renamed_after_loading_is_refused_when_it_writes(tmp_path, monkeypatch):
    """A Scene whose name was changed after loading wrote with that name (write=True)."""
    import daebench
    from daebench.api import ParamError

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "r"))
    sc = daebench.load_scene("pendulum", {"t_end": 0.01})
    sc.name = "../../escaped"
    with pytest.raises(ParamError, match="contains a path"):
        daebench.run(sc, "hht", write=True)
    assert not any(tmp_path.parent.glob("escaped*")) and not any(tmp_path.glob("**/escaped*"))


def test_the_study_defaults_honour_the_results_root(tmp_path, monkeypatch):
    """plot, stability, capture, seed003 wrote to ./results whatever DAEBENCH_RESULTS said."""
    import inspect

    from daebench.api import figures, studies, sweeps
    from daebench.cli import plot, studies as cli_studies, sweeps as cli_sweeps

    for fn in (figures.plot_histories, studies.averaged_gap_chain, studies.averaged_gap_pendulum,
               studies.interactive_mode, studies.capture_page, sweeps.stability, plot.plot_history,
               cli_studies.chain, cli_studies.pendulum, cli_studies.page, cli_studies.interactive_mode,
               cli_sweeps.stability):
        for p in inspect.signature(fn).parameters.values():
            d = getattr(p.default, "default", p.default)
            assert not (isinstance(d, str) and d.startswith("results/")), (fn.__qualname__, p.name, d)


# ==== 6, 9: no traceback on deep or broken scene files; one broken thing blocks only itself =====
@pytest.fixture()
def odd_cases(tmp_path, monkeypatch):
    import shutil

    from daebench.core.scene import cases_dir

    d = tmp_path / "cases"
    d.mkdir()
    shutil.copy(cases_dir() / "pendulum.toml", d)
    (d / "deep.toml").write_text('model = "pendulum"\nx = ' + "[" * 3000 + "]" * 3000 + "\n")
    (d / "broken.toml").write_text('model = "pendulum\n')
    (d / "tables.toml").write_text('model = "pendulum"\n[' + ".".join(["a"] * 2500) + "]\nb = 1\n")
    (d / "inline.toml").write_text('model = "pendulum"\nx = ' + "{a = " * 900 + "1" + "}" * 900 + "\n")
    (d / "twice.toml").write_text('model = "ball"\n"contact.restitution" = 0.3\n[contact]\nrestitution = 0.9\n')
    monkeypatch.setenv("DAEBENCH_CASES", str(d))
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path / "results"))
    return d


@pytest.mark.parametrize("case, why", [("deep", "nested too deeply"), ("broken", "not valid TOML"),
                                       ("tables", "nested more than 16 deep"), ("inline", "nested too deeply"),
                                       ("twice", "'contact.restitution' is given twice")])
def test_a_deep_broken_or_conflicting_scene_file_is_refused_by_name(odd_cases, case, why):
    r = cli(["run", case, "-i", "hht"])
    assert r.exit_code == 2 and why in r.output, r.output
    r = cli(["run", str(odd_cases / f"{case}.toml"), "-i", "hht"])
    assert r.exit_code == 2 and why in r.output, r.output


def test_one_broken_scene_file_does_not_block_the_others(odd_cases):
    """An invalid TOML in DAEBENCH_CASES made `run pendulum` and `list` refuse."""
    r = cli(["list"])
    assert r.exit_code == 0 and "pendulum" in r.output and "cannot be read" in r.output, r.output
    r = cli(["run", "pendulum", "-i", "hht", "--set", "t_end=0.01"])
    assert r.exit_code == 0, r.output


def test_one_broken_plugin_does_not_block_a_survey_of_others(monkeypatch):
    """A plugin that fails to import made `survey` refuse even with -i naming others."""
    from daebench.integrators import registry as integrator_registry
    from daebench.models.scenes import load_scene
    from daebench.workflows import survey

    reg = {**integrator_registry.registry(), "broken": integrator_registry.Registered("broken", None, "bad-plugin", "ImportError: no module x")}
    monkeypatch.setattr(integrator_registry, "registry", lambda refresh=False: dict(reg))
    proto = survey.survey_protocol(load_scene("pendulum"), quick=True)
    assert any(e.integrator == "broken" for e in proto.entries)
    assert any(e.integrator == "hht" and e.steps for e in proto.entries)


# ==== 8: a refused sweep leaves nothing behind ===================================================
B3 = ["bench", "pendulum", "-i", "hht", "--steps", "1e-2", "--set", "t_end=0.05", "--reference", "none",
      "--repeats", "1"]


@pytest.mark.parametrize("bad", [["-j", "0"], ["--repeats", "0"], ["--run-cap", "-1"]])
def test_a_refused_sweep_leaves_no_store_and_the_corrected_command_runs(tmp_path, monkeypatch, bad):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    args = [a for a in B3 if a not in ("--repeats", "1")] if bad[0] == "--repeats" else B3
    r = cli(args + bad + ["--name", "x"])
    assert r.exit_code == 2, r.output
    assert not list((tmp_path / "bench").glob("*")) if (tmp_path / "bench").exists() else True
    r = cli(B3 + ["--name", "x"])
    assert r.exit_code == 0, r.output


def test_a_sweep_refused_for_its_reference_leaves_no_store(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    args = ["bench", "beam-impact", "-i", "hht", "--steps", "1e-4", "--set", "t_end=0.01", "--reference", "require"]
    for extra in (["--name", "y"], []):  # named, and with a unique name (no orphan store either)
        r = cli(args + extra)
        assert r.exit_code == 2 and "no reference" in r.output, r.output
        assert sorted(p.name for p in (tmp_path / "bench").glob("*")) == []


def test_a_reference_that_fails_to_compute_in_a_bench_exits_1(tmp_path, monkeypatch):
    """It exited 2 ('input refused') though the input was fine."""
    from daebench.harness.references import reference as references

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))

    def fails(scene, **kw):
        raise RuntimeError("reference run of 'beam-impact' failed: step size too small")

    monkeypatch.setattr(references, "compute_reference", fails)
    r = cli(["bench", "beam-impact", "-i", "hht", "--steps", "1e-4", "--set", "t_end=0.01", "--reference", "compute",
             "--name", "z"])
    assert r.exit_code == 1 and "could not be computed" in r.output, r.output
    assert sorted(p.name for p in (tmp_path / "bench").glob("*")) == []


# ==== 12: messages that say what to change =========================================================
@pytest.mark.parametrize("args, fragment", [
    (["stability", "pendulum", "--n", "abc", "--n-key", "pendulum.mass"], "--n takes whole numbers"),
    (["stability", "pendulum", "-m", "hht:alpha"], "'alpha' is not name=value"),
])
def test_stability_options_say_what_they_take(tmp_path, monkeypatch, args, fragment):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    r = cli(args)
    assert r.exit_code == 2 and fragment in r.output, r.output


def test_an_unwritable_folder_is_not_called_full():
    import errno

    from daebench.harness.files import write_error

    msg = str(write_error(PermissionError(errno.EACCES, "Permission denied"), "the table", "/x/t.csv"))
    assert "Free space" not in msg and "Make it writable" in msg
    msg = str(write_error(OSError(errno.ENOSPC, "No space left on device"), "the table", "/x/t.csv"))
    assert "Free space there" in msg


# ==== 7: resources stated and enforced before the run =============================================
def test_a_scene_too_large_for_the_machine_is_refused_before_the_run(tmp_path, monkeypatch):
    """rod-wall with 2000 × 50 elements asked numpy for 310 GiB after 13 s ('a bug in integrator
    hht'); at 2000 × 8 it would take 9.7 GiB of a 24 GiB machine without a word."""
    from daebench.harness.running import checks

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    monkeypatch.setattr(checks, "machine_memory", lambda: 24 << 30)
    r = cli(["run", "rod-wall", "-i", "hht", "--set", "rod.elements=2000", "--set", "rod.elements_across=8"])
    assert r.exit_code == 2 and "GiB" in r.output and "of this machine's 24 GiB" in r.output, r.output
    assert "coarser mesh" in r.output
    assert not (tmp_path / "runs").exists() or not list((tmp_path / "runs").iterdir())
    r = cli(["bench", "rod-wall", "-i", "hht", "--steps", "1e-6", "--set", "rod.elements=2000",
             "--set", "rod.elements_across=8", "--reference", "none", "--name", "big"])
    assert r.exit_code == 2 and "GiB" in r.output, r.output


# ==== 10, 11: summaries that agree with themselves; the API's values checked like overrides ========
def test_a_diverged_run_summary_says_where_it_stopped(tmp_path, monkeypatch):
    """A diverged Baumgarte run printed 'max |E − E0 − W_nc + D_impacts| = 0 … 0 is exact' and
    'final t 0' while the JSON said t_final 0.001."""
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    r = cli(["run", "spring-wall", "-i", "baumgarte", "--opt", "h=1e-2", "--set", "spring.stiffness=1e8",
             "--set", "t_end=0.5"])
    assert r.exit_code == 1 and "diverged" in r.output, r.output
    assert "final t" not in r.output and "0 is exact" not in r.output
    assert "last kept t [s]: 0" in r.output and "stopped at: t = 0.001 s" in r.output


@pytest.mark.parametrize("key, value, why", [("t_end", -1, "'t_end' = -1"), ("output.dt", 0, "'output.dt' = 0"),
                                             ("pendulum.length", -1.0, "'pendulum.length' = -1"),
                                             ("t_end", "1", "not a value of its type")])
def test_values_changed_in_place_are_refused_as_param_errors(key, value, why):
    """scene.values["t_end"] = -1 raised ValueError, ["output.dt"] = 0 ZeroDivisionError, and a
    negative pendulum length completed."""
    import daebench

    sc = daebench.load_scene("pendulum")
    sc.values[key] = value
    with pytest.raises(daebench.ParamError, match=why):
        daebench.run(sc, "hht")


def test_numpy_booleans_and_huge_integers():
    import numpy as np

    import daebench
    from daebench.core.params import coerce

    sc = daebench.load_scene("ball", {"effects.contact": np.bool_(False)})
    assert sc["effects.contact"] is False
    for v in ("9" * 800, 9 ** 900):
        with pytest.raises(daebench.ParamError, match="-digit number \\(beyond any range; write e.g. 1e6\\)"):
            coerce(v, float, "scene key 'x'")


def test_compile_report_refuses_an_unknown_command():
    r = cli(["compile-report", "--", "nosuchcmd"])
    assert r.exit_code == 2 and "'nosuchcmd' is not a daebench command" in r.output, r.output


def test_sigterm_during_reference_and_ctrl_c_after_compares_runs_are_said(tmp_path, monkeypatch):
    """SIGTERM during `reference` and SIGINT during compare's last phase exited silently."""
    import os
    import signal

    import daebench.api as api

    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))

    def terminated(*a, **kw):
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("SIGTERM was not turned into an interruption")

    monkeypatch.setattr(api, "reference", terminated)
    r = cli(["reference", "pendulum"])
    assert r.exit_code == 130 and "interrupted (Ctrl-C or SIGTERM)" in r.output and "nothing was cached" in r.output

    def ctrl_c(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(api, "compare", ctrl_c)
    r = cli(["compare", "pendulum"])
    assert r.exit_code == 130 and "interrupted (Ctrl-C or SIGTERM)" in r.output, r.output


def test_every_generated_module_runs_the_generated_text_not_the_file(tmp_path):
    """The stepper entries of a plugin (daebench.stepping.method_handles) ran whatever file was
    on disk, while the kernel modules were regenerated: both now load through one function, a
    planted file is rewritten and its line does not run."""
    from daebench.core import handles

    path = tmp_path / "_daebench_method_probe_step_0123.py"
    text = "VALUE = _GIVEN * 2\n"
    marker = tmp_path / "planted"
    path.write_text(f"open({str(marker)!r}, 'w').write('ran')\nVALUE = -1\n")
    module = handles.load_generated("_daebench_method_probe_step_0123", path, text, {"_GIVEN": 21})
    assert module.VALUE == 42 and not marker.exists() and path.read_text() == text
    path.write_text(text[:5])                                 # truncated: written anew
    assert handles.load_generated("_daebench_method_probe_step_0123", path, text, {"_GIVEN": 1}).VALUE == 2
    assert path.read_text() == text
