"""The command line as a newcomer meets it: nothing silent for long, output readable in a
pipe and an 80-column terminal, an integrator's settings one command away."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from typing import ClassVar

import pytest
from typer.testing import CliRunner

from daebench.harness.running import progress
from daebench.cli.app import app
from daebench.integrators import registry as integrator_registry
from daebench.integrators.base import STEP_SETTINGS, Capabilities, Integrator, State
from daebench.integrators.registry import Registered
from daebench.harness.running.history_io import history_label

runner = CliRunner()
LINES: list[str] = []
TICK = re.compile(r": (compiling|no step yet), \d+ s elapsed")


class SlowStart(Integrator):
    """Reports no step until the progress reporter has written the compile notice and two
    elapsed-time lines (as a first run does while the kernels compile)."""

    name: ClassVar[str] = "slowstart"
    description: ClassVar[str] = "test only: silent start"
    capabilities: ClassVar[Capabilities] = Capabilities(order=1, constraints=True, index=3)
    settings_spec = STEP_SETTINGS

    def _start(self) -> None:
        give_up = time.monotonic() + 60.0  # a safety net, not a timed assertion
        while sum(bool(TICK.search(line)) for line in LINES) < 2 and time.monotonic() < give_up:
            time.sleep(0.01)

    def _step_impl(self, t_stop: float) -> State:
        s = self.state
        return State(min(s.t + self.h, t_stop), s.q.copy(), s.v.copy(), s.a.copy(), s.lam.copy())


def test_compile_notice_then_a_line_every_tick_until_the_first_step(monkeypatch, tmp_path):
    reg = {**integrator_registry.registry(), "slowstart": Registered("slowstart", SlowStart, "tests")}
    monkeypatch.setattr(integrator_registry, "registry", lambda refresh=False: dict(reg))
    monkeypatch.setattr(progress, "NOTICE_AFTER", 0.05)
    monkeypatch.setattr(progress, "TICK_S", 0.05)
    real = progress.RunProgress.line
    monkeypatch.setattr(progress.RunProgress, "line", lambda self, text: (LINES.append(text), real(self, text)))
    LINES.clear()
    r = runner.invoke(app, ["run", "pendulum", "-i", "slowstart", "--opt", "h=1e-2", "--set", "t_end=0.05",
                            "--out", str(tmp_path), "--json"])
    assert r.exit_code == 0, r.output
    assert "no step yet after" in LINES[0]
    assert ("numerical kernels are being compiled for their first use" in LINES[0]
            and "cached for later runs" in LINES[0]) or "a slow first step" in LINES[0]
    assert sum(bool(TICK.search(line)) for line in LINES) >= 2
    assert json.loads(r.stdout)["status"] == "completed"  # stdout: the record only; progress went to stderr


@pytest.mark.parametrize("compiling", [True, False])
def test_the_notice_says_compiling_only_while_the_compiler_runs(monkeypatch, compiling):
    """Issue 24 item 16: a warm run under load said the kernels were being compiled. The
    notice follows the compiler's own events (compile_events.compiling)."""
    monkeypatch.setattr(progress, "compiling", lambda: compiling)
    lines: list[str] = []
    bar = progress.RunProgress("case", 2.0, write=lines.append, terminal=False, notice_after=0.0, tick=0.0)
    with bar:
        give_up = time.monotonic() + 30.0
        while len(lines) < 3 and time.monotonic() < give_up:
            time.sleep(0.01)
    assert "no step yet after" in lines[0]
    assert ("being compiled for their first use" in lines[0]) == compiling
    assert ("a slow first step; nothing is being compiled" in lines[0]) == (not compiling)
    assert all((": compiling," in ln) == compiling for ln in lines[1:])


def test_on_a_terminal_the_wait_is_one_updating_line(monkeypatch):
    """Issue 24 item 16: in a terminal the notice printed ~38 separate lines; now one notice,
    then the bar's description updates in place."""
    monkeypatch.setattr(progress, "compiling", lambda: True)
    printed: list[str] = []
    monkeypatch.setattr(progress.RunProgress, "line", lambda self, text: printed.append(text))
    bar = progress.RunProgress("case", 2.0, terminal=True, notice_after=0.0, tick=0.0)
    bar.poll = 0.01
    with bar:
        give_up = time.monotonic() + 30.0
        while bar._bar.tasks[0].description == "case" and time.monotonic() < give_up:
            time.sleep(0.01)
        time.sleep(0.2)                                        # ~20 more ticks
        assert bar._bar.tasks[0].description.startswith("case: compiling, ")
        bar(1.0)
        time.sleep(0.1)
        assert bar._bar.tasks[0].description == "case"        # the first step: the bar is the run's again
    assert len(printed) == 1 and "no step yet after" in printed[0]


def test_run_progress_reports_simulated_time():
    lines: list[str] = []
    bar = progress.RunProgress("case", 2.0, write=lines.append, terminal=False, notice_after=100.0, tick=0.0)
    with bar:
        bar(0.5)
        give_up = time.monotonic() + 30.0
        while not lines and time.monotonic() < give_up:
            time.sleep(0.01)
    assert lines and "t = 0.5 of 2 s (25 %)" in lines[0]


def _cli(*args: str, columns: int = 80) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS=str(columns))
    return subprocess.run([sys.executable, "-m", "daebench.cli.app", *args], capture_output=True, text=True, env=env)


def test_piped_80_columns_never_breaks_a_number(tmp_path):
    """`daebench run … | cat` with COLUMNS=80: every number of the summary is whole on one line,
    and every line fits 80 columns unless it is one unbreakable token (a file path)."""
    r = _cli("run", "beam-impact", "-i", "hht", "--set", "discretization.n=3", "--set", "t_end=0.05",
             "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    for line in lines:
        assert len(line) <= 80 or " " not in line.strip(), line
    rec = json.loads(_cli("run", "beam-impact", "-i", "hht", "--set", "discretization.n=3", "--set",
                          "t_end=0.05", "--out", str(tmp_path), "--json").stdout)
    for k in ("theta_deg", "tip_w2", "tip_y"):
        number = f"{rec['observables'][k]:.10g}"
        assert any(number in line for line in lines), (k, number)
    assert f"{rec['energy_residual']:.3e}" in r.stdout
    assert "run: beam-impact with integrator hht" in r.stdout and "settings:" in r.stdout


def test_narrow_bench_table_keeps_every_value_whole(tmp_path, monkeypatch):
    monkeypatch.setenv("DAEBENCH_RESULTS", str(tmp_path))
    monkeypatch.setenv("COLUMNS", "60")
    r = runner.invoke(app, ["bench", "pendulum", "-i", "hht,newmark", "--steps", "1e-2,5e-3", "--set", "t_end=0.2",
                            "--reference", "compute", "--name", "n"])
    assert r.exit_code == 0, r.output
    import pandas as pd

    df = pd.read_parquet(tmp_path / "bench" / "n.parquet")
    for v in df["err_theta_max"]:
        assert re.search(rf"(^|\s){re.escape(f'{v:.3g}')}(\s|$)", r.stdout), v
    assert "complet…" not in r.stdout and "err_th…" not in r.stdout


def test_show_integrator_lists_settings_and_capabilities():
    r = runner.invoke(app, ["show", "HHT"])
    assert r.exit_code == 0, r.output
    for fragment in ("capabilities: order 2", "constraints at index 3", "alpha", "float [-0.333333, 0]",
                     "HHT numerical damping", "newton_maxiter", "int [1, 100]"):
        assert fragment in r.stdout, fragment


@pytest.mark.parametrize("columns", ["80", "250"])
def test_run_summary_names_integrator_settings_and_exact_error(tmp_path, monkeypatch, columns):
    """Whatever COLUMNS the caller exported (issue 24 item 18: it failed at ≥ ~100)."""
    monkeypatch.setenv("COLUMNS", columns)
    r = runner.invoke(app, ["run", "pendulum", "--opt", "rtol=1e-8", "--set", "t_end=0.2", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert "pendulum with integrator ida" in r.stdout and "rtol=1e-08" in r.stdout
    assert re.search(r"error vs exact solution [^\n]*\s+theta \d\.\d{3}e-\d+,.*?\bpos \d\.\d{3}e-\d+", r.stdout,
                     re.S), r.stdout


@pytest.mark.parametrize("cmd", [["paper", "--help"], ["bench", "--help"], ["run", "--help"]])
def test_help_points_nowhere_missing(cmd):
    r = runner.invoke(app, cmd)
    assert r.exit_code == 0 and "CASES.md" not in r.output


def test_history_legend_names_integrator_and_settings(tmp_path):
    """`plot history` labels each line by integrator and its non-default settings (read from
    the sidecar `run` writes), not by the file's hash."""
    from daebench.harness.analysis import plots

    r = runner.invoke(app, ["run", "pendulum", "-i", "hht", "--opt", "h=1e-2", "--opt", "alpha=-0.3",
                            "--set", "t_end=0.1", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    (path,) = tmp_path.glob("pendulum-hht-*.csv")
    assert history_label(path) == "hht (h=0.01, alpha=-0.3)"
    r = runner.invoke(app, ["plot", "history", str(path), "--out", str(tmp_path / "fig")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "fig.png").exists() and (tmp_path / "fig.svg").exists()


def test_compare_piped_prints_one_table_row_per_run_and_the_recommendation_table(tmp_path):
    """`daebench compare … | cat` with COLUMNS=80: one line per run holding its integrator,
    settings, status and CPU time whole (plain text: no escape codes), then the
    recommendation as a table; compare.json holds the recommendation records."""
    out = tmp_path / "cmp"
    r = _cli("compare", "pendulum", "--set", "t_end=0.2", "-j", "1", "--out", str(out),
             "--reference", "none")
    assert r.returncode in (0, 1), r.stderr
    assert "\x1b[" not in r.stdout
    import pandas as pd

    from daebench.cli.textout import _short_exp, fmt

    df = pd.read_csv(out / "table.csv")
    lines = r.stdout.splitlines()
    for _, row in df.iterrows():
        setting = f"h={row['h']:g}" if pd.notna(row.get("h")) else (f"tol={row['tol']:g}" if pd.notna(row.get("tol"))
                                                                     else "defaults")
        mine = [ln for ln in lines if ln.split()[:3] == [row["integrator"], _short_exp(setting), row["status"]]]
        assert len(mine) == 1, (row["integrator"], setting, r.stdout)
        assert re.search(rf"(^|\s){re.escape(_short_exp(fmt(float(row['cpu_s']))))}(\s|$)", mine[0]), mine[0]
    head = next(i for i, ln in enumerate(lines) if ln.split()[:2] == ["target", "pick"])
    assert "CPU s" in lines[head] and "runner-up" in lines[head] and "why" in lines[head]
    side = json.loads((out / "compare.json").read_text())
    assert side["recommendations"], side
    for rec in side["recommendations"]:
        assert {"target", "pick", "cost_cpu_s", "runner_up", "ratio", "reasons"} <= set(rec)
