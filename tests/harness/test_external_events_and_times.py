"""daebench.harness.scoring.external.events, .checks and .records: impacts read off another code's gap
series, checked against the bouncing ball's closed form (dropped 1 m, e = 0.8: t₁ = √(2h/g),
t_{k+1} = t_k + 2 e^k v₁/g), the time column's rules with the fix each refusal gives, and what a
message may echo of a file."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daebench.harness.scoring.external.checks import check_times
from daebench.harness.scoring.external.events import gap_events, repeated_time_events
from daebench.harness.scoring.external.records import ExternalDataError

G, H0, E = 9.81, 1.0, 0.8


def _ball(t: np.ndarray) -> tuple[np.ndarray, list[float]]:
    """Height of the exact bouncing ball at ``t`` and its impact times."""
    v1 = math.sqrt(2 * G * H0)
    hits = [math.sqrt(2 * H0 / G)]
    for k in range(1, 6):
        hits.append(hits[-1] + 2 * E ** k * v1 / G)
    x = np.empty_like(t)
    for i, s in enumerate(t):
        if s < hits[0]:
            x[i] = H0 - 0.5 * G * s * s
            continue
        k = max(j for j, th in enumerate(hits) if th <= s)
        up = E ** (k + 1) * v1
        tau = s - hits[k]
        x[i] = max(up * tau - 0.5 * G * tau * tau, 0.0)
    return x, hits


def test_impacts_from_a_sampled_gap_are_the_closed_forms():
    t = np.arange(0.0, 2.5, 1e-4)
    x, hits = _ball(t)
    found = gap_events(t, x)
    exact = [h for h in hits if h < 2.5]
    assert len(found) == len(exact)
    for f, h in zip(found, exact):
        assert abs(f.t - h) < 1e-4 and f.contact == 0          # within one output interval


def test_an_event_driven_files_repeated_rows_are_its_impacts():
    t = np.array([0.0, 0.1, 0.2, 0.2, 0.3, 0.45, 0.45, 0.5])
    assert [i.t for i in repeated_time_events(t)] == [0.2, 0.45]


@pytest.mark.parametrize("t, t_end, match", [
    ([0.0, 0.2, 0.1, 1.0], 1.0, "times decrease at row 3.*sort the rows"),
    ([0.0, 0.5, 0.5, 0.5, 1.0], 1.0, "three or more rows at t = 0.5"),
    ([0.0, 500.0, 1000.0], 1.0, "outside the case's span.*look like milliseconds"),
    ([0.1, 0.5, 1.0], 1.0, "start at t = 0.1"),
    ([0.0, 0.5, 0.9], 1.0, "end at t = 0.9.*--set t_end=0.9"),
])
def test_time_column_refusals_say_the_fix(t, t_end, match):
    with pytest.raises(ExternalDataError, match=match):
        check_times(np.array(t), t_end, "the file")


def test_a_trajectory_over_the_span_with_an_impacts_two_sides_passes():
    check_times(np.array([0.0, 0.25, 0.5, 0.5, 1.0]), 1.0, "the file")
    check_times(np.array([0.2, 0.7]), 1.0, "the impacts file", trajectory=False)   # impacts: no span rule


def test_what_a_message_echoes_of_a_file_is_bounded():
    from daebench.harness.scoring.external.records import ECHO_CHARS, clip

    assert clip("t,x") == "'t,x'" and clip(3.5) == "3.5"
    long = "x" * 10_000
    shown = clip(long)
    assert shown.startswith("'" + "x" * ECHO_CHARS + "'") and shown.endswith("(10000 characters)")
    assert len(shown) < ECHO_CHARS + 40
