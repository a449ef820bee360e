"""Sweeps: many runs → one tidy table that loses nothing. The options travel as values
(:mod:`.options`); the plan is checked before anything runs (:mod:`.plan`); each run
becomes one scored row (:mod:`.row`) on an executor (:mod:`.executors`: this process,
worker processes; :mod:`.dask_cluster`: a Dask cluster, its faults told apart from the
runs'), stored as it finishes (:mod:`.store`); :mod:`.sweep` ties them
together, and :mod:`.digest` fingerprints a history for the determinism checks.

May import: :mod:`daebench.harness.running`, :mod:`.scoring`, :mod:`.references` and the
layers below the harness.
"""
