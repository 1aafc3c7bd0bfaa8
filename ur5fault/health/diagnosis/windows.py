"""The classifier inputs of a measured log, window by window: the log's commands replayed through its digital
twin (:class:`ur5fault.twin.LogReplay`, the one path from a log to the model) and the same features a
campaign computes for a run (:func:`ur5fault.health.features.run_features`,
:func:`ur5fault.health.twin_features.twin_features`) over consecutive windows as long as the training runs.

A log without motor encoders (the NIST and Kufieta logs) has no encoder mismatch: every feature that needs it
is NaN (never 0, which would read as "healthy"), and the diagnosis says so.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ...errors import ParameterError
from ...logs import MeasuredLog
from ...logs.plausible import MinLength
from ...sim.axes import N_JOINTS
from ...twin import LogReplay, Replayed
from ...twin.residuals import CONDITION_REST_SPEED_RAD_S
from ..features import run_features
from ..signals import needs_motor_encoders
from ..twin_features import ESTIMATE_UNITS, projection_columns, twin_features
from ..twin_fit import fed_back_torque


@dataclasses.dataclass(frozen=True)
class Window:
    """One window of the log: its sample range, its features, and what its motion exercises per joint."""

    start_s: float
    end_s: float
    #: ``twin_gear_flank_share_j<k>`` among them: whether the twin's gear torque reverses (backlash is seen only
    #: there, :func:`ur5fault.health.diagnostics.limits.reverses`)
    features: dict[str, float]
    #: per joint, share of the window's samples where the commanded joint moves (faster than the twin's
    #: "at rest" speed; Coulomb friction is seen only in motion)
    share_moving: tuple[float, ...]
    #: the ``twin_est_*`` size estimates of the window's first and second half (their spread: the interval)
    halves: tuple[dict[str, float], dict[str, float]] = ({}, {})
    #: per joint, the variance inflation factor of each size estimate (name of
    #: :data:`ur5fault.health.twin_features.ESTIMATE_UNITS` -> VIF): how far its signature is told apart
    #: from the others of its fit in this window (inf: the signature is absent or a mix of the others)
    vif: tuple[dict[str, float], ...] = ()


def _signals(log: MeasuredLog, rep: Replayed, lo: int, hi: int, ratio: NDArray) -> tuple[dict, dict]:
    """Measured and twin signals of samples ``lo..hi-1`` of the replay (log samples ``lo+1..hi``)."""
    nan = np.full((hi - lo, N_JOINTS), np.nan)
    meas = {"q_FB_rad": log.q_actual_rad[lo + 1 : hi + 1], "i_FB_A": log.current_A[lo + 1 : hi + 1],
            "q_M_FB_rad": nan if log.q_motor_rad is None else log.q_motor_rad[lo + 1 : hi + 1]}
    pos = rep.y[lo:hi, 1]
    twin_motor = nan if log.q_motor_rad is None else (rep.y[lo:hi, 2] + pos) * ratio
    twin = {"q_FB_rad": pos, "i_FB_A": rep.y[lo:hi, 0], "q_M_FB_rad": twin_motor,
            "i_q_A": rep.current_true_A[lo:hi], "T_gear_Nm": rep.torque_gear_Nm[lo:hi]}
    if rep.com_A_per_m is not None:
        twin["com_A_per_m"] = rep.com_A_per_m[lo:hi]
    return meas, twin


#: the fewest samples a window may have (the features take gradients of gradients)
MIN_WINDOW_SAMPLES = 3


def window_length(window_s: float) -> MinLength:
    """What ``ur5fault diagnose`` needs of a log: one whole window of ``window_s`` (the detector's training runs'
    duration), nothing more - it fits nothing to the log."""
    return MinLength(window_s, MIN_WINDOW_SAMPLES, f"`ur5fault diagnose` needs at least one window of {window_s:g} s "
                                                   "(the detector's training runs' duration)", one_log=True)


def inflation(cols: list[NDArray]) -> list[float]:
    """Variance inflation factor of each column ``(n,)`` of a least-squares fit (uncentred: the fits have a
    constant column of their own): 1 / (1 - R^2) of that column regressed on the others; inf where a column
    is zero or the others explain it."""
    a = np.stack(cols, axis=1)
    a = a[np.all(np.isfinite(a), axis=1)]
    out = []
    for k in range(a.shape[1]):
        y, x = a[:, k], np.delete(a, k, axis=1)
        ss = float(y @ y)
        if a.shape[0] <= a.shape[1] or ss <= 0:
            out.append(float("inf"))
            continue
        r = y - x @ np.linalg.lstsq(x, y, rcond=None)[0]
        unexplained = float(r @ r) / ss
        out.append(1.0 / unexplained if unexplained > 1e-12 else float("inf"))
    return out


def window_features(log: MeasuredLog, replay: LogReplay, rep: Replayed, window_s: float,
                    context: dict[str, float]) -> list[Window]:
    """Features of every whole window of ``window_s`` in the replayed log (``rep``: the twin's replay of all
    samples after the first); ``context``: the known operating conditions (payload, temperature)."""
    period = log.period_s
    n_win = int(round(window_s / period))
    n = rep.y.shape[0]
    if n_win < MIN_WINDOW_SAMPLES or n < n_win:
        raise ParameterError(f"{log.source}: {n * period:.2f} s after its first sample, shorter than one window "
                             f"of {window_s:g} s (the detector's training runs' duration)")
    ratio = replay.gear_ratio
    t = log.t_s[1 : n + 1] - log.t_s[1]
    q_set = log.q_target_rad[1 : n + 1]
    dt = period
    payload = float(context.get("payload_kg", 0.0))
    # when the gripper holds it: ur5fault's own logs record it; a robot's log does not (held throughout)
    held = None if log.payload_held is None else np.asarray(log.payload_held, bool)[1 : n + 1]
    out = []
    for lo in range(0, n - n_win + 1, n_win):
        hi = lo + n_win
        meas, twin = _signals(log, rep, lo, hi, ratio)
        zeros = np.zeros((hi - lo, 3))
        with warnings.catch_warnings(), np.errstate(invalid="ignore", divide="ignore"):
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN mismatch of a log without motor encoders
            f = {k: v for k, v in run_features(t[lo:hi], q_set[lo:hi], meas["q_FB_rad"], meas["q_M_FB_rad"],
                                               meas["i_FB_A"], ratio, zeros, zeros, None).items()
                 if not k.startswith("tcp_")}
            hw = None if held is None else held[lo:hi]
            f.update(twin_features(t[lo:hi], q_set[lo:hi], meas, twin, replay.params, payload, hw))
            mid = (hi - lo) // 2
            halves = tuple({k: v for k, v in twin_features(t[lo:hi][sl], q_set[lo:hi][sl],
                                                            {k2: v2[sl] for k2, v2 in meas.items()},
                                                            {k2: v2[sl] for k2, v2 in twin.items()},
                                                            replay.params, payload,
                                                            None if hw is None else hw[sl]).items()
                            if k.startswith("twin_est_")}
                           for sl in (slice(0, mid), slice(mid, None)))
        if log.q_motor_rad is None:
            f.update({k: float("nan") for k in f if needs_motor_encoders(k)})
        f.update(context)
        # the columns the window's fits used: the mismatch fit's gear torque with the CoM it found fed back
        torque = fed_back_torque(q_set[lo:hi], twin, replay.params, f, payload, hw)
        cur, mis = projection_columns(t[lo:hi], q_set[lo:hi], {**twin, "T_gear_Nm": torque}, replay.params)
        vif = tuple(dict(zip(ESTIMATE_UNITS, inflation([c[:, j] for c in cur]) + inflation([c[:, j] for c in mis])))
                    for j in range(N_JOINTS))
        moving = np.abs(np.gradient(q_set[lo:hi], dt, axis=0)) > CONDITION_REST_SPEED_RAD_S
        out.append(Window(float(t[lo]), float(t[hi - 1] + dt), f, tuple(float(v) for v in moving.mean(axis=0)),
                          halves, vif))
    return out


def features_frame(windows: list[Window]) -> pd.DataFrame:
    """The windows' features as a table, one row per window."""
    return pd.DataFrame([w.features for w in windows])


def window_inputs(windows: Sequence[Window], names: Sequence[str]) -> NDArray:
    """The classifier inputs ``names`` of ``windows``, ``(n_windows, n_inputs)`` (NaN where a window has none)."""
    return np.array([[w.features.get(c, np.nan) for c in names] for w in windows], float).reshape(len(windows),
                                                                                                   len(names))
