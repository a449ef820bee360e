"""Trajectories from other codes: a file (CSV or Parquet) or a DataFrame of a case's
observables, read, checked and turned into what the one scoring pipeline
(:mod:`daebench.harness.scoring.pipeline`) scores — a history and its impact records — so
that an Exudyn, Siconos, Chrono or MATLAB result is held to the same truth, over the same
trusted span, with the same measures and the same verdict rules as a daebench run.

**What a file holds.** A time column ``t`` [s] and any of the case's observables, named and
in the units the model declares (``daebench show CASE`` lists them); optionally the energy
terms ``E`` or ``E_<term>`` [J], the work ``W_<effect>`` [J] and the impact losses
``D_impacts`` [J, cumulative] (the energy balance is then scored), and the constraint
residuals ``C``, ``Cdot``, ``Cddot``. Times never decrease, from the case's start t = 0 to its
t_end; an event-driven code writes two rows at an impact (before and after, the same t):
they are the two sides of the jump, as an exact reference holds them, and at most two rows
share a time. The first row is the case's start: its values are checked against the case's.

**Metadata.** A CSV file may start with comment lines ``# key: value``; a Parquet file
carries the same keys in its schema metadata; a DataFrame in ``df.attrs``. Read:
``label`` (the row's name), ``cost_s`` (the external run's cost [s], its work–precision
abscissa), ``steps`` (its step count); every other key (``code: Exudyn 1.13.6``,
``method: generalized-alpha``) is kept in the row's ``settings`` as provenance.

The modules, one concept each:

* :mod:`.records` — the impact records, the checked data, the error every refusal raises;
* :mod:`.reading` — CSV and Parquet read within bounds;
* :mod:`.checks` — metadata, columns, numbers, times, units, start values;
* :mod:`.events` — the event sequence (impacts table, gap column, repeated times);
* :mod:`.grid` — sparse files on the case's output times, impact rows matched one-sidedly;
* :mod:`.judge` — the verdict, by the rules of a run;
* :mod:`.loading` — the whole input (:func:`load`).

May import: :mod:`daebench.harness.running`, the scoring modules, the sweeps' digest and the
layers below the harness (as every scoring module).
"""

from daebench.harness.scoring.external.checks import (ENERGY_COLUMNS, RESIDUAL_COLUMNS, accepted_columns,
                                                      check_history, check_times, check_units, metadata,
                                                      start_mismatches)
from daebench.harness.scoring.external.events import gap_events, read_impacts, repeated_time_events
from daebench.harness.scoring.external.loading import load
from daebench.harness.scoring.external.reading import read_table
from daebench.harness.scoring.external.records import ExternalData, ExternalDataError, ExternalImpact, clip

__all__ = ["ENERGY_COLUMNS", "RESIDUAL_COLUMNS", "ExternalData", "ExternalDataError", "ExternalImpact",
           "accepted_columns", "check_history", "check_times", "check_units", "clip", "gap_events", "load",
           "metadata", "read_impacts", "read_table", "repeated_time_events", "start_mismatches"]
