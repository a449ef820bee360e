"""The survey report page in a real headless browser (Chromium from the system's packages;
.ci/run installs it when missing — this test fails, never skips, without it).

The page (daebench.workflows.report) is built from a synthetic survey (no runs: known
tables and one real matplotlib figure), opened with ``?selftest&table=I&col=J``: the page
clicks the header of column J of table I and writes what it saw into the DOM, which
``--dump-dom`` returns. Asserted: no error on the page nor on the browser's console log,
every figure drawn with a non-zero size, and the click reordering the rows (the column
after the click is sorted and differs from before)."""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd

from daebench.harness.analysis import costs, profiles, recommend
from daebench.workflows import report
from daebench.workflows.survey import CaseResult, SurveyResult

BROWSERS = ("chromium", "chromium-browser", "google-chrome")


def _browser() -> str:
    for b in BROWSERS:
        path = shutil.which(b)
        if path:
            return path
    raise AssertionError("no Chromium on PATH: install it (Debian: apt-get install -y chromium; .ci/run does)")


def _survey(folder: Path) -> SurveyResult:
    rows = []
    rng = np.random.default_rng(3)
    for case in ("p1", "p2"):
        for lab, k in (("slow", 3.0), ("fast", 1.0), ("mid", 2.0)):
            for h in (1e-2, 5e-3, 2.5e-3):
                rows.append(dict(case=case, label=lab, integrator=lab, h=h, status="completed",
                                 wall_s=k * 1e-2 / h * (1 + 0.1 * rng.random()), steps=1 / h,
                                 err_x_max=2.0 * h ** 2, scene_hash="0123456789abcdef", message="",
                                 trust_t=0.8))
    table = pd.DataFrame(rows)
    reach = costs.reach_table(table, {"err_x_max": [1e-4, 5e-5]})
    prof = profiles.profile_table(reach)
    profiles.figure(reach, folder / "profile-wall")
    cases = [CaseResult(c, table[table.case == c], {"x": "refused: <why> & so"}, ["err_x_max"], 1.0, 1, 1)
             for c in ("p1", "p2")]
    return SurveyResult("synthetic", folder, table, reach, prof, recommend.paragraphs(reach), cases, 2.0)


def _dump(page: Path, query: str, tmp: Path) -> tuple[str, str]:
    cmd = [_browser(), "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
           f"--user-data-dir={tmp / 'profile'}", "--enable-logging=stderr", "--v=0",
           "--virtual-time-budget=5000", "--dump-dom", page.as_uri() + query]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    return p.stdout, p.stderr


def _selftest(dom: str) -> dict:
    m = re.search(r'<pre id="selftest">(.*?)</pre>', dom, re.S)
    assert m and m.group(1).strip(), f"the page wrote no self-test result: {dom[-500:]}"
    return json.loads(html.unescape(m.group(1)))


def _num(x: str) -> float:
    return float(x.replace("∞", "inf")) if x not in ("-", "") else float("nan")


def test_report_in_headless_chromium(tmp_path):
    res = _survey(tmp_path)
    page = report.write_survey_report(res)
    text = page.read_text()
    assert text.index("Recommendation") < text.index("Performance profiles")   # the recommendation first
    assert "&lt;why&gt; &amp; so" in text and "src=\"http" not in text          # escaped; nothing external
    # table 2 is 'Cost to reach each target'; its column 4 is reach_wall_s (rows are in setting order)
    dom, log = _dump(page, "?selftest&table=1&col=4", tmp_path)
    st = _selftest(dom)
    assert st["errors"] == [], st["errors"]
    console = [ln for ln in log.splitlines() if ":CONSOLE" in ln]   # the page writes nothing to the console
    assert not console, console
    assert st["figures"] >= 3 and st["zero_size"] == 0       # profile figure + one work-precision figure per case
    assert st["header"].startswith("reach_wall_s")
    before, after = [_num(x) for x in st["before"]], [_num(x) for x in st["after"]]
    fin = [x for x in after if np.isfinite(x)]
    assert fin == sorted(fin) and after != before               # the click sorted the rows ascending
    assert sorted(map(str, before)) == sorted(map(str, after))  # the same rows, reordered


def test_compare_report_in_headless_chromium(tmp_path):
    """`daebench compare CASE --report`: the page of one comparison, built from a synthetic
    result (known table, one real figure) and checked in the browser like the survey's."""
    from daebench.harness.analysis import plots
    from daebench.workflows.compare import CompareResult, Protocol
    from daebench.models.scenes import load_scene

    sc = load_scene("ball")
    table = _survey(tmp_path).table
    table = table[table.case == "p1"].assign(case="ball")
    fig = plots.work_precision(table, "wall_s", ["err_x_max"], "label", tmp_path / "wp-ball")[1]
    res = CompareResult(table, {"ida": "refused: <no> friction"}, list(fig),
                        Protocol((), measures=("err_x_max",), why="three steps & two halvings"))
    page = report.write_compare_report(res, sc, tmp_path / "report.html")
    text = page.read_text()
    assert text.index("Recommendation") < text.index("Work–precision")
    assert "fast" in text.split("Work–precision")[0]     # the recommendation names the cheapest setting
    assert "&lt;no&gt; friction" in text and "three steps &amp; two halvings" in text
    dom, log = _dump(page, "?selftest&table=0&col=3", tmp_path)   # "Every run": label, h, status, wall_s
    st = _selftest(dom)
    assert st["errors"] == [] and not [ln for ln in log.splitlines() if ":CONSOLE" in ln]
    assert st["figures"] == 1 and st["zero_size"] == 0
    assert st["header"].startswith("wall_s")
    after = [_num(x) for x in st["after"]]
    assert after == sorted(after) and sorted(after) != [_num(x) for x in st["before"]]
