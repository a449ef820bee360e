"""The documentation holds: the site builds with warnings as errors and its how-to pages
execute; the CLI and API reference pages list every command and every public function;
every path and every `daebench` command that README.md and docs/ name exists; the cheap
commands they show run; the front page stays a front page; every command's summary in
`daebench --help` is one sentence on one line."""

from __future__ import annotations

import html
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

import daebench
from daebench.cli.app import app
from daebench.cli.click_command import command as CLI
import _peers  # noqa: E402  (tests/ is on sys.path under pytest)

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
README = ROOT / "README.md"
#: the pages users read: the front page, the changelog and every Markdown page of the site
PAGES = [README, ROOT / "CHANGELOG.md"] + sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.parts)

#: what an account of the work looks like, not a user document
WORK_ACCOUNT = re.compile(r"issue [0-9]|helper [a-z0-9]|[0-9](st|nd|rd|th) stop", re.I)
#: a path named from the repository's root: a top-level folder of the repository, or one of its files
ROOT_PATH = re.compile(r"(?<![\w/.\-(])((?:daebench|cases|docs|tests|results/curated|\.ci)/[\w./*\-]*"
                       r"|README\.md|CHANGELOG\.md|pyproject\.toml)")
LINK = re.compile(r"\]\(([^)\s]+)\)")


def visible_commands(cmd=CLI, path=()):
    """(path, command) of every command and sub-command a user sees."""
    for name, sub in sorted(getattr(cmd, "commands", {}).items()):
        if getattr(sub, "hidden", False):
            continue
        yield path + (name,), sub
        yield from visible_commands(sub, path + (name,))


def code_lines(text: str) -> list[str]:
    """Lines of fenced code blocks and inline code spans: where commands are shown."""
    blocks = re.findall(r"```[^\n]*\n(.*?)```", text, re.S)
    spans = re.findall(r"(?<!`)`([^`\n]+)`(?!`)", re.sub(r"```.*?```", "", text, flags=re.S))
    return [ln.strip() for b in blocks for ln in b.splitlines()] + [s.strip() for s in spans]


def shown_commands(text: str) -> list[list[str]]:
    """The words after `daebench` of every command shown in code."""
    out = []
    for line in code_lines(text):
        for m in re.finditer(r"(?:^|[;&|]\s*)daebench\s+([^#;&|]*)", line):
            words = m.group(1).split()
            if words:
                out.append(words)
    return out


# -- the site ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built as CI builds it: warnings as errors, every how-to page executed (the
    peer how-to runs Siconos: found, or installed as the browser is)."""
    _peers.ensure_siconos()
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
               DAEBENCH_DOCS_EXECUTE="force", DAEBENCH_RESULTS=str(out / "results"))
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           "-d", str(out / "doctrees"), str(DOCS), str(out / "html")],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    return proc, out / "html"


def test_the_site_builds_with_warnings_as_errors_and_its_pages_execute(site):
    proc, html_dir = site
    assert proc.returncode == 0, proc.stderr[-5000:]
    for page in ("getting-started", "howto/write-a-model", "howto/survey-on-dask", "howto/compare-contact-laws"):
        text = (html_dir / f"{page}.html").read_text()
        assert "cell_output" in text, f"{page}: no executed output"
        assert "Traceback" not in text, f"{page}: a cell raised"


def test_the_cli_reference_lists_every_command(site):
    _, html_dir = site
    text = html.unescape(re.sub(r"<[^>]+>", "", (html_dir / "reference" / "cli.html").read_text()))
    missing = [" ".join(p) for p, _ in visible_commands() if f"daebench {' '.join(p)} [OPTIONS]" not in text]
    assert not missing, f"the CLI reference has no usage line of: {missing}"


def test_the_api_reference_lists_every_public_name(site):
    _, html_dir = site
    text = (html_dir / "reference" / "api.html").read_text()
    missing = [name for name in daebench.__all__ if f'id="daebench.{name}"' not in text]
    assert not missing, f"the API reference does not document: {missing}"


# -- what the pages name -----------------------------------------------------------------------

@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_path_a_page_names_exists(page):
    text = page.read_text()
    missing = []
    for m in ROOT_PATH.finditer(text):
        path = m.group(1).rstrip(".,:;")
        if "<" in path or "NAME" in path or path.startswith("docs/_build"):
            continue  # a placeholder, or the site's build output (made by the command the page shows)
        if not (list(ROOT.glob(path)) if "*" in path else (ROOT / path).exists()):
            missing.append(path)
    for target in LINK.findall(text):
        target = target.split("#")[0]
        if not target or re.match(r"[a-z]+:", target):
            continue
        if not (page.parent / target).exists():
            missing.append(target)
    assert not missing, f"{page.relative_to(ROOT)} names paths that do not exist: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_command_a_page_shows_is_a_command(page):
    bad = []
    for words in shown_commands(page.read_text()):
        cmd, path = CLI, []
        for w in words:
            subs = getattr(cmd, "commands", None)
            if not subs or w.startswith("-"):
                break
            if w not in subs or getattr(subs[w], "hidden", False):
                bad.append(" ".join(["daebench", *path, w]))
                break
            cmd, path = subs[w], path + [w]
    assert not bad, f"{page.relative_to(ROOT)} shows commands that do not exist: {bad}"


def test_the_pages_show_the_commands_they_are_about():
    shown = {tuple(w[:1]) for p in PAGES for w in shown_commands(p.read_text())}
    for name in ("list", "show", "run", "compare", "bench", "survey", "reference", "paper", "verify"):
        assert (name,) in shown, f"no page shows `daebench {name}`"


@pytest.mark.parametrize("args, expect", [
    (["list"], ["pendulum", "beam-impact", "hht", "moreau"]),
    (["show", "pendulum"], ["pendulum"]),
    (["show", "hht"], ["capabilities", "alpha"]),
    (["show", "beam-impact", "--keys"], ["contact.restitution", "discretization.n"]),
])
def test_the_cheap_commands_the_pages_show_run(args, expect):
    shown = [w for p in PAGES for w in shown_commands(p.read_text())]
    assert any(w[:len(args)] == args for w in shown), f"no page shows `daebench {' '.join(args)}`"
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    for word in expect:
        assert word in result.output


def test_no_page_or_module_is_an_account_of_the_work():
    files = PAGES + sorted((ROOT / "daebench").rglob("*.py"))
    hits = [f"{f.relative_to(ROOT)}: {ln.strip()}" for f in files for ln in f.read_text().splitlines()
            if WORK_ACCOUNT.search(ln)]
    assert not hits, hits


# -- the front page and the help ---------------------------------------------------------------

def test_the_readme_is_a_front_page():
    text = README.read_text()
    assert len(text.splitlines()) <= 200
    assert "results/curated/compare-beam-impact.png" in text
    assert not re.search(r"\b20\d\d-\d\d-\d\d\b", text), "a dated measurement"
    assert not re.search(r"\b[0-9a-f]{7,40}\b", re.sub(r"```.*?```", "", text, flags=re.S)), "a commit hash"


def test_ci_runs_exactly_the_readmes_test_command():
    """The README's second command installs the test tools and runs the suite; .ci/run ends
    with it, verbatim. The first installs the package alone (the main job needs no more)."""
    text = README.read_text()
    command = re.search(r"^([^\n#]*pytest[^\n#]*?)\s*#", text, re.M).group(1).strip()
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert command == 'pip install -e ".[dev]" && pytest -m "not slow"' and ci[-1].strip() == command
    assert re.search(r"^pip install -e \. && daebench compare beam-impact\s+#", text, re.M)


@pytest.mark.parametrize("path, cmd", list(visible_commands()), ids=lambda x: " ".join(x) if isinstance(x, tuple) else "")
def test_every_command_summary_is_one_sentence_on_one_line(path, cmd):
    summary = (cmd.help or "").strip().split("\n\n")[0]
    assert summary and "\n" not in summary and summary.endswith("."), repr(summary)
