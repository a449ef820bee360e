"""Provenance footer for every table and figure: versions, machine, scene, date."""

from __future__ import annotations

import json
import os
import platform
import subprocess
from datetime import datetime, timezone
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any, Iterable

#: distribution name → short label in the footer
PACKAGES = {"daebench": "daebench", "numpy": "numpy", "scipy": "scipy", "scikit-sundae": "sksundae",
            "numba": "numba", "pandas": "pandas", "matplotlib": "matplotlib"}


def package_versions() -> dict[str, str]:
    """Installed versions of the packages results depend on ('-' if absent)."""
    out = {}
    for dist, label in PACKAGES.items():
        try:
            out[label] = version(dist)
        except PackageNotFoundError:
            out[label] = "-"
    return out


def git_commit() -> str:
    """Short commit of the daebench source tree (with '+dirty'), or '' outside git."""
    here = Path(__file__).resolve().parents[2]  # the daebench package
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=here, capture_output=True,
                             text=True, timeout=5)
        if rev.returncode != 0:
            return ""
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "."], cwd=here,
                               capture_output=True, text=True, timeout=5).stdout.strip()
        return rev.stdout.strip() + ("+dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return ""


def machine() -> dict[str, Any]:
    """Platform, processor and CPU count of this machine."""
    return {"platform": platform.platform(), "python": platform.python_version(),
            "processor": platform.processor() or platform.machine(), "cpus": os.cpu_count()}


def collect(scenes: Iterable[Any] = ()) -> dict[str, Any]:
    """All provenance as a JSON-ready dict; ``scenes`` are Scene objects or
    (name, hash) pairs."""
    sc = []
    for s in scenes:
        sc.append({"name": s.name, "hash": s.hash} if hasattr(s, "hash") else {"name": s[0], "hash": s[1]})
    return {"versions": package_versions(), "commit": git_commit(), "machine": machine(),
            "scenes": sc, "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}


def footer_text(prov: dict[str, Any]) -> str:
    """One line: versions · machine · scenes · date."""
    v = " ".join(f"{k} {x}" for k, x in prov["versions"].items() if x != "-")
    if prov.get("commit"):
        v += f" ({prov['commit']})"
    m = prov["machine"]
    mach = f"{m['platform']}, {m['cpus']} CPUs, Python {m['python']}"
    sc = ", ".join(f"{s['name']}#{s['hash'][:8]}" for s in prov.get("scenes", [])[:6])
    if len(prov.get("scenes", [])) > 6:
        sc += f" (+{len(prov['scenes']) - 6})"
    parts = [v, mach] + ([f"scene {sc}"] if sc else []) + [prov["date"]]
    return " · ".join(parts)


def markdown_footer(prov: dict[str, Any]) -> str:
    """A Markdown footer block for tables and reports."""
    return f"\n---\n<sub>provenance: {footer_text(prov)}</sub>\n"


def add_figure_footer(fig: Any, prov: dict[str, Any]) -> None:
    """Print the provenance line at the bottom of a matplotlib figure."""
    fig.text(0.005, 0.003, footer_text(prov), fontsize=5.5, color="0.4", ha="left", va="bottom", wrap=True)


#: the PNG text key (and the SVG description's prefix) holding a figure's provenance as JSON
FIGURE_KEY = "daebench-provenance"


def figure_metadata(fig: Any, prov: dict[str, Any]) -> dict[str, dict[str, str]]:
    """File metadata of a figure, per format: its provenance and its titles (what it
    shows: case, N) as JSON, so that a page showing the figure can be checked against
    it (:func:`read_figure_provenance`)."""
    titles = [t for t in ([fig._suptitle.get_text()] if fig._suptitle is not None else [])
              + [ax.get_title() for ax in fig.axes] if t]
    text = json.dumps({**prov, "titles": titles}, default=str)
    return {"png": {FIGURE_KEY: text}, "svg": {"Description": f"{FIGURE_KEY} {text}"}}


def write_figure(fig: Any, *paths: str | os.PathLike, prov: dict[str, Any] | None = None, dpi: int = 130,
                 fmt: str | None = None) -> list[Path]:
    """Write ``fig`` to each of ``paths`` with its provenance printed at the bottom and stored
    as file metadata (:func:`figure_metadata`): every figure daebench writes goes through
    here, so that each can be traced to its commit and checked against the page that shows
    it. ``prov`` defaults to :func:`collect` (no scenes); a file's format is ``fmt`` or its
    suffix."""
    prov = prov if prov is not None else collect()
    add_figure_footer(fig, prov)
    meta = figure_metadata(fig, prov)
    out = []
    for path in paths:
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(p, dpi=dpi, format=fmt, metadata=meta.get((fmt or p.suffix.lstrip(".") or "png").lower()))
        out.append(p)
    return out


def read_figure_provenance(png: str | os.PathLike) -> dict[str, Any] | None:
    """The provenance a PNG written by daebench carries (None if it carries none)."""
    from PIL import Image   # lazy: only figure checks read PNGs (Pillow comes with matplotlib)

    with Image.open(png) as im:
        text = im.info.get(FIGURE_KEY)
    return json.loads(text) if isinstance(text, str) else None


def write_sidecar(path: str | os.PathLike, prov: dict[str, Any], **extra: Any) -> Path:
    """Write ``prov`` (plus ``extra`` fields) as JSON next to an output file."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps({**extra, "provenance": prov}, indent=2, default=str))
    return p
