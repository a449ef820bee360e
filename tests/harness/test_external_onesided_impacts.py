"""Rows an event-driven code writes at an impact (before and after, one time) are matched
one-sidedly to the truth's impact within the event tolerance: the pre-impact row to the
truth's left limit, the post-impact row to its right limit.

Independent truth: the dropped ball's closed form (tests/_closed_forms.py), written as an
exact event-driven code writes it, its impact rows one unit in the last place before the
exact impact times (where an exact event location may land)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import daebench
from _external_files import ball_event_driven


@pytest.mark.parametrize("ulps", [-1, 0, 1])
def test_an_exact_event_driven_ball_has_no_jump_error(ulps):
    row = daebench.score("ball", ball_event_driven(ulps), write=False).row
    assert row["status"] == "completed" and row["impacts_matched"] == 4 and row["impacts_missed"] == 0
    assert row["err_v_max"] < 1e-12, "the post-impact row met the truth's pre-impact branch"
    assert row["err_x_max"] < 1e-12 and row["err_impact_t_max"] < 1e-12
    assert row["err_graph_v"] < 1e-12 and row["err_graph_q"] < 1e-12


def test_an_impact_written_late_keeps_its_error():
    """A pair moved 10.5 ms after the exact impact, past ten output rows, stays where the file
    puts it: its post-impact row (v⁺ of the exact impact) meets the truth 10.5 ms into the
    rebound, g × 10.5 ms away, and the pair is a spurious impact."""
    df = ball_event_driven(0)
    t = df["t"].to_numpy()
    shifted = df.copy()
    k = np.flatnonzero(np.diff(t) == 0)[0]
    shifted.loc[[k, k + 1], "t"] = t[k] + 0.0105
    shifted = shifted.sort_values("t", kind="stable").reset_index(drop=True)
    r = daebench.score("ball", shifted, write=False).row
    assert r["err_v_max"] == pytest.approx(9.81 * 0.0105, rel=1e-6)
    assert r["impacts_spurious"] == 1


def test_the_truths_own_pair_is_split_to_its_limits():
    from daebench.harness.scoring.external.grid import split_truth_pairs

    truth = pd.DataFrame({"t": [0.0, 1.0, 1.0, 2.0], "v": [0.0, -1.0, 0.8, 0.0]})
    out = split_truth_pairs(truth, [1.0])["t"].to_numpy()
    assert out[1] < 1.0 < out[2] and out[2] - out[1] < 1e-15 and np.all(np.diff(out) > 0)


def test_against_a_reference_holding_its_own_impact_rows():
    """Against a reference that writes two rows at each of its impacts (as an exact one holds
    them), the file's pair one unit in the last place early meets each branch's limit."""
    from daebench.api.catalogue import load_scene
    from daebench.harness.scoring.pipeline import Truth
    from daebench.workflows import score as S
    from _closed_forms import ball_impacts

    scene = load_scene("ball")
    ref = ball_event_driven(0).drop(columns="gap")
    tr = Truth(ref, tuple(ball_impacts()), "reference", 1e-11, trust_t=2.5, trust_impacts=4, made_by="closed form")
    ext = S.prepare(scene, S.Source(ball_event_driven(-1)))
    row = S.external_row(scene, ext, tr)
    assert row["against"] == "reference" and row["status"] == "completed"
    assert row["err_v_max"] < 1e-12 and row["err_x_max"] < 1e-12 and row["err_graph_v"] < 1e-12
