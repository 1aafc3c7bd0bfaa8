"""Every scored run's call, one row each: the benchmark's ``predictions.parquet`` (docs/outputs.md).

The report and ``metrics.json`` give the figures; this table gives the runs behind them, so a user can find the
runs a detector misses, join them with the campaign's ``features.parquet`` on ``run_id`` and read them in pandas.
Nothing here decides anything new: each column is a score or call the metrics already use.

Columns (one row per scored test run, in the order of the test split):

- ``run_id``, ``split_group``, ``fault``, ``fault_joint`` (0: none or several), ``fault_size``,
  ``fault_size_unit``: the run's labels, as in ``features.parquet``;
- ``score_run`` (-): the run-level detector's probability of a fault; ``flagged_run`` (bool): above its 5 %
  false-alarm threshold (the flags the backlash ``alpha_90`` is read from);
- ``p_fault`` (-): the fault-kind classifier by joint's probability of a fault on any joint (the p(fault) of
  ``ur5fault diagnose``); ``flagged`` (bool): above its saved operating point; ``kind_called``: the kind it calls
  there (``healthy`` where not flagged); ``joint_called`` (1-6): the joint with the largest probability of a fault.
  NaN, False, ``""`` and 0 where the benchmark has no classifier by joint (the paper's features alone); with the
  classifier but no operating point (a shuffled-label control) ``p_fault`` and ``joint_called`` are filled,
  ``flagged`` is False and ``kind_called`` ``""``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from . import joint_kind

#: the label columns copied from the scored table (those it has)
LABEL_COLUMNS = ("run_id", "split_group", "fault", "fault_joint", "fault_size", "fault_size_unit")
#: the benchmark folder's file
FILE = "predictions.parquet"


def test_predictions(test: pd.DataFrame, score_run: np.ndarray, threshold_run: float, models, inputs: tuple[str, ...],
                     joint_threshold: float | None) -> pd.DataFrame:
    """The table of the module docstring for the scored runs ``test``: ``score_run`` and ``threshold_run`` are the
    run-level detector's scores and threshold, ``models`` the benchmark's classifiers (``models.joint_kind`` may
    be None), ``joint_threshold`` the by-joint operating point (None: not read; nothing is flagged by it)."""
    out = test[[c for c in LABEL_COLUMNS if c in test.columns]].reset_index(drop=True).copy()
    score_run = np.asarray(score_run, dtype=float)
    out["score_run"] = score_run
    out["flagged_run"] = score_run > float(threshold_run)
    n = len(out)
    p_fault, flagged = np.full(n, np.nan), np.zeros(n, dtype=bool)
    kind, joint = np.full(n, "", dtype=object), np.zeros(n, dtype=np.int64)
    if models.joint_kind is not None and n:
        p_fault = joint_kind.fault_score(models.joint_kind, test, inputs)
        if joint_threshold is not None:
            thr = float(joint_threshold)
            flagged = p_fault > thr
            called, joint = joint_kind.predict(models.joint_kind, test, inputs, thr, strict=True)
            kind = called.astype(object)
        else:
            joint = joint_kind.predict(models.joint_kind, test, inputs)[1]
    out["p_fault"] = p_fault
    out["flagged"] = flagged
    out["kind_called"] = pd.Series(kind, dtype=str)
    out["joint_called"] = np.asarray(joint, dtype=np.int64)
    return out


__all__ = ["FILE", "LABEL_COLUMNS", "test_predictions"]
