"""Display names of the measures: words and units from the models' own declarations, and
the glossary page kept equal to its generator's output."""

from __future__ import annotations

from pathlib import Path

from daebench.harness.scoring import glossary

ROOT = Path(__file__).resolve().parents[2]


def test_error_columns_read_as_words_with_the_models_unit_and_span():
    assert glossary.display("err_theta_max_trusted", "hub-beam") == "θ max error over the trusted span [deg]"
    assert glossary.display("err_pre_theta_max", "hub-beam") == "θ max error before the first impact [deg]"
    assert glossary.display("err_impact1_t") == "error of the first impact time [s]"
    assert glossary.display("cpu_s") == "CPU time [s]"
    m = glossary.describe("err_theta_max_trusted", "hub-beam")
    assert m.short == "θ max trusted" and m.unit == "deg" and "trust_t" in m.definition
    assert glossary.display("not_a_column") == "not_a_column"   # an unknown column keeps its name


def test_the_glossary_page_is_current():
    page = (ROOT / "docs" / "reference" / "glossary.md").read_text(encoding="utf-8")
    assert page == glossary.markdown(), ("docs/reference/glossary.md is stale: run `python -m "
                                         "daebench.harness.scoring.glossary docs/reference/glossary.md`")
