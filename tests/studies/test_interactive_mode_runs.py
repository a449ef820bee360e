"""The runs behind the interactive-mode tables (daebench.studies.interactive_mode_contact.runs),
one part at a size a test can afford: the cost part's row against what is known without it —
the model's degrees of freedom, a fixed step's count (t_end / h) — written to the part's JSON."""

from __future__ import annotations

import json

from daebench.models import build_system
from daebench.models.scenes import load_scene
from daebench.studies.interactive_mode_contact import runs


def test_cost_part_writes_a_row_per_run_with_the_models_size_and_step_count(tmp_path, monkeypatch):
    monkeypatch.setattr(runs, "COST_RUNS", [(10, "IMM", "imm", dict(h=1e-8))])
    runs.run_part("cost", tmp_path)
    rows = json.loads((tmp_path / "cost.json").read_text())
    assert len(rows) == 1
    (row,) = rows
    assert row["n"] == build_system(load_scene("rod-wall", {"rod.elements": 10})).n == 44
    assert row["steps"] == round(1e-4 / 1e-8)          # t_end = 1e-4 s at h = 1e-8 s
    assert row["treatment"] == "IMM" and row["us_per_step"] > 0.0
