"""The fault kind a run is called, saying "cannot tell" where its signals cannot tell two kinds apart, and how such
calls are scored.

A current-sensor gain g reads g i while the loops hold the true current where the motion needs it; a torque
constant scaled by s needs i / s for the same torque.  Both leave a current residual proportional to the current,
with the position and encoder signals held by the loops (docs/diagnostics.md).  Two things tell them apart:

* the sensor's noise (twin residuals format 9): a gain multiplies the sensor's noise with its signal, a
  torque-constant loss leaves it alone, so the current-noise ratio at rest (:data:`NOISE_RATIO`,
  :func:`ur5fault.twin.residuals.noise_ratio`) reads about g for a gain and 1 for a torque-constant loss.
  Where that ratio is among the classifier's inputs and has a value on the called joint (the joint rests
  somewhere in the run), the classifier's call between the two stands;
* their sign, one way: a torque-constant loss (demagnetisation, s <= 1: the campaign draws it
  ``direction: down``) makes the gain-error estimate ``b = 1/s - 1 >= 0``, so a negative estimate on the called
  joint can only be a gain below 1.

So a run whose likeliest kind is either of the pair is called ``current_sensor_gain`` where the gain estimate on
the called joint is negative; else the classifier's call stands where the noise ratio has a value there; else it
is called :data:`PAIR` ("current gain or torque constant: cannot tell which": the joint never rests, or the
feature set lacks the ratio, as the paper's does).

Scored as a set: a :data:`PAIR` call is right for either kind of the pair; every other call is right only on its
own kind (:func:`balanced_accuracy_as_called`).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

#: fault kinds whose signatures are the same shape in every signal the twin features read (module docstring),
#: each mapped to the name of the pair
MERGED_KINDS = {"current_sensor_gain": "current_gain_or_torque_constant",
                "torque_constant": "current_gain_or_torque_constant"}
#: the call "current gain or torque constant: cannot tell which"
PAIR = "current_gain_or_torque_constant"
#: the twin's gain-error estimate (per joint, ``<stem>_j<k>``) whose sign tells a gain below 1 from the pair
GAIN_ESTIMATE = "twin_est_current_gain_err"
#: the current-noise ratio at rest (per joint, ``<stem>_j<k>``) that tells a gain from a torque-constant loss
NOISE_RATIO = "twin_current_noise_ratio_rest"


def noise_tells(features: pd.DataFrame, joint: np.ndarray, inputs: tuple[str, ...] | list[str]) -> np.ndarray:
    """Per row of ``features``: whether its :data:`NOISE_RATIO` on ``joint`` (1-6) is an input and has a value,
    i.e. whether the classifier could tell a current gain from a torque-constant loss there (module docstring)."""
    cols = [f"{NOISE_RATIO}_j{k}" for k in range(1, 7)]
    if not all(c in inputs for c in cols):
        return np.zeros(len(features), bool)
    return np.isfinite(features[cols].to_numpy(float)[np.arange(len(features)), np.asarray(joint, int) - 1])


def merge_kinds(labels: np.ndarray) -> np.ndarray:
    """``labels`` with the kinds of :data:`MERGED_KINDS` replaced by their common name."""
    return np.array([MERGED_KINDS.get(str(v), str(v)) for v in labels])


def tell_pair(calls: np.ndarray, df: pd.DataFrame, joint: np.ndarray, inputs: tuple[str, ...] | list[str]
              ) -> np.ndarray:
    """``calls`` (one kind per run of ``df``) with a call of either kind of the pair replaced by
    ``current_sensor_gain`` where the run's :data:`GAIN_ESTIMATE` on ``joint`` (1-6, its likeliest faulty joint)
    is negative and that estimate is an input; else kept where its :data:`NOISE_RATIO` there tells them apart
    (:func:`noise_tells`); else replaced by :data:`PAIR` (module docstring)."""
    calls = np.asarray(calls).astype(object)
    in_pair = np.isin(calls.astype(str), list(MERGED_KINDS))
    cols = [f"{GAIN_ESTIMATE}_j{k}" for k in range(1, 7)]
    if all(c in inputs for c in cols):
        est = df[cols].to_numpy(float)[np.arange(len(df)), np.asarray(joint, int) - 1]
        below_one = est < 0  # NaN: not below
    else:
        below_one = np.zeros(len(df), bool)
    told = noise_tells(df, joint, inputs)
    return np.where(in_pair & below_one, "current_sensor_gain",
                    np.where(in_pair & ~told, PAIR, calls)).astype(str)


def right_as_called(y: np.ndarray, calls: np.ndarray) -> np.ndarray:
    """Whether each call is right: its own kind, or :data:`PAIR` on either kind of the pair."""
    y, calls = np.asarray(y).astype(str), np.asarray(calls).astype(str)
    return (calls == y) | ((calls == PAIR) & np.isin(y, list(MERGED_KINDS)))


def balanced_accuracy_as_called(y: np.ndarray, calls: np.ndarray) -> float:
    """The mean over the true kinds of ``y`` of the share of their runs called right (:func:`right_as_called`)."""
    y = np.asarray(y).astype(str)
    ok = right_as_called(y, calls)
    return float(np.mean([ok[y == k].mean() for k in np.unique(y)]))


__all__ = ["GAIN_ESTIMATE", "MERGED_KINDS", "NOISE_RATIO", "PAIR", "balanced_accuracy_as_called", "merge_kinds",
           "noise_tells", "right_as_called", "tell_pair"]
