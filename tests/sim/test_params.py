"""Frozen, validated parameters: every bad value is named with its range."""

import dataclasses

import numpy as np
import pytest

from ur5fault.errors import ParameterError, UnknownNameError
from ur5fault.sim.params import GearParams, load_params


def test_default_file_loads_and_is_frozen():
    p = load_params()
    assert p.gear.ratio == (101.0,) * 6
    assert p.motor.kind[1] == "pmsm" and p.motor.kind.count("dc") == 5
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.gear.ratio = (1.0,) * 6  # type: ignore[misc]


def test_scalar_broadcasts_to_all_joints():
    g = GearParams(ratio=101, stiffness_Nm_per_rad=1e5, damping_Nms_per_rad=10)
    assert g.stiffness_Nm_per_rad == (1e5,) * 6 and g.backlash_rad == (0.0,) * 6


def test_numpy_scalars_and_arrays_are_numbers():
    g = GearParams(ratio=np.int64(101), stiffness_Nm_per_rad=np.float32(1e5), damping_Nms_per_rad=np.float64(10))
    assert g.ratio == (101.0,) * 6 and g.stiffness_Nm_per_rad == (1e5,) * 6 and g.damping_Nms_per_rad == (10.0,) * 6
    assert all(type(v) is float for v in g.ratio + g.stiffness_Nm_per_rad)
    g = GearParams(ratio=np.full(6, 101), stiffness_Nm_per_rad=1e5, damping_Nms_per_rad=10)
    assert g.ratio == (101.0,) * 6
    assert load_params(overrides={"gear": {"ratio": np.int64(100)}}).gear.ratio == (100.0,) * 6
    with pytest.raises(ParameterError, match=r"^GearParams.ratio = np.True_ must be a list of 6 values$"):
        GearParams(ratio=np.True_, stiffness_Nm_per_rad=1e5, damping_Nms_per_rad=10)


def test_out_of_range_message_names_field_value_and_range():
    with pytest.raises(ParameterError) as e:
        load_params(overrides={"gear": {"backlash_rad": [0, -0.01, 0, 0, 0, 0]}})
    assert str(e.value) == "ur5_drive.yaml.gear.backlash_rad[2] = -0.01 is out of range [0, 0.1] rad"
    with pytest.raises(ParameterError) as e:  # a ratio has no unit (its "-" was written: "[1, 1000] -")
        load_params(overrides={"gear": {"ratio": 0}})
    assert str(e.value) == "ur5_drive.yaml.gear.ratio = 0 is out of range [1, 1000]"


def test_unknown_key_lists_valid_keys():
    with pytest.raises(UnknownNameError) as e:
        load_params(overrides={"gear": {"stifness": 1}})
    assert "unknown key 'stifness'" in str(e.value)
    assert "stiffness_Nm_per_rad" in str(e.value)
    assert isinstance(e.value, KeyError)


def test_wrong_length_and_type_and_choice():
    with pytest.raises(ParameterError, match="needs 6 values"):
        load_params(overrides={"gear": {"ratio": [101, 101]}})
    with pytest.raises(ParameterError, match="must be a number"):
        load_params(overrides={"physics_dt_s": "fast"})
    with pytest.raises(ParameterError, match="choose one of: dc, pmsm"):
        load_params(overrides={"motor": {"kind": "ac"}})


def test_servo_period_must_be_whole_number_of_steps():
    with pytest.raises(ParameterError, match="whole multiple"):
        load_params(overrides={"physics_dt_s": 3e-5})
    assert load_params(overrides={"physics_dt_s": 2.5e-5}).steps_per_servo == 4


def test_every_default_value_has_a_source_tag():
    """docs rule: every number in the parameter file carries [paper], [facts], [nist] or [A]."""
    from ur5fault.sim.params import DEFAULT_PARAMS_PATH

    lines = DEFAULT_PARAMS_PATH.read_text().splitlines()
    blocks, current = [], []
    for line in lines:
        if line.strip().startswith("#") or not line.strip():
            current.append(line)
            continue
        current.append(line)
        if ":" in line and line.split(":", 1)[1].strip():
            blocks.append("\n".join(current))
            current = []
        elif ":" in line:
            current = []
    untagged = [b.splitlines()[-1] for b in blocks if not any(t in b for t in ("[paper]", "[facts]", "[nist]", "[A]"))]
    assert not untagged, f"values without a source tag: {untagged}"


def test_one_joint_temperature_range_and_one_nominal_temperature():
    """The temperature effect (campaigns), a life fleet's duty and a log's temperatures took -10..90 degC in two places
    and -20..120 in the parameters (a log at 100 degC was replayed where a campaign at 100 degC was refused); 28 degC
    was typed in six. Now one range and one nominal value, the parameter file's."""
    from ur5fault.health.prognostics.spec import build_life
    from ur5fault.sim.effects import REGISTRY
    from ur5fault.sim.params import JOINT_TEMPERATURE_RANGE_C, NOMINAL_JOINT_TEMPERATURE_C

    assert load_params().joint_temperature_C == (NOMINAL_JOINT_TEMPERATURE_C,) * 6  # the file's [paper] value
    for eff, name in (("temperature", "temperature_C"), ("current_temperature_drift", "reference_C")):
        p = REGISTRY[eff].param(name)
        assert (p.lo, p.hi, p.absent) == (*JOINT_TEMPERATURE_RANGE_C, NOMINAL_JOINT_TEMPERATURE_C), eff
    life = {"name": "t", "life": {"units": 2, "duty": {"temperature_C": [100.0, 110.0]}}}
    assert all(100.0 <= u.temperature_C <= 110.0 for u in build_life(life, "t").units)  # was refused above 90
