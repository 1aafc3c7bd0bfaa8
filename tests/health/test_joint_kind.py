"""The fault-kind classifier by joint (ur5fault/health/diagnostics/joint_kind.py): joint rows built from the
inputs, labels per joint, the decision rule on hand-set probabilities, and - on a synthetic table whose only
fault evidence sits in one per-joint column - that it learns the kind and the joint while shuffled labels
stay at chance."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("sklearn")

from ur5fault.health.diagnostics import joint_kind  # noqa: E402


def test_layout_and_rows():
    inputs = ("a_j1", "a_j2", "b_j2", "payload_kg")
    assert joint_kind.layout(inputs) == (["a", "b"], ["payload_kg"])
    df = pd.DataFrame({"a_j1": [1.0, 2.0], "a_j2": [3.0, 4.0], "b_j2": [5.0, 6.0], "payload_kg": [0.5, 1.5],
                       "a_j3": [9.0, 9.0]})  # a_j3 is no input: NaN in the rows
    x = joint_kind.joint_rows(df, inputs)
    assert x.shape == (2, 6, 4)
    np.testing.assert_array_equal(x[0, 0], [1.0, np.nan, 0.5, 1.0])
    np.testing.assert_array_equal(x[1, 1], [4.0, 6.0, 1.5, 2.0])
    assert np.isnan(x[0, 2, 0]) and x[0, 5, 3] == 6.0


def test_labels_per_joint():
    df = pd.DataFrame({"fault": ["healthy", "backlash"], "fault_joint": [0, 3]})
    y = joint_kind.joint_labels(df)
    assert y.tolist() == [["none"] * 6, ["none", "none", "backlash", "none", "none", "none"]]


class _Fixed:
    """A stand-in classifier with set probabilities per joint row."""

    classes_ = np.array(["backlash", "none", "resolver_offset"])

    def __init__(self, p):
        self.p = np.asarray(p, float)

    def predict_proba(self, x):
        return self.p.reshape(-1, 3)


def test_rule_healthy_below_even_odds_else_the_likeliest_kind_on_any_joint():
    df = pd.DataFrame({"a_j1": np.zeros(2)})
    calm = [0.1, 0.9, 0.0]
    run0 = [calm] * 6  # no joint reaches p(fault) 0.5: healthy
    run0[4] = [0.2, 0.6, 0.2]
    run1 = [calm] * 6  # J2: resolver offset 0.55 (p(fault) 0.6); J5: backlash 0.45 alone (p(fault) 0.5)
    run1[1] = [0.05, 0.4, 0.55]
    run1[4] = [0.45, 0.5, 0.05]
    kind, joint = joint_kind.predict(_Fixed([run0, run1]), df, ("a_j1",))
    assert kind.tolist() == ["healthy", "resolver_offset"]
    assert joint.tolist() == [5, 2]


def _table(n_groups: int = 12, per: int = 24, seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = []
    kinds = ["healthy", "backlash", "resolver_offset"]
    for g in range(n_groups):
        for r in range(per):
            kind = kinds[r % 3]
            j = 0 if kind == "healthy" else int(rng.integers(1, 7))
            row = {"fault": kind, "fault_joint": j, "split": "test" if g < 3 else "train"}
            for k in range(1, 7):
                # evidence: a t value on the faulty joint, in the column of its kind
                row[f"twin_est_backlash_rad_t_j{k}"] = rng.normal() + (6.0 if (kind, j) == ("backlash", k) else 0)
                row[f"twin_est_mismatch_offset_rad_t_j{k}"] = rng.normal() + (
                    6.0 if (kind, j) == ("resolver_offset", k) else 0)
            rows.append(row)
    return pd.DataFrame(rows)


@pytest.mark.slow
def test_learns_kind_and_joint_from_one_column_per_joint_and_shuffled_is_chance():
    from sklearn.metrics import balanced_accuracy_score

    df = _table()
    inputs = tuple(c for c in df.columns if c.startswith("twin_"))
    tr, te = df[df.split == "train"], df[df.split == "test"]
    model = joint_kind.fit(tr, inputs, 0, None)
    kind, joint = joint_kind.predict(model, te, inputs)
    assert balanced_accuracy_score(te["fault"], kind) > 0.9
    faulty = te["fault_joint"].to_numpy() > 0
    assert (joint[faulty] == te["fault_joint"].to_numpy()[faulty]).mean() > 0.9
    shuffled = joint_kind.fit(tr, inputs, 0, np.random.default_rng(0))
    kind_s, _ = joint_kind.predict(shuffled, te, inputs)
    assert balanced_accuracy_score(te["fault"], kind_s) < 0.55  # chance: 1/3


def test_rule_at_an_operating_point_and_the_detector_score():
    # runs read at an operating point below even odds: a run whose largest joint probability of a fault (the
    # score) exceeds it is faulty, with its likeliest kind
    df = pd.DataFrame({"a_j1": np.zeros(2)})
    calm = [0.05, 0.9, 0.05]
    run0 = [calm] * 6
    run0[4] = [0.1, 0.6, 0.3]
    run1 = [calm] * 6
    run1[1] = [0.05, 0.7, 0.25]
    model = _Fixed([run0, run1])
    np.testing.assert_allclose(joint_kind.fault_score(model, df, ("a_j1",)), [0.4, 0.3])
    kind, joint = joint_kind.predict(model, df, ("a_j1",), 0.35, strict=True)
    assert kind.tolist() == ["resolver_offset", "healthy"] and joint.tolist() == [5, 2]
    kind, _ = joint_kind.predict(model, df, ("a_j1",), 0.25)
    assert kind.tolist() == ["resolver_offset", "resolver_offset"]
    kind, _ = joint_kind.predict(model, df, ("a_j1",))  # even odds: neither
    assert kind.tolist() == ["healthy", "healthy"]


def test_every_fit_runs_the_same_rounds_whatever_its_row_count():
    """The saved by-joint classifier and its out-of-fold fits must be the same model: scikit-learn's early stopping
    ('auto') switched on above 10,000 rows, so the full dataset's final fit stopped at 75 rounds while the folds,
    under 10,000 rows, ran 300, and the threshold read off the folds gave 42 % false alarms (docs/diagnostics.md)."""
    pytest.importorskip("sklearn")
    from ur5fault.health.diagnostics.classifier import HGB_PARAMS, make_classifier

    rng = np.random.default_rng(0)
    X = rng.normal(size=(10_200, 3))
    y = rng.integers(0, 2, size=10_200)  # noise: early stopping would end the fit after about ten rounds
    clf = make_classifier(0)
    clf.set_params(max_iter=40)  # the rule, not the count, is tested: a short fit above the 10,000-row switch
    clf.fit(X, y)
    assert clf.n_iter_ == 40
    assert HGB_PARAMS["early_stopping"] is False
    auto = make_classifier(0).set_params(max_iter=40, early_stopping="auto").fit(X, y)
    assert auto.n_iter_ < 40  # the switch this guards against is real in the installed scikit-learn
