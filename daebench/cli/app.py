"""The `daebench` command: a thin layer over :mod:`daebench.api`, one module per command
group, each registering its commands with ``register(app)``.

Exit codes: 0 done; 1 a run did not complete (diverged, failed, timed out) or a sweep
has rows that failed for a reason other than the integrator's verdict (error, timeout,
crashed); 2 the input was refused (nothing ran, the message says what to change);
130 interrupted (finished sweep rows are kept). Results go to stdout (``--json``:
machine-only), progress and errors to stderr; no line is wrapped inside a number.
"""

from __future__ import annotations

import sys

import typer

from daebench.cli import catalogue, external, peers, perf, plot, runs, studies, sweeps, verify

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False, rich_markup_mode="markdown",
                  help="Benchmark time integrators for constrained mechanical systems with impact.")

for group in (catalogue, runs, external, peers, sweeps, studies, perf, plot, verify):
    group.register(app)


def main() -> None:  # pragma: no cover
    try:
        app()
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        sys.exit(130)


if __name__ == "__main__":  # pragma: no cover
    main()
