"""The baseline classifiers: one detector (healthy vs faulty), one localiser (which joint, among
joint faults), one fault-kind classifier (healthy and every kind) and the same by joint (:mod:`.joint_kind`)
- gradient-boosted trees on the benchmark inputs, trained on the train split only.

Gradient boosting (scikit-learn's ``HistGradientBoostingClassifier``) because the features differ
in scale by orders of magnitude and interact with the operating conditions (a spike that means
backlash at 0 kg is normal at 3 kg); trees need no scaling and the histogram variant trains in
about a second on a few thousand rows.  Hyper-parameters are fixed, not tuned on the test split.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from . import joint_kind
from .classifier import make_classifier
from .data import Dataset


@dataclasses.dataclass
class Models:
    """Fitted classifiers (``None`` when the train split has fewer than two classes for the task)."""

    detector: Any
    localiser: Any
    kind: Any
    shuffled_labels: bool
    #: the map from the detector's probability to a calibrated one (:mod:`.calibration`); None: not calibrated
    calibrator: Any = None
    #: the fault-kind classifier by joint (:mod:`.joint_kind`); None: saved before it
    joint_kind: Any = None


def joint_fault_rows(df) -> np.ndarray:
    """Mask of rows with a single per-joint fault."""
    return (df["fault_scope"] == "joint").to_numpy() if "fault_scope" in df else (df["fault_joint"] > 0).to_numpy()


def _fit(x: np.ndarray, y: np.ndarray, seed: int, rng: np.random.Generator | None):
    if len(np.unique(y)) < 2:
        return None
    if rng is not None:
        y = rng.permutation(y)
    return make_classifier(seed).fit(x, y)


def fit_models(ds: Dataset, seed: int = 0, shuffle_labels: bool = False) -> Models:
    """Train the three classifiers on ``ds.train``.

    Args:
        seed: random state of the classifiers (and of the label permutation).
        shuffle_labels: permute the training labels of every task (a control: the test scores must
            then be at chance, which shows the pipeline leaks no label into the inputs).
    """
    rng = np.random.default_rng(seed) if shuffle_labels else None
    x, tr = ds.x("train"), ds.train
    det = _fit(x, (tr["fault"] != "healthy").to_numpy(int), seed, rng)
    jm = joint_fault_rows(tr)
    loc = _fit(x[jm], tr.loc[jm, "fault_joint"].to_numpy(int), seed, rng)
    kind = _fit(x, tr["fault"].to_numpy(str), seed, rng)
    by_joint = joint_kind.fit(tr, ds.inputs, seed, rng)
    return Models(det, loc, kind, shuffle_labels, joint_kind=by_joint)
