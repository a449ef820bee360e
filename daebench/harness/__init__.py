"""Everything around a run that turns it into a verdict: making an integrator for a
scene and running it (:mod:`.runner`), input checks and wall-time caps (:mod:`.guards`),
references (:mod:`.references`, :mod:`.fingerprints`), one scoring pipeline
(:mod:`.scoring`, against an exact solution or the reference, with the measures of
:mod:`.metrics`, :mod:`.impact_metrics` and others), timing (:mod:`.timing`), sweeps
with their options, row store and executors (:mod:`.options`, :mod:`.bench`,
:mod:`.sweeprun`, :mod:`.sweepstore`, :mod:`.executors`),
the comparison protocol (:mod:`.compare`), provenance, progress and figures.

May import: every layer below it (core, stepping, models, integrators, driver);
never :mod:`daebench.api`, :mod:`daebench.studies` or :mod:`daebench.cli`.
"""
