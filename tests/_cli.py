"""The command line as the surface tests drive it: one invocation that never shows a traceback."""

from typer.testing import CliRunner

from daebench.cli.app import app

runner = CliRunner()


def cli(args: list[str]):
    """``daebench ARGS`` in-process; fails the test on a traceback or an exception other than exit."""
    r = runner.invoke(app, args)
    assert "Traceback" not in r.output, r.output
    assert r.exception is None or isinstance(r.exception, SystemExit), (args, r.exception, r.output)
    return r
