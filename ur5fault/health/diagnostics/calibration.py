"""The detector's probability of a fault, calibrated on training runs it was not fitted on, and how reliable a
probability is (Brier score, expected calibration error, reliability bins).

Gradient-boosted trees give a probability that ranks runs well but need not be a frequency: of the runs given
0.8, maybe 95 % are faulty.  The calibration maps the detector's probability ``p`` to one that is:

* the detector is refitted on the train split :data:`N_FOLDS` times, each time without one group of motions
  (``split_group``: a run's motion, so no motion is on both sides - scikit-learn's ``GroupKFold``), and predicts
  the runs it left out: an out-of-fold probability for every training run;
* a logistic regression of the label on ``logit(p)`` of those out-of-fold probabilities (Platt scaling) is the
  calibration map saved with the classifiers.  Platt rather than isotonic regression because the campaigns
  here train on a few hundred runs, and an isotonic map (a free step function) fitted on that few overfits;
  both are fitted, and the benchmark reports both on the test split (``metrics.json`` ``calibration``).

The map is monotonic, so it changes no ranking: the AUCs and the runs flagged at the 5 % false-alarm threshold
are those of the detector's own probability; only the numbers a user reads as probabilities change.
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


def _logit(p: np.ndarray) -> np.ndarray:
    p = np.clip(np.asarray(p, float), EPS, 1 - EPS)
    return np.log(p / (1 - p)).reshape(-1, 1)


def out_of_fold(ds: Dataset, seed: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Out-of-fold detector probabilities of the train runs, their labels (1 = faulty) and the number of folds."""
    from sklearn.model_selection import GroupKFold, cross_val_predict

    from .models import make_classifier

    tr = ds.train
    y = (tr["fault"] != "healthy").to_numpy(int)
    groups = tr["split_group"].astype(str).to_numpy()
    k = min(N_FOLDS, len(np.unique(groups)))
    if k < 2:
        raise ValueError("calibration needs at least two motions in the train split")
    p = cross_val_predict(make_classifier(seed), ds.x("train"), y, groups=groups, cv=GroupKFold(n_splits=k),
                          method="predict_proba")[:, 1]
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
    """The Platt map fitted on out-of-fold predictions of the train split, the isotonic map of the same
    predictions (for the comparison only), and what was done (JSON-able)."""
    p, y, k = out_of_fold(ds, seed)
    platt, iso = fit_platt(p, y), fit_isotonic(p, y)
    info = {"method": METHOD, "n_folds": k, "grouped_by": "split_group (the run's motion)",
            "n_train": int(y.size), "train_out_of_fold": {"detector": reliability(p, y),
                                                         "platt": reliability(apply(platt, p), y)}}
    return platt, {"info": info, "isotonic": iso}


def test_reliability(score: np.ndarray, faulty: np.ndarray, calibrator: Any, isotonic: Any = None
                     ) -> dict[str, Any]:
    """Reliability on the test runs of the detector's probability and of the calibrated one (and the isotonic
    map's, when given)."""
    out = {"detector": reliability(score, faulty), "calibrated": reliability(apply(calibrator, score), faulty)}
    if isotonic is not None:
        out["isotonic"] = reliability(apply(isotonic, score), faulty)
    return out


__all__ = ["apply", "fit_calibration", "reliability", "test_reliability"]
