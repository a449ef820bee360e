"""`daebench score`: another code's trajectory scored as a daebench run is.

Independent truths, written here and not taken from daebench: the pendulum's closed form
(Jacobi elliptic functions, scipy.special.ellipj) and the dropped ball's closed form (its
impact times t_k = t_1 + (2 v_1/g) Σ e^j and parabolas between them). A known perturbation
of the first must come back as the error; an impact removed from the second must come back
as a missed impact; a row of the sweep table and the scored record must have the same keys.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from _closed_forms import E_BALL, G, H0, L, T_BALL, ball_impacts, ball_motion, pendulum_theta_deg
from daebench.cli.app import app

runner = CliRunner()

def _score_json(*args: str) -> dict:
    r = runner.invoke(app, ["score", *args, "--json"])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module", autouse=True)
def results(tmp_path_factory):
    """One results folder for the module: the ball's reference is computed once."""
    root = tmp_path_factory.mktemp("score") / "results"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("DAEBENCH_RESULTS", str(root))
        yield root


def test_a_known_perturbation_of_the_exact_pendulum_is_its_error(tmp_path):
    t = np.linspace(0.0, 1.0, 1001)
    truth = pendulum_theta_deg(t)
    f = tmp_path / "pendulum.csv"
    pd.DataFrame({"t": t, "theta_deg": truth + 1e-6 * t}).to_csv(f, index=False)
    written = pd.read_csv(f)["theta_deg"].to_numpy() - truth   # the perturbation as the file holds it
    r = _score_json("pendulum", str(f))
    assert r["against"] == "exact solution" and r["integrator"] == "external"
    assert r["err_theta_max"] == pytest.approx(float(np.max(np.abs(written))), rel=1e-12, abs=0.0)
    assert r["err_theta_max"] == pytest.approx(1e-6, rel=1e-8)   # 1e-6·t at t = 1; binary64 rounding of θ + p
    assert r["err_theta_final"] == pytest.approx(abs(written[-1]), rel=1e-12, abs=0.0)
    assert r["err_theta_max_trusted"] == r["err_theta_max"] and r["trust_t"] == 1.0


def test_the_json_record_has_the_keys_of_a_bench_row(tmp_path):
    import daebench

    row = daebench.bench("pendulum", ["hht"], steps=[1e-2], reference="auto", repeats=1, executor="inline",
                         write=False).iloc[0].to_dict()
    t = np.linspace(0.0, 1.0, 1001)
    th = np.radians(pendulum_theta_deg(t))
    df = pd.DataFrame({"t": t, "theta_deg": np.degrees(th), "x": L * np.sin(th), "y": -L * np.cos(th)})
    f = tmp_path / "exact.parquet"
    df.to_parquet(f, index=False)
    rec = _score_json("pendulum", str(f), "--label", "closed-form", "--cost-s", "0.5", "--steps", "1000")
    from daebench.workflows.score import FILE_COLUMNS

    assert set(rec) == set(row) | set(FILE_COLUMNS)
    assert (rec["file_dt_max"], rec["file_rows"], rec["file_resampled"]) == (pytest.approx(1e-3), 1001, False)
    assert rec["label"] == "closed-form" and rec["wall_s"] == 0.5 and rec["steps"] == 1000
    assert rec["err_pos_max"] < 1e-12 and rec["status"] == "completed"


def test_an_impact_removed_from_the_exact_ball_is_missed(tmp_path):
    imp = ball_impacts()
    assert len(imp) >= 3
    t = np.linspace(0.0, T_BALL, 2501)
    x, v = ball_motion(t, imp)
    f, fi = tmp_path / "ball.csv", tmp_path / "impacts.csv"
    pd.DataFrame({"t": t, "x": x, "v": v}).to_csv(f, index=False)
    pd.DataFrame({"t": imp[:1] + imp[2:], "contact": 0}).to_csv(fi, index=False)
    r = _score_json("ball", str(f), "--impacts", str(fi))
    assert r["against"] == "exact solution" and r["impacts_ref"] == len(imp)
    assert (r["impacts_missed"], r["impacts_matched"], r["impacts_spurious"]) == (1, len(imp) - 1, 0)
    assert r["err_x_max"] < 1e-9


def test_an_event_driven_file_gives_its_impacts_by_two_rows_at_one_time(tmp_path):
    """Two rows at each impact (before and after, gap 0) are the jump's sides: the impacts are
    found from the gap, none is missed, and the errors stay those of the exact motion."""
    imp = ball_impacts()
    t = np.sort(np.concatenate([np.linspace(0.0, T_BALL, 2501), imp, imp]))   # at the case's output.dt
    x, v = ball_motion(t, imp)
    first = np.flatnonzero(np.diff(t) == 0)            # the row before each impact: v⁻
    x[first], x[first + 1] = 0.0, 0.0
    v[first] = -math.sqrt(2 * G * H0) * E_BALL ** np.arange(len(imp))
    df = pd.DataFrame({"t": t, "x": x, "v": v, "gap": x})
    r = _score_json("ball", str(_csv(tmp_path / "ed.csv", df)))
    assert r["impacts"] == len(imp) and r["impacts_matched"] == len(imp) and r["impacts_missed"] == 0
    assert r["err_impact_t_max"] < 1e-12 and r["err_x_max"] < 1e-9


def _csv(path, df, meta=()):
    with open(path, "w") as fh:
        for line in meta:
            fh.write(line + "\n")
        df.to_csv(fh, index=False)
    return path


# ---- refusals: exit 2, a message that names the problem, no traceback, nothing written ------------
def _pendulum(n=101, t_end=1.0):
    t = np.linspace(0.0, t_end, n)
    return pd.DataFrame({"t": t, "theta_deg": pendulum_theta_deg(t)})


def _files(root) -> set:
    return set(root.rglob("*")) if root.exists() else set()


def _refused(results, *args) -> str:
    before = _files(results)
    r = runner.invoke(app, ["score", *args])
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output and (r.exception is None or isinstance(r.exception, SystemExit))
    assert _files(results) == before, "a refused file wrote something"
    return " ".join(r.output.split())


def test_refuses_a_file_without_a_time_column(tmp_path, results):
    f = _csv(tmp_path / "a.csv", _pendulum().rename(columns={"t": "time"}))
    msg = _refused(results, "pendulum", str(f))
    assert "no time column 't'" in msg and "'time' looks like it: name it 't'" in msg


def test_refuses_an_unknown_observable_with_a_suggestion(tmp_path, results):
    f = _csv(tmp_path / "a.csv", _pendulum().rename(columns={"theta_deg": "theta_dg"}))
    msg = _refused(results, "pendulum", str(f))
    assert "unknown column 'theta_dg'" in msg and "did you mean 'theta_deg'?" in msg


def test_refuses_a_file_without_any_observable(tmp_path, results):
    f = _csv(tmp_path / "a.csv", _pendulum()[["t"]].assign(E=0.0))
    msg = _refused(results, "pendulum", str(f))
    assert "holds no observable of the case" in msg and "theta_deg, x, y" in msg


def test_refuses_decreasing_times(tmp_path, results):
    df = _pendulum()
    df.loc[50, "t"] = 0.2
    msg = _refused(results, "pendulum", str(_csv(tmp_path / "a.csv", df)))
    assert "a.csv': the times decrease at row 51 (t = 0.2 s after 0.49 s)" in msg


def test_refuses_three_rows_at_one_time(tmp_path, results):
    df = _pendulum()
    df = pd.concat([df, df.iloc[[40, 40]]]).sort_values("t", kind="stable").reset_index(drop=True)
    msg = _refused(results, "pendulum", str(_csv(tmp_path / "a.csv", df)))
    assert "three or more rows at t = 0.4" in msg


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_refuses_nan_and_inf(tmp_path, results, bad):
    df = _pendulum()
    df.loc[7, "theta_deg"] = bad
    msg = _refused(results, "pendulum", str(_csv(tmp_path / "a.csv", df)))
    assert "column 'theta_deg' is" in msg and "in row 8" in msg and "finite values only" in msg


@pytest.mark.parametrize("times, what", [((-0.01, 1.0), "outside the case's span"),
                                         ((0.0, 1.02), "outside the case's span"),
                                         ((0.0, 0.5), "before the case's t_end")])
def test_refuses_times_outside_the_span(tmp_path, results, times, what):
    t = np.linspace(*times, 101)
    df = pd.DataFrame({"t": t, "theta_deg": 30.0 * np.cos(3.0 * t)})
    assert what in _refused(results, "pendulum", str(_csv(tmp_path / "a.csv", df)))


def test_refuses_what_is_not_csv_or_parquet(tmp_path, results):
    npz = tmp_path / "a.npz"
    np.savez(npz, t=np.zeros(3))
    assert "neither CSV nor Parquet" in _refused(results, "pendulum", str(npz))
    fake = tmp_path / "b.csv"
    fake.write_bytes(b"\x00\x01binary\x00" * 10)
    assert "is named .csv but is not a text file" in _refused(results, "pendulum", str(fake))
    pq = tmp_path / "c.parquet"
    pq.write_text("t,theta_deg\n0,30\n")
    assert "is not a Parquet file" in _refused(results, "pendulum", str(pq))
    assert "cannot be read" in _refused(results, "pendulum", str(tmp_path / "missing.csv"))


def test_refuses_a_file_over_the_size_limit(tmp_path, results, monkeypatch):
    from daebench.harness.scoring.external import reading as external

    f = _csv(tmp_path / "a.csv", _pendulum())
    monkeypatch.setattr(external, "MAX_BYTES", 1000)
    assert "more than the" in _refused(results, "pendulum", str(f))


def test_refuses_theta_in_radians_where_the_case_declares_degrees(tmp_path, results):
    t = np.linspace(0.0, 1.0, 1001)
    df = pd.DataFrame({"t": t, "theta_deg": np.radians(pendulum_theta_deg(t))})
    msg = _refused(results, "pendulum", str(_csv(tmp_path / "a.csv", df)))
    assert "looks like a unit error" in msg and "57.3" in msg and "radians where the case declares degrees" in msg


def test_refuses_a_sign_convention_and_non_numbers(tmp_path, results):
    t = np.linspace(0.0, 1.0, 1001)
    df = pd.DataFrame({"t": t, "theta_deg": -pendulum_theta_deg(t)})
    assert "opposite sign convention" in _refused(results, "pendulum", str(_csv(tmp_path / "a.csv", df)))
    bad = _pendulum().astype({"theta_deg": object})
    bad.loc[3, "theta_deg"] = "29,9"
    assert "holds something other than numbers (row 4: '29,9')" in _refused(
        results, "pendulum", str(_csv(tmp_path / "b.csv", bad)))


def test_refuses_bad_impacts_and_metadata(tmp_path, results):
    t = np.linspace(0.0, T_BALL, 251)
    x, v = ball_motion(t, ball_impacts())
    f = _csv(tmp_path / "ball.csv", pd.DataFrame({"t": t, "x": x, "v": v}))
    imp = _csv(tmp_path / "imp.csv", pd.DataFrame({"t": [0.45], "contact": [3]}))
    assert "contact 3 in row 1 is not a contact of the case" in _refused(results, "ball", str(f), "--impacts",
                                                                          str(imp))
    meta = _csv(tmp_path / "m.csv", _pendulum(), ["# cost_s: soon"])
    assert "must be a positive number of seconds" in _refused(results, "pendulum", str(meta))
    assert "must be a positive integer" in _refused(results, "pendulum", str(_csv(tmp_path / "n.csv", _pendulum())),
                                                   "--steps", "0")


# ---- the parts -------------------------------------------------------------------------------------
def test_metadata_lines_name_the_row_and_give_its_cost(tmp_path):
    t = np.linspace(0.0, 1.0, 1001)
    f = _csv(tmp_path / "run.csv", pd.DataFrame({"t": t, "theta_deg": pendulum_theta_deg(t) + 1e-5}),
             ["# label: my-code", "# cost_s: 0.25", "# steps: 500", "# code: MyCode 2.1"])
    r = _score_json("pendulum", str(f))
    assert (r["label"], r["wall_s"], r["steps"]) == ("my-code", 0.25, 500)
    assert json.loads(r["settings"]) == {"source": "run.csv", "events": "none", "code": "MyCode 2.1"}
    assert r["err_theta_max"] == pytest.approx(1e-5, rel=1e-8)


def test_a_row_written_twice_is_no_error_and_no_impact_without_contacts(tmp_path):
    t = np.linspace(0.0, 1.0, 1001)
    df = pd.DataFrame({"t": t, "theta_deg": pendulum_theta_deg(t)})
    df = pd.concat([df, df.iloc[[300]]]).sort_values("t", kind="stable")
    r = _score_json("pendulum", str(_csv(tmp_path / "twice.csv", df)))
    assert r["impacts"] == 0 and r["err_theta_max"] < 1e-12 and json.loads(r["settings"])["events"] == "none"


def test_gap_events_start_where_the_gap_closes():
    from daebench.harness.scoring.external import gap_events

    t = np.array([0.0, 1.0, 2.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    g = np.array([1.0, 0.5, 0.0, 0.0, 0.5, 0.2, -0.2, -0.1])   # a bounce at 2, a penetration from 4.5 on
    ev = gap_events(t, g)
    assert [e.t for e in ev] == [2.0, 4.5] and ev[0].t_end == 2.0 and ev[1].closed and ev[1].min_gap == -0.2


def test_the_api_takes_a_dataframe_and_a_list_of_impacts():
    import daebench

    imp = ball_impacts()
    t = np.linspace(0.0, T_BALL, 2501)
    x, v = ball_motion(t, imp)
    res = daebench.score("ball", pd.DataFrame({"t": t, "x": x, "v": v}), impacts=imp[:-1], write=False,
                         label="list")
    assert res.path is None and res.row["impacts_missed"] == 1 and res.row["label"] == "list"
