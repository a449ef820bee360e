"""What a command does, as one function each, between the harness and the API:
:mod:`.compare` (every applicable integrator at a case's protocol), :mod:`.survey` (every
case within a budget, profiles and recommendations), :mod:`.effects` (what each switchable
effect costs and changes), :mod:`.stability` (the largest stable step, measured and
predicted; its outputs in :mod:`.stability_report`), :mod:`.report` (one HTML page of a
comparison or a survey), :mod:`.score` (another code's trajectory scored as a run is),
:mod:`.export` (a case written out for another code to set up) and :mod:`.verify` (an
integrator's conformance run).

May import: :mod:`daebench.harness` and every layer below it; never :mod:`daebench.studies`,
:mod:`daebench.api` or :mod:`daebench.cli`.
"""
