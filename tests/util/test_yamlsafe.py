"""The one YAML writer: numpy scalars and arrays written as the plain YAML numbers, booleans and lists they hold
(read back by the strict loader as the same values); a value YAML cannot write plainly refused by name."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ur5fault.errors import ParameterError
from ur5fault.util.yamlsafe import dump, loads, plain


def test_numpy_values_are_written_as_plain_yaml():
    data = {"duration_s": np.float64(1.5), "seed": np.int64(3), "on": np.bool_(True), "name": np.str_("x"),
            "sizes": np.array([0.1, 0.2]), "pair": (np.int32(1), 2.0), np.int64(7): "key"}
    text = dump(data, sort_keys=False)
    assert text == "duration_s: 1.5\nseed: 3\n'on': true\nname: x\nsizes:\n- 0.1\n- 0.2\npair:\n- 1\n- 2.0\n7: key\n"
    assert "!!python" not in text
    back = loads(text)
    assert back == {"duration_s": 1.5, "seed": 3, "on": True, "name": "x", "sizes": [0.1, 0.2], "pair": [1, 2.0],
                    7: "key"}
    assert type(back["seed"]) is int and type(back["duration_s"]) is float


def test_plain_leaves_python_values_alone():
    data = {"a": [1, 2.5, "x", None, True], "b": {"c": 1}}
    assert plain(data) == data
    assert dump(data) == dump(plain(data))


def test_a_value_yaml_cannot_write_is_refused_by_name():
    with pytest.raises(ParameterError, match=r"^campaign.yaml: cannot write PosixPath\('/tmp'\) \(PosixPath\) as "
                                             r"YAML; give numbers, text, true/false, lists and mappings$"):
        dump({"out": Path("/tmp")}, "campaign.yaml")
