"""The effect registry: validation at the edge and each entry acting on its row only."""

import numpy as np
import pytest

from ur5fault.errors import ParameterError, UnknownNameError
from ur5fault.sim.effects import REGISTRY, make_effect
from ur5fault.sim.params import load_params
from ur5fault.sim.run_arrays import build_run_arrays


def test_unknown_effect_lists_registry():
    with pytest.raises(UnknownNameError) as e:
        make_effect("backlassh", 2, backlash_deg=0.1)
    assert "backlash" in str(e.value) and "cogging" in str(e.value)


def test_joint_required_and_validated():
    with pytest.raises(ParameterError, match="needs a joint"):
        make_effect("backlash", backlash_deg=0.1)
    with pytest.raises(UnknownNameError, match="unknown joint 'knee'"):
        make_effect("backlash", "knee", backlash_deg=0.1)
    with pytest.raises(ParameterError, match="takes no joint"):
        make_effect("temperature", 1, temperature_C=30)


def test_range_and_unknown_parameter():
    with pytest.raises(ParameterError) as e:
        make_effect("backlash", "elbow", backlash_deg=-0.1)
    assert str(e.value) == "backlash.backlash_deg = -0.1 is out of range [0, 5] deg"
    with pytest.raises(UnknownNameError, match="unknown parameter of effect 'backlash' 'alpha'"):
        make_effect("backlash", 3, alpha=0.1)


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_each_effect_changes_only_its_run_and_absent_means_no_change(name):
    eff = REGISTRY[name]
    p = load_params()
    values = {q.name: (q.hi if q.absent is None else (q.absent + (q.hi - q.absent) * 0.5)) for q in eff.params}
    spec = make_effect(name, 3 if eff.per_joint else None, **values)
    base = build_run_arrays(p, [(), ()], 2.0)
    arr = build_run_arrays(p, [(), (spec,)], 2.0)
    changed = [f for f in vars(arr) if not np.array_equal(getattr(arr, f)[1], getattr(base, f)[1])]
    assert changed, f"effect {name} changed nothing"
    for f in vars(arr):  # run 0 untouched
        np.testing.assert_array_equal(getattr(arr, f)[0], getattr(base, f)[0])
    if eff.per_joint:  # only joint 3 (index 2) of per-joint arrays
        for f in changed:
            a, b = getattr(arr, f)[1], getattr(base, f)[1]
            if a.shape == (6,):
                assert np.flatnonzero(a != b).tolist() == [2]
    if all(q.absent is not None for q in eff.params):
        absent = make_effect(name, 3 if eff.per_joint else None)
        same = build_run_arrays(p, [(), (absent,)], 2.0)
        for f in vars(same):
            np.testing.assert_array_equal(getattr(same, f)[1], getattr(base, f)[1])


def test_backlash_in_degrees_becomes_radians():
    a = build_run_arrays(load_params(), [(make_effect("backlash", "shoulder_lift_joint", backlash_deg=0.1),)], 0.0)
    assert a.backlash_rad[0, 1] == pytest.approx(np.radians(0.1))
