"""What every `daebench` command shares: plain output lines, the one way to refuse input
(exit 2 with a message), loading a scene with that refusal, tables, and the exit codes of
the API's errors (:func:`refusals`). The API is imported where a command runs, so that
`daebench --help` stays quick."""

from __future__ import annotations

import sys
from contextlib import contextmanager
from typing import Any, Iterator, NoReturn

import typer

from daebench.cli import textout


def out(line: str = "") -> None:
    sys.stdout.write(line + "\n")


def fail(msg: str, code: int = 2) -> NoReturn:
    sys.stderr.write(f"error: {msg}\n")
    raise typer.Exit(code)


@contextmanager
def refusals() -> Iterator[None]:
    """Exit 1 for a result that could not be written (the work ran, its input was fine),
    2 for refused input (:class:`daebench.api.ParamError`: nothing ran)."""
    from daebench import api

    try:
        yield
    except api.OutputWriteError as exc:
        fail(str(exc), 1)
    except api.ParamError as exc:  # refused input: 2; a failure of the work itself (a reference run): its code
        fail(str(exc), getattr(exc, "exit_code", 2))


def load_scene_or_exit(scene: str, sets: list[str]) -> Any:
    from daebench import api

    try:
        sc = api.load_scene(scene, sets)
    except api.ParamError as exc:
        fail(str(exc))
    for effect, keys in sc.idle_keys().items():  # accepted, but never silently
        sys.stderr.write(f"note: effects.{effect} = false, so {', '.join(keys)} "
                         f"{'has' if len(keys) == 1 else 'have'} no effect in this run\n")
    return sc


def print_table(columns: list[str], rows: list[list[Any]], title: str = "") -> None:
    for line in textout.table_lines(columns, rows, title=title):
        out(line)


def floats(text: str | None, what: str) -> list[str] | None:
    """Comma-separated values of an option (checked as numbers by the API), or None."""
    if text is None:
        return None
    vals = [x.strip() for x in text.split(",") if x.strip()]
    if not vals:
        fail(f"{what} needs comma-separated numbers, e.g. {what} 1e-3,5e-4; got '{text}'")
    return vals
