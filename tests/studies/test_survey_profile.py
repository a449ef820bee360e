"""The survey profile's table (daebench.studies.perf.survey_profile): stages summed per case
over the workers, the graph distance apart from the rest of scoring."""

from __future__ import annotations

import json

from daebench.studies.perf import survey_profile as sp


def test_table_sums_stages_per_case(tmp_path):
    lines = [("pendulum", "case", 10.0, 1.0), ("pendulum", "timed", 0.5, 0.4), ("pendulum", "timed", 0.25, 0.2),
             ("pendulum", "score:graphdist", 2.0, 1.5), ("pendulum", "score:eventseq", 0.5, 0.5),
             ("pendulum", "score:trusted", 0.25, 0.25), ("ball", "case", 3.0, 0.5), ("ball", "repeats", 1.5, 1.0)]
    path = tmp_path / "p.jsonl"
    path.write_text("".join(json.dumps({"pid": 1, "case": c, "stage": s, "wall": w, "cpu": u}) + "\n"
                            for c, s, w, u in lines))
    out = sp.table(path).splitlines()
    head = [c.strip() for c in out[0].strip("|").split("|")]
    cells = {r.split("|")[1].strip(): [c.strip() for c in r.strip("|").split("|")] for r in out[2:] if r.startswith("|")}
    col = {k: i for i, k in enumerate(head)}
    pend, ball = cells["pendulum"], cells["ball"]
    assert pend[col["case"]] == "10.0" and pend[col["timed"]] == "0.8"     # 0.5 + 0.25 (rounded to 0.1)
    assert pend[col["graph distance"]] == "2.0" and pend[col["scoring"]] == "0.8"
    assert ball[col["repeats"]] == "1.5" and ball[col["timed"]] == ""
    assert cells["**wall**"][col["case"]] == "13.0" and cells["CPU"][col["graph distance"]] == "1.5"
