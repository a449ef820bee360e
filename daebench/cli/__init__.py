"""The `daebench` command: :mod:`.app` holds the Typer application and the core commands
(list, show, run, bench, reference, paper, perf); one module per further command group
(:mod:`.compare`, :mod:`.capture`, :mod:`.plot`, :mod:`.seed003`, :mod:`.stability`)
registers itself on it; :mod:`.common` is what they share (output lines, refusal with
exit 2), :mod:`.textout` the plain-text tables.

May import: every layer (it is the top one); nothing imports it.
"""
