"""Everything around a run that turns it into a verdict: making an integrator for a
scene and running it (:mod:`.runner`), input checks and wall-time caps (:mod:`.guards`),
references (:mod:`.references`, :mod:`.fingerprints`), scores (:mod:`.metrics`,
:mod:`.impact_metrics`), timing (:mod:`.timing`), sweeps with their row store and
executors (:mod:`.bench`, :mod:`.sweeprun`, :mod:`.sweepstore`, :mod:`.executors`),
the comparison protocol (:mod:`.compare`), provenance, progress and figures.

May import: every layer below it (core, stepping, models, integrators, driver);
never :mod:`daebench.api`, :mod:`daebench.studies` or :mod:`daebench.cli`.
"""
