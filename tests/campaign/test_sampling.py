"""Sampled campaigns (ur5fault/campaign/sampling.py): coverage of the design, reproducibility,
validation before any simulation, twins only where asked, and a small sampled campaign end to end."""

from __future__ import annotations

import copy
import json
import math
import re

import numpy as np
import pandas as pd
import pytest

from ur5fault.campaign import build_campaign, run_campaign, status
from ur5fault.campaign.design import parse_dist, unit_design
from ur5fault.campaign.identity import Identities
from ur5fault.campaign.labels import fault_labels
from ur5fault.errors import ParameterError, UnknownNameError

from conftest import as_numpy

SPEC = {
    "name": "s",
    "sample": {
        "n": 240, "method": "lhs", "seed": 3, "twins": ["backlash"], "joints": [1, 2, 3, 4, 5, 6],
        "faults": {
            "healthy": {"weight": 2},
            "backlash": {"weight": 3, "size": {"log": [0.005, 0.5]}},
            "torque_constant": {"size": {"log": [0.02, 0.5]}, "direction": "down"},
            "current_sensor_offset": {"size": {"log": [0.005, 0.5]}, "direction": "both"},
        },
        "conditions": {
            "seed": {"integers": [0, 999]},
            "payload_kg": [0.0, 3.0],
            "temperature_C": [15.0, 45.0],
            "payload_com.dz_m": [0.0, 0.08],
            "delay.delay_ms": {"uniform": [0.0, 2.0], "step": 0.1},
            "trajectory": {"name": "random_pick_and_place", "seed": {"integers": [0, 11]}},
        },
    },
}


def table(camp):
    rows = []
    for rc in camp.runs:
        c = rc.cond
        rows.append({"run_id": rc.run_id, **fault_labels(rc.fault_effects()), "traj": c["trajectory"]["seed"],
                     "faults": dict(rc.faults), **{k: v for k, v in c.items() if k != "trajectory"}})
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def camp():
    return build_campaign(SPEC, "s.yaml")


def drawn(camp):
    """The drawn runs (twins of backlash runs removed: healthy runs whose id is some run's twin)."""
    df = table(camp)
    twin_ids = {rc.twin().run_id for rc in camp.runs if rc.faults and rc.fault_effects()[0].name == "backlash"}
    return df[~df["run_id"].isin(twin_ids)], df


def test_unit_design_is_stratified_in_every_dimension():
    for method, n in (("lhs", 97), ("sobol", 64)):
        u = unit_design(method, n, 5, seed=1)
        assert u.shape == (n, 5) and (u >= 0).all() and (u < 1).all()
        for j in range(5):  # one point per interval of width 1/n in each 1-D projection
            assert sorted(np.floor(u[:, j] * n).astype(int)) == list(range(n)), (method, j)
    np.testing.assert_array_equal(unit_design("lhs", 50, 3, 7), unit_design("lhs", 50, 3, 7))
    assert not np.array_equal(unit_design("lhs", 50, 3, 7), unit_design("lhs", 50, 3, 8))


def test_same_file_same_runs_other_seed_other_runs(camp):
    again = build_campaign(copy.deepcopy(SPEC), "s.yaml")
    assert [r.run_id for r in again.runs] == [r.run_id for r in camp.runs]
    other = copy.deepcopy(SPEC)
    other["sample"]["seed"] = 4
    assert not {r.run_id for r in build_campaign(other, "s.yaml").runs} & {r.run_id for r in camp.runs}
    sobol = copy.deepcopy(SPEC)
    sobol["sample"]["method"] = "sobol"
    assert [r.run_id for r in build_campaign(sobol, "s.yaml").runs] == [
        r.run_id for r in build_campaign(copy.deepcopy(sobol), "s.yaml").runs]


def test_kinds_joints_and_trajectories_get_their_shares(camp):
    runs, _ = drawn(camp)
    assert len(runs) == 240
    counts = runs["fault"].value_counts()
    for kind, share in (("healthy", 2 / 7), ("backlash", 3 / 7), ("torque_constant", 1 / 7),
                        ("current_sensor_offset", 1 / 7)):
        assert abs(counts[kind] - 240 * share) <= 1, kind
    assert abs(runs["traj"].value_counts() - 20).max() <= 1 and runs["traj"].nunique() == 12
    joints = runs.loc[runs["fault_joint"] > 0, "fault_joint"].value_counts()
    assert set(joints.index) == set(range(1, 7)) and joints.min() >= 10  # kind and joint drawn independently


def test_sizes_and_conditions_cover_their_ranges(camp):
    runs, _ = drawn(camp)
    for kind, lo, hi in (("backlash", 0.005, 0.5), ("torque_constant", 0.02, 0.5),
                         ("current_sensor_offset", 0.005, 0.5)):
        s = np.log(runs.loc[runs["fault"] == kind, "fault_size"].to_numpy())
        assert s.min() >= math.log(lo) - 1e-6 and s.max() <= math.log(hi) + 1e-6
        x = np.sort((s - math.log(lo)) / math.log(hi / lo))  # log-uniform: uniform in log size
        assert np.abs(x - (np.arange(len(x)) + 0.5) / len(x)).max() < 0.25, kind
    tc = runs[runs["fault"] == "torque_constant"]["faults"].map(lambda f: f["torque_constant.scale"])
    assert (tc < 1).all()  # direction: down
    off = runs[runs["fault"] == "current_sensor_offset"]["faults"].map(lambda f: f["current_sensor_offset.offset_A"])
    assert (off > 0).sum() >= 8 and (off < 0).sum() >= 8  # direction: both
    n = len(runs)
    for key, lo, hi in (("payload_kg", 0, 3), ("temperature_C", 15, 45), ("payload_com.dz_m", 0, 0.08)):
        v = runs[key].to_numpy()
        assert v.min() >= lo and v.max() <= hi
        # Latin hypercube over all drawn runs: one value per stratum (the 6-digit rounding aside)
        assert len(set(np.floor((v - lo) / (hi - lo) * n).astype(int))) >= n - 2, key
    d = runs["delay.delay_ms"].to_numpy()
    np.testing.assert_allclose(d * 10, np.round(d * 10), atol=1e-9)  # step 0.1 ms
    assert set(runs["seed"]) <= set(range(1000))


def test_twins_only_for_the_listed_kinds(camp):
    runs, everything = drawn(camp)
    ids = set(everything["run_id"])
    for rc in camp.runs:
        eff = rc.fault_effects()
        if eff:
            assert (rc.twin().run_id in ids) == (eff[0].name == "backlash")
    n_backlash = (runs["fault"] == "backlash").sum()
    assert len(everything) == len(runs) + n_backlash
    none = copy.deepcopy(SPEC)
    none["sample"]["twins"] = "none"
    assert len(build_campaign(none, "s.yaml").runs) == 240


def sample_with(**changes):
    spec = copy.deepcopy(SPEC)
    for path, value in changes.items():
        node = spec["sample"]
        keys = path.split("__")
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = value
    return spec


BAD = [
    (sample_with(n=0), ParameterError, "s.yaml: sample.n = 0 must be an integer in [1, 1000000]"),
    (sample_with(method="grid"), UnknownNameError, "unknown sampling method 'grid'; valid: lhs, sobol"),
    (sample_with(faults__rust={"size": [0.1, 1]}), UnknownNameError, "unknown fault kind 'rust'"),
    (sample_with(faults__backlash={"size": {"log": [0.01, 9.0]}}), ParameterError,
     "sample.faults.backlash.size: size 9 gives backlash.backlash_deg = 9, out of range [0, 5] deg"),
    (sample_with(faults__torque_constant={"size": {"log": [0.02, 0.5]}}), UnknownNameError,
     "unknown direction None; valid: both, down, up"),
    (sample_with(faults__backlash={"size": {"log": [0, 0.5]}}), ParameterError, "log = [0, 0.5] needs 0 < lo <= hi"),
    (sample_with(faults__backlash={"size": {"normal": [0, 0.5]}}), UnknownNameError, "unknown distribution 'normal'"),
    (sample_with(faults__payload={"size": [0.1, 1]}), ParameterError, "it cannot be a sampled fault kind"),
    (sample_with(conditions__payload_kg=[0.0, 9.0]), ParameterError, "payload.mass_kg = 9.0 is out of range [0, 5] kg"),
    (sample_with(conditions__rust=[0, 1]), UnknownNameError, "unknown condition 'rust'"),
    (sample_with(**{"conditions__backlash.backlash_deg": [0, 1]}), ParameterError, "is per joint"),
    (sample_with(conditions__trajectory={"name": "random_pick_and_place", "seed": [0, 9]}), ParameterError,
     "trajectory options are drawn from integers or choices only"),
    (sample_with(conditions__trajectory={"name": "zigzag"}), UnknownNameError, "unknown trajectory 'zigzag'"),
    (sample_with(twins=["gear_stiffness"]), UnknownNameError, "unknown twin kind 'gear_stiffness'"),
    (sample_with(joints=[7]), UnknownNameError, "unknown joint 7"),
    (sample_with(joints=[2, "shoulder_lift_joint"]), ParameterError,
     "sample.joints: joint 2 is given twice (by number and name or alias)"),
    ({**SPEC, "sweep": {"seed": [0, 1]}}, ParameterError, "sample cannot be combined with sweep or zip"),
]


@pytest.mark.parametrize("spec, exc, message", BAD)
def test_validation_before_any_simulation(spec, exc, message):
    with pytest.raises(exc) as info:
        build_campaign(spec, "s.yaml")
    assert str(info.value).startswith("s.yaml") and message in str(info.value), str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("size, message", [
    ({"log": [0.1, 20.0]}, "size 20 gives coulomb_friction.scale = 21, out of range [0, 10]"),
    ([-1, 1], "-1.0 must be a positive number (scale deviation)")])
def test_a_factors_size_is_refused_without_a_unit(size, message):
    """A dimensionless size was refused as "out of range [0, 10] -" and "(scale deviation in -)"."""
    with pytest.raises(ParameterError) as info:
        build_campaign(sample_with(faults__coulomb_friction={"size": size, "direction": "up"}), "s.yaml")
    assert str(info.value) == f"s.yaml: sample.faults.coulomb_friction.size: {message}"


def test_distributions_map_the_unit_interval():
    assert parse_dist([1.0, 3.0], "x").value(0.5) == 2.0
    assert parse_dist({"log": [0.01, 1.0]}, "x").value(0.5) == pytest.approx(0.1)
    d = parse_dist({"integers": [0, 3]}, "x")
    assert [d.value(u) for u in (0.0, 0.24, 0.25, 0.99)] == [0, 0, 1, 3]
    assert parse_dist({"choices": ["a", "b"]}, "x").value(0.7) == "b"
    assert parse_dist(5, "x").value(0.3) == 5 and not parse_dist(5, "x").drawn


def test_distributions_of_numpy_numbers_give_the_python_numbers_they_hold():
    """`{integers: [np.int64(0), np.int64(3)]}` was refused as no numbers; a numpy choice or fixed value was drawn as
    the numpy scalar itself, which run ids hash by its text."""
    d = parse_dist({"integers": [np.int64(0), np.int64(3)], "step": np.float64(1.0)}, "x")
    assert d == parse_dist({"integers": [0, 3], "step": 1.0}, "x") and type(d.value(0.5)) is int
    for spec in ({"choices": [np.float32(0.5), np.int64(2)]}, np.float64(0.5), [np.float64(0.5), np.float64(0.5)]):
        assert {type(v) for v in parse_dist(spec, "x").bounds()} <= {int, float}, spec


# ----------------------------------------------------------------------------- end to end
TINY = {
    "name": "tiny", "duration_s": 0.05, "batch_size": 16,
    "sample": {"n": 8, "seed": 1, "twins": ["backlash"],
               "faults": {"healthy": {}, "backlash": {"weight": 2, "size": {"log": [0.05, 0.5]}}},
               "conditions": {"payload_kg": [0.5, 3.0], "delay.delay_ms": {"choices": [0.0, 0.5]},
                              "payload_com.dz_m": [0.0, 0.05],
                              "trajectory": {"name": "random_pick_and_place", "seed": {"integers": [0, 1]}}}},
    "split": {"test_fraction": 0.5},
}


def test_small_sampled_campaign_runs_labels_and_resumes(tmp_path):
    camp = build_campaign(TINY, "tiny.yaml", out=tmp_path)
    run_campaign(camp, tmp_path, jobs=1, progress=False)
    df = pd.read_parquet(tmp_path / "features.parquet")
    assert len(df) == len(camp.runs) and set(df["status"]) == {"ok"}
    assert {"delay_ms", "payload_com_dz_m", "split", "split_group", "fault_size"} <= set(df.columns)
    bl = df[df["fault"] == "backlash"]
    assert len(bl) and np.isfinite(bl["tcp_dev_max_mm"]).all() and (bl["twin_run_id"] != "").all()
    assert df.groupby("split_group")["split"].nunique().eq(1).all() and set(df["split"]) == {"train", "test"}
    stamp = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "runs").iterdir()}
    run_campaign(build_campaign(copy.deepcopy(TINY), "tiny.yaml", out=tmp_path), tmp_path, jobs=1, progress=False)
    assert stamp == {p.name: p.stat().st_mtime_ns for p in (tmp_path / "runs").iterdir()}  # resumed: nothing to do
    info = status(tmp_path)  # rebuilt from the manifest's campaign text: the same draws
    assert info["n_runs_expected"] == len(camp.runs) == info["runs"]["ok"]


def test_twin_residuals_add_features_and_change_the_identity(tmp_path):
    from ur5fault.campaign.digital_twin import twin_effects, twin_id, twin_seed
    from ur5fault.campaign.identity import Identities
    from ur5fault.health.twin_features import FEATURE_UNITS as TWIN_UNITS

    spec = {**copy.deepcopy(TINY), "twin_residuals": True}
    camp = build_campaign(spec, "tiny.yaml", out=tmp_path)
    plain = build_campaign(copy.deepcopy(TINY), "tiny.yaml")
    assert Identities(camp).identity(camp.runs[0]) != Identities(plain).identity(plain.runs[0])
    for rc in camp.runs:  # what the twin knows: payload mass and temperature; never the fault, the centre of
        names = {e.name for e in twin_effects(camp, rc)}  # mass or the latency; its own noise seed
        assert names == {"payload", "temperature"} and twin_seed(rc.cond["seed"]) != rc.cond["seed"]
        if rc.fault_effects():
            assert twin_id(rc) == twin_id(rc.twin())  # a run and its healthy twin share one digital twin
    run_campaign(camp, tmp_path, jobs=1, progress=False)
    df = pd.read_parquet(tmp_path / "features.parquet")
    assert len(df) == len(camp.runs) and set(df["status"]) == {"ok"} and set(TWIN_UNITS) <= set(df.columns)
    est = [c for c in TWIN_UNITS if c.startswith("twin_est_")]
    values = [c for c in est if not c.endswith(("_se", "_t")) and not any(f"_{s}_j" in c for s in ("se", "t"))]
    assert np.isfinite(df[values].to_numpy()).all()  # every size estimate (0 where its column is not identified)
    assert not np.isinf(df[est].to_numpy()).any()  # standard errors and t values: a number or NaN (not identified)


def test_com_twins_option_changes_the_identity_and_the_com_estimates(tmp_path):
    # twin_com_twins: the current fit's payload CoM columns from CoM-shifted noise-free twins (format 4); its runs
    # get other identities (a folder of the other kind is not resumed silently) and other CoM estimates
    from ur5fault.campaign.identity import Identities

    spec = {**copy.deepcopy(TINY), "twin_residuals": True, "duration_s": 2.0}  # the payload gripped by 1 s
    plain, com = (build_campaign({**spec, "twin_com_twins": on}, "tiny.yaml", out=tmp_path / str(on))
                  for on in (False, True))
    assert Identities(com).identity(com.runs[0]) != Identities(plain).identity(plain.runs[0])
    tables = {}
    for camp in (plain, com):
        run_campaign(camp, camp.out, jobs=1, progress=False)
        tables[camp.twin_com_twins] = pd.read_parquet(camp.out / "features.parquet").sort_values("run_id")
    assert set(tables[True]["status"]) == {"ok"}
    assert np.isfinite(tables[True]["twin_est_current_gain_err_j5"]).all()
    assert not np.allclose(tables[True]["twin_est_payload_com_x_m"], tables[False]["twin_est_payload_com_x_m"])
    with pytest.raises(ParameterError, match="twin_com_twins needs twin_residuals"):
        build_campaign({**copy.deepcopy(TINY), "twin_com_twins": True}, "tiny.yaml")


def test_twin_residuals_must_be_a_bool():
    with pytest.raises(ParameterError, match="twin_residuals"):
        build_campaign({**copy.deepcopy(TINY), "twin_residuals": "yes"}, "tiny.yaml")


def test_runs_logged_without_motor_encoders_have_no_mismatch_features(tmp_path):
    # motor_encoders: false logs the runs like a UR robot: every feature of the encoder mismatch is NaN (as
    # `ur5fault diagnose` computes it from a real log), everything else is there
    from ur5fault.campaign.identity import Identities
    from ur5fault.health.features import FEATURE_UNITS
    from ur5fault.health.twin_features import FEATURE_UNITS as TWIN_UNITS

    spec = {**copy.deepcopy(TINY), "twin_residuals": True, "motor_encoders": False, "log_period_s": 0.008,
            "duration_s": 0.2}
    camp = build_campaign(spec, "tiny.yaml", out=tmp_path)
    with_enc = build_campaign({**spec, "motor_encoders": True}, "tiny.yaml")
    assert Identities(camp).identity(camp.runs[0]) != Identities(with_enc).identity(with_enc.runs[0])
    run_campaign(camp, tmp_path, jobs=1, progress=False)
    df = pd.read_parquet(tmp_path / "features.parquet")
    assert set(df["status"]) == {"ok"}
    blind = [c for c in list(FEATURE_UNITS) + list(TWIN_UNITS) if "mismatch" in c or "backlash" in c
             or "compliance" in c]
    seen = [c for c in list(FEATURE_UNITS) + list(TWIN_UNITS) if c.startswith(("twin_est_current", "current_"))]
    # per joint: 3 paper features, 8 mismatch residual statistics, 3 mismatch-fit estimates with their SE and t
    assert len(blind) == 6 * 3 + 6 * (8 + 3 * 3) and df[blind].isna().all().all()
    assert len(seen) > 18 and np.isfinite(df[seen].to_numpy()).all()
    man = json.loads((tmp_path / "manifest.json").read_text())
    assert man["motor_encoders"] is False
    from ur5fault.campaign.identity import TWIN_RESIDUALS_FORMAT

    assert man["twin_residuals_format"] == TWIN_RESIDUALS_FORMAT  # what a detector trained on it records
    with pytest.raises(ParameterError, match="motor_encoders"):
        build_campaign({**copy.deepcopy(TINY), "motor_encoders": "no"}, "tiny.yaml")


def test_the_cost_estimate_counts_every_run_the_campaign_simulates(tmp_path, monkeypatch):
    # a twin campaign simulates its runs, their digital twins and each batch's noise-free regressor twins (with
    # twin_com_twins their CoM twins too): the estimate checked against the steps the simulator was asked for
    from ur5fault.campaign.limits import estimate
    from ur5fault.sim.engine import Simulator

    camp = build_campaign({**copy.deepcopy(TINY), "twin_residuals": True, "twin_com_twins": True,
                           "duration_s": 0.2}, "tiny.yaml", out=tmp_path)
    asked = []
    run = Simulator.run

    def counting(self, traj, specs, **kw):
        asked.append(len(specs) * round(kw["duration_s"] / self.params.physics_dt_s))
        return run(self, traj, specs, **kw)

    monkeypatch.setattr(Simulator, "run", counting)
    run_campaign(camp, tmp_path, jobs=1, progress=False)
    assert sum(asked) > len(camp.runs) * round(0.2 / 50e-6)  # twins simulated beside the runs
    assert estimate(camp, 1).run_steps == sum(asked)


def test_equal_draws_collapsing_into_one_run_are_said(camp):
    """Draws with nothing to tell them apart (a fixed size, no conditions) are one run each: said in a note that
    `campaign run` prints, not a shorter table without a word; the shipped-size design keeps every draw."""
    spec = {"name": "few", "sample": {"n": 4, "seed": 0, "joints": [2], "faults": {"backlash": {"size": 0.1}}}}
    few = build_campaign(spec, "f.yaml")
    assert len(few.runs) == 2 and few.notes == (  # the run and its healthy twin
        "f.yaml: sample: 4 draws gave 1 distinct runs (equal draws are one run; draw the sensor-noise seed among the "
        "conditions, e.g. seed: {integers: [0, 999999]}, for repeats)",)
    assert camp.notes == ()


def test_a_swept_value_given_twice_is_refused():
    for sweep, message in (({"backlash.joint": [1, 1], "backlash.backlash_deg": [0.1]},
                            "sweep.backlash.joint[1]: 1 repeats [0] (1); give each value once"),
                           ({"backlash.joint": ["shoulder_lift_joint", 2], "backlash.backlash_deg": [0.1]},
                            "sweep.backlash.joint[1]: 2 repeats [0] ('shoulder_lift_joint')")):
        with pytest.raises(ParameterError, match=re.escape(message)):
            build_campaign({"name": "dup", "sweep": sweep}, "d.yaml")


def test_a_sample_of_numpy_numbers_is_the_sample_of_the_numbers_they_hold():
    """A campaign mapping built in a notebook from numpy results: `sample.n = np.int64(40)` was refused as no integer,
    `integers: [np.int64(0), ...]` as no numbers, `split.seed` likewise; its runs, their identities, its text and the
    manifest's mapping are the ones of the plain numbers."""
    spec = copy.deepcopy(SPEC)
    spec["sample"]["n"] = 40
    spec["sample"]["conditions"]["temperature_C"] = {"choices": [20.0, 30.0]}
    spec.update(split={"by": "trajectory_seed", "test_fraction": 0.3, "seed": 2}, threshold_mm=0.7, batch_size=8,
                base={"seed": 1, "payload_kg": 1.5}, twin_residuals=True)
    plain, numpy = build_campaign(spec, "s.yaml"), build_campaign(as_numpy(spec), "s.yaml")
    assert [r.run_id for r in numpy.runs] == [r.run_id for r in plain.runs]
    ids_plain, ids_numpy = Identities(plain), Identities(numpy)
    assert [ids_numpy.identity(r) for r in numpy.runs] == [ids_plain.identity(r) for r in plain.runs]
    assert numpy.text == plain.text and "!!python" not in numpy.text
    assert json.dumps(numpy.data, sort_keys=True) == json.dumps(plain.data, sort_keys=True)  # np.int64: TypeError
    assert numpy == plain
    values = [v for r in numpy.runs for part in (r.cond, r.cond["trajectory"], dict(r.faults)) for v in part.values()]
    assert {type(v) for v in values} == {int, float, str, dict}


def test_numpy_arrays_are_the_lists_they_hold_in_a_sample():
    """`payload_kg: np.array([0.5, 2.0])` (a range built in a notebook) was a fixed value, refused as "must be a
    number"; as a list it is a uniform range, as its arguments too."""
    for spec, listed in ((np.array([0.5, 2.0]), [0.5, 2.0]),
                         ({"uniform": np.array([0.5, 2.0])}, {"uniform": [0.5, 2.0]})):
        assert (build_campaign(sample_with(conditions__payload_kg=spec), "s.yaml")
                == build_campaign(sample_with(conditions__payload_kg=listed), "s.yaml"))


@pytest.mark.parametrize("path, value, message", [
    ("n", np.True_, "sample.n = np.True_ must be an integer in [1, 1000000]"),
    ("seed", True, "sample.seed = True must be a non-negative integer"),
    ("faults__healthy", {"weight": np.True_}, "sample.faults.healthy.weight = np.True_ must be a positive number"),
    ("conditions__seed", {"integers": [np.False_, 9]}, "integers = [False, 9] must be a list [lo, hi] of two numbers"),
    ("conditions__seed", {"choices": [np.int64(1), True]}, "conditions.seed: seed = True must be a non-negative"),
    ("conditions__payload_kg", {"uniform": [0.0, 2.0], "step": np.True_}, "step = np.True_ must be a positive"),
    ("conditions__payload_kg", {"uniform": [0.0, 2.0], "step": np.inf}, "step = inf must be a positive finite number"),
])
def test_a_bool_is_no_number_of_a_sample(path, value, message):
    with pytest.raises(ParameterError) as info:
        build_campaign(sample_with(**{path: value}), "s.yaml")
    assert message in str(info.value)
