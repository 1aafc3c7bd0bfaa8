"""The one replay of a log through the model (ur5fault/twin/replay.py): it carries the log's tool,
temperatures and payload into the model, equals the plain simulator run it stands for bit for bit, and
replays several logs of one robot each under its own conditions."""

from __future__ import annotations

import dataclasses
from concurrent.futures import Future

import numpy as np
import pytest

from ur5fault import RunSpec, Simulator
from ur5fault.errors import ParameterError
from ur5fault.logs import MeasuredLog
from ur5fault.sim.effects import make_effect
from ur5fault.sim.params import load_params
from ur5fault.twin.replay import LogReplay, log_overrides, replay_params
from ur5fault.util import parallel

PERIOD_S = 0.008  # the NIST log's 125 Hz
N = 40  # samples: 0.32 s


def _log(temperature_C: float = 30.0, payload_kg: float = 0.5, tcp=(0.0, 0.0, 0.12), motor: bool = True,
         amplitude_rad: float = 0.02) -> MeasuredLog:
    """A short log whose target swings every joint and whose 'measurement' is the target itself."""
    t = np.arange(N) * PERIOD_S
    home = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
    q = home + amplitude_rad * (1 - np.cos(2 * np.pi * t / t[-1]))[:, None] * np.linspace(0.5, 1.0, 6)
    temp = np.full((N, 6), temperature_C)
    return MeasuredLog("synthetic", t, q, q.copy(), np.zeros((N, 6)), temperature_C=temp,
                       q_motor_rad=q * 101.0 if motor else None, payload_kg=payload_kg, tcp_offset_m=tcp)


def test_log_overrides_carry_the_tool_and_clip_the_temperature():
    over = log_overrides(_log(temperature_C=150.0, tcp=(0.01, 0.02, 0.2)))
    assert over["tcp_offset_m"] == [0.01, 0.02, 0.2]
    assert over["joint_temperature_C"] == [120.0] * 6  # the parameters' upper bound
    assert log_overrides(_log(temperature_C=-40.0))["joint_temperature_C"] == [-20.0] * 6
    p = replay_params(_log(temperature_C=35.0), {"joint_temperature_C": [40.0] * 6})
    assert list(p.joint_temperature_C) == [35.0] * 6  # the log's measurement wins over the robot's model
    assert tuple(p.tcp_offset_m) == (0.0, 0.0, 0.12)
    unlogged = dataclasses.replace(_log(), temperature_C=None)
    assert list(replay_params(unlogged, {"joint_temperature_C": [40.0] * 6}).joint_temperature_C) == [40.0] * 6


def test_a_model_overlay_with_another_tool_is_refused():
    """An overlay's tcp_offset_m replaced the log's stated tool in the replay while the report named the stated
    one, and was carried into the written model.yaml. The replay now keeps the log's tool, and the workflows refuse
    the overlay where they start (a log whose tool is not stated, an unknown payload's, is not compared)."""
    from ur5fault.twin.replay import refuse_log_owned

    assert tuple(replay_params(_log(), {"tcp_offset_m": [0.0, 0.0, 0.6]}).tcp_offset_m) == (0.0, 0.0, 0.12)
    with pytest.raises(ParameterError, match=r"tcp_offset_m = \[0.0, 0.0, 0.6\] m, but synthetic's tool offset is "
                                             r"\[0.0, 0.0, 0.12\] m"):
        refuse_log_owned({"tcp_offset_m": [0.0, 0.0, 0.6]}, (), [_log()])
    refuse_log_owned({"tcp_offset_m": [0.0, 0.0, 0.12]}, (), [_log()])
    refuse_log_owned({"tcp_offset_m": [0.0, 0.0, 0.6]}, (), [dataclasses.replace(_log(), tcp_offset_m=None)])
    refuse_log_owned({}, (), [_log()])


@pytest.mark.parametrize("effect", [make_effect("payload", mass_kg=2.0), make_effect("payload_com", dz_m=0.1)],
                         ids=["payload", "payload_com"])
def test_a_model_overlay_with_a_payload_is_refused(effect):
    """A payload effect in a --model / --baseline overlay was ignored for the fit (the payload is the log's) and
    then copied into discrepancy's model.yaml, which simulate --model applied. Refused where the overlay's tool is,
    for every workflow that replays logs under an overlay: discrepancy, monitor (observe) and diagnose
    (replay_twin, checked here; the other two from the command line in tests/test_user_refusals.py)."""
    from ur5fault.health.diagnosis import replay_twin
    from ur5fault.twin.replay import refuse_log_owned

    message = (rf"the model overlay holds a {effect.name} effect, but the payload is the log's \(--payload-kg and "
               r"--tcp-offset-m, a manifest's payload_kg, or the log's layout; fitted where unknown\), not the "
               r"robot's model; leave it out of the overlay")
    with pytest.raises(ParameterError, match=message):
        refuse_log_owned({}, (effect,), [_log()])
    with pytest.raises(ParameterError, match=message):
        replay_twin(_log(), None, (effect,))
    refuse_log_owned({}, (make_effect("coulomb_friction", 2, scale=1.5),), [_log()])  # a robot's effect: kept


def test_replay_equals_the_plain_simulator_run():
    """The obvious way (parameters by hand, Simulator.run) against the replay, bit for bit."""
    log = _log()
    eff = (make_effect("coulomb_friction", 2, scale=1.5),)
    over = {"tcp_offset_m": [0.0, 0.0, 0.12], "joint_temperature_C": [30.0] * 6}
    res = Simulator(load_params(overrides=over)).run(log.to_trajectory(), [RunSpec("x", 7, eff)],
                                                     log_period_s=PERIOD_S)
    sim = LogReplay(log, seed=7).run([eff])[0]
    assert sim.ok and sim.y.shape == (N - 1, 3, 6)
    np.testing.assert_array_equal(sim.current_A, res["i_FB_A"][0])
    np.testing.assert_array_equal(sim.position_rad, res["q_FB_rad"][0])
    np.testing.assert_array_equal(sim.y[:, 2], res["q_M_FB_rad"][0] / 101.0 - res["q_FB_rad"][0])
    np.testing.assert_array_equal(sim.torque_gear_Nm, res["T_gear_Nm"][0])


def test_signals_follow_the_log_and_bad_lengths_are_refused():
    rp = LogReplay(_log(motor=False), seed=1)
    assert rp.signals == ("current_A", "position_rad")
    assert rp.measured().shape == (N - 1, 2, 6)
    assert rp.measured(5).shape == (5, 2, 6)
    with pytest.raises(ParameterError, match="cannot replay 40 samples; the log has 39"):
        rp.run([()], N)


def test_several_logs_each_under_its_own_conditions():
    """Two logs of one robot with different payloads: each log's own payload reaches the model (the heavier
    one needs more shoulder current)."""
    light, heavy = _log(payload_kg=0.0), _log(payload_kg=3.0, temperature_C=40.0)
    both = [LogReplay(g, seed=3).run([()])[0] for g in (light, heavy)]
    shoulder = [float(np.mean(np.abs(b.current_A[:, 1]))) for b in both]
    assert shoulder[1] > shoulder[0] + 0.1, shoulder


def test_a_batch_split_over_processes_equals_one_process():
    """``jobs=2``: a share of the batch in this process, the rest in a worker; the same replays bit for bit."""
    log = _log()
    sets = [(), (make_effect("coulomb_friction", 2, scale=1.5),), (make_effect("backlash", 3, backlash_deg=0.1),)]
    one = LogReplay(log, seed=7).run(sets)
    two = LogReplay(log, seed=7, jobs=2).run(sets)
    for a, b in zip(one, two):
        assert a.status == b.status
        np.testing.assert_array_equal(a.y, b.y)
        np.testing.assert_array_equal(a.torque_gear_Nm, b.torque_gear_Nm)


def _equal(a, b) -> None:
    assert a.status == b.status
    for name in ("y", "q_rad", "q_motor_rad", "current_true_A", "torque_gear_Nm"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


@pytest.mark.parametrize("jobs", [1, 2])
def test_batches_of_different_lengths_at_once_equal_each_batch_alone(jobs):
    """``run_batches``: the runs of several batches spread over the processes together (longest first, the split
    decided as they go) give each batch's own replays, bit for bit."""
    log = _log()
    sets = [(), (make_effect("coulomb_friction", 2, scale=1.5),), (make_effect("backlash", 3, backlash_deg=0.1),)]
    alone = [LogReplay(log, seed=7).run(sets, N - 1), LogReplay(log, seed=7).run(sets[1:], 12)]
    rp = LogReplay(log, seed=7, jobs=jobs)
    together = rp.run_batches([(sets, N - 1), (sets[1:], 12)])
    for want, got in zip(alone, together):
        assert len(want) == len(got)
        for a, b in zip(want, got):
            _equal(a, b)
    assert rp.n_simulated == 5 and rp.simulated_s == pytest.approx((3 * (N - 1) + 2 * 12) * PERIOD_S)


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_prefetched_replay_equals_the_replay_it_stands_for(jobs):
    """``prefetch``: a replay started early (on a worker with ``jobs=2``) and taken by a later run, whole or its
    first samples, equals that run simulated there and then; it is simulated once."""
    log = _log()
    eff = (make_effect("coulomb_friction", 2, scale=1.5),)
    plain = LogReplay(log, seed=7).run([(), eff], N - 1)
    rp = LogReplay(log, seed=7, jobs=jobs)
    rp.prefetch([()], N - 1)
    got = rp.run([(), eff], N - 1)
    for a, b in zip(plain, got):
        _equal(a, b)
    _equal(LogReplay(log, seed=7).run([()], 10)[0], rp.run([()], 10)[0])  # a shorter run: the first samples
    simulated = 3 if jobs == 1 else 2  # one job: nothing was started early, both runs of () are simulated
    assert rp.n_simulated == simulated


def _held_as_if_prefetched(rp: LogReplay, effects: tuple, r) -> None:
    """``r`` held by ``rp`` as :meth:`LogReplay.prefetch` holds it: a finished worker's future."""
    fut: Future = Future()
    fut.set_result([r])
    rp._held[rp._key(effects)] = (r.y.shape[0], fut)


def test_a_prefetched_run_that_is_not_ok_does_not_stand_for_a_shorter_run():
    """A whole-log run that diverged after sample 20 held (as with ``jobs=2``): the 10-sample run is ok there, so a
    run of 10 samples is simulated and equals the plain one, status included -- what ``jobs=1`` gives; a run as long
    as the held one is the held one, diverged; an ok held run gives its first samples without simulating."""
    log = _log()
    whole = LogReplay(log, seed=7).run([()], N - 1)[0]
    y = whole.y.copy()
    y[20:] = np.nan  # what a run stopped at its divergence logs
    diverged = dataclasses.replace(whole, status="diverged", y=y)
    rp = LogReplay(log, seed=7, jobs=2)
    _held_as_if_prefetched(rp, (), diverged)
    _equal(rp.run([()], 10)[0], LogReplay(log, seed=7).run([()], 10)[0])
    assert rp.n_simulated == 1
    got = rp.run([()], N - 1)[0]
    assert got.status == "diverged" and rp.n_simulated == 1
    np.testing.assert_array_equal(got.y, y)
    ok = LogReplay(log, seed=7, jobs=2)
    _held_as_if_prefetched(ok, (), whole)
    _equal(ok.run([()], 10)[0], LogReplay(log, seed=7).run([()], 10)[0])
    assert ok.n_simulated == 0


def test_close_drops_the_prefetched_runs_and_stops_a_worker_still_on_one(monkeypatch):
    stopped: list[int] = []
    monkeypatch.setattr(parallel, "stop_workers", stopped.append)
    log = _log()
    rp = LogReplay(log, seed=7, jobs=2)
    _held_as_if_prefetched(rp, (), LogReplay(log, seed=7).run([()], N - 1)[0])
    rp.close()  # a finished one: nothing runs, nothing is stopped
    assert not rp.holds((), 1) and stopped == []
    rp._held[rp._key(())] = (N - 1, Future())  # a worker still on it
    rp.close()
    assert not rp.holds((), 1) and stopped == [2]
    assert rp.run([()], 10)[0].ok  # and later runs simulate what they need


def test_the_parameters_of_a_log_whose_tool_is_unknown_are_refused_in_one_line():
    """MeasuredLog's payload and tool default to unknown (None): replay_params and log_overrides raised a bare
    TypeError on such a log; they now say what to give."""
    import dataclasses

    from ur5fault.twin.replay import log_overrides, replay_params

    unknown = dataclasses.replace(_log(), payload_kg=None, tcp_offset_m=None)
    for call in (log_overrides, replay_params):
        with pytest.raises(ParameterError, match="payload and tool offset"):
            call(unknown)


def test_a_failed_replay_says_what_its_status_means():
    """`monitor` with a payload its drives could not carry said only "the replay under the baseline model failed
    (protective_stop)": a failed replay's one line now says what stopped it and what to check."""
    from ur5fault.sim.loops import PROTECTIVE_STOP_RAD
    from ur5fault.twin.replay import Replayed

    z = np.zeros((2, 2, 6))
    q = np.zeros((2, 6))

    def replayed(status):
        return Replayed(status, z, q, q, q, q)

    assert replayed("ok").failure == ""
    stop = replayed("protective_stop").failure
    assert stop.startswith(f"protective stop: the simulated arm fell more than {PROTECTIVE_STOP_RAD:g} rad behind the "
                           "log's targets") and "--payload-kg" in stop
    assert replayed("diverged").failure.startswith("diverged: the simulation ran away")


def test_a_log_stated_at_0_kg_carries_a_payload_effect():
    """A log stated at 0 kg held nothing (the grip followed the stated mass), so the discrepancy library's payload
    and payload_com candidates replayed exactly as the baseline on every 0 kg log: a tool the statement left out
    could not be named a payload, only a link mass. Now the grip is the log's (throughout, or its own schedule),
    the mass the replay's: the 0 kg replay is the same as with no grip, and a payload effect changes the
    shoulder_lift current by what a 1 kg mass on the flange weighs."""
    from ur5fault.sim.trajectories.base import Trajectory

    log = _log(payload_kg=0.0)
    traj = log.to_trajectory()
    assert traj.payload_gripped_at_start and traj.payload_events == ()
    over = {"tcp_offset_m": [0.0, 0.0, 0.12], "joint_temperature_C": [30.0] * 6}
    not_held = Trajectory(traj.name, traj.setpoint_period_s, traj.q_set_rad, (), False, 0.0)
    plain = Simulator(load_params(overrides=over)).run(not_held, [RunSpec("x", 7)], log_period_s=PERIOD_S)
    rp = LogReplay(log, seed=7)
    bare, heavy = rp.run([(), (make_effect("payload", mass_kg=1.0),)])
    np.testing.assert_array_equal(bare.current_A, plain["i_FB_A"][0])
    # 1 kg at about 0.5 m from the shoulder_lift axis (home pose, arm out): ~4.9 N·m of gravity at the joint,
    # ~0.36 A of motor current at the model's 0.135 N·m/A x 101
    dI = np.abs(np.mean(heavy.current_A[:, 1] - bare.current_A[:, 1]))
    assert 0.2 < dI < 0.6, dI
