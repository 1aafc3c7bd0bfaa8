"""A CB2 log's rest stretches at the pose the controller holds (``bench/cb2_rest_target.py``'s ``held_pose``,
which ``bench/bench_monitor.py --held-pose`` replays: docs/monitoring.md, "The CB2's held pose")."""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from ur5fault.logs import MeasuredLog, read_nist, read_rtde

from conftest import KUFIETA_DIR, NIST_LOG, REPO

sys.path.insert(0, str(REPO / "bench"))
from cb2_rest_target import held_pose, reading_rows  # noqa: E402


def _cb2_like(n=40, logged=None) -> MeasuredLog:
    """A move to pose P (rows 0..9), then rest: row 10 carries P, every later row the previous reading; the arm
    is pushed off P at rows 20..29 and comes back."""
    rng = np.random.default_rng(1)
    t = np.arange(n) * 0.008
    P = np.full(6, 0.5)
    target = np.vstack([np.linspace(0.0, 0.5, 11)[:, None] * np.ones(6)] + [np.zeros((n - 11, 6))])
    actual = target + 1e-4 * rng.standard_normal((n, 6))
    actual[11:] = P + 2e-6 * rng.integers(-2, 3, (n - 11, 6))
    actual[20:30, 0] += 4e-4 * np.sin(np.linspace(0, np.pi, 10))  # the push
    target[11:] = actual[10:-1]  # the CB2's logged target: the previous reading
    return MeasuredLog(source="cb2", t_s=t, q_target_rad=target, q_actual_rad=actual, current_A=np.zeros((n, 6)),
                       logged=logged)


def test_the_rest_is_held_at_the_commanded_pose_and_the_move_untouched():
    log = _cb2_like()
    held, n = held_pose(log)
    assert n == 29  # rows 11..39 (row 10 already carries P)
    np.testing.assert_array_equal(held.q_target_rad[:11], log.q_target_rad[:11])
    np.testing.assert_array_equal(held.q_target_rad[10:], np.full((30, 6), 0.5))
    np.testing.assert_array_equal(log.q_target_rad[11:], log.q_actual_rad[10:-1])  # the input is not changed


def test_ticks_the_reader_filled_in_take_the_held_pose():
    logged = np.ones(40, dtype=bool)
    logged[25:27] = False  # a recorder dropped two rows; the reader interpolated them from their neighbours
    log = _cb2_like(logged=logged)
    q = np.array(log.q_target_rad)
    q[25:27] = np.linspace(q[24], q[27], 4)[1:3]
    q[27] = log.q_actual_rad[24]  # the robot's row after the gap: the reading of the last row it wrote
    log = dataclasses.replace(log, q_target_rad=q)
    assert reading_rows(log)[27] and not reading_rows(log)[25:27].any()
    held, _ = held_pose(log)
    np.testing.assert_array_equal(held.q_target_rad[10:], np.full((30, 6), 0.5))


def test_a_log_without_reading_rows_is_returned_as_is():
    nist = read_nist(NIST_LOG)
    held, n = held_pose(nist)
    assert n == 0 and held is nist


def test_the_standstill_run_is_held_where_the_robot_returns_after_each_push():
    """The real CB2 standstill run: one held pose (its first row's) for the whole run, and the arm's reading
    returns to it after the pushes - checked against the readings, which the held pose is not made from."""
    log = read_rtde(KUFIETA_DIR / "Movement_No10_Standstill_WDist.csv.gz", payload_kg=0.0, tcp_offset_m=(0, 0, 0))
    held, n = held_pose(log)
    assert n > 0.8 * log.t_s.size
    np.testing.assert_array_equal(held.q_target_rad, np.broadcast_to(log.q_target_rad[0], held.q_target_rad.shape))
    t = log.t_s - log.t_s[0]
    deflection = np.abs(log.q_actual_rad[:, 0] - held.q_target_rad[:, 0])
    assert deflection[(t > 6.5) & (t < 7.0)].max() > 1e-4  # shoulder_pan pushed off the pose (0.15 mrad)
    assert deflection[t > 12.0].max() <= 1.1e-5  # and back within a quantum or two after the last push
