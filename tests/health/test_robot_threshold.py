"""The robot's own false-alarm threshold of ``ur5fault diagnose --baseline-logs``
(ur5fault/health/diagnosis/robot_threshold.py).

Expected values are worked out by hand from the definitions: the split-conformal rank ceil((1 - alpha)(n + 1)),
and, for the held-out scores, the baseline map of a group of fewer than five windows, which shifts each input by
that group's median (x' = m + x - b).  The classifiers are replaced by a score that is the mapped first input, so
the test sees exactly which windows each held-out reference was fitted on.
"""

from __future__ import annotations

import numpy as np
import pytest

import ur5fault.health.diagnosis.robot_threshold as rt
from ur5fault.health.diagnosis.baseline import Reference
from ur5fault.health.diagnosis.windows import Window


def test_the_conformal_rank_by_hand():
    scores = np.arange(1.0, 21.0)[::-1]  # 20 scores, given in any order
    assert rt.conformal_threshold(scores, 0.05) == (20.0, 20)  # ceil(0.95 * 21) = 20
    assert rt.conformal_threshold(np.arange(1.0, 40.0), 0.05) == (38.0, 38)  # n = 39: ceil(0.95 * 40) = 38
    assert rt.conformal_threshold(np.arange(1.0, 20.0), 0.05) == (19.0, 19)  # n = 19: ceil(0.95 * 20) = 19
    # five scores: the rank 6 does not exist, the largest is taken and the rank says so
    assert rt.conformal_threshold([0.3, 0.1, 0.5, 0.2, 0.4], 0.05) == (0.5, 6)
    assert rt.conformal_threshold([0.3, 0.1, 0.5, 0.2, 0.4], 0.5) == (0.3, 3)  # ceil(0.5 * 6) = 3
    with pytest.raises(ValueError):
        rt.conformal_threshold([], 0.05)
    with pytest.raises(ValueError):
        rt.conformal_threshold([0.1, np.nan], 0.05)


def _w(v: float) -> Window:
    return Window(0.0, 1.0, {"a": v, "payload_kg": 0.0}, (1.0,) * 6)


def test_the_groups_are_the_logs_or_one_logs_two_halves():
    two = rt.groups_of([("x", [_w(1), _w(2)]), ("empty", []), ("y", [_w(3)])])
    assert [g for g, _ in two] == ["x", "y"]
    one = rt.groups_of([("x", [_w(k) for k in range(5)]), ("empty", [])])
    assert [g for g, _ in one] == ["x windows 1-2", "x windows 3-5"]
    assert [[w.features["a"] for w in ws] for _, ws in one] == [[0, 1], [2, 3, 4]]
    assert rt.groups_of([("x", [_w(1)])]) == []  # one window cannot be held out against anything


def test_each_group_is_scored_against_the_others_only(monkeypatch):
    # the score of a window: its first mapped input (training median 10, spread 1), the same on every joint
    monkeypatch.setattr(rt, "joint_scores", lambda models, names, x: (np.repeat(x[:, :1], 6, axis=1), None, None))
    ref = Reference(("a", "payload_kg"), np.array([10.0, 0.0]), np.array([1.0, 1.0]), "by hand")
    logs = [("p", [_w(1.0), _w(2.0), _w(3.0)]),   # median 2
            ("q", [_w(5.0), _w(7.0)]),            # median 6
            ("r", [_w(0.0)])]                     # median 0
    scores, groups = rt.held_out_scores(None, ref, logs, 0.008)
    assert groups == ("p", "q", "r")
    # p against q + r (0, 5, 7: median 5): 10 + x - 5;  q against p + r (0, 1, 2, 3: median 1.5): 10 + x - 1.5;
    # r against p + q (1, 2, 3, 5, 7: five values, median 3, MAD 2 -> spread 2.9652 > 1: scaled by 1 / 2.9652)
    np.testing.assert_allclose(scores, [6.0, 7.0, 8.0, 13.5, 15.5, 10.0 - 3.0 / (2 * 1.4826)])
    t = rt.threshold_from_baseline(None, ref, logs, 0.008)
    assert t.score == pytest.approx(15.5) and t.rank == 7 and t.n == 6  # ceil(0.95 * 7) = 7 > 6: the largest
    assert t.false_alarm_bound == pytest.approx(1 / 7)
    s = t.summary()
    assert s["n_held_out_windows"] == 6 and s["groups"] == ["p", "q", "r"] and s["rank"] == 7
    assert rt.threshold_from_baseline(None, ref, [("p", [_w(1.0)])], 0.008) is None


def test_with_enough_windows_the_bound_is_alpha(monkeypatch):
    monkeypatch.setattr(rt, "joint_scores", lambda models, names, x: (np.repeat(x[:, :1], 6, axis=1), None, None))
    ref = Reference(("a", "payload_kg"), np.array([0.0, 0.0]), np.array([1e-6, 1.0]), "by hand")
    rng = np.random.default_rng(0)
    logs = [(f"log{k}", [_w(v) for v in rng.normal(size=10)]) for k in range(4)]  # 40 held-out windows
    t = rt.threshold_from_baseline(None, ref, logs, 0.008)
    assert t.n == 40 and t.rank == 39 and t.false_alarm_bound == 0.05  # ceil(0.95 * 41) = 39
    assert t.score == pytest.approx(np.sort(t.held_out_scores)[38])


def test_the_joint_whose_healthy_windows_set_the_threshold_is_named(monkeypatch):
    """A window's score is its joints' largest, so one joint's healthy windows can set the bar for all: the
    threshold records each joint's largest held-out score and the joint at the threshold, and says so."""
    from ur5fault.health.diagnosis.baseline import set_by_sentence

    # the elbow (joint 3) scores the window's first mapped input, every other joint a tenth of it
    def scores(models, names, x):
        s = np.repeat(0.1 * x[:, :1], 6, axis=1)
        s[:, 2] = x[:, 0]
        return s, None, None

    monkeypatch.setattr(rt, "joint_scores", scores)
    ref = Reference(("a", "payload_kg"), np.array([10.0, 0.0]), np.array([1.0, 1.0]), "by hand")
    logs = [("p", [_w(1.0), _w(2.0), _w(3.0)]), ("q", [_w(5.0), _w(7.0)]), ("r", [_w(0.0)])]
    t = rt.threshold_from_baseline(None, ref, logs, 0.008)  # held-out elbow scores as in the test above
    assert t.score == pytest.approx(15.5) and t.set_by_joint == 2
    np.testing.assert_allclose(t.held_out_max_by_joint, [1.55, 1.55, 15.5, 1.55, 1.55, 1.55])
    s = t.summary()
    assert s["set_by_joint"] == "elbow_joint" and s["held_out_max_by_joint"]["wrist_1_joint"] == pytest.approx(1.55)
    text = set_by_sentence(s)
    assert text.startswith("the raw-score threshold 15.500 (the detector's score, before calibration to p(fault)) is "
                           "elbow_joint's raw score in a held-out healthy window; each joint's largest held-out "
                           "healthy raw score: shoulder_pan_joint 1.55,") and "elbow_joint 15.50" in text
    assert set_by_sentence({"score": 1.0}) == ""  # a summary without the joints (written before) says nothing
    # a detector saved without a calibration has no p(fault) to be "before": its own score is said to be the bar
    uncal = set_by_sentence(s, calibrated=False)
    assert uncal.startswith("the raw-score threshold 15.500 (the detector's own score: it was saved without a "
                            "calibration to p(fault)) is elbow_joint's raw score") and "before calibration" not in uncal


def test_with_enough_windows_the_joint_at_the_conformal_rank_is_named(monkeypatch):
    """40 held-out windows: the threshold is the 39th smallest score, not the largest; the joint named is the one
    whose score that window's is, and the sentence gives the threshold itself (the largest scores lie above it)."""
    from ur5fault.health.diagnosis.baseline import set_by_sentence

    def scores(models, names, x):  # wrist 1 scores the input, every other joint half of it
        s = np.repeat(0.5 * x[:, :1], 6, axis=1)
        s[:, 3] = x[:, 0]
        return s, None, None

    monkeypatch.setattr(rt, "joint_scores", scores)
    ref = Reference(("a", "payload_kg"), np.array([0.0, 0.0]), np.array([1e-6, 1.0]), "by hand")
    rng = np.random.default_rng(0)
    logs = [(f"log{k}", [_w(v) for v in rng.normal(size=10)]) for k in range(4)]
    t = rt.threshold_from_baseline(None, ref, logs, 0.008)
    assert t.rank == 39 and t.score == pytest.approx(np.sort(t.held_out_scores)[38])
    assert t.score < max(t.held_out_scores)
    assert t.set_by_joint == 3 and t.held_out_max_by_joint[3] > t.score
    assert set_by_sentence(t.summary()).startswith(f"the raw-score threshold {t.score:.3f} (the detector's score, "
                                                   "before calibration to p(fault)) is wrist_1_joint's raw score")


def test_the_report_names_the_joint_only_where_the_robots_threshold_is_the_bar():
    """The report's baseline sentence says which joint's window the robot's threshold is where that threshold is
    the one windows are flagged above; where the training runs' is higher, it does not (as the notes)."""
    from ur5fault.health.diagnosis.report import _baseline

    rules = {r: {"n_inputs": 1} for r in ("scaled", "shifted", "shifted_zero_spread", "shifted_training_zero_spread",
                                          "shifted_few_windows", "left_as_measured", "condition")}
    t = {"n_held_out_windows": 4, "groups": ["a", "b"], "rank": 5, "score": 0.97, "false_alarm_bound": 0.2,
         "held_out_max_by_joint": {"wrist_2_joint": 0.97, "wrist_1_joint": 0.1}, "set_by_joint": "wrist_2_joint"}
    b = {"rules": rules, "robot_threshold": t, "n_windows": 4, "logs": ["a", "b"], "mapping": "m", "reference": "r"}
    said = ("the raw-score threshold 0.970 (the detector's score, before calibration to p(fault)) is wrist_2_joint's "
            "raw score in a held-out healthy window")
    assert said in _baseline(b, robot_bar=True) and "wrist_1_joint 0.10" in _baseline(b, robot_bar=True)
    assert said not in _baseline(b, robot_bar=False) and "The robot's own threshold" in _baseline(b, False)


def test_the_reports_threshold_on_both_scales_and_every_rule_counted():
    """The report gave the robot's threshold as a by-joint score (0.849) beside a header's p(fault) 0.926 without
    saying which was which, and its count of inputs left out those shifted for a zero spread in the training runs
    (the notes counted them)."""
    from ur5fault.health.diagnosis.report import _baseline

    rules = {r: {"n_inputs": k} for k, r in enumerate(("scaled", "shifted", "shifted_zero_spread",
                                                       "shifted_training_zero_spread", "shifted_few_windows",
                                                       "left_as_measured", "condition"), start=1)}
    t = {"n_held_out_windows": 4, "groups": ["a", "b"], "rank": 5, "score": 0.849, "false_alarm_bound": 0.2}
    b = {"rules": rules, "robot_threshold": t, "n_windows": 4, "logs": ["a", "b"], "mapping": "m", "reference": "r"}
    text = _baseline(b, robot_bar=True, p_fault=0.926)
    assert "(0.849 on the by-joint score, p(fault) 0.926 on the table's scale;" in text
    assert "4 shifted (zero spread in the training runs)" in text and "5 shifted (too few baseline values)" in text
    assert "p(fault)" not in _baseline(b, robot_bar=False, p_fault=0.926)
