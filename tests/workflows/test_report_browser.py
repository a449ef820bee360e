"""The survey report page in a real headless browser (Chromium from the system's packages:
found on PATH, or installed by the test session when it may, :mod:`tests._browser` — this
test fails, never skips, without it).

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
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from daebench.harness.analysis import profiles
from daebench.workflows import report, survey
from daebench.workflows.survey import CaseResult, SurveyResult
import _browser as browser


def _browser() -> str:
    return browser.ensure()


#: what a run that raised leaves in its row (the page shows it in the tables, never in a verdict)
RAISED = "SystemError: <weakref at 0x7f00> returned a result with an exception set"


def _survey(folder: Path) -> SurveyResult:
    rows = []
    rng = np.random.default_rng(3)
    for case in ("p1", "p2"):
        for lab, k in (("slow", 3.0), ("fast", 1.0), ("mid", 2.0)):
            for h in (1e-2, 5e-3, 2.5e-3):
                raised = case == "p2" and lab == "mid" and h == 2.5e-3
                rows.append(dict(case=case, label=lab, integrator=lab, h=h, status="error" if raised else "completed",
                                 cpu_s=k * 1e-2 / h * (1 + 0.1 * rng.random()), cpu_spread=0.02, steps=1 / h,
                                 err_x_max=np.nan if raised else 2.0 * h ** 2, scene_hash="0123456789abcdef",
                                 message=RAISED if raised else "", trust_t=0.8))
    table = pd.DataFrame(rows)
    cases = [CaseResult(c, table[table.case == c], {"x": "refused: <why> & so"}, ["err_x_max"], 1.0, 1, 1)
             for c in ("p1", "p2")]
    res = survey.score(cases, {"err_x_max": [1e-4, 5e-5]})
    profiles.figure(res.reach, folder / f"{survey.PROFILE_FIGURE}", cost="cpu_s")
    return replace(res, name="synthetic", folder=folder, wall_s=2.0)


def _dump(page: Path, query: str, tmp: Path) -> tuple[str, str]:
    cmd = [_browser(), "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
           f"--user-data-dir={tmp / 'profile'}", "--enable-logging=stderr", "--v=0",
           "--window-size=1400,900", "--virtual-time-budget=5000", "--dump-dom", page.as_uri() + query]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    return p.stdout, p.stderr


def _selftest(dom: str) -> dict:
    m = re.search(r'<pre id="selftest">(.*?)</pre>', dom, re.S)
    assert m and m.group(1).strip(), f"the page wrote no self-test result: {dom[-500:]}"
    return json.loads(html.unescape(m.group(1)))


def _num(x: str) -> float:
    return float(x.replace("∞", "inf")) if x not in ("-", "") else float("nan")


def _prose(page: str) -> str:
    """The page's words outside its tables, script and footer."""
    body = re.sub(r"<(table|script|style|footer|pre)\b.*?</\1>", " ", page, flags=re.S)
    return html.unescape(re.sub(r"<[^>]+>", " ", body))


def test_report_in_headless_chromium(tmp_path):
    res = _survey(tmp_path)
    page = report.write_survey_report(res)
    text = page.read_text()
    # the answer first: the library-wide conclusion and the profile figure, then the small multiples, then the cases
    assert text.index("The answer") < text.index("Work–precision per case") < text.index("<h2>p1</h2>")
    assert "&lt;why&gt; &amp; so" in text and "src=\"http" not in text          # escaped; nothing external
    prose = _prose(text)
    assert "err_" not in prose and "SystemError" not in prose      # words for people; no exception in a verdict
    assert "mid (error at h=0.0025)" in res.paragraphs["p2"]       # the raised run: its status and where
    assert html.escape(RAISED) in text                             # … its reason in the runs table
    # table 0 is p1's runs (collapsed): setting, h, status, CPU time …; sorting by CPU time
    dom, log = _dump(page, "?selftest&table=0&col=3", tmp_path)
    st = _selftest(dom)
    assert st["errors"] == [], st["errors"]
    console = [ln for ln in log.splitlines() if ":CONSOLE" in ln]   # the page writes nothing to the console
    assert not console, console
    assert st["figures"] >= 4 and st["zero_size"] == 0   # profile + small multiples + one per case
    assert st["header"].startswith("CPU [s]")
    # the first screen (1400×900) shows the conclusion and the profile figure
    a = st["answer"]
    assert a["viewport"][0] == 1400            # (the headless window keeps ~140 px of its 900 for itself)
    assert 0 < a["text_top"] < a["viewport"][1] and 0 < a["figure_top"] < 0.5 * a["viewport"][1]
    assert a["figure_height"] > 150
    before, after = [_num(x) for x in st["before"]], [_num(x) for x in st["after"]]
    fin = [x for x in after if np.isfinite(x)]
    assert fin == sorted(fin) and after != before               # the click sorted the rows ascending
    assert sorted(map(str, before)) == sorted(map(str, after))  # the same rows, reordered


def test_compare_report_in_headless_chromium(tmp_path):
    """`daebench compare CASE --report`: the page of one comparison, built from a synthetic
    result (known table, one real figure) and checked in the browser like the survey's."""
    from daebench.harness.analysis import plots
    from daebench.workflows.compare import CompareResult, Protocol, recommendation
    from daebench.models.scenes import load_scene

    sc = load_scene("ball")
    table = _survey(tmp_path).table
    table = table[table.case == "p1"].assign(case="ball")
    fig = plots.work_precision(table, "cpu_s", ["err_x_max"], "label", tmp_path / "wp-ball")[1]
    proto = Protocol((), measures=("err_x_max",), why="three steps & two halvings")
    recs, paras = recommendation(table, proto, sc.model)
    res = CompareResult(table, {"ida": "refused: <no> friction"}, list(fig), proto, recommendations=recs,
                        paragraphs=paras, model=sc.model)
    page = report.write_compare_report(res, sc, tmp_path / "report.html")
    text = page.read_text()
    assert text.index("Recommendation") < text.index("Work–precision")
    assert "take fast" in text.split("Work–precision")[0]     # the recommendation names the cheapest setting
    assert "&lt;no&gt; friction" in text and "three steps &amp; two halvings" in text
    dom, log = _dump(page, "?selftest&table=0&col=3", tmp_path)   # "Every run": label, h, status, cpu_s
    st = _selftest(dom)
    assert st["errors"] == [] and not [ln for ln in log.splitlines() if ":CONSOLE" in ln]
    assert st["figures"] == 1 and st["zero_size"] == 0
    assert st["header"].startswith("CPU [s]")
    after = [_num(x) for x in st["after"]]
    assert after == sorted(after) and sorted(after) != [_num(x) for x in st["before"]]
