"""daebench.cli.common: the command line's exit codes (2: refused input, nothing ran; 1: the
work ran and its result could not be written), its error line, a scene loaded or its unknown
key refused with exit 2, and comma-separated numbers."""

from __future__ import annotations

import pytest
import typer

from daebench import api
from daebench.cli import common


def test_refused_input_exits_2_and_an_unwritten_result_1(capsys):
    with pytest.raises(typer.Exit) as exc:
        with common.refusals():
            raise api.ParamError("bad key 'x'")
    assert exc.value.exit_code == 2 and capsys.readouterr().err == "error: bad key 'x'\n"
    with pytest.raises(typer.Exit) as exc:
        with common.refusals():
            raise api.OutputWriteError("results/ is read-only")
    assert exc.value.exit_code == 1 and "error: results/ is read-only" in capsys.readouterr().err
    with common.refusals():     # nothing raised: nothing said
        pass
    assert capsys.readouterr().err == ""


def test_a_scene_loads_and_an_unknown_key_exits_2_naming_it(capsys):
    sc = common.load_scene_or_exit("beam-impact", [])
    assert sc.name == "beam-impact" and "note:" not in capsys.readouterr().err
    with pytest.raises(typer.Exit) as exc:
        common.load_scene_or_exit("beam-impact", ["no.such=1"])
    assert exc.value.exit_code == 2 and "no.such" in capsys.readouterr().err


def test_comma_separated_numbers():
    assert common.floats(None, "--steps") is None
    assert common.floats(" 1e-3, 5e-4 ,", "--steps") == ["1e-3", "5e-4"]
    with pytest.raises(typer.Exit):
        common.floats(" , ", "--steps")
