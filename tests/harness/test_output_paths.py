"""One rule for every written path: names with a path refused, nothing written outside the
results root, output folders checked writable before the work."""

from __future__ import annotations

from pathlib import Path

import pytest

from _cli import cli


@pytest.fixture()
def sandbox(tmp_path, monkeypatch):
    """cwd and the results root three levels down in tmp_path (so '../../x' stays inside tmp_path
    and can be looked for), a regular file to make unwritable folders under, a sweep table, a
    history and a written survey 'sv'."""
    import pandas as pd

    from daebench.workflows import survey
    from tests.workflows.test_report_browser import _survey

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
