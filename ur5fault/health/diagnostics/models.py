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
from .data import Dataset

#: fixed hyper-parameters, not tuned on the test split: scikit-learn's defaults except a lower learning rate
#: with more rounds and a little L2 (the usual choice for small tabular data), and leaves of at least 5 runs
#: instead of 20, so that a few dozen runs can still be split
HGB_PARAMS = {"learning_rate": 0.05, "max_iter": 300, "max_leaf_nodes": 15, "min_samples_leaf": 5,
              "l2_regularization": 1.0}


def single_threaded():
    """Context limiting OpenMP to one thread while the classifiers fit and predict.

    Scikit-learn's gradient boosting spreads even a 30-row prediction over OpenMP threads; on a
    shared or busy machine that costs 20-30x more than one thread (measured here: 70 ms vs 3.6 ms
    per prediction of 300 trees with the machine loaded).  The OpenMP runtime is loaded first, so
    that the limit reaches it.
    """
    require_sklearn()  # also loads the OpenMP runtime the limit must reach
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="openmp")


def require_sklearn() -> None:
    """Import scikit-learn and skops, or say in one line how to install them."""
    try:
        import sklearn.ensemble  # noqa: F401
        import skops.io  # noqa: F401
    except ImportError:  # pragma: no cover - depends on the installation
        from ...errors import Ur5FaultError

        raise Ur5FaultError("ur5fault benchmark and diagnose need scikit-learn and skops: pip install "
                            "'scikit-learn>=1.3' 'skops>=0.10' (the package's [ml] extra)") from None


def make_classifier(seed: int):
    """A fresh, unfitted baseline classifier."""
    from sklearn.ensemble import HistGradientBoostingClassifier

    return HistGradientBoostingClassifier(random_state=seed, **HGB_PARAMS)


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
