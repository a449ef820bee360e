"""Scoring a run: one pipeline (:mod:`.pipeline`) that finds the truth (the model's exact
solution or a cached reference) and applies every measure — whole-run errors and energy
balance (:mod:`.metrics`), errors around impacts (:mod:`.impact_metrics`), the event
sequence (:mod:`.eventseq`), the exact impact oracle (:mod:`.oracle`) and the graph
distance (:mod:`.graphdist`); and other codes' trajectories read and checked as the same
pipeline's input (:mod:`.external`).

May import: :mod:`daebench.harness.running` and the layers below the harness; a reference
reaches it as a value, so it never imports :mod:`daebench.harness.references`.
"""
