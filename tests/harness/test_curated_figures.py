"""Curated figures are what the pages that show them say: each carries its provenance
(a clean commit, the scenes it shows), and the case and N in its titles are the ones the
page names. Planted mismatches are caught (the check is tested on figures made here)."""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from daebench.harness.analysis import plots  # noqa: E402
from daebench.harness.running import provenance  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
FIGURE_REF = re.compile(r"results/curated/([\w.-]+\.png)")


def figure_problems(page: str, png: Path) -> list[str]:
    """What is wrong with showing ``png`` on a page whose text is ``page``."""
    prov = provenance.read_figure_provenance(png)
    if prov is None:
        return [f"{png.name} carries no provenance (made before figures recorded it: draw it again)"]
    out = []
    if not prov.get("commit") or prov["commit"].endswith("+dirty"):
        out.append(f"{png.name} comes from commit {prov.get('commit') or '(none)'!r}, not a clean one")
    for s in prov.get("scenes", []):
        if not re.search(rf"(?<![\w-]){re.escape(s['name'])}(?![\w-])", page):
            out.append(f"{png.name} shows scene {s['name']!r}, which its page never names")
    for title in prov.get("titles", []):
        for n in re.findall(r"\bN = (\d+)", title):
            if not re.search(rf"\bN = {n}\b", page):
                out.append(f"{png.name} is titled {title!r} (N = {n}); its page never says N = {n}")
    return out


def _figure(tmp_path: Path, title: str, prov: dict) -> Path:
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set_title(title)
    return plots.save(fig, tmp_path / "fig", prov)[0]


def _prov(commit: str, scene: str = "beam-impact") -> dict:
    p = provenance.collect([(scene, "0" * 16)])
    return {**p, "commit": commit}


def test_a_clean_figure_on_its_own_page_passes(tmp_path):
    png = _figure(tmp_path, "beam-impact, N = 5", _prov("abc1234"))
    assert figure_problems("The main comparison, beam-impact at N = 5.", png) == []


def test_a_dirty_commit_is_caught(tmp_path):
    png = _figure(tmp_path, "beam-impact, N = 5", _prov("abc1234+dirty"))
    assert any("not a clean one" in p for p in figure_problems("beam-impact, N = 5", png))


def test_a_figure_of_another_n_or_case_is_caught(tmp_path):
    png = _figure(tmp_path, "order of convergence, N = 3", _prov("abc1234", "beam-impact-hub"))
    problems = figure_problems("The comparison on beam-impact at N = 5.", png)
    assert any("N = 3" in p for p in problems) and any("beam-impact-hub" in p for p in problems)


def test_a_case_named_only_as_part_of_another_is_caught(tmp_path):
    png = _figure(tmp_path, "beam-impact", _prov("abc1234", "beam-impact"))
    assert figure_problems("beam-impact-hub only", png)


def test_a_figure_without_provenance_is_caught(tmp_path):
    png = tmp_path / "bare.png"
    plt.figure().savefig(png)
    assert "carries no provenance" in figure_problems("", png)[0]


def _pages() -> dict[Path, str]:
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    return {p: p.read_text(encoding="utf-8") for p in pages if "_build" not in p.parts}


def test_every_curated_figure_is_shown_and_agrees_with_each_page_that_shows_it():
    pages = _pages()
    shown: dict[str, list[Path]] = {}
    for path, text in pages.items():
        for name in FIGURE_REF.findall(text):
            shown.setdefault(name, []).append(path)
    curated = sorted((ROOT / "results" / "curated").glob("*.png"))
    assert curated
    problems = [f"{png.name} is shown on no page (delete it or show it)" for png in curated if png.name not in shown]
    problems += [f"{name} is shown on {[str(p.relative_to(ROOT)) for p in where]} but not in results/curated"
                 for name, where in shown.items() if not (ROOT / "results" / "curated" / name).exists()]
    for png in curated:
        for page in shown.get(png.name, []):
            problems += [f"{page.relative_to(ROOT)}: {p}" for p in figure_problems(pages[page], png)]
    assert problems == []


def test_every_curated_table_names_a_clean_commit():
    """A curated Markdown table ends with its provenance footer, and that commit is clean."""
    problems = []
    for md in sorted((ROOT / "results" / "curated").glob("*.md")):
        found = re.search(r"provenance: .*?\(([0-9a-f]{7,}(?:\+dirty)?)\)", md.read_text(encoding="utf-8"))
        if found is None:
            problems.append(f"{md.name} carries no provenance footer with a commit")
        elif found.group(1).endswith("+dirty"):
            problems.append(f"{md.name} comes from a modified tree ({found.group(1)})")
    assert problems == []
