"""`daebench stability`: its options are validated and its files are never replaced silently."""

from __future__ import annotations

import pytest

from daebench import api
from daebench.core.params import ParamError


def test_an_unknown_n_key_is_refused_with_the_scene_whole_number_keys(tmp_path):
    with pytest.raises(ParamError) as err:
        api.stability("pendulum", ["hht"], "", api.Bisection(n_key="nope.key"), out=tmp_path)
    msg = str(err.value)
    assert "--n-key 'nope.key'" in msg and "has no such key" in msg
    assert list(tmp_path.iterdir()) == []


def test_a_second_map_of_the_same_name_is_refused_without_overwrite(tmp_path):
    earlier = tmp_path / "pendulum-stability.csv"
    earlier.write_text("the first run's table\n")
    with pytest.raises(ParamError) as err:
        api.stability("pendulum", ["hht"], "", api.Bisection(h_min=1e-3, h_max=1e-2, tol=0.5), out=tmp_path)
    assert "--overwrite" in str(err.value) and "pendulum-stability.csv" in str(err.value)
    assert earlier.read_text() == "the first run's table\n"


def test_overwrite_replaces_the_earlier_map(tmp_path):
    earlier = tmp_path / "pendulum-stability.csv"
    earlier.write_text("the first run's table\n")
    res = api.stability("pendulum", ["hht"], "", api.Bisection(t_end=0.2, h_min=5e-3, h_max=1e-2, tol=0.5),
                        out=tmp_path, overwrite=True)
    assert earlier in res.files and earlier.read_text().startswith("integrator,")
