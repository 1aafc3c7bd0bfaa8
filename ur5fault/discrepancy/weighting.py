"""Each channel its own variance in the discrepancy workflow's linearised problem (an option: the workflow's
default is one pooled variance, :mod:`.statistics`).

Dividing by the sensor's sigma makes a channel of pure sensor noise unit-variance, but a replay's residual is
mostly the model's own error, and that differs by channel: 10-50 x the noise on the Kufieta J1-J3 currents, near
the noise on the wrists.  A Gaussian model with one variance for all channels judges a one-joint effect's
improvement against residual energy pooled over every channel, so a joint with a large model error dilutes the
improvement on a quiet one.  The statistically right form gives each channel ``c`` (signal x joint) its own
variance ``sigma_c^2`` and effective sample count ``n_c = n (1 - rho_c) / (1 + rho_c)`` (its lag-1 autocorrelation
``rho_c``).  With each variance profiled out, a candidate that lowers channel ``c``'s residual sum of squares from
``RSS0_c`` to ``RSS1_c`` changes ``-2 log L`` by ``sum_c n_c log(RSS1_c / RSS0_c)``, to first order ``-sum_c n_c
dRSS_c / RSS0_c``.

Feasible weighted least squares gives the same to first order and keeps one pooled problem and its
sufficient statistics (:class:`.statistics.BlockGram`): divide each channel of the residual and of every column by its
scale ``s_c``, with ``s_c^2 = RSS_c / n_c`` (the residual's variance times its autocorrelation inflation
``n / n_c``; :func:`channel_scale`).  In the rescaled problem each channel's sum of squares is ``n_c``, the
pooled one ``sum_c n_c = n_eff`` (what :func:`.statistics.effective_n` counts: lag-1 autocorrelation does not change
with a channel's scale), and the pooled criterion ``n_eff log(RSS~1 / RSS~0)`` is, to first order,
``-sum_c n_c dRSS_c / RSS0_c``: the per-channel one.  Beyond first order the two differ by terms of the
order of each channel's share of improvement squared (the pooled form averages ``RSS0_c / RSS1_c`` over the
channels inside the logarithm, the per-channel one outside it); at the decision threshold (delta BIC -10 over
thousands of effective samples) those shares are small (``tests/discrepancy/test_per_channel.py``: -47.16
against -47.17).  The coefficients become the weighted least-squares estimates, and the block
jackknife, the stability blocks (whose residual scale is then 1 per channel) and the collinearity are taken
in the same metric, so every test sees a joint's improvement against that joint's own unexplained variance.

Which residual gives ``RSS_c``: the one the problem's *full* model leaves (all the columns being judged,
least squares; :func:`per_channel`), as Mallows' C_p takes sigma^2 from the full model.  The starting
model's residual would hold the effect itself: on a channel where a fault dominates the residual it is
both large and smooth (``rho_c`` near 1), so ``s_c`` would be large and the fault's own channel the least
trusted.  The full model's residual holds what none of the candidates explains - the model's own error and
the noise - and does not depend on which candidates a forward step has chosen so far, so the scale is
estimated once per linearised problem (each stage), not at every step.  ``s_c`` is never below 1: no
channel is trusted beyond its sensor's noise (with every ``s_c = 1`` this is the pooled form).  The workflow's
default is the pooled form (``DiscrepancyModel(likelihood=...)``): measured on real logs, the per-channel one
was no better (docs/discrepancy.md, *Each channel its own variance*).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .statistics import BlockGram, lag1


def channel_scale(e: NDArray) -> NDArray:
    """Each channel's residual scale ``s_c = sqrt(RSS_c / n_c)`` of ``e`` ``(n, n_channels)``, ``n_c`` its
    autocorrelation-discounted sample count, never below 1 (the sensor's noise; module docstring)."""
    rho = lag1(e)
    n_c = e.shape[0] * (1 - rho) / (1 + rho)
    return np.sqrt(np.maximum(np.sum(e**2, axis=0) / np.maximum(n_c, 1.0), 1.0))


@dataclasses.dataclass(frozen=True)
class VarianceGroups:
    """Each channel's samples split into groups with a variance of their own (:func:`per_channel`): ``labels``
    ``(n_all, n_channels)``, a small whole number per sample and channel over the log's samples ``1..n_all``
    (every linearised problem starts at sample 1, so a problem of ``n`` samples takes the first ``n`` rows).
    The workflow's groups are a joint at rest and moving (``DiscrepancyModel(likelihood="per_condition")``)."""

    labels: NDArray
    #: the drift nuisance of a problem of ``n`` samples (``drift.Drift``; None: none), projected out again in the
    #: weighted metric: a drift removed unweighted would carry the model's error in motion into the samples at rest
    drift: Callable[[int], Any] | None = None

    def __post_init__(self) -> None:
        if np.ndim(self.labels) != 2:
            raise ValueError(f"variance group labels must be (n, n_channels), not {np.shape(self.labels)}")

    def of(self, n: int, n_channels: int) -> NDArray:
        if self.labels.shape[0] < n or self.labels.shape[1] != n_channels:
            raise ValueError(f"variance groups of {self.labels.shape} applied to ({n}, {n_channels})")
        return self.labels[:n]


#: what a selection's likelihood gives its own variance (:func:`per_channel`): False nothing (pooled), True each
#: channel, :class:`VarianceGroups` each group of each channel's samples
OwnVariance = bool | VarianceGroups

#: a group's own variance is estimated only from at least this many effective (autocorrelation-discounted)
#: samples, else the channel's: the RMS over 25 independent samples lies within 0.7..1.3 of its true value at
#: 95 % (the chi distribution; the same bound as ``ur5fault.twin.residuals.MIN_BIN_SAMPLES``)
MIN_GROUP_SAMPLES = 25


def group_scale(e: NDArray, labels: NDArray) -> NDArray:
    """Each sample's residual scale ``(n, n_channels)``: per channel, each group of samples (``labels``, same
    shape) its own :func:`channel_scale` (the group's samples in time order; the few joins between its runs
    hardly change the lag-1 autocorrelation), a group of fewer than MIN_GROUP_SAMPLES effective samples the
    channel's whole scale; never below 1."""
    s = np.broadcast_to(channel_scale(e), e.shape).copy()
    for c in range(e.shape[1]):
        for k in np.unique(labels[:, c]):
            m = labels[:, c] == k
            x = e[m, c][:, None]
            rho = lag1(x)[0]
            if x.shape[0] * (1 - rho) / (1 + rho) >= MIN_GROUP_SAMPLES:
                s[m, c] = channel_scale(x)[0]
    return s


def per_channel(X: NDArray, e: NDArray, own_variance: OwnVariance = False) -> tuple[NDArray, NDArray, NDArray]:
    """The linearised problem ``e ~ X theta`` (``X`` ``(p, n, n_channels)``, ``e`` ``(n, n_channels)``) with
    each channel divided by the scale of the residual its full model (every column of ``X``) leaves
    (:func:`channel_scale`; module docstring): ``(X / s, e / s, s)``.  ``own_variance`` False: the pooled
    form, one variance for every channel (``s = 1``); :class:`VarianceGroups`: each group of each channel's
    samples its own variance (:func:`group_scale`; ``s`` is then ``(n, n_channels)``)."""
    grouped = isinstance(own_variance, VarianceGroups)
    if not grouped and not own_variance:
        return X, e, np.ones(e.shape[-1])
    r = e
    if X.shape[0]:
        G, g, _ = BlockGram.build(X, e, 1).total()
        theta = np.linalg.lstsq(G, g, rcond=1e-12)[0]
        r = e - np.tensordot(theta, X, axes=1)
    if not grouped:
        s = channel_scale(r)
        return X / s, e / s, s
    s = group_scale(r, own_variance.of(*e.shape))
    if own_variance.drift is None:
        return X / s, e / s, s
    d = own_variance.drift(e.shape[0])
    return d.remove_weighted(X / s, s), d.remove_weighted(e / s, s), s


def rescaled(e: NDArray, s: NDArray, own_variance: OwnVariance = False) -> NDArray:
    """Another residual ``e`` of the same problem in the metric :func:`per_channel` gave it (its scale ``s``, and
    for variance groups with a drift that drift projected out again): e.g. a replay's scatter about the model."""
    if isinstance(own_variance, VarianceGroups) and own_variance.drift is not None:
        return own_variance.drift(e.shape[0]).remove_weighted(e / s, s)
    return e / s
