"""The diagnostics benchmark (``ur5fault benchmark OUT``): baseline classifiers trained on a
campaign's train split and scored on its test split (split by trajectory seed, so no motion is on
both sides).

Modules by concern: :mod:`.run` (the command: a campaign folder's benchmark written, ``--test``, the feature
sets compared), :mod:`.evaluation` (one evaluation: train, score, every figure), :mod:`.data` (split and inputs),
:mod:`.models` (the classifiers), :mod:`.metrics` (detection, localisation, kind, importance), :mod:`.thresholds`
(smallest backlash detected and its TCP deviation), :mod:`.figures` (matplotlib Figures), :mod:`.report` (files),
:mod:`.saved` (the trained classifiers, saved and loaded safely).
Needs scikit-learn and skops: ``pip install 'scikit-learn>=1.3' 'skops>=0.10'`` (from a checkout:
``pip install '.[ml]'``).
"""

from .data import load_dataset, load_features
from .evaluation import evaluate
from .run import RESULT_FILES, compare_feature_sets, run_benchmark, summary

__all__ = ["RESULT_FILES", "compare_feature_sets", "evaluate", "load_dataset", "load_features", "run_benchmark",
           "summary"]
