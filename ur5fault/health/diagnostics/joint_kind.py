"""The fault-kind classifier by joint: one classifier shared by the six joints, reading one joint's evidence at
a time.

The run-level kind classifier (:mod:`.models`) sees all 300-odd inputs at once and must learn every kind on
every joint separately from a few hundred runs - 48 kind-joint pairs, a handful of training runs each.  Yet a
fault's evidence has the same form on every joint: a current-sensor offset is a large offset t value in that
joint's current residual, a resolver offset a large mismatch offset, whichever the joint.  So this classifier
is trained on joint rows: for every run and joint, that joint's inputs (every input ending in ``_j<k>``, the
suffix dropped, NaN where the joint has no such column), the run's other inputs (known conditions, the
nuisance estimates) and the joint's number; its label is the run's fault kind on the faulty joint and
``none`` on every other joint (and on every joint of a healthy run).  Six times the rows, the evidence of
one kind pooled over the joints.

A run's kind: ``healthy`` when no joint's probability of a fault (1 - p(none)) reaches the decision threshold;
otherwise the kind with the largest probability on any joint.  Its location: the joint with the largest
probability of a fault.  The threshold is one half (the rule's own even odds) unless a caller passes the
detector's operating point: this classifier's largest joint probability of a fault, :func:`fault_score`, is
the detector of ``ur5fault diagnose`` (its ``p_fault``, calibrated by :mod:`.calibration`), and a run flagged at
its 5 % false-alarm threshold is called faulty with the likeliest kind, so that the kind and the flag agree.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from ...sim.axes import N_JOINTS
from .classifier import make_classifier

NONE = "none"
_JOINT = re.compile(r"^(.*)_j([1-6])$")


def layout(inputs: tuple[str, ...] | list[str]) -> tuple[list[str], list[str]]:
    """``(stems, run_columns)`` of the inputs: per-joint stems (an input ``<stem>_j<k>`` for some joint) in
    the order first met, and the inputs that belong to no joint."""
    stems: list[str] = []
    run_cols = []
    for c in inputs:
        m = _JOINT.match(c)
        if m:
            if m.group(1) not in stems:
                stems.append(m.group(1))
        else:
            run_cols.append(c)
    return stems, run_cols


def joint_rows(df: pd.DataFrame, inputs: tuple[str, ...] | list[str]) -> np.ndarray:
    """``(n_runs, 6, n_stems + n_run_columns + 1)``: each run's rows, one per joint (module docstring)."""
    stems, run_cols = layout(inputs)
    n = len(df)
    run_x = df[run_cols].to_numpy(dtype=float) if run_cols else np.zeros((n, 0))
    out = np.empty((n, N_JOINTS, len(stems) + len(run_cols) + 1))
    allowed = set(inputs)
    for j in range(N_JOINTS):
        cols = [f"{s}_j{j + 1}" for s in stems]
        out[:, j, : len(stems)] = np.stack(
            [df[c].to_numpy(dtype=float) if c in allowed else np.full(n, np.nan) for c in cols], axis=1
        ) if stems else np.zeros((n, 0))
        out[:, j, len(stems) : -1] = run_x
        out[:, j, -1] = j + 1
    return out


def joint_labels(df: pd.DataFrame) -> np.ndarray:
    """``(n_runs, 6)``: the fault kind on the faulty joint of a single-joint fault, ``none`` elsewhere."""
    fault = df["fault"].to_numpy(str)
    joint = df["fault_joint"].to_numpy(int)
    return np.stack([np.where(joint == j + 1, fault, NONE) for j in range(N_JOINTS)], axis=1)


def fit(df: pd.DataFrame, inputs: tuple[str, ...], seed: int, rng: np.random.Generator | None):
    """The classifier trained on the joint rows of ``df`` (``rng``: permute the runs' labels first, the
    shuffled-label control); None when the rows carry fewer than two labels."""
    x = joint_rows(df, inputs)
    y = joint_labels(df)
    if rng is not None:
        y = y[rng.permutation(len(y))]
    if len(np.unique(y)) < 2:
        return None
    return make_classifier(seed).fit(x.reshape(-1, x.shape[2]), y.reshape(-1))


def probabilities(model, df: pd.DataFrame, inputs: tuple[str, ...]) -> np.ndarray:
    """``(n_runs, 6, n_classes)``: each joint's class probabilities (``model.classes_``)."""
    x = joint_rows(df, inputs)
    return model.predict_proba(x.reshape(-1, x.shape[2])).reshape(len(df), N_JOINTS, -1)


def joint_fault_probabilities(model, df: pd.DataFrame, inputs: tuple[str, ...]) -> np.ndarray:
    """``(n_runs, 6)``: each joint's probability of a fault of any kind, ``1 - p(none)``."""
    p = probabilities(model, df, inputs)
    return 1.0 - p[:, :, [str(c) for c in model.classes_].index(NONE)]


def fault_score(model, df: pd.DataFrame, inputs: tuple[str, ...]) -> np.ndarray:
    """``(n_runs,)``: the largest joint probability of a fault, ``max_j (1 - p_j(none))`` - the detector score."""
    return joint_fault_probabilities(model, df, inputs).max(axis=1)


#: the decision threshold of :func:`predict` without an operating point: even odds
EVEN_ODDS = 0.5


def predict(model, df: pd.DataFrame, inputs: tuple[str, ...], threshold: float = EVEN_ODDS,
            strict: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Each run's kind (``healthy`` or a fault kind: module docstring) and its likeliest faulty joint (1-6, the
    joint with the largest probability of a fault, whatever the kind call: as the localiser, it is read on
    every single-joint fault).  ``threshold``: the largest joint probability of a fault at which a run is
    called faulty (reached: ``>=``; exceeded with ``strict``, as the detector's operating point is read)."""
    p = probabilities(model, df, inputs)
    cls = [str(c) for c in model.classes_]
    kinds = [k for k in cls if k != NONE]
    if NONE not in cls or not kinds:
        return np.full(len(df), "healthy"), np.ones(len(df), int)
    p_fault = 1.0 - p[:, :, cls.index(NONE)]
    pk = p[:, :, [cls.index(k) for k in kinds]].max(axis=1)  # each kind's largest probability on any joint
    score = p_fault.max(axis=1)
    faulty = score > threshold if strict else score >= threshold
    return np.where(faulty, np.array(kinds)[pk.argmax(axis=1)], "healthy"), p_fault.argmax(axis=1) + 1


__all__ = ["EVEN_ODDS", "NONE", "fault_score", "fit", "joint_fault_probabilities", "joint_labels", "joint_rows",
           "layout", "predict", "probabilities"]
