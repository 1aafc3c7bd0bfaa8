"""Measured logs: UR RTDE CSV, the NIST layout, and ur5fault's own time series.

Every reader returns a :class:`MeasuredLog` in SI units and ur5fault's sign conventions
(motor current positive when it drives the joint positive).  UR's controller configuration
lists joint directions ``[1, 1, -1, 1, 1, 1]``, but in the NIST log the elbow current has the
*same* sign as UR's own elbow torque (-1.35 A for -18.4 N*m at the start, 13.6 N*m/A like
J1-J2, and it rises with elbow speed), so no sign is flipped there; ``UR_CURRENT_SIGN`` is
where a log with the other convention would be corrected.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .axes import N_JOINTS
from .errors import LogFormatError
from .trajectory import Trajectory

#: sign of the reported motor current w.r.t. joint torque (all +1 in the NIST log, see above)
UR_CURRENT_SIGN = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
NIST_TOOL_OFFSET_M = (-0.001, -0.001, 0.1856)  # fitted on the NIST log (tests/test_nist_fk.py)
NIST_PAYLOAD_KG = 0.726  # 1.6 lb, from the NIST run name


@dataclasses.dataclass(frozen=True)
class MeasuredLog:
    """A measured (or simulated) robot log, SI units, batch-free ``(n_samples, 6)`` arrays.

    ``current_A`` is in joint-positive sense; optional arrays are ``None`` when absent.
    """

    source: str
    t_s: NDArray
    q_target_rad: NDArray
    q_actual_rad: NDArray
    current_A: NDArray
    target_current_A: NDArray | None = None
    temperature_C: NDArray | None = None
    tcp_m: NDArray | None = None
    q_motor_rad: NDArray | None = None
    payload_kg: float = 0.0
    tcp_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.15)

    @property
    def period_s(self) -> float:
        return float(np.median(np.diff(self.t_s)))

    def to_trajectory(self, name: str | None = None) -> Trajectory:
        """The log's target positions as a setpoint stream (payload held throughout)."""
        return Trajectory(name or self.source, self.period_s, self.q_target_rad, (), self.payload_kg > 0,
                          self.payload_kg)

    def window(self, t0_s: float, t1_s: float) -> MeasuredLog:
        """The part of the log with ``t0 <= t < t1`` (times relative to the log start), time re-zeroed."""
        t = self.t_s - self.t_s[0]
        sel = (t >= t0_s) & (t < t1_s)
        if sel.sum() < 2:
            raise LogFormatError(f"{self.source}: window [{t0_s}, {t1_s}) s holds fewer than 2 samples")
        kw = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for key, v in kw.items():
            if isinstance(v, np.ndarray) and v.shape[:1] == self.t_s.shape:
                kw[key] = v[sel]
        kw["t_s"] = kw["t_s"] - kw["t_s"][0]
        return MeasuredLog(**kw)


def _require(df: pd.DataFrame, cols: list[str], source: str) -> None:
    missing = [c for c in cols if c not in df.columns]
    if missing:
        raise LogFormatError(f"{source}: missing required column {missing[0]!r}" +
                             (f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""))


def _check(source: str, t: NDArray, arrays: dict[str, NDArray]) -> None:
    for name, arr in arrays.items():
        bad = ~np.isfinite(arr)
        if bad.any():
            row = int(np.argwhere(bad)[0][0])
            raise LogFormatError(f"{source}: NaN or inf in {name} at data row {row + 1}")
    dt = np.diff(t)
    if np.any(dt <= 0):
        row = int(np.argmax(dt <= 0)) + 1
        raise LogFormatError(f"{source}: time is not increasing at data row {row + 1} (t={t[row]})")


def _plausible_ur5(source: str, q: NDArray) -> None:
    if q.shape[1] != N_JOINTS:
        raise LogFormatError(f"{source}: expected 6 joints, found {q.shape[1]}; not a UR5 log")
    if np.any(np.abs(q) > 2.0 * np.pi + 0.1):
        j = int(np.argmax(np.max(np.abs(q), axis=0)))
        raise LogFormatError(f"{source}: joint {j + 1} beyond +-360 deg; wrong robot or unit (degrees vs radians)")


def read_nist(path: str | Path) -> MeasuredLog:
    """Read the NIST UR5 layout (positions in degrees; see ../shared/data/nist-ur5/README.md)."""
    path = Path(path)
    df = pd.read_csv(path)
    src = path.name
    pos_t = [f"ROBOT_TARGET_JOINT_POSITIONS (J{j})" for j in range(1, 7)]
    pos_a = [f"ROBOT_ACTUAL_JOINT_POSITIONS (J{j})" for j in range(1, 7)]
    cur_a = [f"ROBOT_ACTUAL_JOINT_CURRENT (J{j})" for j in range(1, 7)]
    cur_t = [f"ROBOT_TARGET_JOITN_CURRENT (J{j})" for j in range(1, 7)]
    temp = [f"ROBOT_JOINT_TEMP (J{j})" for j in range(1, 7)]
    tcp = [f"ROBOT_CARTESIAN_COORD_TOOL ({a})" for a in "xyz"]
    _require(df, ["ROBOT_TIME", *pos_t, *pos_a, *cur_a], src)
    t = df["ROBOT_TIME"].to_numpy(float)
    arrays = {"target positions": df[pos_t].to_numpy(float), "actual positions": df[pos_a].to_numpy(float),
              "actual currents": df[cur_a].to_numpy(float)}
    _check(src, t, arrays)
    qt, qa = np.radians(arrays["target positions"]), np.radians(arrays["actual positions"])
    _plausible_ur5(src, qa)
    opt = lambda cols: df[cols].to_numpy(float) if all(c in df.columns for c in cols) else None  # noqa: E731
    ct = opt(cur_t)
    return MeasuredLog(
        source=src, t_s=t - t[0], q_target_rad=qt, q_actual_rad=qa, current_A=arrays["actual currents"] * UR_CURRENT_SIGN,
        target_current_A=None if ct is None else ct * UR_CURRENT_SIGN, temperature_C=opt(temp), tcp_m=opt(tcp),
        payload_kg=NIST_PAYLOAD_KG, tcp_offset_m=NIST_TOOL_OFFSET_M,
    )
