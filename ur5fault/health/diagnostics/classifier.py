"""The one classifier the benchmark trains for every task (scikit-learn's ``HistGradientBoostingClassifier`` with
fixed hyper-parameters), the check that scikit-learn is installed, and the single-thread limit its fits and
predictions run under.  Used by :mod:`.models` (detector, localiser, kind) and :mod:`.joint_kind` (by joint)."""

from __future__ import annotations

#: fixed hyper-parameters, not tuned on the test split: scikit-learn's defaults except a lower learning rate
#: with more rounds and a little L2 (the usual choice for small tabular data), and leaves of at least 5 runs
#: instead of 20, so that a few dozen runs can still be split. Early stopping off: scikit-learn's default ('auto')
#: switches it on above 10,000 rows, so the by-joint classifier of the full dataset (six rows per run, 11,454) was
#: saved after 75 rounds while its out-of-fold fits (under 10,000 rows) ran 300, and the 5 % false-alarm threshold
#: read off the latter flagged 42 % of healthy test runs under the former (docs/diagnostics.md); early stopping
#: would also validate on a random 10 % of rows, a run's six rows on both sides
HGB_PARAMS = {"learning_rate": 0.05, "max_iter": 300, "max_leaf_nodes": 15, "min_samples_leaf": 5,
              "l2_regularization": 1.0, "early_stopping": False}


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
