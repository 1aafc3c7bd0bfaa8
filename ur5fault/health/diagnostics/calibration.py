"""The probability of a fault, calibrated on training runs its classifier was not fitted on, and how reliable a
probability is (Brier score, expected calibration error, reliability bins).

The score calibrated is the one ``ur5fault diagnose`` reports as ``p_fault``: the fault-kind classifier by
joint's largest joint probability of a fault (:func:`.joint_kind.fault_score`; schema format 3 - formats 1-2
calibrated the run-level detector's probability).  Gradient-boosted trees give a probability that ranks runs
well but need not be a frequency: of the runs given 0.8, maybe 95 % are faulty.  The calibration maps the score
``p`` to one that is:

* the classifier by joint is refitted on the train split :data:`N_FOLDS` times, each time without one group of
  motions (``split_group``: a run's motion, so no motion is on both sides - scikit-learn's ``GroupKFold``), and
  scores the runs it left out: an out-of-fold score for every training run;
* a logistic regression of the label (faulty or not) on ``logit(p)`` of those out-of-fold scores (Platt
  scaling) is the calibration map saved with the classifiers.  Platt rather than isotonic regression because
  the campaigns here train on a few hundred runs, and an isotonic map (a free step function) fitted on that
  few overfits; both are fitted, and the benchmark reports both on the test split (``metrics.json``
  ``calibration``).

The map is monotonic, so it changes no ranking: the AUCs and the runs flagged at the 5 % false-alarm threshold
are those of the score itself; only the numbers a user reads as probabilities change.  The out-of-fold scores
also give a second 5 % false-alarm threshold that no test run has seen (``threshold_out_of_fold``: the healthy
training runs' 95th percentile), reported with the false alarms it gives on the test split.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .data import Dataset

#: folds of the out-of-fold predictions (fewer when the train split has fewer motions)
N_FOLDS = 5
#: equal-width probability bins of the reliability table and the expected calibration error
N_BINS = 10
#: out-of-fold probabilities are clipped this far from 0 and 1 before the logit
EPS = 1e-6
#: inverse regularisation of the Platt fit: large, i.e. the maximum-likelihood fit of its two numbers
PLATT_C = 1e4
METHOD = "platt"
#: the score calibrated (schema format 3): the classifier by joint's largest joint probability of a fault
SCORE = "by_joint"


def _logit(p: np.ndarray) -> np.ndarray:
    p = np.clip(np.asarray(p, float), EPS, 1 - EPS)
    return np.log(p / (1 - p)).reshape(-1, 1)


def out_of_fold(ds: Dataset, seed: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Out-of-fold scores (:func:`.joint_kind.fault_score`) of the train runs, their labels (1 = faulty) and the
    number of folds."""
    from sklearn.model_selection import GroupKFold

    from . import joint_kind

    tr = ds.train
    y = (tr["fault"] != "healthy").to_numpy(int)
    groups = tr["split_group"].astype(str).to_numpy()
    k = min(N_FOLDS, len(np.unique(groups)))
    if k < 2:
        raise ValueError("calibration needs at least two motions in the train split")
    p = np.full(len(tr), np.nan)
    for fit_rows, left_out in GroupKFold(n_splits=k).split(np.zeros(len(tr)), y, groups):
        model = joint_kind.fit(tr.iloc[fit_rows], ds.inputs, seed, None)
        if model is None or joint_kind.NONE not in [str(c) for c in model.classes_]:
            raise ValueError("calibration: a fold of the train split holds a single label")
        p[left_out] = joint_kind.fault_score(model, tr.iloc[left_out], ds.inputs)
    return p, y, k


def fit_platt(p: np.ndarray, y: np.ndarray):
    """The Platt map: logistic regression of ``y`` on ``logit(p)``."""
    from sklearn.linear_model import LogisticRegression

    return LogisticRegression(C=PLATT_C).fit(_logit(p), y)


def fit_isotonic(p: np.ndarray, y: np.ndarray):
    from sklearn.isotonic import IsotonicRegression

    return IsotonicRegression(y_min=0.0, y_max=1.0, out_of_bounds="clip").fit(p, y)


def apply(calibrator: Any, p: np.ndarray) -> np.ndarray:
    """Calibrated probabilities of the detector's probabilities ``p`` (a Platt or an isotonic map)."""
    p = np.asarray(p, float)
    if hasattr(calibrator, "predict_proba"):
        return calibrator.predict_proba(_logit(p))[:, 1]
    return np.asarray(calibrator.predict(p), float)


def reliability(p: np.ndarray, y: np.ndarray, n_bins: int = N_BINS) -> dict[str, Any]:
    """Brier score, expected calibration error (bins of equal width, weighted by their runs) and the bins
    (range, runs, mean probability, share faulty) of probabilities ``p`` against labels ``y`` (1 = faulty)."""
    p, y = np.asarray(p, float), np.asarray(y, float)
    edges = np.linspace(0.0, 1.0, n_bins + 1)
    idx = np.clip(np.digitize(p, edges[1:-1]), 0, n_bins - 1)
    bins, ece = [], 0.0
    for b in range(n_bins):
        m = idx == b
        if not m.any():
            continue
        mean_p, frac = float(p[m].mean()), float(y[m].mean())
        ece += m.sum() / p.size * abs(mean_p - frac)
        bins.append({"lo": float(edges[b]), "hi": float(edges[b + 1]), "n": int(m.sum()), "mean_p": mean_p,
                     "share_faulty": frac})
    return {"n": int(p.size), "brier": float(np.mean((p - y) ** 2)), "ece": float(ece), "bins": bins}


def fit_calibration(ds: Dataset, seed: int) -> tuple[Any, dict[str, Any]]:
    """The Platt map fitted on out-of-fold scores of the train split, the isotonic map of the same scores (for
    the comparison only), and what was done (JSON-able)."""
    from .metrics import alarm_threshold

    p, y, k = out_of_fold(ds, seed)
    platt, iso = fit_platt(p, y), fit_isotonic(p, y)
    info = {"method": METHOD, "score": SCORE, "n_folds": k, "grouped_by": "split_group (the run's motion)",
            "n_train": int(y.size), "threshold_out_of_fold": alarm_threshold(p, y == 0),
            "train_out_of_fold": {"detector": reliability(p, y), "platt": reliability(apply(platt, p), y)}}
    return platt, {"info": info, "isotonic": iso}


def test_reliability(score: np.ndarray, faulty: np.ndarray, calibrator: Any, isotonic: Any = None
                     ) -> dict[str, Any]:
    """Reliability on the test runs of the score and of the calibrated one (and the isotonic map's, when
    given)."""
    out = {"detector": reliability(score, faulty), "calibrated": reliability(apply(calibrator, score), faulty)}
    if isotonic is not None:
        out["isotonic"] = reliability(apply(isotonic, score), faulty)
    return out


__all__ = ["apply", "fit_calibration", "reliability", "test_reliability"]
