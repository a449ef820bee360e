"""What every `daebench` command shares: plain output lines, the one way to refuse
input (exit 2 with a message), loading a scene with that refusal, and tables."""

from __future__ import annotations

import sys
from typing import Any, NoReturn

import typer

from daebench.cli import textout
from daebench.core.params import ParamError


def out(line: str = "") -> None:
    sys.stdout.write(line + "\n")


def fail(msg: str, code: int = 2) -> NoReturn:
    sys.stderr.write(f"error: {msg}\n")
    raise typer.Exit(code)


def load_scene_or_exit(scene: str, sets: list[str]):
    from daebench.models.scenes import load_scene

    try:
        sc = load_scene(scene, sets)
    except ParamError as exc:
        fail(str(exc))
    for effect, keys in sc.idle_keys().items():  # accepted, but never silently
        sys.stderr.write(f"note: effects.{effect} = false, so {', '.join(keys)} "
                         f"{'has' if len(keys) == 1 else 'have'} no effect in this run\n")
    return sc


def print_table(columns: list[str], rows: list[list[Any]], title: str = "") -> None:
    for line in textout.table_lines(columns, rows, title=title):
        out(line)
