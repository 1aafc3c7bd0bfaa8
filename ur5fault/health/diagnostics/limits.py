"""The smallest fault a run's motion could show, per joint and fault kind: its detection limit.

Every run carries, per joint, the twin features' least-squares size estimate of each kind's signature with its
standard error (:mod:`ur5fault.health.twin_features`: ``twin_est_<estimate>_j<k>`` and ``..._se_j<k>``).  A fault
stands out of a healthy run's estimate once its own contribution passes ``z`` standard errors; so the limit of a
kind on a joint, in the estimate's unit, is ``z * c * SE``, converted to the unit of the campaign's
``fault_size`` (:func:`size_from_estimate`).  No label is used: the SE is the run's own.

``c`` calibrates the SE: the robust spread (1.4826 x the median absolute deviation, about the median) of the t
values ``estimate / SE`` of that estimate on that joint over the **healthy training runs** (:class:`LimitCalibration`).
It is 1 where the SE is right; above 1 where model error, the nuisance the robot does not know, or a too-small
Newey-West SE spread the healthy estimates wider than their SE says.  A constant healthy bias (a median t away
from 0) does not enter: a fault adds its contribution to whatever a healthy run gives.

Where the SE is undefined (NaN: the motion does not identify the estimate, e.g. a backlash whose flank never
changes because the gear torque never reverses; see :data:`WHY_NOT_IDENTIFIED`) or the calibration has no
healthy training value, the limit is infinite: "cannot tell on this motion", with the reason (:func:`reason`).

``z``: shown at :data:`Z_VALUES`; :data:`DEFAULT_Z` = 3 is the one of them nearest 1.96 + 1.28 = 3.24, the size at
which a single estimate's two-sided test at 5 % false alarms detects 90 % of the faults (the goal's operating
point and the alpha_90's probability).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from ...errors import ConfigFileError
from ...sim.axes import N_JOINTS
from ...util.robust import robust_spread
from ..twin_features import ESTIMATE_UNITS, FLANK_SHARE

#: each fault kind's size estimate (name of :data:`ur5fault.health.twin_features.ESTIMATE_UNITS`); a current-sensor
#: gain and a torque-constant loss share one (the same signature: ``kind_call.MERGED_KINDS``)
ESTIMATE_OF = {"current_sensor_offset": "current_offset_A", "current_sensor_gain": "current_gain_err",
               "torque_constant": "current_gain_err", "coulomb_friction": "coulomb_scale_err",
               "resolver_offset": "mismatch_offset_rad", "backlash": "backlash_rad", "gear_stiffness": "compliance_err"}
#: the estimates the limits read
ESTIMATES = tuple(ESTIMATE_UNITS)
#: each kind's ``fault_size`` unit as ``ur5fault diagnose`` writes it (the campaign writes ``fraction`` for the
#: dimensionless ones; the same numbers)
SIZE_UNIT = {"backlash": "deg", "current_sensor_offset": "A", "current_sensor_gain": "gain - 1",
             "torque_constant": "loss (1 - scale)", "coulomb_friction": "scale - 1", "resolver_offset": "deg",
             "gear_stiffness": "loss (1 - scale)"}
#: why each estimate can be undefined on a joint (its fit leaves the column out: zero, or a mix of the others)
WHY_NOT_IDENTIFIED = {
    "current_offset_A": "the current fit cannot tell a constant current from the joint's other columns on this "
                        "motion (its standard error is undefined)",
    "current_gain_err": "the joint's twin current is zero or a mix of its other columns on this motion (the gain "
                        "estimate's standard error is undefined)",
    "coulomb_scale_err": "the joint never moves, or its friction current is a mix of its other columns on this "
                         "motion: friction is not exercised (standard error undefined)",
    "mismatch_offset_rad": "no encoder mismatch to fit on this joint (no motor encoder, or its columns are mixed; "
                           "standard error undefined)",
    "backlash_rad": "the gear torque never changes flank on this joint in this motion: the clearance is never "
                    "crossed (the twin's torque on its weaker flank stays under 2 % of its peak, "
                    "twin_gear_flank_share; standard error undefined or not read)",
    "compliance_err": "the gear torque's windup is a mix of the offset and flank columns on this motion (standard "
                      "error undefined)",
}
#: why a limit cannot be calibrated
WHY_NOT_CALIBRATED = "no healthy training run identifies this estimate on this joint: its spread is not calibrated"
Z_VALUES = (2.0, 3.0, 5.0)
DEFAULT_Z = 3.0


def _known(kind: str) -> None:
    """Refuse a fault kind without a size estimate (naming the known ones)."""
    if kind not in ESTIMATE_OF:
        raise KeyError(f"no size estimate for fault kind {kind!r} (known: {', '.join(sorted(ESTIMATE_OF))})")


def size_from_estimate(kind: str, limit: np.ndarray | float) -> np.ndarray:
    """A limit on ``kind``'s size estimate (its unit, >= 0; inf allowed) -> the same limit on ``fault_size``.

    The estimates, as :mod:`ur5fault.health.twin_features` builds them: backlash alpha gives ``alpha`` [rad] and a
    resolver offset o gives ``-o`` [rad] (-> deg); a current offset its offset [A]; a gain 1 +- s gives +-s; a
    Coulomb scale 1 + s gives s; a torque constant or a gear stiffness scaled by 1 - s gives ``1/(1 - s) - 1``, so
    an estimate limit L is a size limit ``L / (1 + L)`` (1 at L = inf)."""
    return np.abs(signed_size(kind, limit))


def signed_size(kind: str, estimate: np.ndarray | float) -> np.ndarray:
    """``kind``'s size estimate (its unit, signed) -> the fault's size in the unit of ``fault_size``, signed where the
    fault has a direction (``ur5fault diagnose``'s sizes; :func:`size_from_estimate` the same for limits): the
    conversions of :func:`size_from_estimate`, a resolver offset's sign turned back (its estimate is ``-o``); a loss
    estimate at or below -1 (no scale gives it) is NaN."""
    x = np.asarray(estimate, dtype=float)
    _known(kind)
    if kind == "backlash":
        return np.degrees(x)
    if kind == "resolver_offset":
        return -np.degrees(x)
    if kind in ("torque_constant", "gear_stiffness"):  # the estimate of 1/(1 - s) - 1 -> the loss s
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(1.0 + x > 0, 1.0 - 1.0 / (1.0 + x), np.nan)
    return x


def estimate_from_size(kind: str, size: np.ndarray | float) -> np.ndarray:
    """The magnitude of ``kind``'s size estimate that a fault of ``fault_size`` ``size`` gives (the inverse of
    :func:`size_from_estimate`)."""
    s = np.asarray(size, dtype=float)
    _known(kind)
    if kind in ("backlash", "resolver_offset"):
        return np.radians(s)
    if kind in ("torque_constant", "gear_stiffness"):
        return 1.0 / (1.0 - s) - 1.0
    return s


def _cols(est: str, what: str) -> list[str]:
    return [f"twin_est_{est}_{what}_j{j}" for j in range(1, N_JOINTS + 1)]


def has_estimates(df: pd.DataFrame) -> bool:
    """Whether ``df`` holds every estimate's SE and t column the limits read."""
    return all(c in df.columns for e in ESTIMATES for w in ("se", "t") for c in _cols(e, w))


@dataclasses.dataclass(frozen=True)
class LimitCalibration:
    """Per estimate, per joint (6): the robust spread of the t values on the healthy training runs and how many
    finite t values it was read from (NaN spread: none).  Build it with :meth:`from_training`."""

    spread: Mapping[str, tuple[float, ...]]
    n: Mapping[str, tuple[int, ...]]

    def __post_init__(self) -> None:
        for est in ESTIMATES:
            if len(self.spread.get(est, ())) != N_JOINTS or len(self.n.get(est, ())) != N_JOINTS:
                raise ConfigFileError(f"detection-limit calibration: estimate {est!r} needs {N_JOINTS} joint values")
            if any(math.isfinite(v) and v < 0 for v in self.spread[est]):
                raise ConfigFileError(f"detection-limit calibration: negative spread for {est!r}")

    @classmethod
    def from_training(cls, train: pd.DataFrame) -> LimitCalibration:
        """From the training rows ``train`` (only those with ``fault == "healthy"`` are read)."""
        h = train[train["fault"] == "healthy"]
        spread, n = {}, {}
        for est in ESTIMATES:
            t = h[_cols(est, "t")].apply(pd.to_numeric, errors="coerce").to_numpy(float)
            _, s, k = robust_spread(t)
            spread[est] = tuple(math.nan if np.isnan(v) else float(v) for v in s)  # math.nan: one NaN, as read back
            n[est] = tuple(int(v) for v in k)
        return cls(spread, n)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able (NaN as None), as saved in the detector's schema."""
        return {"from": "healthy training runs: 1.4826 MAD of each estimate's t value per joint",
                "t_spread": {e: [v if math.isfinite(v) else None for v in self.spread[e]] for e in ESTIMATES},
                "n_healthy": {e: list(self.n[e]) for e in ESTIMATES}}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> LimitCalibration:
        try:
            return cls({e: tuple(math.nan if v is None else float(v) for v in d["t_spread"][e]) for e in ESTIMATES},
                       {e: tuple(int(v) for v in d["n_healthy"][e]) for e in ESTIMATES})
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigFileError(f"detection-limit calibration unreadable ({exc!r}); run `ur5fault benchmark` "
                                  "again") from None


#: the column of each joint's gear-torque flank share (twin residuals format 5); absent from older campaigns
FLANK_COLUMN = "twin_gear_flank_share_j{}"


def reverses(share: np.ndarray | float) -> np.ndarray:
    """Whether a flank share (:func:`ur5fault.health.twin_features.flank_share`) means the gear torque reverses:
    above :data:`~ur5fault.health.twin_features.FLANK_SHARE`, the share the backlash fit's flank column counts.
    NaN (a campaign without the column) counts as reversing: the SE alone decides there, as before the column."""
    x = np.asarray(share, dtype=float)
    return np.isnan(x) | (x > FLANK_SHARE)


def standard_errors(df: pd.DataFrame, est: str) -> np.ndarray:
    """``(n_runs, 6)`` standard errors of ``est``; the backlash's as NaN where the gear torque does not reverse."""
    se = df[_cols(est, "se")].apply(pd.to_numeric, errors="coerce").to_numpy(float)
    if est == ESTIMATE_OF["backlash"]:
        cols = [FLANK_COLUMN.format(j) for j in range(1, N_JOINTS + 1)]
        if all(c in df.columns for c in cols):
            se = np.where(reverses(df[cols].apply(pd.to_numeric, errors="coerce").to_numpy(float)), se, np.nan)
    return se


def estimate_limits(df: pd.DataFrame, cal: LimitCalibration, z: float = DEFAULT_Z) -> dict[str, np.ndarray]:
    """Per estimate, ``(n_runs, 6)``: ``z * spread * SE`` in the estimate's unit, inf where SE or spread is
    undefined (not finite, or not positive) - for the backlash also where the run's gear torque does not reverse
    on the joint (:func:`reverses`)."""
    if not z > 0:
        raise ValueError(f"z = {z!r} must be positive")
    out = {}
    for est in ESTIMATES:
        se = standard_errors(df, est)
        c = np.asarray(cal.spread[est], float)[None, :]
        ok = np.isfinite(se) & (se > 0) & np.isfinite(c) & (c > 0)
        out[est] = np.where(ok, z * np.where(ok, c * se, 0.0), np.inf)
    return out


def detection_limits(df: pd.DataFrame, cal: LimitCalibration, z: float = DEFAULT_Z) -> dict[str, np.ndarray]:
    """Per fault kind, ``(n_runs, 6)``: the smallest ``fault_size`` each run's motion could show on each joint
    (module docstring); inf: cannot tell."""
    lim = estimate_limits(df, cal, z)
    return {kind: size_from_estimate(kind, lim[est]) for kind, est in ESTIMATE_OF.items()}


def reason(kind: str, se: float, spread: float) -> str | None:
    """Why ``kind``'s limit is infinite given its estimate's SE and calibrated spread on a joint; None if it is
    finite."""
    if not (math.isfinite(spread) and spread > 0):
        return WHY_NOT_CALIBRATED
    if not (math.isfinite(se) and se > 0):
        return WHY_NOT_IDENTIFIED[ESTIMATE_OF[kind]]
    return None


def joint_limits(features: Mapping[str, float], cal: LimitCalibration, joint: int, z: float = DEFAULT_Z
                 ) -> dict[str, dict[str, Any]]:
    """One window's or run's limits on ``joint`` (1-6) from its ``twin_est_*_se_j<k>`` values: per kind
    ``{"detectable_from": size, "unit": ...}`` or ``{"detectable_from": None, "unit": ..., "cannot_tell": why}``."""
    out = {}
    for kind, est in ESTIMATE_OF.items():
        v = features.get(f"twin_est_{est}_se_j{joint}")
        se = math.nan if v is None else float(v)
        share = features.get(FLANK_COLUMN.format(joint))
        if kind == "backlash" and share is not None and not reverses(float(share)):
            se = math.nan  # the torque never reverses: a finite SE there is the approach to zero, not a crossing
        spread = cal.spread[est][joint - 1]
        why = reason(kind, se, spread)
        if why is None:
            out[kind] = {"detectable_from": float(size_from_estimate(kind, z * spread * se)), "unit": SIZE_UNIT[kind]}
        else:
            out[kind] = {"detectable_from": None, "unit": SIZE_UNIT[kind], "cannot_tell": why}
    return out


__all__ = ["DEFAULT_Z", "ESTIMATES", "ESTIMATE_OF", "SIZE_UNIT", "Z_VALUES", "LimitCalibration", "detection_limits",
           "estimate_from_size", "estimate_limits", "has_estimates", "joint_limits", "reason", "reverses",
           "signed_size", "size_from_estimate", "standard_errors"]
