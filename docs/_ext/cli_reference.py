"""The CLI reference, generated from the commands: ``.. typer-cli:: module:attribute`` renders
a Typer application's click command (``typer.main.get_command(app)``) — every command and
sub-command with its help, usage, arguments and options.

Typer vendors its own click, whose command classes sphinx-click does not accept; this
directive reads the same attributes (name, help, params, commands) from the command tree."""

from __future__ import annotations

import importlib
import re

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles


def _text(s: str | None) -> str:
    """Help text as reStructuredText: `code` as literals, markup characters escaped."""
    s = (s or "").replace("\\", "\\\\")
    parts = re.split(r"(`[^`]+`)", s)
    out = []
    for part in parts:
        if part.startswith("`") and part.endswith("`") and len(part) > 1:
            out.append("``" + part[1:-1] + "``")
        else:
            out.append(re.sub(r"([*|_<>])", r"\\\1", part))
    return "".join(out)


def _param_rows(command) -> tuple[list[str], list[tuple[str, str]]]:
    args, opts = [], []
    for p in command.params:
        if getattr(p, "hidden", False) or p.name == "help":
            continue
        if p.param_type_name == "argument":
            args.append((p.name.upper(), _text(getattr(p, "help", "")) + ("" if p.required else " (optional)")))
        else:
            names = ", ".join(p.opts)
            if p.secondary_opts:
                names += " / " + ", ".join(p.secondary_opts)
            default = p.default
            tail = ""
            if default not in (None, False, [], (), "") and not callable(default):
                tail = f" Default: ``{default}``."
            opts.append((names, _text(getattr(p, "help", "")) + tail))
    return args, opts


def _lines(command, path: list[str]) -> list[str]:
    title = " ".join(path)
    lines = [title, "-" * len(title) if len(path) == 2 else "~" * len(title), ""]
    if len(path) == 1:
        lines = []
    lines += [_text(command.help).strip(), ""]
    args, opts = _param_rows(command)
    subs = getattr(command, "commands", None)
    usage = " ".join(path) + " [OPTIONS]" + "".join(f" {a}" for a, _ in args) + (" COMMAND [ARGS]..." if subs else "")
    lines += [".. code-block:: text", "", "   " + usage, ""]
    for heading, rows in (("Arguments", args), ("Options", opts)):
        if rows:
            lines += [f".. rubric:: {heading}", ""]
            for name, help_ in rows:
                lines += [f"``{name}``", f"   {help_ or ' '}", ""]
    for name, sub in (subs or {}).items():
        if not getattr(sub, "hidden", False):
            lines += _lines(sub, path + [name])
    return lines


class TyperCli(SphinxDirective):
    required_arguments = 1
    option_spec = {"prog": str}

    def run(self) -> list[nodes.Node]:
        module, attr = self.arguments[0].split(":")
        command = getattr(importlib.import_module(module), attr)
        lines = _lines(command, [self.options.get("prog", command.name or "cli")])
        node = nodes.section()
        node.document = self.state.document
        nested_parse_with_titles(self.state, StringList(lines, source=self.arguments[0]), node)
        return node.children


def setup(app):
    app.add_directive("typer-cli", TyperCli)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
