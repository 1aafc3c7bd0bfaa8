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
    #: UR's own inverse-dynamics joint torque of the target motion [N*m] (NIST ROBOT_TARGET_JOINT_TORQUES,
    #: RTDE target_moment), used as a cross-check by ``ur5fault identify``
    target_torque_Nm: NDArray | None = None

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
    tq = opt([f"ROBOT_TARGET_JOINT_TORQUES (J{j})" for j in range(1, 7)])
    return MeasuredLog(
        source=src, t_s=t - t[0], q_target_rad=qt, q_actual_rad=qa,
        current_A=arrays["actual currents"] * UR_CURRENT_SIGN,
        target_current_A=None if ct is None else ct * UR_CURRENT_SIGN, temperature_C=opt(temp), tcp_m=opt(tcp),
        payload_kg=NIST_PAYLOAD_KG, tcp_offset_m=NIST_TOOL_OFFSET_M, target_torque_Nm=tq,
    )


def read_rtde(path: str | Path, payload_kg: float = 0.0,
              tcp_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.15)) -> MeasuredLog:
    """Read a UR RTDE CSV as the ``rtde`` recorder writes it (radians, amperes, metres).

    Required columns: ``timestamp``, ``target_q_0..5``, ``actual_q_0..5``, ``actual_current_0..5``;
    optional: ``target_current_0..5``, ``joint_temperatures_0..5``, ``actual_TCP_pose_0..5``,
    ``target_moment_0..5``.
    The payload and tool offset are not in the recording and are given by the caller.
    """
    path = Path(path)
    src = path.name
    try:
        df = pd.read_csv(path, sep=None, engine="python") if path.suffix != ".gz" else pd.read_csv(path)
    except (OSError, pd.errors.ParserError) as exc:
        raise LogFormatError(f"{src}: cannot read as CSV ({exc})") from None
    qt = [f"target_q_{j}" for j in range(6)]
    qa = [f"actual_q_{j}" for j in range(6)]
    ia = [f"actual_current_{j}" for j in range(6)]
    _require(df, ["timestamp", *qt, *qa, *ia], src)
    t = df["timestamp"].to_numpy(float)
    arrays = {"target_q": df[qt].to_numpy(float), "actual_q": df[qa].to_numpy(float),
              "actual_current": df[ia].to_numpy(float)}
    _check(src, t, arrays)
    _plausible_ur5(src, arrays["actual_q"])
    opt = lambda cols: df[cols].to_numpy(float) if all(c in df.columns for c in cols) else None  # noqa: E731
    ct = opt([f"target_current_{j}" for j in range(6)])
    tcp = opt([f"actual_TCP_pose_{j}" for j in range(3)])
    return MeasuredLog(
        source=src, t_s=t - t[0], q_target_rad=arrays["target_q"], q_actual_rad=arrays["actual_q"],
        current_A=arrays["actual_current"] * UR_CURRENT_SIGN,
        target_current_A=None if ct is None else ct * UR_CURRENT_SIGN,
        temperature_C=opt([f"joint_temperatures_{j}" for j in range(6)]), tcp_m=tcp,
        payload_kg=payload_kg, tcp_offset_m=tuple(tcp_offset_m),
        target_torque_Nm=opt([f"target_moment_{j}" for j in range(6)]),
    )


def read_sim(path: str | Path) -> MeasuredLog:
    """Read a time series written by ``ur5fault simulate`` (or a campaign's ``timeseries/``).

    Uses ``q_set_rad_j*`` as target, ``q_FB_rad_j*`` as the measured position, ``i_FB_A_j*`` as the
    current, and ``q_M_FB_rad_j*`` (motor encoders) when present.
    """
    import json

    import pyarrow.parquet as pq

    path = Path(path)
    src = path.name
    try:
        table = pq.read_table(path)
    except (OSError, ValueError) as exc:
        raise LogFormatError(f"{src}: cannot read as Parquet ({exc})") from None
    df = table.to_pandas()
    cols = lambda name: [f"{name}_j{j}" for j in range(1, 7)]  # noqa: E731
    _require(df, ["t_s", *cols("q_set_rad"), *cols("q_FB_rad"), *cols("i_FB_A")], src)
    t = df["t_s"].to_numpy(float)
    arrays = {"q_set_rad": df[cols("q_set_rad")].to_numpy(float), "q_FB_rad": df[cols("q_FB_rad")].to_numpy(float),
              "i_FB_A": df[cols("i_FB_A")].to_numpy(float)}
    _check(src, t, arrays)
    _plausible_ur5(src, arrays["q_FB_rad"])
    meta = json.loads((table.schema.metadata or {}).get(b"ur5fault", b"{}"))
    tcp = df[["tcp_x_m", "tcp_y_m", "tcp_z_m"]].to_numpy(float) if "tcp_x_m" in df.columns else None
    qm = df[cols("q_M_FB_rad")].to_numpy(float) if all(c in df.columns for c in cols("q_M_FB_rad")) else None
    temp = meta.get("joint_temperature_C")
    return MeasuredLog(
        source=src, t_s=t, q_target_rad=arrays["q_set_rad"], q_actual_rad=arrays["q_FB_rad"],
        current_A=arrays["i_FB_A"], tcp_m=tcp, q_motor_rad=qm,
        temperature_C=None if temp is None else np.tile(np.asarray(temp, float), (t.size, 1)),
        payload_kg=float(meta.get("payload_kg", 0.0) or 0.0),
        tcp_offset_m=tuple(meta.get("tcp_offset_m", (0.0, 0.0, 0.15))),
    )


READERS = {"nist": read_nist, "rtde": read_rtde, "sim": read_sim}


def read_log(path: str | Path, fmt: str, **kwargs) -> MeasuredLog:
    """Read a log in one of the formats of :data:`READERS` (``nist``, ``rtde``, ``sim``)."""
    from .errors import UnknownNameError

    if fmt not in READERS:
        raise UnknownNameError("log format", fmt, READERS)
    p = Path(path)
    if not p.exists():
        raise LogFormatError(f"{p}: no such file")
    return READERS[fmt](p, **kwargs)
