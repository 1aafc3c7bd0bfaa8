"""Push labels of the Kufieta robot's pushed runs, from signals ``ur5fault monitor`` does not judge by.

*Moving run* (:data:`PUSHED`): from UR's own current model (``actual - target_current``), which knows nothing of
ur5fault's: smoothed like the monitor's residual (0.1 s), its deviation from its median; a push is a stretch of
at least :data:`MIN_PUSH_S` where that deviation exceeds the largest one of the paired undisturbed run
:data:`QUIET` (whole run, deviation from its median); stretches closer than MERGE_S joined.

*Standstill run* (:data:`STANDSTILL`), two labellings:

* ``labels`` as for the moving run, the reference being :data:`QUIET`'s standing start (before its target
  first moves) - the earlier labelling, kept for comparison. Wrong as windows: after each push the arm holds at
  a new current (the position controller settles at another holding torque), and a deviation from the run's
  median marks those holding levels as pushes, merging several pushes into one 4 s label.
* ``accel_labels``, the one used: from the tool accelerometer (``tool_accelerometer_0..2``, a sensor the monitor
  never reads): a push is a stretch of at least :data:`MIN_PUSH_S` where the accelerometer's rate of change
  (smoothed 0.1 s) exceeds its largest value in the run's first :data:`UNTOUCHED_S`; stretches closer than
  MERGE_S joined. Its joints are those whose UR residual leaves its level of the :data:`PRE_PUSH_S` before the
  push by more than the largest deviation of :data:`QUIET`'s standing start from its median. The rule was fixed
  before the monitor's events on the run were looked at. (A first version took the accelerometer's deviation
  from its median against :data:`QUIET`'s standing start: that reference holds one constant reading, and the
  standstill's resting level moves by 1-4 steps of 25 counts after each push, so it marked the whole run.)

*Moving run, second labelling* (``cycle_labels``): ``labels`` and the monitor now share the reference run
(:data:`QUIET`: the monitor judges the pushed run against the quiet run's ur5fault residual at the same point of
the task; ``labels`` takes its bar from the quiet run's UR residual, not aligned in time). This one shares no
reference in time with the monitor: UR's residual of the pushed run against the median of *the same run's*
other repeats of its cycle at the same point (the cycle's period found on the run's own targets, by the lag
under :data:`MAX_PERIOD_S` at which they repeat best; a repeat counts where the targets agree within
:data:`CYCLE_TOL_RAD`; a push in one cycle is outvoted by the others). A push is a stretch of at least
:data:`MIN_PUSH_S` where that deviation exceeds its largest value on :data:`QUIET` computed the same way (the
quiet run against its own repeats: the recording is shared, as a bar on UR's model, not as a reference). The
tool accelerometer was checked for this and does not separate pushes in motion: axis 1 oscillates by about 1000
counts within every move of both runs, axis 0 steps once (at the largest push) and axis 2 reads 0 throughout.

A label is *found* when an event on one of its joints starts and ends within :data:`WINDOW_S` of it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
KUFIETA = REPO / "data" / "kufieta-ur5"
QUIET, PUSHED, STANDSTILL = ("Movement_No5_Acc_slow_no_disturbance", "Movement_No5_Acc_slow_w_disturbance",
                             "Movement_No10_Standstill_WDist")
WINDOW_S = 0.5
#: a push by hand lasts at least this long [s] (the monitor's smoothing assumes the same, events.SMOOTH_S)
MIN_PUSH_S = 0.2
#: a target this far from its start has begun to move [rad] (the CB2 targets jitter by up to 3e-4 rad at rest)
START_MOVE_RAD = 1e-3
#: the tool accelerometer's columns
ACCEL = [f"tool_accelerometer_{i}" for i in range(3)]
#: the UR residual's level before a push is its median over this long before the push starts [s]
PRE_PUSH_S = 0.25
#: the standstill run's first seconds, before anyone touched the arm [s] (its accelerometer holds one level, up
#: to one step of 25 counts, until 3.0 s; UR's residual moves first at 3.2 s)
UNTOUCHED_S = 1.0
#: a cyclic run's period is looked for up to this [s] (the Kufieta No5 runs repeat every 5.98 s)
MAX_PERIOD_S = 10.0
#: two samples are the same point of the cycle when their targets agree within this [rad] (the controller's
#: jitter, 3e-4, plus a sample at the runs' largest speed, 1.05 rad/s x 8 ms)
CYCLE_TOL_RAD = 3e-4 + 1.05 * 0.008


def read(name: str):
    from ur5fault.logs import read_rtde

    return read_rtde(KUFIETA / f"{name}.csv.gz", payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))


def ur_smoothed(log):
    from ur5fault.health.monitoring.events import smooth

    return smooth((log.current_A - log.target_current_A)[1:], log.period_s)


def standing_start(log) -> np.ndarray:
    """``(n - 1,)``: the samples before the log's target first leaves its start by :data:`START_MOVE_RAD`."""
    away = np.abs(log.q_target_rad - log.q_target_rad[0]).max(axis=1)[1:] > START_MOVE_RAD
    return np.arange(away.size) < int(np.argmax(away))


def stretches(over: np.ndarray, t: np.ndarray, period_s: float) -> list[tuple[int, int]]:
    """``[(first, last)]`` row ranges where ``over`` ``(n,)`` holds, rows closer than MERGE_S joined, at least
    :data:`MIN_PUSH_S` long."""
    from ur5fault.health.monitoring.events import MERGE_S

    rows = np.flatnonzero(over)
    out, gap = [], int(round(MERGE_S / period_s))
    for k, row in enumerate(rows):
        if not out or row - rows[k - 1] > gap:
            out.append([row, row])
        out[-1][1] = row
    return [(a, b) for a, b in out if t[b] - t[a] >= MIN_PUSH_S]


def labels(log, ref: np.ndarray) -> list[dict]:
    """Push labels of ``log`` from UR's residual (module docstring): ``ref`` the smoothed UR residual of the
    undisturbed reference."""
    from ur5fault.sim.axes import JOINT_NAMES

    limit = np.abs(ref - np.median(ref, axis=0)).max(axis=0)
    r = ur_smoothed(log)
    level = np.median(r, axis=0)
    over = np.abs(r - level) > limit
    t = log.t_s[1:] - log.t_s[0]
    return [{"t_start_s": float(t[a]), "t_end_s": float(t[b]),
             "joints": [JOINT_NAMES[j] for j in range(6) if over[a : b + 1, j].any()]}
            for a, b in stretches(over.any(axis=1), t, log.period_s)]


def accel_activity(name: str) -> tuple[np.ndarray, np.ndarray]:
    """Log time ``(n - 1,)`` [s] and the tool accelerometer's rate of change ``(n - 1,)`` (the norm over its three
    axes of the change from one sample to the next, a missing reading: no change), smoothed like the monitor's
    residual. The monitor never reads the accelerometer."""
    import pandas as pd

    from ur5fault.health.monitoring.events import smooth

    log = read(name)
    acc = pd.read_csv(KUFIETA / f"{name}.csv.gz", usecols=ACCEL)[ACCEL].to_numpy(float)[: log.t_s.size]
    rate = np.linalg.norm(np.nan_to_num(np.diff(acc, axis=0), nan=0.0), axis=1) / log.period_s
    return log.t_s[1:] - log.t_s[0], smooth(rate[:, None], log.period_s)[:, 0]


def accel_labels(name: str) -> list[dict]:
    """Push labels of a run that stands still throughout, from the tool accelerometer (module docstring): a push
    is a stretch of at least :data:`MIN_PUSH_S` where its rate of change exceeds the largest one of the run's
    first :data:`UNTOUCHED_S` (stretches closer than MERGE_S joined); its joints are those whose UR residual
    leaves its level of the :data:`PRE_PUSH_S` before the push by more than the largest deviation of the
    undisturbed :data:`QUIET` run's standing start from its median (so a holding level the arm settles at
    after one push is the next push's starting level, not a push)."""
    from ur5fault.sim.axes import JOINT_NAMES

    quiet = read(QUIET)
    ref = ur_smoothed(quiet)[standing_start(quiet)]
    ur_limit = np.abs(ref - np.median(ref, axis=0)).max(axis=0)
    log = read(name)
    t, a = accel_activity(name)
    limit = a[t < UNTOUCHED_S].max()
    r = ur_smoothed(log)
    pre = int(round(PRE_PUSH_S / log.period_s))
    out = []
    for first, last in stretches(a > limit, t, log.period_s):
        level = np.median(r[max(0, first - pre) : max(1, first)], axis=0)
        dev = np.abs(r[first : last + 1] - level) > ur_limit
        out.append({"t_start_s": float(t[first]), "t_end_s": float(t[last]),
                    "joints": [JOINT_NAMES[j] for j in range(6) if dev[:, j].any()]})
    return out


def found(label: dict, events: list[dict]) -> bool:
    return any(abs(e["t_start_s"] - label["t_start_s"]) <= WINDOW_S and abs(e["t_end_s"] - label["t_end_s"]) <= WINDOW_S
               and set(e["joints"]) & set(label["joints"]) for e in events)


def cycle_period(q: np.ndarray, period_s: float) -> int:
    """The lag [samples] at which the targets ``q`` ``(n, 6)`` repeat best (mean absolute difference over the
    overlap), between 1 s and :data:`MAX_PERIOD_S`."""
    lags = range(int(1.0 / period_s), min(int(MAX_PERIOD_S / period_s), q.shape[0] // 2))
    return min(lags, key=lambda k: float(np.abs(q[k:] - q[:-k]).mean()))


def own_cycle_deviation(log) -> np.ndarray:
    """``(n - 1, 6)``: UR's smoothed residual less the median of the same run's other repeats of the point of its
    cycle (NaN where no other repeat matches)."""
    r = ur_smoothed(log)
    q = log.q_target_rad[1:]
    per = cycle_period(q, log.period_s)
    n = r.shape[0]
    out = np.full(r.shape, np.nan)
    for i in range(n):
        others = [i + k * per for k in range(-n // per - 1, n // per + 2) if k and 0 <= i + k * per < n]
        others = [j for j in others if np.abs(q[j] - q[i]).max() <= CYCLE_TOL_RAD]
        if others:
            out[i] = r[i] - np.median(r[others], axis=0)
    return out


def cycle_labels(log, quiet) -> list[dict]:
    """Push labels of a cyclic run from UR's residual against its own other cycles (module docstring)."""
    from ur5fault.sim.axes import JOINT_NAMES

    limit = np.nanmax(np.abs(own_cycle_deviation(quiet)), axis=0)
    dev = np.abs(own_cycle_deviation(log))
    over = np.nan_to_num(dev, nan=0.0) > limit
    t = log.t_s[1:] - log.t_s[0]
    return [{"t_start_s": float(t[a]), "t_end_s": float(t[b]),
             "joints": [JOINT_NAMES[j] for j in range(6) if over[a : b + 1, j].any()]}
            for a, b in stretches(over.any(axis=1), t, log.period_s)]
