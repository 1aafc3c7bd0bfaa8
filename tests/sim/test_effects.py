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


def test_a_sizeless_effect_is_refused_from_python_as_from_yaml():
    """make_effect once filled every missing value with its absent one, so make_effect("backlash", 2) was a
    backlash of 0 deg labelled as a fault; the command line and YAML refused it already."""
    with pytest.raises(ParameterError) as e:
        make_effect("backlash", "shoulder_lift_joint")
    assert str(e.value) == "effect 'backlash' has no size; give backlash_deg [0..5 deg]"
    with pytest.raises(ParameterError, match=r"^here: effect 'payload' has no size; give mass_kg \[0\.\.5 kg\]$"):
        make_effect("payload", where="here")


def test_a_factors_range_is_written_without_a_unit():
    """A dimensionless size's unit "-" was written in the messages: `give scale [0..10 -]`, `[0, 10] -`."""
    with pytest.raises(ParameterError) as e:
        make_effect("coulomb_friction", "elbow")
    assert str(e.value) == "effect 'coulomb_friction' has no size; give scale [0..10]"
    with pytest.raises(ParameterError) as e:
        make_effect("coulomb_friction", "elbow", scale=11)
    assert str(e.value) == "coulomb_friction.scale = 11 is out of range [0, 10]"


def test_numpy_scalars_are_sizes_and_joints():
    e = make_effect("backlash", np.int64(2), backlash_deg=np.float32(0.5))
    assert e == make_effect("backlash", 2, backlash_deg=0.5) and type(e.value("backlash_deg")) is float
    assert make_effect("backlash", 2, backlash_deg=np.int64(1)) == make_effect("backlash", 2, backlash_deg=1.0)
    with pytest.raises(ParameterError, match=r"^backlash.backlash_deg = np.True_ must be a number in \[0, 5\] deg$"):
        make_effect("backlash", 2, backlash_deg=np.True_)


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
        absent = make_effect(name, 3 if eff.per_joint else None, **{q.name: q.absent for q in eff.params})
        same = build_run_arrays(p, [(), (absent,)], 2.0)
        for f in vars(same):
            np.testing.assert_array_equal(getattr(same, f)[1], getattr(base, f)[1])


def test_backlash_in_degrees_becomes_radians():
    a = build_run_arrays(load_params(), [(make_effect("backlash", "shoulder_lift_joint", backlash_deg=0.1),)], 0.0)
    assert a.backlash_rad[0, 1] == pytest.approx(np.radians(0.1))


def test_effect_keys_parse_at_the_first_dot_only():
    from ur5fault.sim.effect_types import EffectKey

    k = EffectKey.parse("backlash.backlash_deg")
    assert (k.effect, k.param, str(k)) == ("backlash", "backlash_deg", "backlash.backlash_deg")
    assert EffectKey.parse("payload_com.dz_m.x") == EffectKey("payload_com", "dz_m.x")
    assert EffectKey.parse("seed") is None and EffectKey.parse(3) is None


def test_effects_of_keys_group_validate_and_skip_plain_keys():
    from ur5fault.sim.effects import effects_of_keys

    specs = effects_of_keys([("seed", 1), ("payload_com.dz_m", 0.05), ("backlash.joint", 3),
                             ("backlash.backlash_deg", 0.2)])
    assert [s.name for s in specs] == ["backlash", "payload_com"]  # name order
    assert specs[0].joint == 2 and specs[0].values == (("backlash_deg", 0.2),)
    assert specs[1].values == (("dx_m", 0.0), ("dy_m", 0.0), ("dz_m", 0.05))
    with pytest.raises(ParameterError, match=r"here: backlash.backlash_deg = 9 is out of range \[0, 5\] deg"):
        effects_of_keys([("backlash.joint", 1), ("backlash.backlash_deg", 9)], "here")


def test_absent_values_come_from_the_registry():
    assert REGISTRY["cogging"].absent("periods_per_rev") == 6.0
    with pytest.raises(ParameterError, match="'payload': parameter 'mass_kg' has no absent value"):
        REGISTRY["payload"].absent("mass_kg")
    assert make_effect("backlash", 1, backlash_deg=0.0).is_absent
    assert not make_effect("backlash", 1, backlash_deg=0.1).is_absent
    # a run without effects holds every term field at the registry's absent value
    a = build_run_arrays(load_params(), [()], 0.0)
    assert np.all(a.term_holding_speed_rad_s == REGISTRY["torque_holding"].absent("speed_rad_s"))
    assert np.all(a.cogging_periods_per_rev == 6.0)


@pytest.mark.parametrize("key", ["where", "name"])
def test_a_key_named_like_an_argument_is_an_unknown_parameter(key):
    """`{effect: backlash, joint: 2, where: 5}` in a file, an overlay or `--effect` crashed with "make_effect() got
    multiple values for keyword argument 'where'" (a traceback, exit 1)."""
    from ur5fault.config import parse_effects
    from ur5fault.errors import UnknownNameError

    with pytest.raises(UnknownNameError, match=rf"f.yaml: effects\[0\]: unknown parameter of effect 'backlash' "
                                               rf"'{key}'; valid: backlash_deg"):
        parse_effects([{"effect": "backlash", "joint": 2, "backlash_deg": 0.1, key: 5}], "f.yaml: effects")


def test_where_is_given_by_name_only():
    """`make_effect("backlash", 2, 0.1)` took 0.1 for the message context and said the effect had no size."""
    with pytest.raises(TypeError):
        make_effect("backlash", 2, 0.1)


def test_an_effect_at_zero_size_is_absent_whatever_its_shape():
    """A sweep of `cogging.periods_per_rev` alone (amplitude 0) gave runs labelled "cogging", size 0, physically
    healthy (a newcomer probe). A shape at zero size is no effect; a link's centre-of-mass shift acts alone."""
    assert make_effect("cogging", 2, periods_per_rev=12).is_absent
    assert make_effect("torque_joint_harmonic", 2, periods_per_rev=3).is_absent
    assert make_effect("current_temperature_drift", 2, reference_C=40.0).is_absent
    assert not make_effect("cogging", 2, amplitude_Nm=0.1, periods_per_rev=12).is_absent
    assert not make_effect("link_mass", 2, com_dx_m=0.05).is_absent
    assert make_effect("link_mass", 2, mass_kg=0.0).is_absent
    assert make_effect("backlash", 2, backlash_deg=0.0).is_absent
