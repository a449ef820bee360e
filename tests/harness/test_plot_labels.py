"""Axis labels and legends of the work-precision figure: units from the case's own model
(two models score 'theta' in different units), the trusted-span columns named, the step
sizes of each line in its legend entry."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pandas as pd

from daebench.harness.analysis.plots import label_of, model_of, sweep_title, work_precision


def test_units_come_from_the_cases_model():
    assert model_of(pd.DataFrame({"case": ["beam-impact", "beam-impact"]})) == "hub-beam"
    assert model_of(pd.DataFrame({"case": ["rocking-block"]})) == "rigid2d"
    assert model_of(pd.DataFrame({"case": ["rocking-block", "beam-impact"]})) is None
    assert label_of("err_theta_max_trusted", "hub-beam") == "θ max error over the trusted span [deg]"
    assert label_of("err_theta_max_trusted", "rigid2d") == "θ max error over the trusted span [rad]"
    assert label_of("err_pre_theta_max", "rigid2d") == "θ max error before the first impact [rad]"
    # without the model, a unit the models agree on is still given
    assert label_of("err_omega_max").endswith("[rad/s]")


def test_legend_names_the_step_sizes():
    df = pd.DataFrame({"case": ["rocking-block"] * 4, "label": ["moreau", "moreau", "moreau", "ida"],
                       "h": [2e-3, 1e-3, 5e-4, np.nan], "wall_s": [1.0, 2.0, 4.0, 3.0],
                       "err_theta_max_trusted": [1e-3, 5e-4, 2.5e-4, 1e-5]})
    fig, _ = work_precision(df, "wall_s", ["err_theta_max_trusted"], "label")
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "moreau (h 0.002…0.0005 s)" in labels and "ida" in labels
    assert ax.get_ylabel() == "θ max error over the trusted span [rad]"
    assert ax.get_xlabel() == "wall time [s]"


def _wp_rows() -> pd.DataFrame:
    # three steps of one method whose CPU times span less than a decade (0.24–0.62 s)
    return pd.DataFrame({"label": ["hht"] * 3, "integrator": ["hht"] * 3, "h": [1e-4, 5e-5, 2.5e-5],
                         "cpu_s": [0.24, 0.37, 0.62], "err_theta_max": [2.0, 1.5, 1.1]})


def test_a_short_cost_range_still_has_labelled_ticks():
    fig, _ = work_precision(_wp_rows(), y="err_theta_max")
    fig.canvas.draw()
    ax = fig.axes[0]
    shown = [t for t in ax.get_xticklabels(minor=False) + ax.get_xticklabels(minor=True)
             if t.get_text() and ax.get_xlim()[0] <= t.get_position()[0] <= ax.get_xlim()[1]]
    assert len(shown) >= 2, [t.get_text() for t in shown]
    lo, hi = ax.get_xlim()
    assert lo <= 0.24 and hi >= 0.62


def test_each_point_is_named_by_its_step_and_cost_is_cpu_time():
    fig, _ = work_precision(_wp_rows(), y="err_theta_max")
    texts = {t.get_text() for t in fig.axes[0].texts}
    assert {"0.0001", "5e-05", "2.5e-05"} <= texts
    assert "CPU" in fig.axes[0].get_xlabel()


def test_a_sweep_title_names_what_its_answer_depends_on_by_symbol():
    df = pd.DataFrame({"case": ["beam-impact"] * 2,
                       "scene_set": ['{"discretization.n": 3, "t_end": 0.38}'] * 2})
    assert sweep_title(df, "convergence") == "convergence, beam-impact N = 3, e = 0, t_end=0.38 (2 runs)"
    # a value left at the case's default is named too
    default_n = sweep_title(df.assign(scene_set='{"t_end": 0.38}'))
    assert default_n == "work–precision, beam-impact N = 5, e = 0, t_end=0.38 (2 runs)"
