"""The named checks of single values at the public edge: numpy scalars pass as the Python values they hold and come
back as them; bools (Python's or numpy's) never pass as numbers; messages name the value and the range."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.errors import ParameterError
from ur5fault.util.checks import check_bool, check_count, check_int, check_number, check_text, range_text


@pytest.mark.parametrize("value", [np.float64(0.5), np.float32(0.5), np.float16(0.5)])
def test_numpy_floats_are_numbers(value):
    out = check_number(value, "x", 0.0, 1.0)
    assert out == 0.5 and type(out) is float


@pytest.mark.parametrize("value", [np.int64(3), np.int8(3), np.uint32(3)])
def test_numpy_integers_are_numbers_and_integers(value):
    assert check_number(value, "x", 0, 5) == 3.0 and type(check_number(value, "x", 0, 5)) is float
    out = check_int(value, "x", 0, 5)
    assert out == 3 and type(out) is int
    out = check_count(value, "--jobs", 1)
    assert out == 3 and type(out) is int


def test_numpy_float_of_integral_value_is_the_integer():
    out = check_int(np.float64(4.0), "x", 0, 5)
    assert out == 4 and type(out) is int


def test_numpy_bool_is_a_bool_never_a_number():
    assert check_bool(np.bool_(True), "x") is True and check_bool(np.False_, "x") is False
    with pytest.raises(ParameterError, match=r"^x = np.True_ must be a number in \[0, 1\]$"):
        check_number(np.True_, "x", 0, 1)
    with pytest.raises(ParameterError, match=r"^x = np.True_ must be an integer in \[0, 5\]$"):
        check_int(np.True_, "x", 0, 5)
    with pytest.raises(ParameterError, match=r"^--jobs np.True_: must be a whole number of at least 1$"):
        check_count(np.True_, "--jobs", 1)


def test_numpy_values_refused_as_python_ones_are():
    with pytest.raises(ParameterError, match=r"^x = np.float64\(nan\) must be a finite number in \[0, 1\]$"):
        check_number(np.float64("nan"), "x", 0, 1)
    with pytest.raises(ParameterError, match=r"^x = np.int64\(7\) is out of range \[0, 1\]$"):
        check_number(np.int64(7), "x", 0, 1)
    with pytest.raises(ParameterError, match=r"^x = np.float64\(1.5\) must be an integer in \[0, 5\]$"):
        check_int(np.float64(1.5), "x", 0, 5)
    with pytest.raises(ParameterError, match=r"^--jobs np.int64\(0\): must be a whole number of at least 1$"):
        check_count(np.int64(0), "--jobs", 1)
    with pytest.raises(ParameterError, match=r"^x = 1 must be true or false$"):
        check_bool(1, "x")


def test_numpy_string_is_text():
    out = check_text(np.str_("abc"), "name")
    assert out == "abc" and type(out) is str


def test_a_range_of_a_factor_has_no_unit():
    """A dimensionless unit "-" ended messages as `[0, 10] -`, read as a line cut off."""
    assert range_text(0, 10, "-") == range_text(0, 10) == "[0, 10]"
    assert range_text(0, 3600, "s", lo_open=True) == "(0, 3600] s"
    with pytest.raises(ParameterError) as e:
        check_number(11, "x", 0, 10, "-")
    assert str(e.value) == "x = 11 is out of range [0, 10]"
