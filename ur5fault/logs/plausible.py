"""Plausibility checks of a log before anything is fitted to it; each failure is one line naming
what is wrong and where.

Limits and their reasons:

- sample rate between :data:`MIN_RATE_HZ` and :data:`MAX_RATE_HZ`: UR controllers log at 125 Hz
  (CB3) or 500 Hz (e-Series); below 10 Hz the drive dynamics are invisible, above 10 kHz the
  time column is almost surely in the wrong unit (a time in milliseconds read as seconds gives
  0.125 Hz, in microseconds read as milliseconds 125 kHz);
- no more than :data:`MAX_GAP_TICKS` controller ticks missing in a row, counted in whole ticks
  (:func:`.regular.ticks`, the grid the rows are put on): the missing ticks are interpolated linearly
  for the replay (0.9 mrad of setpoint error at most over 6 ticks at the 3.2 rad/s^2 of the fastest
  real run), a longer stretch is a straight line the robot did not move. A gap counted in seconds
  against 5 median periods refused a NIST log whose clock (10578 s) left a 4-tick gap at
  5.0000000002 periods, while a Kufieta log with the same gap passed; a refused gap names the rows
  to cut the log at, as two logs of one robot (to ``diagnose``, which reads one log, the part to keep);
- at least :data:`MIN_DURATION_S` seconds and :data:`MIN_SAMPLES` samples (the discrepancy
  workflow fits on a share of the log and judges on the rest; a 3-row log once produced a
  "finding" and NaN; ``ur5fault monitor`` asks the same of the logs it judges, said as judging,
  :data:`JUDGE_LENGTH`; ``ur5fault diagnose``, which fits nothing, asks instead for one window of its
  detector, a :class:`MinLength` of its own), and at most the run length a simulation may have
  (:data:`ur5fault.sim.budget.MAX_DURATION_S`);
- exactly six joints;
- currents within the current sensor's range, :data:`CURRENT_RANGE_A` (the 14-bit ADC over +-20 A
  assumed for ``sensors.current_lsb_A`` in ``ur5_drive.yaml``): a reading beyond it is a unit mistake,
  and one that fits once divided by 1000 is named as milliamperes (a current in mA once reached the
  discrepancy report as 3300 A "unexplained");
- a current reading that changes: a recorded joint current holding one value in every row is a dead sensor or a
  column the recorder filled (a real reading's noise gives it 43..3,700 distinct values per joint in the real logs
  of data/; identify fitted an all-zero one as a Coulomb level of 0.04 A and an offset of -1.36 A);
- a current of the torque's sign, where the log has UR's target currents: on a joint whose target current is at least
  :data:`SIGN_CHECK_MIN_RMS_A` RMS, the reading's cosine with the target (uncentred, so that gravity's share counts)
  must not be :data:`SIGN_CHECK_MAX_COSINE` or below (the real logs of data/ give 0.79..1.00 on every such joint, a
  log with every current negated -0.99 and -0.94 on the shoulder and elbow; identify once wrote a negative torque
  constant and negative friction from it, which every other command refused);
- a current that carries the torque, where the log has UR's target currents: on a joint whose target current is at
  least :data:`SIGN_CHECK_MIN_RMS_A` RMS, the reading's RMS must be at least :data:`CURRENT_MIN_RMS_RATIO` of the
  target's (the real logs of data/ give 0.84..2.40 on every such joint; a channel reading noise around 0 A or 0.3 A
  gave ``monitor`` a "changed" torque constant, scale 1.89, and ``identify`` a negative friction it took for a sign
  error);
- a measured position that follows its target: no joint's ``|target - actual|`` above
  :data:`MAX_FOLLOWING_ERROR_RAD` (a UR stops itself on a far smaller following error; a reading frozen for 3 s while
  its joint moved, 0.42 rad from its target, was called "consistent" by ``monitor`` and gave ``identify`` a velocity
  feed-forward of -1.2); not for simulated logs, whose faults may carry the twin up to its own protective stop;
- joint temperatures, where logged: each joint's median within the model's range for
  ``joint_temperature_C`` (``sim.params.JOINT_TEMPERATURE_RANGE_C``, -20..120 degC), one in 253..393 named as kelvin (a
  log in kelvin once gave ``identify`` a viscous friction of 2337 N*m*s/rad, which every other command refused,
  and was silently clipped to 120 degC by the replays);
- units: where a log carries joint velocities, the time derivative of the positions (as declared,
  converted to radians) must agree with them; a factor of 180/pi = 57.3 either way is named as a
  degrees/radians mix-up, any other factor outside [0.5, 2] as a disagreement.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import LogFormatError
from ..sim.axes import JOINT_NAMES, N_JOINTS
from ..sim.budget import MAX_DURATION_S
from ..sim.params import JOINT_TEMPERATURE_RANGE_C
from . import regular

MIN_RATE_HZ = 10.0
MAX_RATE_HZ = 10_000.0
#: the most controller ticks missing in a row that are interpolated (a step of 6 ticks)
MAX_GAP_TICKS = 5
MIN_DURATION_S = 5.0
MIN_SAMPLES = 250


@dataclasses.dataclass(frozen=True)
class MinLength:
    """The least a log must cover for a command: ``duration_s`` and ``samples``, and the reason, said when a log
    is refused. ``one_log``: the command reads one log (``diagnose``), so a log with a gap it cannot use is advised
    as the part to keep (:func:`.regular.cut_in_two`), not as two logs it takes together."""

    duration_s: float
    samples: int
    why: str
    one_log: bool = False

    def covered_by(self, duration_s: float, samples: int, period_s: float) -> bool:
        """Whether ``samples`` samples spanning ``duration_s`` [s] are this long; a span short of ``duration_s`` by
        less than half a sample period counts (its samples' own periods would reach it)."""
        return duration_s + 0.5 * period_s >= self.duration_s and samples >= self.samples


def usable_length(need: str) -> MinLength:
    """The one length rule (:data:`MIN_DURATION_S`, :data:`MIN_SAMPLES`), its refusal saying what needs it
    (``need``: "fitting", "judging")."""
    return MinLength(MIN_DURATION_S, MIN_SAMPLES,
                     f"{need} needs at least {MIN_DURATION_S:g} s and {MIN_SAMPLES} samples")


#: what ``identify`` and ``discrepancy`` need of a log, and ``monitor`` of a baseline log (they fit on a share of the
#: log and judge the rest; the monitor's limits are fitted on its baseline logs)
FIT_LENGTH = usable_length("fitting")
#: what ``monitor`` needs of a log it judges (it fits nothing to it): the same rule, not said as fitting
JUDGE_LENGTH = usable_length("judging")
#: joints count as moving above this speed [rad/s] (3 deg/s, far above standstill noise) and
#: need this many moving samples for the units check
UNITS_CHECK_SPEED_RAD_S = 0.05
MIN_MOVING = 20
DEG_PER_RAD = 180.0 / math.pi
#: range of the joint current sensor [A] (assumption of ur5_drive.yaml's current_lsb_A: 14-bit ADC over +-20 A)
CURRENT_RANGE_A = 20.0
#: the sign check's joints carry at least this RMS target current [A] (the shoulder and elbow under gravity, 0.8..4.3 A
#: in the real logs; a wrist's 0..0.2 A target is too close to the reading's noise and friction to tell a sign) ...
SIGN_CHECK_MIN_RMS_A = 0.5
#: ... and a reading whose cosine with the target is this or below runs against it
SIGN_CHECK_MAX_COSINE = -0.5
#: ... and a reading whose RMS is below this share of the target's RMS carries no torque: a dead channel reading
#: noise, or a column of another quantity. Measured on the ten real logs of data/ (every joint whose target is at least
#: 0.5 A RMS, 24 joints of 10 logs): 0.84 (NIST, elbow) .. 2.40 (Movement_No1, base, 0.54 A RMS target); the shoulder
#: 0.87..1.06, the elbow 0.84..1.37; a channel of N(0, 0.01 A) noise on the shoulder gives 0.003, 0.3 A plus that
#: noise 0.07
CURRENT_MIN_RMS_RATIO = 0.2
#: the largest |target - actual| joint position a log of a running robot may show [rad]. Measured on the ten real logs
#: of data/ (every joint, every row, all ten): NIST 0.13..0.88 mrad; the Kufieta runs up to 7.34 mrad
#: (Movement_No3_Acc's elbow at 3.2 rad/s; Movement_No4_Acc 7.17), the pushed runs 7.04 mrad
#: (Movement_No5_Acc_slow_w_disturbance, the base, pushed in motion) and 0.41 mrad (Movement_No10_Standstill_WDist:
#: pushed at rest, where a CB2 logs the previous reading as its target, so a push never opens a gap there), the other
#: runs 1.38..2.28 mrad. The limit is 6.8 times the largest, half the twin's own protective stop
#: (``sim.loops.PROTECTIVE_STOP_RAD``, 0.1 rad), and an eighth of a reading frozen for 3 s while its joint moved
#: (0.42 rad)
MAX_FOLLOWING_ERROR_RAD = 0.05


def _joint(j: int) -> str:
    """Joint ``j`` (0-based) as the reader's messages name it: its number from 1 and its name (an RTDE log numbers its
    columns from 0, so "joint 2" alone was read as actual_current_2)."""
    return f"joint {j + 1} ({JOINT_NAMES[j]})"


def check_joint_count(src: str, indices: Iterable[int], first: int) -> None:
    """``indices``: the joint numbers found in the column names (counted from ``first``)."""
    found = sorted(set(indices))
    if found != list(range(first, first + N_JOINTS)):
        shown = ", ".join(str(i) for i in found[:10]) + (", ..." if len(found) > 10 else "")
        raise LogFormatError(f"{src}: {len(found)} joints in the columns ({shown}); a UR5 has exactly "
                             f"{N_JOINTS}, numbered {first}..{first + N_JOINTS - 1}")


def check_finite(src: str, arrays: Mapping[str, NDArray], columns: Mapping[str, Sequence[str]] | None = None) -> None:
    """Every value of ``arrays`` (name -> ``(n,)`` or ``(n, k)``) finite; a NaN or inf is named by its column
    (``columns``: name -> the file's column of each array column; else the name, with ``_{j}`` on a 2-D array), its
    first data row and how many rows of that column hold one."""
    for name, arr in arrays.items():
        bad = ~np.isfinite(arr)
        if not bad.any():
            continue
        row, *col = (int(i) for i in np.argwhere(bad)[0])
        j = col[0] if col else 0
        labels = (columns or {}).get(name) or ([f"{name}_{k}" for k in range(arr.shape[1])] if arr.ndim == 2
                                               else [name])
        rows = np.flatnonzero(bad[:, j] if bad.ndim == 2 else bad)
        extent = (" (every row)" if rows.size == bad.shape[0] else
                  f" ({rows.size} rows, the last data row {rows[-1] + 1})" if rows.size > 1 else "")
        raise LogFormatError(f"{src}: NaN or inf in {labels[j]} at data row {row + 1}{extent}")


def check_increasing(src: str, t: NDArray) -> None:
    dt = np.diff(t)
    if np.any(dt <= 0):
        row = int(np.argmax(dt <= 0)) + 1
        raise LogFormatError(f"{src}: time is not increasing at data row {row + 1} (t={t[row]})")


def check_sampling(src: str, t: NDArray, length: MinLength | None = None) -> None:
    """A plausible sample rate, no long gap, a usable length (``t`` increasing; ``length``: the least a log
    must cover, default :data:`FIT_LENGTH`; a log short of it by less than half a sample period passes)."""
    length = length or FIT_LENGTH
    dt = np.diff(t)
    if t.size < 2:
        raise LogFormatError(f"{src}: {t.size} sample; at least {MIN_SAMPLES} are needed")
    period = float(np.median(dt))
    rate = 1.0 / period
    if not MIN_RATE_HZ <= rate <= MAX_RATE_HZ:
        raise LogFormatError(f"{src}: sample rate {rate:.3g} Hz (median step {period:.3g}) is outside "
                             f"{MIN_RATE_HZ:g} Hz..{MAX_RATE_HZ / 1e3:g} kHz; is the time column in seconds?")
    ticks, tick = regular.ticks(t)
    k = int(np.argmax(np.diff(ticks)))
    missing = int(ticks[k + 1] - ticks[k]) - 1
    if missing > MAX_GAP_TICKS:
        raise LogFormatError(f"{src}: a gap of {dt[k]:.3g} s after t = {t[k] - t[0]:.3f} s (data row {k + 1}): "
                             f"{missing} ticks of {tick * 1e3:.3g} ms missing in a row, more than the {MAX_GAP_TICKS} "
                             f"interpolated; {regular.cut_in_two(t, k + 1, k + 2, length, 'at the gap')}")
    duration = float(t[-1] - t[0])
    if duration > MAX_DURATION_S:
        raise LogFormatError(f"{src}: {duration:.0f} s long, above the {MAX_DURATION_S:g} s one simulation may "
                             "cover; cut the log into pieces")
    if not length.covered_by(duration, t.size, period):
        raise LogFormatError(f"{src}: {duration:.3g} s and {t.size} samples; {length.why}")


def check_range(src: str, q_rad: NDArray, t: NDArray | None = None, v_rad_s: NDArray | None = None,
                declared: str = "radians") -> None:
    """Joint positions within +-360 deg (with 0.1 rad of slack); beyond, logged velocities (when
    given) tell whether the positions are degrees read as radians."""
    if np.any(np.abs(q_rad) > 2.0 * np.pi + 0.1):
        r = velocity_ratio(t, q_rad, v_rad_s) if t is not None and v_rad_s is not None and t.size > 2 else None
        if r is not None and DEG_PER_RAD / 1.5 <= r <= DEG_PER_RAD * 1.5:
            raise LogFormatError(f"{src}: positions beyond +-360 deg that change {r:.3g} times faster than the "
                                 f"logged velocities (rad/s): they look like degrees, but this layout declares "
                                 f"{declared}")
        j = int(np.argmax(np.max(np.abs(q_rad), axis=0)))
        raise LogFormatError(f"{src}: {_joint(j)} beyond +-360 deg; wrong robot or unit (degrees vs radians)")


def velocity_ratio(t: NDArray, q_rad: NDArray, v_rad_s: NDArray) -> float | None:
    """Median over moving joints of the least-squares factor between dq/dt and the logged velocity."""
    dq = np.gradient(q_rad, t, axis=0)
    ratios = []
    for j in range(q_rad.shape[1]):
        m = np.abs(v_rad_s[:, j]) > UNITS_CHECK_SPEED_RAD_S
        if m.sum() >= MIN_MOVING:
            ratios.append(float(np.sum(dq[m, j] * v_rad_s[m, j]) / np.sum(v_rad_s[m, j] ** 2)))
    return float(np.median(ratios)) if ratios else None


def check_units(src: str, t: NDArray, q_rad: NDArray, v_rad_s: NDArray | None, what: str, declared: str) -> None:
    """Positions (declared in ``declared`` units, converted to rad) against logged velocities [rad/s]."""
    if v_rad_s is None:
        return
    r = velocity_ratio(t, q_rad, v_rad_s)
    if r is None or 0.5 <= r <= 2.0:
        return
    if DEG_PER_RAD / 1.5 <= r <= DEG_PER_RAD * 1.5:
        raise LogFormatError(f"{src}: {what} change {r:.3g} times faster than the logged velocities (rad/s): "
                             f"they look like degrees, but this layout declares {declared}")
    if 1 / (1.5 * DEG_PER_RAD) <= r <= 1.5 / DEG_PER_RAD:
        raise LogFormatError(f"{src}: {what} change {1 / r:.3g} times slower than the logged velocities (rad/s): "
                             f"they look like radians, but this layout declares {declared}")
    raise LogFormatError(f"{src}: {what} and the logged velocities disagree by a factor {r:.3g} "
                         "(time derivative / velocity); check the units of both")


def check_current_units(src: str, arrays: Mapping[str, NDArray | None]) -> None:
    """Every current column within +-:data:`CURRENT_RANGE_A`; milliamperes named as such."""
    for name, a in arrays.items():
        if a is None or a.size == 0:
            continue
        peak = float(np.max(np.abs(a)))
        if peak <= CURRENT_RANGE_A:
            continue
        j = int(np.argmax(np.max(np.abs(a), axis=0))) if a.ndim == 2 else 0
        hint = ("they look like milliamperes; give the log in amperes" if peak / 1000.0 <= CURRENT_RANGE_A
                else "wrong column or unit")
        raise LogFormatError(f"{src}: {name} of {_joint(j)} reaches {peak:.4g} A, beyond the +-{CURRENT_RANGE_A:g} A "
                             f"a UR5 current sensor reads: {hint}")


def _against_target(current_A: NDArray, target_current_A: NDArray | None) -> tuple[NDArray, NDArray, list[int]] | None:
    """The reading and UR's target current ``(n, 6)`` and the joints whose target is at least
    :data:`SIGN_CHECK_MIN_RMS_A` RMS (the ones a reading can be judged against it on), or None for a log without
    target currents: what :func:`check_current_sign` and :func:`check_current_carries_torque` judge."""
    if target_current_A is None or target_current_A.size == 0:
        return None
    a, t = np.asarray(current_A, float), np.asarray(target_current_A, float)
    rms_t = np.sqrt(np.mean(t**2, axis=0))
    return a, t, [j for j in range(a.shape[1]) if rms_t[j] >= SIGN_CHECK_MIN_RMS_A]


def check_current_sign(src: str, current_A: NDArray, target_current_A: NDArray | None) -> None:
    """On every joint whose target current is at least :data:`SIGN_CHECK_MIN_RMS_A` RMS, the reading runs with the
    target (their uncentred cosine above :data:`SIGN_CHECK_MAX_COSINE`); a log without target currents is not
    checked."""
    judged = _against_target(current_A, target_current_A)
    if judged is None:
        return
    a, t, joints = judged
    cos = np.sum(a * t, axis=0) / np.maximum(np.sqrt(np.sum(a**2, axis=0) * np.sum(t**2, axis=0)), 1e-300)
    bad = [j for j in joints if cos[j] <= SIGN_CHECK_MAX_COSINE]
    if bad:
        names = ", ".join(_joint(j) for j in bad)
        got = ", ".join(f"{cos[j]:.2f}" for j in bad)
        raise LogFormatError(f"{src}: the current of {names} runs against UR's target current (cosine "
                             f"{got}): its sign convention is opposite to the torque's, as in a log with currents of "
                             "the other sign (ur5fault takes a current positive when it drives the joint positive); "
                             "negate the current columns of the other sign, as a rule every joint's (only the joints "
                             f"whose target current reaches {SIGN_CHECK_MIN_RMS_A:g} A RMS can be checked here)")


def check_current_carries_torque(src: str, current_A: NDArray, target_current_A: NDArray | None) -> None:
    """On every joint whose target current is at least :data:`SIGN_CHECK_MIN_RMS_A` RMS, the reading's RMS is at least
    :data:`CURRENT_MIN_RMS_RATIO` of the target's; a log without target currents is not checked."""
    judged = _against_target(current_A, target_current_A)
    if judged is None:
        return
    a, t, joints = judged
    rms_a, rms_t = np.sqrt(np.mean(a**2, axis=0)), np.sqrt(np.mean(t**2, axis=0))
    bad = [j for j in joints if rms_a[j] < CURRENT_MIN_RMS_RATIO * rms_t[j]]
    if bad:
        said = "; ".join(f"{_joint(j)} reads {rms_a[j]:.3g} A RMS where UR's target current is {rms_t[j]:.3g} A RMS"
                         for j in bad)
        raise LogFormatError(f"{src}: the current of {said} (below {CURRENT_MIN_RMS_RATIO:g} of it; every real log of "
                             "data/ reads 0.84 of its target or more): a dead channel or a column of another quantity, "
                             "nothing to fit")


def check_following_error(src: str, t: NDArray, target_q_rad: NDArray, actual_q_rad: NDArray) -> None:
    """No joint's measured position departs from its target by more than :data:`MAX_FOLLOWING_ERROR_RAD` (whole turns
    between the two, which a logger's wrap may leave, do not count); ``t``: the times [s] from the log's start."""
    d = np.asarray(target_q_rad, float) - np.asarray(actual_q_rad, float)
    err = np.abs((d + np.pi) % (2.0 * np.pi) - np.pi)
    peak = err.max(axis=0, initial=0.0)
    j = int(np.argmax(peak))
    if peak[j] <= MAX_FOLLOWING_ERROR_RAD:
        return
    over = np.flatnonzero(err[:, j] > MAX_FOLLOWING_ERROR_RAD)
    i = int(np.argmax(err[:, j]))
    raise LogFormatError(f"{src}: the measured position of {_joint(j)} departs from its target by up to "
                         f"{peak[j]:.3g} rad (at t = {t[i]:.2f} s; more than {MAX_FOLLOWING_ERROR_RAD:g} rad from "
                         f"t = {t[over[0]]:.2f} to {t[over[-1]]:.2f} s), far beyond what a running UR allows (it stops "
                         "itself on a much smaller following error; every real log of data/ stays within 0.008 rad): "
                         "a stuck encoder, a column the recorder filled, or a target and a reading of different joints")


def check_temperature_units(src: str, temperature_C: NDArray | None) -> None:
    """Each joint's median temperature within ``JOINT_TEMPERATURE_RANGE_C``; kelvin named as such."""
    if temperature_C is None or temperature_C.size == 0:
        return
    lo, hi = JOINT_TEMPERATURE_RANGE_C
    median = np.nanmedian(temperature_C, axis=0)
    for j, m in enumerate(median):
        if np.isnan(m) or lo <= m <= hi:  # a joint never read is the optional columns' business (regular.py)
            continue
        hint = (f"they look like kelvin ({m - 273.15:.1f} degC); give the log in degC" if 253.0 <= m <= 393.0
                else "wrong column or unit")
        raise LogFormatError(f"{src}: the temperature of {_joint(j)} has a median of {m:.4g} degC, outside the "
                             f"{lo:g}..{hi:g} degC the model takes: {hint}")


def check_enough_rows(src: str, t: NDArray, length: MinLength | None = None) -> None:
    """At least ``length.samples`` rows (default :data:`FIT_LENGTH`), before any check of what the rows hold: a log
    of two rows is refused as too short, not as a current that never changes; said as :func:`check_sampling` says a
    log too short (which then checks the length in seconds too)."""
    length = length or FIT_LENGTH
    if t.size < length.samples:
        duration = float(t[-1] - t[0]) if t.size else 0.0
        raise LogFormatError(f"{src}: {duration:.3g} s and {t.size} sample{'' if t.size == 1 else 's'}; "
                             f"{length.why}")


def check_current_alive(src: str, current_A: NDArray) -> None:
    """Each joint's recorded current takes more than one value over the log (not for simulated logs, whose
    sensor noise may be switched off)."""
    if current_A.shape[0] < 2:
        return
    for j in range(current_A.shape[1]):
        if np.all(current_A[:, j] == current_A[0, j]):
            raise LogFormatError(f"{src}: the current of {_joint(j)} reads {current_A[0, j]:g} A in every row: a "
                                 "dead sensor or a column the recorder filled, nothing to fit")
