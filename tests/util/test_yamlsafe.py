"""The one YAML writer: numpy scalars and arrays written as the plain YAML numbers, booleans and lists they hold
(read back by the strict loader as the same values); a value YAML cannot write plainly refused by name."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

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
    assert dump(data) == "a:\n- 1\n- 2.5\n- x\n- null\n- true\nb:\n  c: 1\n"


def test_nested_numpy_values_are_written_as_the_yaml_their_numbers_make():
    """Against YAML written by hand (not against ``dump(plain(data))``, which ``dump`` is): numpy numbers of every
    width, bools, arrays of two dimensions and none, inside dicts and tuples nested in each other."""
    data = {"outer": {"inner": {"gain": np.float32(0.5), "n": np.uint8(7), "flags": (np.bool_(False), True)},
                      "grid": np.array([[1, 2], [3, 4]], dtype=np.int16),
                      "pair": (np.float64(-1e-9), (np.int64(2),))},
            "empty": np.array([])}
    text = dump(data)
    assert text == ("empty: []\n"
                    "outer:\n"
                    "  grid:\n"
                    "  - - 1\n"
                    "    - 2\n"
                    "  - - 3\n"
                    "    - 4\n"
                    "  inner:\n"
                    "    flags:\n"
                    "    - false\n"
                    "    - true\n"
                    "    gain: 0.5\n"
                    "    n: 7\n"
                    "  pair:\n"
                    "  - -1.0e-09\n"
                    "  - - 2\n")
    assert "!!" not in text
    expected = {"empty": [], "outer": {"grid": [[1, 2], [3, 4]], "inner": {"flags": [False, True], "gain": 0.5, "n": 7},
                                       "pair": [-1e-9, [2]]}}
    for back in (yaml.safe_load(text), loads(text)):
        assert back == expected
        assert type(back["outer"]["inner"]["n"]) is int and type(back["outer"]["inner"]["gain"]) is float
        assert type(back["outer"]["inner"]["flags"][0]) is bool and type(back["outer"]["grid"][0][0]) is int


def test_a_value_yaml_cannot_write_is_refused_by_name():
    with pytest.raises(ParameterError, match=r"^campaign.yaml: cannot write PosixPath\('/tmp'\) \(PosixPath\) as "
                                             r"YAML; give numbers, text, true/false, lists and mappings$"):
        dump({"out": Path("/tmp")}, "campaign.yaml")
