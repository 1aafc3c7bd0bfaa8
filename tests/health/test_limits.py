"""Detection limits (ur5fault/health/diagnostics/limits.py, limit_metrics.py): the unit conversions against
hand-computed values, the calibration read off the healthy training runs only, the limit z * spread * SE with
"cannot tell" where the SE or the spread is undefined, and the benchmark's figures over the runs above their
limit on hand-built frames whose answer is known."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from ur5fault.health.diagnostics.limit_metrics import detectable, limit_detection, own_limit
from ur5fault.health.diagnostics.limits import (
    ESTIMATE_OF,
    ESTIMATES,
    WHY_NOT_CALIBRATED,
    LimitCalibration,
    detection_limits,
    estimate_from_size,
    joint_limits,
    size_from_estimate,
)

DEG = 180.0 / math.pi


@pytest.mark.parametrize("kind, limit, size", [
    ("backlash", 0.001, 0.001 * DEG),             # alpha [rad] -> deg
    ("resolver_offset", 0.01, 0.01 * DEG),        # |-o| [rad] -> deg
    ("current_sensor_offset", 0.05, 0.05),        # A
    ("current_sensor_gain", 0.03, 0.03),          # gain 1 +- s gives +-s
    ("coulomb_friction", 0.1, 0.1),               # scale 1 + s gives s
    ("torque_constant", 0.25, 0.2),               # scale 0.8: 1/0.8 - 1 = 0.25
    ("gear_stiffness", 1.0, 0.5),                 # scale 0.5: 1/0.5 - 1 = 1
    ("torque_constant", math.inf, 1.0),           # nothing identifiable: the whole constant
    ("backlash", math.inf, math.inf),
])
def test_unit_conversions_against_hand_computed_values(kind, limit, size):
    assert float(size_from_estimate(kind, limit)) == pytest.approx(size, rel=1e-12)
    if math.isfinite(limit):
        assert float(estimate_from_size(kind, size)) == pytest.approx(limit, rel=1e-12)


def test_the_limit_is_on_the_same_scale_as_diagnose_size_estimate():
    # diagnose's own conversion of an estimate to a size (signed), inverted: a fault exactly at its limit
    from ur5fault.health.diagnosis.score import size_estimate

    for kind, est in ESTIMATE_OF.items():
        size = 0.3
        sign = -1.0 if kind == "resolver_offset" else 1.0  # the estimate of a resolver offset o is -o
        e = {f"twin_est_{est}_j2": sign * float(estimate_from_size(kind, size))}
        assert size_estimate(kind, e, 2)[0] == pytest.approx(size, rel=1e-12), kind
    with pytest.raises(KeyError, match="known: backlash"):
        size_from_estimate("delay", 1.0)


def _frame(rows: list[dict]) -> pd.DataFrame:
    """Rows with every estimate's SE and t column (SE 0.002, t 0 unless given)."""
    base = {f"twin_est_{e}_{w}_j{j}": (0.002 if w == "se" else 0.0) for e in ESTIMATES for w in ("se", "t")
            for j in range(1, 7)}
    return pd.DataFrame([{**base, **r} for r in rows])


T_HEALTHY = [-2.0, -1.0, 0.0, 1.0, 2.0, 100.0]  # median 0.5, absolute deviations 2.5 1.5 0.5 0.5 1.5 99.5: MAD 1.5


def _training() -> pd.DataFrame:
    rows = [{"fault": "healthy", "split": "train", "twin_est_backlash_rad_t_j1": t} for t in T_HEALTHY]
    rows += [{"fault": "backlash", "split": "train", "twin_est_backlash_rad_t_j1": 50.0}]  # faulty: not read
    rows += [{"fault": "healthy", "split": "test", "twin_est_backlash_rad_t_j1": 70.0}]    # test: not read
    df = _frame(rows)
    df["twin_est_coulomb_scale_err_t_j6"] = np.nan  # never identified on a healthy training run
    return df


def test_calibration_is_the_robust_spread_of_healthy_training_t_values_only():
    df = _training()
    cal = LimitCalibration.from_training(df[df["split"] == "train"])
    assert cal.spread["backlash_rad"][0] == pytest.approx(1.4826 * 1.5)
    assert cal.n["backlash_rad"][0] == 6
    assert cal.spread["backlash_rad"][1] == 0.0  # every t 0
    assert math.isnan(cal.spread["coulomb_scale_err"][5]) and cal.n["coulomb_scale_err"][5] == 0
    assert LimitCalibration.from_dict(cal.to_dict()) == cal


def test_moving_a_test_row_leaves_the_benchmark_calibration_unchanged_and_a_training_row_does_not():
    from ur5fault.health.diagnostics.data import load_dataset
    from ur5fault.health.diagnostics.limit_metrics import for_dataset

    def table(test_t: float, train_t: float) -> pd.DataFrame:
        rows = []
        for k in range(16):
            side = "test" if k >= 12 else "train"
            faulty = k % 2 == 1
            rows.append({"fault": "backlash" if faulty else "healthy", "fault_joint": 1 if faulty else 0,
                         "fault_scope": "joint" if faulty else "none", "fault_size": 0.3 if faulty else 0.0,
                         "fault_size_unit": "deg" if faulty else "", "status": "ok", "split": side,
                         "split_group": f"{side}:{k // 4}", "payload_kg": 1.0, "temperature_C": 28.0,
                         "twin_est_backlash_rad_t_j1": float(k)})
        df = _frame(rows)
        df.loc[(df["split"] == "test") & (df["fault"] == "healthy"), "twin_est_backlash_rad_t_j1"] = test_t
        df.loc[2, "twin_est_backlash_rad_t_j1"] = train_t  # a healthy training row
        return df

    def cal(df: pd.DataFrame) -> dict:
        ds = load_dataset(df, "twin")
        n = len(ds.test)
        return for_dataset(ds, None, np.zeros(n), np.zeros(n), np.zeros(n, bool))["calibration"]

    ref = cal(table(3.0, 2.0))
    assert cal(table(-500.0, 2.0)) == ref
    assert cal(table(3.0, 5.0)) != ref  # healthy training t 0 4 5 6 8 10: MAD 2 against 3


def test_limit_is_z_spread_se_and_infinite_where_se_or_spread_is_undefined():
    df = _training()
    cal = LimitCalibration.from_training(df[df["split"] == "train"])
    runs = _frame([{"twin_est_backlash_rad_se_j1": 0.002}, {"twin_est_backlash_rad_se_j1": np.nan}])
    lim = detection_limits(runs, cal, z=3.0)
    assert lim["backlash"][0, 0] == pytest.approx(3.0 * 1.4826 * 1.5 * 0.002 * DEG)
    assert np.isinf(lim["backlash"][1, 0])
    assert np.isinf(lim["backlash"][0, 1])  # spread 0 on J2: not calibrated
    assert np.isinf(lim["coulomb_friction"][:, 5]).all()
    one = joint_limits(runs.iloc[1].to_dict(), cal, 1)
    assert one["backlash"]["detectable_from"] is None and "never changes flank" in one["backlash"]["cannot_tell"]
    assert joint_limits(runs.iloc[0].to_dict(), cal, 6)["coulomb_friction"]["cannot_tell"] == WHY_NOT_CALIBRATED
    assert joint_limits(runs.iloc[0].to_dict(), cal, 1, z=2.0)["backlash"]["detectable_from"] == pytest.approx(
        2.0 * 1.4826 * 1.5 * 0.002 * DEG)
    with pytest.raises(ValueError, match="z = 0"):
        detection_limits(runs, cal, z=0)


def _unit_calibration() -> LimitCalibration:
    return LimitCalibration({e: (1.0,) * 6 for e in ESTIMATES}, {e: (10,) * 6 for e in ESTIMATES})


def test_detection_over_the_runs_above_their_limit_on_a_hand_built_test_split():
    # backlash on J1 with SE 0.001 rad: limit at z = 3 is 0.003 rad = 0.172 deg.  Four runs above it (0.3-0.45 deg)
    # score 0.9, above every healthy run; four below (0.05-0.1 deg) score 0.1, below every healthy run.  A fifth
    # backlash run on J2 has an undefined SE there: cannot tell.
    se = "twin_est_backlash_rad_se_j"
    healthy = [{"fault": "healthy", "fault_joint": 0, "fault_size": 0.0, f"{se}2": np.nan if k == 0 else 0.001}
               for k in range(4)]
    big = [{"fault": "backlash", "fault_joint": 1, "fault_size": a, f"{se}1": 0.001} for a in (0.3, 0.35, 0.4, 0.45)]
    small = [{"fault": "backlash", "fault_joint": 1, "fault_size": a, f"{se}1": 0.001} for a in (0.05, 0.06, 0.08, 0.1)]
    blind = [{"fault": "backlash", "fault_joint": 2, "fault_size": 0.4, f"{se}2": np.nan}]
    test = _frame(healthy + big + small + blind)
    score = np.array([0.5] * 4 + [0.9] * 4 + [0.1] * 4 + [0.2])
    lims = detection_limits(test, _unit_calibration(), 3.0)
    np.testing.assert_allclose(own_limit(test, lims)[4:12], 0.003 * DEG)
    assert np.isinf(own_limit(test, lims)[12]) and np.isnan(own_limit(test, lims)[:4]).all()
    np.testing.assert_array_equal(detectable(test, lims), [False] * 4 + [True] * 4 + [False] * 5)
    upper = np.array([True] * 4 + [True] * 4 + [False] * 4 + [True])
    m = limit_detection(test, _unit_calibration(), upper, score, score, score > 0.5, (2.0, 3.0))
    k3 = m["by_z"]["3"]["per_kind"]["backlash"]
    assert (k3["n_upper_half"], k3["n_upper_half_kept"], k3["n_upper_half_cannot_tell"]) == (5, 4, 1)
    assert k3["auc_upper_half_kept"] == 1.0 and (k3["n_test"], k3["n_kept"]) == (9, 4) and k3["auc_kept"] == 1.0
    ct = m["cannot_tell"]["backlash"]
    assert ct["share_of_test_runs_by_joint"]["2"] == pytest.approx(2 / 13)  # one healthy run, the blind one
    assert ct["share_of_test_runs_by_joint"]["1"] == 0.0
    assert ct["faulty_cannot_tell_by_joint"]["2"] == [1, 1] and ct["faulty_cannot_tell_by_joint"]["1"] == [0, 8]
    assert ct["median_limit_z3_by_joint"]["1"] == pytest.approx(0.003 * DEG)
    # at z = 2 the limit is 0.115 deg: still none of the small ones
    assert m["by_z"]["2"]["per_kind"]["backlash"]["n_kept"] == 4
    assert m["by_z"]["3"]["backlash_alpha_90"]["1"]["n_test"] == 4  # alpha_90 over the kept runs only


def test_alpha_90_on_the_motions_that_reverse_the_gear_torque_reads_the_twin_not_the_label():
    # backlash on J2: eight runs whose motion reverses J2's gear torque (SE defined), flagged from 0.1 deg up; six
    # whose motion never does (SE undefined), never flagged whatever their size.  Over all fourteen the detector
    # never reaches 90 % (the goal's literal alpha_90 is not reached); over the eight reversing ones it does.
    se = "twin_est_backlash_rad_se_j2"
    rev = [{"fault": "backlash", "fault_joint": 2, "fault_size": a, se: 0.001}
           for a in (0.02, 0.03, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5)]
    blind = [{"fault": "backlash", "fault_joint": 2, "fault_size": a, se: np.nan}
             for a in (0.1, 0.2, 0.3, 0.4, 0.5, 0.5)]
    healthy = [{"fault": "healthy", "fault_joint": 0, "fault_size": 0.0, se: np.nan} for _ in range(3)]
    test = _frame(rev + blind + healthy)
    flagged = np.array([False, False, False, True, True, True, True, True] + [False] * 6 + [False] * 3)
    from ur5fault.health.diagnostics.limit_metrics import reversing_alpha_90, torque_reverses
    from ur5fault.health.diagnostics.thresholds import backlash_thresholds

    np.testing.assert_array_equal(torque_reverses(test)[:, 1], [True] * 8 + [False] * 9)
    out = reversing_alpha_90(test, flagged)["2"]
    assert out["n_test"] == 8 and out["detected"] == 5 and out["n_not_reversing"] == 6
    assert 0.05 <= out["alpha_90_empirical_deg"] <= 0.1
    everything = backlash_thresholds(test, flagged, pd.DataFrame())["per_joint"]["2"]
    assert everything["n_test"] == 14 and math.isnan(everything["alpha_90_empirical_deg"])
    # the label does not decide which runs count: the same rows with their sizes shuffled keep the same runs
    shuffled = test.copy()
    shuffled.loc[:13, "fault_size"] = test.loc[:13, "fault_size"].to_numpy()[::-1]
    assert reversing_alpha_90(shuffled, flagged)["2"]["n_test"] == 8
    m = limit_detection(test, _unit_calibration(), np.ones(len(test), bool), flagged.astype(float),
                        flagged.astype(float), flagged, (3.0,))
    assert m["backlash_alpha_90_torque_reverses"]["2"]["n_not_reversing"] == 6


def test_flank_share_against_hand_computed_torques():
    from ur5fault.health.twin_features import flank_share

    T = np.zeros((4, 6))
    T[:, 0] = [-30.0, -10.0, 0.0, 3.0]     # weaker flank 3 of a peak 30
    T[:, 1] = [-30.0, -10.0, -0.5, 0.0]    # approaches zero from one side only
    T[:, 2] = [2.0, -2.0, 1.0, -1.0]       # equal both ways
    T[:, 3] = [5.0, 4.0, 6.0, 1.0]         # one sign
    # joint 5 carries no torque; joint 6 a single reversal sample
    T[:, 5] = [10.0, 10.0, -0.1, 10.0]
    np.testing.assert_allclose(flank_share(T), [0.1, 0.0, 1.0, 0.0, 0.0, 0.01])


def test_the_backlash_cannot_be_told_where_the_twin_torque_does_not_reverse_whatever_its_se():
    # J3 of three runs with the same finite backlash SE: the twin's torque reverses by 10 % of its peak, by 1 %
    # (under the flank column's 2 %: it only approaches zero) or the campaign has no flank column (NaN: the SE
    # alone decides, as before the column)
    se, share = "twin_est_backlash_rad_se_j3", "twin_gear_flank_share_j3"
    rows = [{se: 0.001, share: 0.10}, {se: 0.001, share: 0.01}, {se: 0.001, share: np.nan}]
    runs = _frame(rows)
    for j in (1, 2, 4, 5, 6):
        runs[f"twin_gear_flank_share_j{j}"] = 0.5
    lim = detection_limits(runs, _unit_calibration(), 3.0)["backlash"][:, 2]
    assert lim[0] == pytest.approx(0.003 * DEG) and np.isinf(lim[1]) and lim[2] == pytest.approx(0.003 * DEG)
    assert np.isfinite(detection_limits(runs, _unit_calibration(), 3.0)["current_sensor_offset"][1, 2])  # others
    one = joint_limits(runs.iloc[1].to_dict(), _unit_calibration(), 3)
    assert one["backlash"]["detectable_from"] is None and "never changes flank" in one["backlash"]["cannot_tell"]
    assert joint_limits(runs.iloc[0].to_dict(), _unit_calibration(), 3)["backlash"]["detectable_from"] > 0


def test_alpha_90_on_reversing_motions_reads_the_flank_share_where_the_campaign_has_it():
    from ur5fault.health.diagnostics.limit_metrics import reversing_alpha_90

    # backlash on J3, every run with a finite SE: six reverse the torque (share 0.1) and are flagged, three only
    # approach zero (share 0.005) and are missed whatever their size
    rows = [{"fault": "backlash", "fault_joint": 3, "fault_size": a, "twin_est_backlash_rad_se_j3": 0.001,
             "twin_gear_flank_share_j3": s} for a, s in ((0.03, 0.1), (0.05, 0.1), (0.1, 0.1), (0.2, 0.1),
                                                         (0.3, 0.1), (0.4, 0.1),
                                                         (0.15, 0.005), (0.3, 0.005), (0.45, 0.005))]
    test = _frame(rows)
    for j in (1, 2, 4, 5, 6):
        test[f"twin_gear_flank_share_j{j}"] = 0.5
    out = reversing_alpha_90(test, np.array([True] * 6 + [False] * 3))["3"]
    assert (out["n_test"], out["detected"], out["n_not_reversing"]) == (6, 6, 3)
    assert out.get("alpha_90_bound") == "< 0.03"
