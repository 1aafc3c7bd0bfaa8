"""Health features of one run, one number each, units in the names.

Everything except ``tcp_dev_*`` (which needs the simulated healthy twin) can be computed
on a real robot's log too: encoder mismatch needs both encoders, the current features the
motor current only.

Definitions (``j`` = joint 1..6; signals at the log rate):

* ``tcp_dev_max_mm``, ``tcp_dev_rms_mm``: distance of the TCP from the healthy twin's TCP.
* ``tcp_track_max_mm``, ``tcp_track_rms_mm``: distance of the TCP from the desired TCP.
* ``track_err_rms_rad_j``, ``track_err_max_rad_j``: q_set - q_FB.
* ``enc_mismatch_p2p_rad_j``, ``enc_mismatch_rms_rad_j``: m = q_M,FB / N - q_FB, peak-to-peak and
  RMS about its mean; ``enc_mismatch_hyst_rad_j``: median jump of m across torque reversals
  (mean over 0.25 s after minus 0.25 s before, leaving out 20 ms either side of the reversal;
  ~alpha for a backlash, the load change / k if healthy).
* current residual r = i_FB - (its 20 ms moving average): ``current_spike_max_A_j`` its largest
  magnitude within 0.25 s of a torque reversal (sign change of the smoothed current);
  ``current_spike_count_j`` reversals whose residual exceeds ``SPIKE_THRESHOLD_A``;
  ``current_kurtosis_j`` (Pearson, 3 for Gaussian noise), ``current_crest_j`` max|r| / rms(r) and
  ``current_hf_energy_A2s_j`` the integral of r^2 over the run.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS

#: window of the moving average the current residual is taken against [s] (assumption: 20 samples at the 1 kHz
#: log rate average the sensor noise, and 20 ms is short against the 0.1-1 s torque phases of a motion)
SMOOTH_S = 0.02
#: half-width of the window around a torque reversal where a spike or a mismatch jump is looked for [s]
#: (assumption: a backlash crossing and its current spike last well under 0.25 s at UR5 speeds)
SPIKE_WINDOW_S = 0.25
#: residual that counts as a spike [A]: about 8 sigma of the current-sensor noise (0.012 A, data/ur5_drive.yaml)
SPIKE_THRESHOLD_A = 0.1
#: dead band of the smoothed current's sign change that marks a torque reversal [A] (assumption: above the
#: residual noise of the 20 ms average, so noise at standstill does not count as reversals)
REVERSAL_HYSTERESIS_A = 0.15
#: sample spacing assumed for a one-sample series [s] (the default log period)
DEFAULT_LOG_PERIOD_S = 1e-3


def moving_average(x: NDArray, n: int) -> NDArray:
    """Centred moving average over ``n`` samples along axis 0 (edges use the available samples)."""
    n = max(1, int(n))
    c = np.cumsum(np.concatenate([np.zeros((1,) + x.shape[1:]), x]), axis=0)
    idx = np.arange(x.shape[0])
    lo = np.clip(idx - n // 2, 0, x.shape[0])
    hi = np.clip(idx + (n - n // 2), 0, x.shape[0])
    return (c[hi] - c[lo]) / (hi - lo).reshape((-1,) + (1,) * (x.ndim - 1))


def sign_changes(x: NDArray, hysteresis: float) -> NDArray:
    """Indices where ``x`` (1-D) changes sign, with a dead band of +-hysteresis against chatter: the samples
    outside the band whose sign differs from that of the last sample outside it before them."""
    x = np.asarray(x)
    s = np.where(x > hysteresis, 1, np.where(x < -hysteresis, -1, 0))
    out = np.flatnonzero(s)
    return out[1:][s[out[1:]] != s[out[:-1]]].astype(int)


def run_features(t_s: NDArray, q_set: NDArray, q_fb: NDArray, q_m_fb: NDArray, i_fb: NDArray, ratio: NDArray,
                 tcp: NDArray, tcp_des: NDArray, tcp_twin: NDArray | None) -> dict[str, float]:
    """Features of one run from its ``(n_log, 6)`` joint signals and ``(n_log, 3)`` TCP paths [m]."""
    dt = float(t_s[1] - t_s[0]) if t_s.size > 1 else DEFAULT_LOG_PERIOD_S
    f: dict[str, float] = {}
    if tcp_twin is not None:
        dev = np.linalg.norm(tcp - tcp_twin, axis=-1) * 1e3
        f["tcp_dev_max_mm"] = float(np.nanmax(dev))
        f["tcp_dev_rms_mm"] = float(np.sqrt(np.nanmean(dev**2)))
    track = np.linalg.norm(tcp - tcp_des, axis=-1) * 1e3
    f["tcp_track_max_mm"] = float(np.nanmax(track))
    f["tcp_track_rms_mm"] = float(np.sqrt(np.nanmean(track**2)))
    err = q_set - q_fb
    mis = q_m_fb / ratio - q_fb
    smooth = moving_average(i_fb, round(SMOOTH_S / dt))
    resid = i_fb - smooth
    win = round(SPIKE_WINDOW_S / dt)
    guard = round(SMOOTH_S / dt)  # the reversal is located to within the smoothing window
    for j in range(N_JOINTS):
        s = f"_j{j + 1}"
        f["track_err_rms_rad" + s] = float(np.sqrt(np.nanmean(err[:, j] ** 2)))
        f["track_err_max_rad" + s] = float(np.nanmax(np.abs(err[:, j])))
        m = mis[:, j]
        f["enc_mismatch_p2p_rad" + s] = float(np.nanmax(m) - np.nanmin(m))
        f["enc_mismatch_rms_rad" + s] = float(np.sqrt(np.nanmean((m - np.nanmean(m)) ** 2)))
        rev = sign_changes(smooth[:, j], REVERSAL_HYSTERESIS_A)
        jumps, spikes = [], []
        for k in rev:
            before, after = m[max(0, k - guard - win) : max(0, k - guard)], m[k + guard : k + guard + win]
            if before.size and after.size:
                jumps.append(abs(np.nanmean(after) - np.nanmean(before)))
            spikes.append(np.nanmax(np.abs(resid[max(0, k - win) : k + win, j])))
        f["enc_mismatch_hyst_rad" + s] = float(np.median(jumps)) if jumps else 0.0
        f["current_spike_max_A" + s] = float(max(spikes)) if spikes else 0.0
        f["current_spike_count" + s] = float(sum(sp > SPIKE_THRESHOLD_A for sp in spikes))
        r = resid[:, j]
        rms = float(np.sqrt(np.nanmean(r**2)))
        f["current_kurtosis" + s] = float(np.nanmean(r**4) / rms**4) if rms > 0 else 0.0
        f["current_crest" + s] = float(np.nanmax(np.abs(r)) / rms) if rms > 0 else 0.0
        f["current_hf_energy_A2s" + s] = float(np.nansum(r**2) * dt)
    return f


#: feature name -> unit, for docs and the manifest
FEATURE_UNITS = {
    "tcp_dev_max_mm": "mm", "tcp_dev_rms_mm": "mm", "tcp_track_max_mm": "mm", "tcp_track_rms_mm": "mm",
    **{f"{name}_j{j}": unit for j in range(1, 7) for name, unit in (
        ("track_err_rms_rad", "rad"), ("track_err_max_rad", "rad"), ("enc_mismatch_p2p_rad", "rad"),
        ("enc_mismatch_rms_rad", "rad"), ("enc_mismatch_hyst_rad", "rad"), ("current_spike_max_A", "A"),
        ("current_spike_count", "count"), ("current_kurtosis", "-"), ("current_crest", "-"),
        ("current_hf_energy_A2s", "A^2*s"))},
}

#: per-joint feature (without ``_j{j}``) or run feature -> what it is, in words, for figure titles and axes
FEATURE_NAMES = {
    "tcp_dev_max_mm": "max TCP deviation from the healthy twin",
    "tcp_dev_rms_mm": "RMS TCP deviation from the healthy twin",
    "tcp_track_max_mm": "max TCP deviation from the desired path",
    "tcp_track_rms_mm": "RMS TCP deviation from the desired path",
    "track_err_rms_rad": "RMS tracking error",
    "track_err_max_rad": "max tracking error",
    "enc_mismatch_p2p_rad": "encoder mismatch, peak to peak",
    "enc_mismatch_rms_rad": "encoder mismatch, RMS",
    "enc_mismatch_hyst_rad": "encoder mismatch jump at torque reversals",
    "current_spike_max_A": "largest current spike at a torque reversal",
    "current_spike_count": "current spikes at torque reversals",
    "current_kurtosis": "current kurtosis",
    "current_crest": "current crest factor",
    "current_hf_energy_A2s": "current high-frequency energy",
}


def feature_label(feature: str) -> str:
    """``"max TCP deviation from the healthy twin [mm]"`` for ``tcp_dev_max_mm``; a per-joint feature with or
    without its ``_j{j}`` suffix (``"... [A], J2"``); any other column by its own name."""
    base, _, j = feature.rpartition("_j")
    if not (base and j.isdigit()):
        base, j = feature, ""
    if base not in FEATURE_NAMES:
        return feature
    unit = FEATURE_UNITS.get(base) or FEATURE_UNITS.get(f"{base}_j1", "-")
    return f"{FEATURE_NAMES[base]}" + (f" [{unit}]" if unit not in ("-", "count") else "") + (f", J{j}" if j else "")
