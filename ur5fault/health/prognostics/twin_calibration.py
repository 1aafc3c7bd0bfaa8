"""The twin's calibration per duty cycle: where the twin's failure boundary sits against where the failed
training units of the same task failed, shrunk towards the calibration of all tasks when a task has few
units or the tasks do not differ.

A model error (a gear stiffness or a friction the twin has wrong) moves the boundary differently on each
task: the TCP deviation is the sum of the joints' errors through the task's own poses and loads, so the
error shifts it by a task-dependent amount (on the default fleet, task 0's elbow jump moves while a
shoulder-led task's smooth growth barely does).  A pooled calibration averages those shifts; the units of
one duty cycle measure their own.

Model (one-way random effects, per checkpoint): the log ratio ``e`` of the radius a training unit reached
to the twin's is ``mu + b_task + eps`` with ``b_task ~ N(0, tau^2)`` and ``eps ~ N(0, s_w^2)``.  ``s_w^2``
is the pooled within-task variance, ``tau^2`` the method-of-moments (one-way ANOVA) between-task variance
(0 when the task means differ no more than the within-task scatter explains).  A task's bias is its
posterior mean ``mu + w (mean_task - mu)``, ``w = tau^2 / (tau^2 + s_w^2 / n_task)``, and its sd
``sqrt(s_w^2 + (1 - w) tau^2)`` (the scatter of one unit about its task plus what is unknown of the task's
bias), so a task with few units keeps an interval as wide as the spread of the tasks.  A task with no
calibration units gets ``mu`` and ``sqrt(s_w^2 + tau^2)``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclasses.dataclass(frozen=True)
class TaskCalibration:
    """Per-task (bias, sd, rays) of the log radius, the pooled mean ``mu`` and the variances behind them."""

    mu: float
    within_var: float
    between_var: float
    tasks: Mapping[str, tuple[float, float, int]]

    def at(self, task: str) -> tuple[float, float]:
        """(bias, sd) of the log radius for a ray of ``task``."""
        if task in self.tasks:
            return self.tasks[task][:2]
        return self.mu, float(np.sqrt(self.within_var + self.between_var))

    def to_dict(self) -> dict:
        return {"pooled_mean": self.mu, "within_task_sd": float(np.sqrt(self.within_var)),
                "between_task_sd": float(np.sqrt(self.between_var)),
                "bias_sd_rays_by_task": {t: list(v) for t, v in self.tasks.items()}}


def task_calibration(resid: ArrayLike, tasks: ArrayLike) -> TaskCalibration:
    """The shrunk per-task calibration of log-radius residuals ``resid`` (n,) of duty cycles ``tasks`` (n,)."""
    e = np.asarray(resid, float)
    t = np.asarray(tasks)
    if e.size < 2:
        raise ValueError("a calibration needs at least two residuals")
    names = sorted(set(t.tolist()))
    groups = {k: e[t == k] for k in names}
    n, n_t = e.size, len(names)
    mu = float(np.mean(e))
    if n > n_t:
        within = float(sum(((g - g.mean()) ** 2).sum() for g in groups.values()) / (n - n_t))
    else:                          # one residual per task: no within-task scatter to tell from the tasks'
        within = float(np.var(e, ddof=1))
    between = 0.0
    if n_t >= 2 and n > n_t:
        msb = sum(g.size * (g.mean() - mu) ** 2 for g in groups.values()) / (n_t - 1)
        n0 = (n - sum(g.size ** 2 for g in groups.values()) / n) / (n_t - 1)
        between = max(0.0, float((msb - within) / n0))
    out = {}
    for k, g in groups.items():
        w = between / (between + within / g.size) if between > 0 else 0.0
        out[str(k)] = (mu + w * (float(g.mean()) - mu), float(np.sqrt(within + (1 - w) * between)), int(g.size))
    return TaskCalibration(mu, within, between, out)


def direction_bias(task_bias: float, resid: NDArray, directions: NDArray, direction: NDArray, kappa: float) -> float:
    """The task's bias corrected by its calibration residuals ``resid`` (m,) along ``directions`` (m, 6) near
    ``direction`` (6,): ``task_bias + sum w (e - task_bias) / (sum w + 1)``, ``w = exp(kappa (cos theta - 1))``.

    Why: a model error moves where along a direction the failure criterion jumps (task 0's elbow jump), so
    the twin's error is a function of the direction, not one number per task.  The kernel and its width
    ``kappa`` are the clearance estimator's (chosen by leave-one-unit-out on how the training units' failure
    radius varies with direction); the ``+ 1`` is one pseudo-unit at the task's bias (assumption), so a
    direction without calibration units nearby keeps the task's bias and one unit straight along it moves
    the bias half-way to its own residual.
    """
    if len(resid) == 0:
        return task_bias
    w = np.exp(kappa * (np.asarray(directions, float) @ np.asarray(direction, float) - 1.0))
    return float(task_bias + w @ (np.asarray(resid, float) - task_bias) / (w.sum() + 1.0))
