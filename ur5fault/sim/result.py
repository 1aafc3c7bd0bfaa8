"""Typed results that know how to leave: arrays, metadata and status, to pandas and Parquet.

Wide table of one run (``SimResult.to_pandas(run)``): one row per logged sample, columns
``t_s``, then ``{signal}_j{1..6}`` for every joint signal (unit in the signal name), the
PMSM phase currents ``i_{a,b,c}_A_j{j}`` for three-phase joints, and the TCP positions
``tcp_{x,y,z}_m`` and ``tcp_des_{x,y,z}_m``.  See docs/outputs.md.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import ParameterError, UnknownNameError
from ..util.checks import is_integer, short
from ..util.io import write_csv_atomic, write_parquet_atomic
from .axes import JOINT_NAMES, N_JOINTS
from .drive.motor import phase_currents

if TYPE_CHECKING:  # pragma: no cover
    from .params import RobotParams
    from .run_arrays import RunArrays
    from .runspec import RunSpec
    from .trajectories import Trajectory


@dataclasses.dataclass(frozen=True)
class SimResult:
    """Signals of a batch of runs, batch axis first.

    Attributes:
        t_s: log times ``(n_log,)`` [s].
        q_set_rad: servo setpoint at the log times ``(n_log, 6)`` (shared by the batch).
        signals: joint signals ``name -> (n_runs, n_log, 6)``; see :attr:`JOINT_SIGNALS`.
        tcp_m, tcp_des_m: actual and desired TCP position in the base frame ``(n_runs, n_log, 3)`` [m].
        motor_pole_pairs, motor_is_pmsm: per run and joint ``(n_runs, 6)``, for :attr:`phase_currents_A`.
        phase_currents_A: ``(n_runs, n_log, 6, 3)`` phase currents (NaN for DC-equivalent joints), computed
            when first asked for (from the logged d/q currents and motor angles: only time series need them).
        run_ids, seeds, status, reason: per run; status is ``ok``, ``diverged`` or ``protective_stop``.
        effects: per run, the effects it carried (``EffectSpec.describe()`` strings).
        meta: physics step, trajectory, gear ratios, versions.
    """

    JOINT_SIGNALS = {
        "q_rad": "joint angle (link side, true)",
        "q_FB_rad": "resolver reading (joint side)",
        "q_M_rad": "motor angle (motor side, true)",
        "q_M_FB_rad": "motor encoder reading (motor side)",
        "w_M_FB_rad_s": "motor speed reading (motor side)",
        "i_ref_A": "current reference from the speed loop",
        "i_FB_A": "current-sensor reading (q axis)",
        "i_q_A": "motor current, q axis (DC-equivalent: the motor current)",
        "i_d_A": "motor current, d axis (0 for DC-equivalent joints)",
        "v_q_V": "applied voltage, q axis (DC-equivalent: the motor voltage)",
        "v_d_V": "applied voltage, d axis",
        "T_gear_Nm": "gear output torque T_id, eq. (1)",
        "T_f_Nm": "joint friction torque T_f, eq. (2)",
    }

    t_s: NDArray
    q_set_rad: NDArray
    signals: dict[str, NDArray]
    tcp_m: NDArray
    tcp_des_m: NDArray
    motor_pole_pairs: NDArray
    motor_is_pmsm: NDArray
    run_ids: tuple[str, ...]
    seeds: tuple[int, ...]
    status: tuple[str, ...]
    reason: tuple[str, ...]
    effects: tuple[tuple[str, ...], ...]
    meta: dict[str, Any]

    @property
    def n_runs(self) -> int:
        return len(self.run_ids)

    @functools.cached_property
    def phase_currents_A(self) -> NDArray:
        """``(n_runs, n_log, 6, 3)`` phase currents [A] (inverse Park/Clarke of the logged d/q currents at the
        motor's electrical angle; NaN for DC-equivalent joints)."""
        sig = self.signals
        elec = sig["q_M_rad"] * self.motor_pole_pairs[:, None, :]
        phases = phase_currents(sig["i_d_A"], sig["i_q_A"], elec)
        return np.where(self.motor_is_pmsm[:, None, :, None], phases, np.nan)

    # ------------------------------------------------------------------ notebooks
    #: runs listed by ``repr`` before it abbreviates
    REPR_RUNS = 4

    def __repr__(self) -> str:
        """One line per batch: shape, trajectory, and each run's id, status and effects (no arrays)."""
        runs = [f"{r} {s}" + (f" [{'; '.join(e)}]" if e else " [healthy]")
                for r, s, e in zip(self.run_ids[: self.REPR_RUNS], self.status, self.effects)]
        if self.n_runs > self.REPR_RUNS:
            runs.append(f"... {self.n_runs - self.REPR_RUNS} more")
        period = self.meta.get("log_period_s", float("nan"))
        return (f"<SimResult {self.n_runs} run(s) x {self.t_s.size} samples every {period:g} s on "
                f"{self.meta.get('trajectory', '?')}, signals (n_runs, n_log, 6): {', '.join(self.signals)}; "
                f"runs: {', '.join(runs)}>")

    def _repr_html_(self) -> str:
        """A table of the runs for notebooks."""
        import html

        head = (f"<p><b>SimResult</b>: {self.n_runs} run(s) x {self.t_s.size} samples on "
                f"{html.escape(str(self.meta.get('trajectory', '?')))}; signals {html.escape(', '.join(self.signals))}"
                "</p>")
        table = pd.DataFrame({"run_id": self.run_ids, "seed": self.seeds, "status": self.status,
                              "effects": ["; ".join(e) or "healthy" for e in self.effects], "reason": self.reason})
        return head + table.to_html(index=False)

    def __getitem__(self, name: str) -> NDArray:
        """A joint signal by name, ``(n_runs, n_log, 6)``; an unknown name (a :class:`KeyError`) lists the
        signals there are."""
        if not isinstance(name, str) or name not in self.signals:
            where = (f"SimResult[...] takes a signal name (a run's table is to_pandas({name}))" if is_integer(name)
                     else "SimResult[...]")
            raise UnknownNameError("signal", name, self.signals, where)
        return self.signals[name]

    def run_index(self, run: int | str) -> int:
        """The batch index of ``run``: a ``run_id`` or an index into the batch (negative from the end, as for a
        list); an unknown run_id lists the run ids, an index out of range says the batch's size."""
        n = self.n_runs
        if isinstance(run, str):
            if run not in self.run_ids:
                raise UnknownNameError("run_id", run, self.run_ids, "SimResult")
            return self.run_ids.index(run)
        if not is_integer(run):
            raise ParameterError(f"SimResult: run = {short(run)} must be a run_id (one of {self._ids_text()}) or an "
                                 f"index 0..{n - 1}")
        if not -n <= run < n:
            raise ParameterError(f"SimResult: run = {run} is out of range: the result holds {n} run(s), index "
                                 f"0..{n - 1} (or -{n}..-1 from the end) or a run_id ({self._ids_text()})")
        return int(run) % n

    def _ids_text(self) -> str:
        shown = ", ".join(map(repr, self.run_ids[: self.REPR_RUNS]))
        return shown + (f", ... {self.n_runs - self.REPR_RUNS} more" if self.n_runs > self.REPR_RUNS else "")

    @classmethod
    def build(cls, params: RobotParams, model_path: Path, tcp_site: int, traj: Trajectory, runs: list[RunSpec],
              a: RunArrays, t_log: NDArray,
              q_set_log: NDArray, log: dict[str, NDArray], status: list[str], reason: list[str],
              models: list[mujoco.MjModel]) -> SimResult:
        n = len(runs)
        tcp = np.full((n, t_log.size, 3), np.nan)
        tcp_des = np.empty((n, t_log.size, 3))
        site = tcp_site
        from .mjlib import site_positions, unavailable_reason

        for r, m in enumerate(models):
            d = mujoco.MjData(m)
            if not unavailable_reason():  # mj_kinematics per sample from compiled code (same calls, no Python)
                site_positions(m, d, site, q_set_log, tcp_des[r])
                site_positions(m, d, site, log["q_rad"][r], tcp[r])
                continue
            for i in range(t_log.size):
                d.qpos[:] = q_set_log[i]
                mujoco.mj_kinematics(m, d)
                tcp_des[r, i] = d.site_xpos[site]
                if np.isfinite(log["q_rad"][r, i, 0]):
                    d.qpos[:] = log["q_rad"][r, i]
                    mujoco.mj_kinematics(m, d)
                    tcp[r, i] = d.site_xpos[site]
        p = params
        meta = {
            "physics_dt_s": p.physics_dt_s,
            "servo_period_s": p.controller.servo_period_s,
            "log_period_s": float(t_log[1] - t_log[0]) if t_log.size > 1 else float(t_log[0]),
            "duration_s": float(t_log[-1]) if t_log.size else 0.0,
            "trajectory": traj.name,
            # what it was built with, defaults filled in; not its default mass: the mass that ran is payload_kg
            "trajectory_options": {k: v for k, v in traj.options if k != "payload_kg"},
            # when the gripper held the payload (the log's reader gives its twin the same schedule)
            "payload_gripped_at_start": bool(traj.payload_gripped_at_start),
            "payload_events": [[float(t), bool(g)] for t, g in traj.payload_events],
            "gear_ratio": list(p.gear.ratio),
            "motor_kind": list(p.motor.kind),
            "tcp_offset_m": list(p.tcp_offset_m),
            "payload_kg": a.payload_kg.tolist(),
            "joint_temperature_C": a.temperature_C.tolist(),
            "mujoco_version": mujoco.__version__,
            "model_path": str(model_path),
        }
        return cls(
            t_s=t_log, q_set_rad=q_set_log, signals=log, tcp_m=tcp, tcp_des_m=tcp_des,
            motor_pole_pairs=np.array(a.motor_pole_pairs), motor_is_pmsm=np.array(a.motor_is_pmsm),
            run_ids=tuple(r.run_id for r in runs), seeds=tuple(r.seed for r in runs), status=tuple(status),
            reason=tuple(reason), effects=tuple(tuple(e.describe() for e in r.effects) for r in runs), meta=meta,
        )

    # ------------------------------------------------------------------ leaving
    def to_pandas(self, run: int | str = 0) -> pd.DataFrame:
        """Wide time-series table of one run (index into the batch or its ``run_id``).

        ``df.attrs["ur5fault"]`` carries the run's metadata (:meth:`run_metadata`: run id, status, effects,
        seed, gear ratios, versions), so figures drawn from the table alone are titled right.
        """
        r = self.run_index(run)
        cols: dict[str, NDArray] = {"t_s": self.t_s}
        for j in range(N_JOINTS):
            cols[f"q_set_rad_j{j + 1}"] = self.q_set_rad[:, j]
        for name, arr in self.signals.items():
            for j in range(N_JOINTS):
                cols[f"{name}_j{j + 1}"] = arr[r, :, j]
        for j in range(N_JOINTS):
            if np.any(np.isfinite(self.phase_currents_A[r, :, j, 0])):
                for k, ph in enumerate("abc"):
                    cols[f"i_{ph}_A_j{j + 1}"] = self.phase_currents_A[r, :, j, k]
        for k, ax in enumerate("xyz"):
            cols[f"tcp_{ax}_m"] = self.tcp_m[r, :, k]
        for k, ax in enumerate("xyz"):
            cols[f"tcp_des_{ax}_m"] = self.tcp_des_m[r, :, k]
        df = pd.DataFrame(cols)
        df.attrs["ur5fault"] = self.run_metadata(r)
        return df

    def run_metadata(self, run: int | str) -> dict[str, Any]:
        """Per-run metadata written beside the time series (``run``: an index or a run_id)."""
        run = self.run_index(run)
        return {
            "run_id": self.run_ids[run], "seed": self.seeds[run], "status": self.status[run],
            "reason": self.reason[run], "effects": list(self.effects[run]), "joint_names": list(JOINT_NAMES),
            **{k: (v[run] if k in ("payload_kg", "joint_temperature_C") else v) for k, v in self.meta.items()},
        }

    def to_parquet(self, path: str | Path, run: int | str = 0) -> Path:
        """Write one run's wide table to Parquet atomically, metadata in the file's schema.

        ``path`` must end in ``.parquet`` (the readers of ur5fault, ``ur5fault show`` among them, tell a file's
        format by its suffix); anything else is refused before the run is looked up."""
        path = _out_path(path, ".parquet", "to_parquet", "to_csv")
        r = self.run_index(run)
        df = self.to_pandas(r)
        return write_parquet_atomic(df, path, {"ur5fault": json.dumps(self.run_metadata(r))})

    def to_csv(self, path: str | Path, run: int | str = 0) -> Path:
        """Write one run's wide table to CSV atomically (the metadata of :meth:`run_metadata` stays behind:
        CSV has no place for it; Parquet keeps it).

        ``path`` must end in ``.csv``: the file is plain text, never compressed (``.csv.gz`` is refused, not
        written as plain text a reader would try to decompress)."""
        path = _out_path(path, ".csv", "to_csv", "to_parquet")
        return write_csv_atomic(self.to_pandas(run), path)

    def summary(self, run: int | str = 0) -> dict[str, float | str | None]:
        """A few headline numbers of one run (for the command line); ``None`` where the run has no finite
        value (a run ended by a protective stop), so that the summary stays valid JSON."""
        import warnings

        run = self.run_index(run)

        with warnings.catch_warnings():  # an all-NaN run: numpy's "All-NaN slice" warning says nothing more
            warnings.simplefilter("ignore", RuntimeWarning)
            err = np.abs(self.q_set_rad - self.signals["q_FB_rad"][run])
            tcp_err = np.linalg.norm(self.tcp_m[run] - self.tcp_des_m[run], axis=-1)
            values = {
                "tracking_rms_deg_max_joint": float(np.degrees(np.sqrt(np.nanmean(err**2, axis=0))).max()),
                "tcp_track_max_mm": float(np.nanmax(tcp_err) * 1e3),
                "peak_current_A": float(np.nanmax(np.abs(self.signals["i_FB_A"][run]))),
                "peak_gear_torque_Nm": float(np.nanmax(np.abs(self.signals["T_gear_Nm"][run]))),
            }
        return {"duration_s": float(self.t_s[-1]), "status": self.status[run],
                **{k: v if np.isfinite(v) else None for k, v in values.items()}}


def _out_path(path: str | Path, suffix: str, method: str, other: str) -> Path:
    """``path`` as a Path, refused unless it is a str or path ending in ``suffix`` (case-insensitive)."""
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise ParameterError(f"SimResult.{method}: path = {short(path)} must be a file path ending in {suffix}")
    path = Path(path)
    if path.suffix.lower() != suffix:
        other_suffix = {".parquet": ".csv", ".csv": ".parquet"}[suffix]
        hint = f"; SimResult.{other} writes {other_suffix} files" if path.suffix.lower() == other_suffix else ""
        ends = f"ends in {path.suffix!r}" if path.suffix else "has no suffix"
        raise ParameterError(f"SimResult.{method}: path {str(path)!r} {ends}, not {suffix}: give a {suffix} file{hint}")
    return path
