"""Axis labels and legends of the work-precision figure: units from the case's own model
(two models score 'theta' in different units), the trusted-span columns named, the step
sizes of each line in its legend entry."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pandas as pd

from daebench.harness.analysis.plots import label_of, model_of, work_precision


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
