"""The kind call with "cannot tell" for the gain / torque-constant pair (ur5fault/health/diagnostics/kind_call.py):
the rule on hand-set calls and estimates, and its set-valued scoring against hand-computed accuracies."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ur5fault.health.diagnostics.kind_call import (
    PAIR,
    balanced_accuracy_as_called,
    merge_kinds,
    right_as_called,
    tell_pair,
)

EST = [f"twin_est_current_gain_err_j{k}" for k in range(1, 7)]


def _runs(est_on_joint: list[tuple[int, float]]) -> pd.DataFrame:
    rows = []
    for joint, est in est_on_joint:
        row = dict.fromkeys(EST, 0.5)  # every other joint positive: only the called joint's sign may count
        row[EST[joint - 1]] = est
        rows.append(row)
    return pd.DataFrame(rows)


def test_the_pair_is_called_as_one_unless_the_called_joints_gain_estimate_is_negative():
    df = _runs([(2, -0.1), (2, 0.3), (5, -0.2), (1, np.nan), (3, -0.4)])
    calls = np.array(["torque_constant", "current_sensor_gain", "current_sensor_gain", "torque_constant", "backlash"])
    joint = np.array([2, 2, 5, 1, 3])
    out = tell_pair(calls, df, joint, EST)
    # negative on the called joint: only a gain below 1 reads low; positive or NaN: cannot tell; other kinds kept
    assert out.tolist() == ["current_sensor_gain", PAIR, "current_sensor_gain", PAIR, "backlash"]
    # the estimate on another joint does not count: joint 4's is 0.5 in the first run
    assert tell_pair(calls[:1], df.iloc[:1], np.array([4]), EST).tolist() == [PAIR]


def test_without_the_gain_estimate_among_the_inputs_the_pair_is_always_one_call():
    df = _runs([(2, -0.1)])
    assert tell_pair(np.array(["current_sensor_gain"]), df, np.array([2]), ["payload_kg"]).tolist() == [PAIR]


NOISE = [f"twin_current_noise_ratio_rest_j{k}" for k in range(1, 7)]


def test_a_noise_ratio_on_the_called_joint_keeps_the_classifiers_call():
    df = _runs([(2, 0.3), (2, 0.3), (4, 0.2), (2, -0.1)])
    for c in NOISE:
        df[c] = 1.0
    df.loc[1, NOISE[1]] = np.nan  # run 2: joint 2 never rests
    df.loc[2, NOISE[4]] = np.nan  # run 3: only another joint lacks it
    calls = np.array(["torque_constant", "current_sensor_gain", "current_sensor_gain", "torque_constant"])
    joint = np.array([2, 2, 4, 2])
    out = tell_pair(calls, df, joint, EST + NOISE)
    # a ratio on the called joint: the classifier's call stands; a negative estimate is a gain whatever (run 4)
    assert out.tolist() == ["torque_constant", PAIR, "current_sensor_gain", "current_sensor_gain"]
    # the ratio not among the inputs: the rules without it
    assert tell_pair(calls, df, joint, EST).tolist() == [PAIR, PAIR, PAIR, "current_sensor_gain"]


def test_a_pair_call_is_right_for_either_kind_and_scored_per_true_kind():
    y = np.array(["healthy", "current_sensor_gain", "torque_constant", "torque_constant", "backlash", "backlash"])
    c = np.array(["healthy", PAIR, PAIR, "current_sensor_gain", "backlash", PAIR])
    assert right_as_called(y, c).tolist() == [True, True, True, False, True, False]
    # recalls: healthy 1, gain 1, torque constant 1/2, backlash 1/2 -> 3 / 4
    assert balanced_accuracy_as_called(y, c) == pytest.approx(0.75)
    assert merge_kinds(np.array(["torque_constant", "backlash"])).tolist() == [PAIR, "backlash"]
