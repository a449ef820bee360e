"""The `daebench` command: :mod:`.app` holds the Typer application, small; one module per
command group registers its commands on it the one way (``register(app)``):
:mod:`.catalogue` (list, show), :mod:`.runs` (run, reference), :mod:`.external` (score,
export), :mod:`.sweeps` (bench, compare, survey, report, effects, stability),
:mod:`.studies` (paper, averaged-gap, interactive-mode, capture), :mod:`.perf` (perf, compile-report) and :mod:`.plot`.
:mod:`.common` is what they share (output lines, refusal with exit 2, exit codes of the
API's errors), :mod:`.textout` the plain-text tables. Each command parses its arguments,
calls the API and prints.

May import: :mod:`daebench.api` only (and its own modules; ``tests/test_layers.py``
checks it); nothing imports it.
"""
