"""The compact survey page (`daebench report NAME --compact`, the one kept in
results/curated/): the same recommendation and tables with fewer columns, the profile
figure as a small palette PNG, no per-case work–precision figures."""

from __future__ import annotations

import base64
import io
import re

from PIL import Image

from daebench.workflows import report
from tests.workflows.test_report_browser import _survey


def _figures(page: str) -> list[Image.Image]:
    return [Image.open(io.BytesIO(base64.b64decode(b))) for b in re.findall(r'base64,([^"]+)"', page)]


def test_compact_page_keeps_the_verdict_and_sheds_the_bytes(tmp_path):
    res = _survey(tmp_path)
    full = report.write_survey_report(res, tmp_path / "full.html").read_text()
    small = report.write_survey_report(res, tmp_path / "small.html", compact=True).read_text()
    for p in res.paragraphs.values():                        # the recommendation, word for word
        assert report.html.escape(p) in small
    figs, big = _figures(small), _figures(full)
    # profile + small multiples + one work–precision per case → profile and small multiples only
    assert len(big) == 2 + len(res.cases) and len(figs) == 2
    src = Image.open(tmp_path / "profile-cpu.png")
    w = min(src.width, report.COMPACT_WIDTH)
    assert figs[0].size == (w, round(src.height * w / src.width)) and figs[0].mode == "P"
    assert 'title="missing"' in full and 'title="missing"' not in small   # fewer columns
    assert small.count("<tr>") == full.count("<tr>")         # every row of every table is still there
    assert len(small) < len(full) / 2
