"""A health index built per joint: each joint's own features estimate the growth of that joint's
clearance, and the clearances are combined into the failure criterion with one non-negative lever arm
per joint and duty task (the 0.5 mm TCP criterion sees each joint's clearance through its own distance
to the tool on that task's motion).

Two fitted stages, both on training inspections only:

1. per joint ``j``: ridge from the change of joint ``j``'s features since the unit's inspection 0 onto
   the change of its clearance ``backlash_deg_j<j>`` (the training units' true clearance is a fitting
   *target* here, as the criterion is for :class:`~.rul.HealthIndex`; :meth:`JointHealthIndex.transform`
   reads features only);
2. per duty task: non-negative least squares of ``criterion / threshold`` on the estimated clearances and
   a constant (the lever arms), so a unit whose failure is led by any joint is tracked by that joint.

Measured on the 100-unit fleet (docs/prognostics.md): this index follows the held-out units' criterion
*worse* than the direct per-task map of all features (residual sd 0.09 vs 0.05 of the threshold),
although stage 1 recovers the clearances well; it is reported beside the baseline, not as it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.optimize import nnls

from .rul import feature_changes, index_features

#: ridge penalty of stage 1, per inspection on standardised features (assumption: only keeps the
#: per-joint fit well posed; 1e-4..1e-1 was measured, docs/prognostics.md)
JOINT_RIDGE = 1e-4
JOINTS = (1, 2, 3, 4, 5, 6)


def joint_features(columns, j: int) -> list[str]:
    """The robot-computable features of joint ``j``."""
    return [c for c in index_features(columns) if c.endswith(f"_j{j}")]


#: stage 1 of one joint: its feature columns, their mean and scale, and the ridge coefficients (+ constant)
ClearanceMap = tuple[list[str], NDArray, NDArray, NDArray]


def fit_clearance_maps(df: pd.DataFrame, ridge: float = JOINT_RIDGE, target: str = "backlash_deg"
                       ) -> dict[int, ClearanceMap]:
    """Stage 1 on training inspections: per joint, ridge from the change of its own features since the
    unit's inspection 0 onto the change of its clearance (the training units' truth is the target);
    ``target``: the per-joint column prefix (``friction_scale``: the friction's rise, twin_friction.py)."""
    maps: dict[int, ClearanceMap] = {}
    for j in JOINTS:
        cols = joint_features(df.columns, j)
        x = feature_changes(df, cols).to_numpy()
        mu, sd = x.mean(0), x.std(0)
        sd[sd == 0] = 1.0
        z = np.column_stack([(x - mu) / sd, np.ones(len(x))])
        b = df[f"{target}_j{j}"].astype(float)
        y = (b - b.groupby(df["unit_id"]).transform("first")).to_numpy()
        reg = ridge * len(x) * np.eye(z.shape[1])
        reg[-1, -1] = 0.0
        maps[j] = (cols, mu, sd, np.linalg.solve(z.T @ z + reg, z.T @ y))
    return maps


def estimate_clearances(maps: dict[int, ClearanceMap], df: pd.DataFrame) -> NDArray:
    """Estimated clearance growth per joint since inspection 0 [deg], shape (rows, 6); reads features only."""
    out = np.zeros((len(df), len(JOINTS)))
    for k, j in enumerate(JOINTS):
        cols, mu, sd, c = maps[j]
        out[:, k] = ((feature_changes(df, cols).to_numpy() - mu) / sd) @ c[:-1] + c[-1]
    return out


@dataclasses.dataclass
class JointHealthIndex:
    """Per-joint clearance estimates through per-task lever arms; ``fit`` on training inspections."""

    criterion: str = "tcp_dev_max_mm"
    threshold: float = 0.5
    ridge: float = JOINT_RIDGE

    def fit(self, df: pd.DataFrame) -> JointHealthIndex:
        self.stage1_ = fit_clearance_maps(df, self.ridge)
        clear = self.clearances(df)
        y = df[self.criterion].to_numpy(float) / self.threshold
        tasks = df["trajectory"].astype(str) if "trajectory" in df.columns else pd.Series("", index=df.index)
        self.lever_pooled_ = nnls(np.column_stack([clear, np.ones(len(y))]), y)[0]  # tasks without training units
        self.lever_: dict[str, NDArray] = {}
        for task, g in df.groupby(tasks):
            ii = df.index.get_indexer(g.index)
            self.lever_[str(task)] = nnls(np.column_stack([clear[ii], np.ones(len(ii))]), y[ii])[0]
        self.features_ = [c for j in JOINTS for c in self.stage1_[j][0]]
        self.failure_level_ = 1.0
        self.residual_sd_ = float(np.std(self.transform(df) - y))  # in-sample
        return self

    def clearances(self, df: pd.DataFrame) -> NDArray:
        """Estimated clearance growth per joint since inspection 0 [deg], shape (rows, 6)."""
        return estimate_clearances(self.stage1_, df)

    def transform(self, df: pd.DataFrame) -> NDArray:
        """The index (criterion / threshold scale) of every row; reads features and the task only."""
        clear = self.clearances(df)
        tasks = df["trajectory"].astype(str) if "trajectory" in df.columns else pd.Series("", index=df.index)
        out = np.full(len(df), np.nan)
        for task, g in df.groupby(tasks):
            ii = df.index.get_indexer(g.index)
            lever = self.lever_.get(str(task), self.lever_pooled_)
            out[ii] = clear[ii] @ lever[:-1] + lever[-1]
        return out
