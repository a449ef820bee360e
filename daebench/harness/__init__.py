"""Everything around a run that turns it into a verdict, one folder per concept, read
bottom-up: :mod:`.running` (one scene with one integrator: the pre-run checks, the
wall-time cap, the history file, progress, timing, provenance), :mod:`.scoring` (one
pipeline that scores a run against an exact solution or a reference, and its measures),
:mod:`.references` (trusted references: computed, checked, cached, shipped), :mod:`.sweeps`
(many runs → one stored table: options, plan, executors, row store) and :mod:`.analysis`
(what the numbers mean: cost to reach a target, performance profiles, recommendations,
figures). :mod:`.files` is where results go and how they are written.

May import: every layer below it (core, stepping, models, integrators, driver), and a
folder here only the folders before it in that list; never :mod:`daebench.workflows`,
:mod:`daebench.studies`, :mod:`daebench.api` or :mod:`daebench.cli`.
"""
