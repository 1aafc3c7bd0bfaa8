"""ML labels of the feature rows (ur5fault/campaign/labels.py): fault, scope, joint, size with unit,
clean healthy rows, and the train/test split by group."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from ur5fault.campaign import build_campaign, run_campaign
from ur5fault.campaign.labels import (
    SplitRule,
    assign_splits,
    condition_column,
    fault_columns,
    fault_labels,
    parse_split,
    refresh_labels,
    split_group,
)
from ur5fault.errors import ParameterError, UnknownNameError
from ur5fault.sim.effects import make_effect


def labels(*effects):
    return fault_labels(effects)


def test_healthy_labels():
    assert labels() == {"fault": "healthy", "fault_scope": "none", "fault_joint": 0, "fault_size": 0.0,
                        "fault_size_unit": ""}
    assert fault_columns(()) == {"backlash_deg": 0.0}  # nothing else: the other fault columns become NaN


@pytest.mark.parametrize("effect, joint, expected_size, unit", [
    (make_effect("backlash", 2, backlash_deg=0.1), 2, 0.1, "deg"),
    (make_effect("torque_constant", "elbow", scale=0.8), 3, 0.2, "fraction"),
    (make_effect("coulomb_friction", 6, scale=2.5), 6, 1.5, "fraction"),
    (make_effect("current_sensor_offset", 1, offset_A=-0.3), 1, 0.3, "A"),
    (make_effect("current_sensor_gain", 4, gain=1.02), 4, 0.02, "fraction"),
    (make_effect("resolver_offset", 5, offset_deg=-0.05), 5, 0.05, "deg"),
    (make_effect("cogging", 2, amplitude_Nm=0.1, periods_per_rev=12), 2, 0.1, "N*m"),
    (make_effect("delay", None, delay_ms=2.0), -1, 2.0, "ms"),
    (make_effect("payload_com", None, dx_m=0.03, dz_m=0.04), -1, 0.05, "m"),
    # effects whose parameters mix units: the size is that of their size parameters (it was NaN, no unit)
    (make_effect("motor_harmonic", 2, sin_Nm=0.03, cos_Nm=-0.04, periods_per_rev=3), 2, 0.05, "N*m"),
    (make_effect("torque_joint_harmonic", 3, sin_Nm=3.0, cos_Nm=4.0, periods_per_rev=2), 3, 5.0, "N*m"),
    (make_effect("torque_coulomb", 1, torque_Nm=-1.5, width_rad_s=0.05), 1, 1.5, "N*m"),
    (make_effect("torque_stribeck", 1, torque_Nm=0.7, speed_rad_s=0.1), 1, 0.7, "N*m"),
    (make_effect("torque_holding", 4, torque_Nm=0.2, speed_rad_s=0.05), 4, 0.2, "N*m"),
    (make_effect("link_mass", 5, mass_kg=1.2, com_dx_m=0.1), 5, 1.2, "kg"),
    (make_effect("current_temperature_drift", 6, coeff_A_per_K=0.002, reference_C=30.0), 6, 0.002, "A/K"),
])
def test_single_fault_labels(effect, joint, expected_size, unit):
    got = labels(effect)
    assert got["fault"] == effect.name and got["fault_joint"] == joint
    assert got["fault_scope"] == ("robot" if joint == -1 else "joint")
    assert got["fault_size"] == pytest.approx(expected_size, rel=1e-12) and got["fault_size_unit"] == unit


def test_every_registered_effect_has_a_size_with_a_unit():
    """Seven effects whose parameters mix units were labelled with a NaN size and no unit: no registry entry may."""
    from ur5fault.sim.effects import REGISTRY

    for name, eff in REGISTRY.items():
        values = {p.name: (p.hi if p.absent is None or p.absent != p.hi else p.lo) for p in eff.params}
        got = labels(make_effect(name, 2 if eff.per_joint else None, **values))
        assert math.isfinite(got["fault_size"]) and got["fault_size"] > 0 and got["fault_size_unit"], (name, got)


def test_multi_fault_labels():
    a, b = make_effect("backlash", 2, backlash_deg=0.1), make_effect("coulomb_friction", 2, scale=2.0)
    got = labels(a, b)
    assert got["fault"] == "backlash+coulomb_friction" and got["fault_scope"] == "multi"
    assert got["fault_joint"] == 2 and math.isnan(got["fault_size"])
    assert labels(a, make_effect("backlash", 3, backlash_deg=0.1))["fault_joint"] == -1
    cols = fault_columns((a, b))
    assert cols == {"backlash_deg": 0.1, "backlash_joint": 2, "backlash_deg_swept": 0.1,
                    "coulomb_friction_joint": 2, "coulomb_friction_scale": 2.0}


def test_condition_columns():
    assert condition_column("delay.delay_ms") == "delay_ms"
    assert condition_column("payload_com.dz_m") == "payload_com_dz_m"
    assert condition_column("payload_kg") == "payload_kg"


# ----------------------------------------------------------------------------- split
def conds(n_traj, per=3):
    return [{"seed": s, "trajectory": {"name": "random_pick_and_place", "seed": t}}
            for t in range(n_traj) for s in range(per)]


def test_split_ratio_groups_and_reproducibility():
    rule = SplitRule("trajectory_seed", 0.25, 7)
    splits = assign_splits(rule, conds(40))
    assert len(splits) == 40 and sum(v == "test" for v in splits.values()) == 10
    assert splits == assign_splits(rule, reversed(conds(40)))  # order of the runs does not matter
    assert splits != assign_splits(SplitRule("trajectory_seed", 0.25, 8), conds(40))
    by_group = {}
    for c in conds(40):
        by_group.setdefault(split_group(c, rule.by), set()).add(splits[split_group(c, rule.by)])
    assert all(len(v) == 1 for v in by_group.values())  # a group is on one side only


def test_split_edge_cases():
    one = [{"seed": 0, "trajectory": "pick_and_place"}] * 3
    assert set(assign_splits(SplitRule(), one).values()) == {"train"}
    two = conds(2)
    assert sorted(assign_splits(SplitRule(test_fraction=0.01), two).values()) == ["test", "train"]
    assert sorted(assign_splits(SplitRule(test_fraction=0.9), two).values()) == ["test", "train"]
    assert set(assign_splits(SplitRule(test_fraction=0.0), two).values()) == {"train"}
    by_seed = assign_splits(SplitRule(by="seed", test_fraction=0.5), one + [{"seed": 1, "trajectory": "x"}])
    assert sorted(by_seed.values()) == ["test", "train"]
    assert split_group({"seed": 0, "trajectory": "pick_and_place"}, "trajectory_seed") == "pick_and_place"


@pytest.mark.parametrize("data, exc, message", [
    ({"by": "colour"}, UnknownNameError, "unknown split group 'colour'; valid: seed, trajectory, trajectory_seed"),
    ({"ratio": 0.2}, UnknownNameError, "split: unknown key 'ratio'; valid: by, seed, test_fraction"),
    ({"test_fraction": 1.0}, ParameterError, "split.test_fraction = 1.0 must be a number in [0, 1)"),
    ({"test_fraction": "a"}, ParameterError, "split.test_fraction = 'a' must be a number in [0, 1)"),
    ({"seed": -2}, ParameterError, "split.seed = -2 must be a non-negative integer"),
    ({"seed": np.True_}, ParameterError, "split.seed = np.True_ must be a non-negative integer"),
    ({"test_fraction": True}, ParameterError, "split.test_fraction = True must be a number in [0, 1)"),
    ([0.2], ParameterError, "split must be a mapping"),
])
def test_split_rule_validation(data, exc, message):
    with pytest.raises(exc) as info:
        parse_split(data, "c.yaml")
    assert str(info.value).startswith("c.yaml") and message in str(info.value)


def test_a_split_of_numpy_numbers_is_the_split_of_the_numbers_they_hold():
    """`split: {seed: np.int64(2)}` (a mapping built from numpy results) was refused as no integer."""
    rule = parse_split({"by": "seed", "test_fraction": np.float32(0.5), "seed": np.int64(2)}, "c.yaml")
    assert rule == SplitRule("seed", 0.5, 2) and type(rule.seed) is int and type(rule.test_fraction) is float


# ----------------------------------------------------------------------------- in a campaign
TINY = {
    "name": "tiny", "trajectory": "pick_and_place", "duration_s": 0.05, "batch_size": 8,
    "sweep": {"seed": [0, 1], "backlash.joint": [2, 3], "backlash.backlash_deg": [0.0, 0.2]},
    "split": {"by": "seed", "test_fraction": 0.5, "seed": 0},
}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiny")
    camp = build_campaign(TINY, "tiny.yaml", out=out)
    run_campaign(camp, out, jobs=1, progress=False)
    return camp, out, pd.read_parquet(out / "features.parquet")


def test_campaign_rows_carry_clean_labels(tiny):
    _, _, df = tiny
    assert len(df) == 2 * (2 + 1)  # per seed: two faulty runs and one healthy (alpha = 0 on any joint is healthy)
    healthy = df[df["fault"] == "healthy"]
    assert len(healthy) == 2
    assert (healthy["fault_joint"] == 0).all() and (healthy["fault_scope"] == "none").all()
    assert (healthy["fault_size"] == 0).all() and (healthy["backlash_deg"] == 0).all()
    assert healthy["backlash_joint"].isna().all() and healthy["backlash_deg_swept"].isna().all()
    faulty = df[df["fault"] == "backlash"].sort_values("fault_joint")
    assert faulty["fault_joint"].tolist() == [2, 2, 3, 3]
    np.testing.assert_array_equal(faulty["backlash_joint"], faulty["fault_joint"])
    assert (faulty["fault_size"] == 0.2).all() and (faulty["fault_size_unit"] == "deg").all()
    assert np.isfinite(faulty["tcp_dev_max_mm"]).all()
    # split by noise seed, half the groups in test: one seed per side, a run and its twin together
    assert df.groupby("seed")["split"].nunique().eq(1).all() and set(df["split"]) == {"train", "test"}
    assert df.set_index("run_id").loc[df["twin_run_id"], "split"].tolist() == df["split"].tolist()


def test_edited_split_rule_relabels_without_resimulating(tiny):
    camp, out, df = tiny
    old = assign_splits(camp.split, (rc.cond for rc in camp.runs))
    for seed in range(1, 20):  # a rule seed that swaps the two groups
        edited = build_campaign({**TINY, "split": {"by": "seed", "test_fraction": 0.5, "seed": seed}}, "tiny.yaml",
                                out=out)
        if assign_splits(edited.split, (rc.cond for rc in edited.runs)) != old:
            break
    stamp = {p.name: p.stat().st_mtime_ns for p in (out / "runs").iterdir()}
    run_campaign(edited, out, jobs=1, progress=False)
    assert stamp == {p.name: p.stat().st_mtime_ns for p in (out / "runs").iterdir()}  # nothing re-run
    again = pd.read_parquet(out / "features.parquet")
    assert (again["split"] != df["split"]).all()  # two groups: both swap sides
    _, changed = refresh_labels(again, edited.split, edited.runs)
    assert not changed


def test_rows_stored_without_a_size_get_the_size_this_version_gives(tiny):
    """A campaign resumed across a change of the size rule (stop 52: seven effects had a NaN ``fault_size``):
    the stored rows' labels are recomputed, the results kept."""
    camp, _, df = tiny
    old = df.assign(fault_size=np.where(df["fault"] == "healthy", 0.0, np.nan), fault_size_unit="")
    fixed, changed = refresh_labels(old, camp.split, camp.runs)
    assert changed
    faulty = fixed[fixed["fault"] == "backlash"]
    assert (faulty["fault_size"] == 0.2).all() and (faulty["fault_size_unit"] == "deg").all()
    assert (fixed.loc[fixed["fault"] == "healthy", "fault_size_unit"] == "").all()
    results = [c for c in df.columns if c.startswith(("enc_", "tcp_", "cur_"))]
    assert results and fixed[results].equals(old[results])
