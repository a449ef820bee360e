"""The `daebench` command as a click command: what the documentation's CLI reference
(sphinx-click) reads, so the reference is generated from the commands themselves."""

from __future__ import annotations

import typer

from daebench.cli.app import app

command = typer.main.get_command(app)
