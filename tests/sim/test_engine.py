"""The batched engine: determinism, batch = singles, fast = simple path, consistent start."""

import mujoco
import numpy as np
import pytest

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.errors import ParameterError
from ur5fault.sim.multibody import LoopMultibody
from ur5fault.sim.trajectories import hold

DUR = 1.0
HOLD = hold(seconds=0.1)
SIM = Simulator()


@pytest.fixture(scope="module")
def runs():
    return [
        RunSpec("healthy", 3),
        RunSpec("bl_shoulder", 3, (make_effect("backlash", "shoulder_lift_joint", backlash_deg=0.1),)),
        RunSpec("bl_wrist", 5, (make_effect("backlash", "wrist_1_joint", backlash_deg=0.2),)),
        RunSpec("friction", 9, (make_effect("coulomb_friction", "elbow_joint", scale=1.5),
                                make_effect("temperature", temperature_C=40.0))),
    ]


@pytest.fixture(scope="module")
def batch(runs):
    return Simulator().run(pick_and_place(), runs, duration_s=DUR)


def _same(a, b, i, j):
    for k in a.signals:
        np.testing.assert_array_equal(a[k][i], b[k][j], err_msg=k)
    np.testing.assert_array_equal(a.tcp_m[i], b.tcp_m[j])


def test_same_seed_bit_identical(runs, batch):
    again = Simulator().run(pick_and_place(), runs, duration_s=DUR)
    for i in range(len(runs)):
        _same(batch, again, i, i)


def test_batch_equals_single_runs_bit_for_bit(runs, batch):
    sim = Simulator()
    for i, r in enumerate(runs):
        _same(batch, sim.run(pick_and_place(), [r], duration_s=DUR), i, 0)


def test_fast_batch_stepper_equals_simple_loop_bit_for_bit(runs, batch):
    loop = Simulator(stepper="loop").run(pick_and_place(), runs, duration_s=DUR)
    for i in range(len(runs)):
        _same(batch, loop, i, i)


def test_fast_path_equals_simple_one_run_path_bit_for_bit(runs, batch):
    """Fast: compiled kernel over a lockstep batch on MuJoCo's threaded batch stepper.
    Simple: one run at a time through a plain mj_step loop."""
    simple = Simulator(stepper="loop", nthread=1)
    for i, r in enumerate(runs):
        _same(batch, simple.run(pick_and_place(), [r], duration_s=DUR), i, 0)


def test_numpy_reference_drive_batch_equals_singles(runs):
    sim = Simulator(drive="numpy")
    b = sim.run(pick_and_place(), runs[:2], duration_s=0.3)
    for i, r in enumerate(runs[:2]):
        _same(b, sim.run(pick_and_place(), [r], duration_s=0.3), i, 0)


def test_two_threads_equal_one(runs, batch):
    two = Simulator(nthread=2).run(pick_and_place(), runs, duration_s=DUR)
    for i in range(len(runs)):
        _same(batch, two, i, i)


def test_different_seed_differs_only_by_noise(batch):
    other = Simulator().run(pick_and_place(), [RunSpec("healthy", 4)], duration_s=DUR)
    d = other["i_FB_A"][0] - batch["i_FB_A"][0]
    assert np.any(d != 0)
    assert np.abs(d).max() < 0.5  # same physics, different noise


def test_runs_differ_where_faults_are(batch):
    # the elbow friction run draws more elbow current than its... (different seed) healthy twin
    i_f, i_h = batch["i_FB_A"][3, :, 2], batch["i_FB_A"][0, :, 2]
    assert np.max(np.abs(i_f - i_h)) > 0.05


def test_backlash_invisible_while_load_keeps_its_sign(batch):
    # eq. (1): under a negative gravity load the teeth rest on the theta = 0 flank, exactly as
    # without clearance, so until the shoulder torque first reverses the two runs are identical
    torque = batch["T_gear_Nm"][0, :, 1]
    assert np.all(torque < 0)  # the first second keeps the sign
    np.testing.assert_array_equal(batch["q_rad"][1], batch["q_rad"][0])


def test_start_is_at_rest_in_equilibrium():
    """Holding still, the consistent initial state needs no transient: currents stay at the
    gravity-holding value and the joints do not move."""
    res = Simulator().run(hold(seconds=0.5, payload_kg=2.0), [RunSpec("h", 0)])
    q = res["q_rad"][0]
    assert np.max(np.abs(q - q[0])) < 2e-5
    i = res["i_q_A"][0]
    first, last = i[:50].mean(axis=0), i[-50:].mean(axis=0)  # 50 ms means
    np.testing.assert_allclose(first, last, atol=0.03)
    assert abs(last[1]) > 1.0  # the shoulder really holds the arm and payload against gravity


def test_a_run_payload_is_carried_by_a_hold_at_its_default_0_kg():
    """hold's default payload is 0 kg; a run's payload effect (simulate --payload-kg, a campaign's payload_kg) gives
    the mass, and the gripper holds it from the start (it was dropped: 0 and 5 kg gave identical runs)."""
    res = Simulator().run(hold(seconds=0.1), [RunSpec(f"{kg}", 0, (make_effect("payload", mass_kg=kg),))
                                              for kg in (0.0, 5.0)], duration_s=0.02)
    i = np.abs(res["i_q_A"][:, :, 1]).mean(axis=1)  # the shoulder's holding current
    assert i[1] > i[0] + 0.5


def test_resolver_offset_starts_held_not_as_a_step():
    """A resolver offset o has been in the reading since the robot was switched on: at rest the position loop
    holds the reading on the setpoint, so the true link sits at setpoint - o from the first sample, and the
    reading shows no step (starting the link at the setpoint made every such run move the link by -o at t = 0,
    a transient at rest that a real log never shows and that the benchmark read as the fault's signature)."""
    o_deg = 0.5
    res = Simulator().run(hold(seconds=0.3, payload_kg=2.0), [
        RunSpec("h", 0), RunSpec("o", 0, (make_effect("resolver_offset", "shoulder_lift_joint", offset_deg=o_deg),))])
    q_true, q_fb = res["q_rad"], res["q_FB_rad"]
    # the link is held o below the setpoint from the first sample to the last (within 1 % of o)
    np.testing.assert_allclose(q_true[1, :, 1] - q_true[0, :, 1], -np.radians(o_deg), atol=0.01 * np.radians(o_deg))
    # the reading equals the healthy robot's (same noise seed) up to the resolver's quantisation: no transient
    assert np.max(np.abs(q_fb[1, :, 1] - q_fb[0, :, 1])) < 0.02 * np.radians(o_deg)


def test_payload_and_its_centre_of_mass_match_independent_dynamics():
    """Gravity torques with a 2 kg payload whose CoM is moved 0.1 m along the tool axis equal the
    independent Newton-Euler reference (tests/reference_ur5.py)."""
    from ur5fault.sim.run_arrays import build_run_arrays

    from reference_ur5 import rnea

    sim = Simulator(stepper="loop")
    a = build_run_arrays(sim.params, [(make_effect("payload_com", dz_m=0.1),)], 2.0)
    mb = sim._multibody(a)
    mb.set_payload(a.payload_kg)
    q = np.array([[0.3, -1.2, 1.0, -1.4, -1.5, 0.2]])
    bias = mb.start(q)
    inertia = np.diag(np.full(3, 2.0 * 0.06**2 / 6.0))
    ref = rnea(q[0], np.zeros(6), np.zeros(6), payload_mass_kg=2.0, payload_pos_flange_m=np.array([0, 0, 0.25]),
               payload_inertia_flange_kgm2=inertia)
    np.testing.assert_allclose(bias[0], ref, atol=1e-9)


def test_mass_diagonal_index_matches_full_matrix():
    sim = Simulator()
    mb = LoopMultibody(sim.model, 1, np.array([0.0, 0.0, 0.15]), np.zeros((1, 3)))
    mb.start(np.array([[0.3, -1.2, 1.0, -1.4, -1.5, 0.2]]))
    full = np.zeros((6, 6))
    mujoco.mj_fullM(mb.models[0], mb.datas[0], full)
    np.testing.assert_array_equal(mb.mass_diagonal()[0], np.diag(full))


def test_signal_shapes_batch_axis_first(batch, runs):
    n_log = round(DUR / 1e-3)
    for k in batch.signals:
        assert batch[k].shape == (len(runs), n_log, 6)
    assert batch.tcp_m.shape == (len(runs), n_log, 3)
    assert batch.phase_currents_A.shape == (len(runs), n_log, 6, 3)
    assert np.all(np.isnan(batch.phase_currents_A[:, :, 0])) and np.all(np.isfinite(batch.phase_currents_A[:, :, 1]))


def test_bad_arguments(tmp_path):
    sim = Simulator()
    with pytest.raises(ParameterError, match="whole multiple"):
        sim.run(pick_and_place(), [RunSpec("a")], log_period_s=1.3e-4)
    with pytest.raises(ParameterError, match="at least one"):
        sim.run(pick_and_place(), [])
    # refused before any step: two runs of one id (the result finds runs by id), a seed that is no seed
    with pytest.raises(ParameterError, match=r"^runs\[1\]: run_id 'a' is given twice; give each run its own run_id$"):
        sim.run(pick_and_place(), [RunSpec("a", seed=0), RunSpec("a", seed=1)], duration_s=0.01)
    with pytest.raises(ParameterError, match=r"^RunSpec .a.: seed = -1 must be an integer in \[0, 9223372036854"):
        sim.run(pick_and_place(), [RunSpec("a", seed=-1)], duration_s=0.01)
    with pytest.raises(ParameterError, match="seed = 0.5"):
        sim.run(pick_and_place(), [RunSpec("a", seed=0.5)], duration_s=0.01)
    with pytest.raises(ParameterError, match=r"runs\[0\] = str: each run is a RunSpec"):
        sim.run(pick_and_place(), ["a"], duration_s=0.01)
    # an effect by name (an AttributeError deep in the batch before, a newcomer probe), or one effect not in a tuple
    one = make_effect("backlash", 2, backlash_deg=0.1)
    for effects in (("backlash",), "backlash", (one, 3), one, None, 5):
        with pytest.raises(ParameterError, match=r"^RunSpec 'a': effects = .*: each effect is an EffectSpec"):
            sim.run(pick_and_place(), [RunSpec("a", effects=effects)], duration_s=0.01)
    res = sim.run(pick_and_place(), [RunSpec("a", seed=np.int64(3))], duration_s=0.01)
    assert res.status == ("ok",) and type(res.seeds[0]) is int
    res.to_parquet(tmp_path / "a.parquet")  # a numpy seed once failed here: not JSON serialisable
    with pytest.raises(ParameterError, match="choose one of: compiled, batch, loop"):
        Simulator(stepper="fast")
    with pytest.raises(ParameterError, match="choose one of: numpy, numba"):
        Simulator(drive="c")


@pytest.mark.parametrize("args, kwargs, message", [
    (("pick_and_place", [RunSpec("a")]), {},
     r"^run\(\): trajectory = 'pick_and_place' must be a Trajectory; get_trajectory\('pick_and_place'\) builds the "
     r"one of that name$"),
    ((None, [RunSpec("a")]), {}, r"^run\(\): trajectory = None must be a Trajectory; build one with "),
    ((HOLD, RunSpec("a")), {},
     r"^run\(\): runs = RunSpec\(run_id='a', seed=0, effects=\(\)\) must be a list of RunSpec; one run is a batch "
     r"of one: \[RunSpec\(...\)\]$"),
    ((HOLD, "ab"), {}, r"^run\(\): runs = 'ab' must be a list of RunSpec\(run_id, seed, effects\)$"),
    ((HOLD, None), {}, r"^run\(\): runs = None must be a list of RunSpec"),
    ((HOLD, [RunSpec(5)]), {}, r"^runs\[0\]: run_id = 5 must be a non-empty one-line string \(the result finds the run "
                               r"by it\)$"),
    ((HOLD, [RunSpec("a"), RunSpec(" ")]), {}, r"^runs\[1\]: run_id = ' ' must be a non-empty one-line string"),
    ((HOLD, [RunSpec("a")]), {"duration_s": -1.0}, r"^duration_s = -1.0 is out of range \(0, inf\] s$"),
    ((HOLD, [RunSpec("a")]), {"duration_s": float("nan")},
     r"^duration_s = nan must be a finite number in \(0, inf\] s$"),
    ((HOLD, [RunSpec("a")]), {"duration_s": float("inf")}, r"^duration_s = inf must be a finite number"),
    ((HOLD, [RunSpec("a")]), {"duration_s": "1"}, r"^duration_s = '1' must be a number in \(0, inf\] s$"),
    ((HOLD, [RunSpec("a")]), {"duration_s": True}, r"^duration_s = True must be a number in \(0, inf\] s$"),
    # any finite length is a duration (the command line's 3600 s cap is its own); the memory of its log bounds it
    ((HOLD, [RunSpec("a")]), {"duration_s": 1e12},
     r"^run\(\): 1 run\(s\) of 1e\+12 s logged every 0.001 s needs about "),
    ((HOLD, [RunSpec("a")]), {"duration_s": 0.01, "log_period_s": 0.1},
     r"^duration_s = 0.01 s is shorter than one log period \(log_period_s = 0.1 s\): nothing would be logged$"),
    ((HOLD, [RunSpec("a")]), {"log_period_s": float("nan")},
     r"^log_period_s = nan must be a finite number in \(0, inf\] s$"),
    ((HOLD, [RunSpec("a")]), {"log_period_s": "1ms"}, r"^log_period_s = '1ms' must be a number in \(0, inf\] s$"),
    ((HOLD, [RunSpec("a")]), {"log_period_s": -1e-3}, r"^log_period_s = -0.001 is out of range \(0, inf\] s$"),
    ((HOLD, [RunSpec("a")]), {"progress": 5},
     r"^progress = 5 must be a function of the finished fraction \(0..1\), or None$"),
    ((HOLD, [RunSpec(str(i)) for i in range(3000)]), {"duration_s": 3600.0},
     r"^run\(\): 3000 run\(s\) of 3600 s logged every 0.001 s needs about .* of memory, more than 80% of the .* "
     r"available; simulate fewer runs at once, a shorter duration_s or a longer log_period_s$"),
])
def test_run_arguments_refused_by_name_before_any_step(args, kwargs, message):
    with pytest.raises(ParameterError, match=message):
        SIM.run(*args, **kwargs)


def test_run_takes_numpy_numbers_and_any_iterable_of_runs():
    res = SIM.run(HOLD, (RunSpec(r, 1) for r in "ab"), duration_s=np.float64(0.01), log_period_s=np.float64(2e-3))
    assert res.run_ids == ("a", "b") and res.t_s.size == 5
    assert SIM.run(HOLD, np.array([RunSpec("a"), RunSpec("b")]), duration_s=np.int64(1)).n_runs == 2


@pytest.mark.parametrize("kwargs, message", [
    ({"nthread": 1.5}, r"^nthread = 1.5 must be a whole number, at least 1$"),
    ({"nthread": "2"}, r"^nthread = '2' must be a whole number, at least 1$"),
    ({"params": "ur5_drive.yaml"},
     r"^params = 'ur5_drive.yaml' must be a RobotParams \(load_params\(path, overrides\)\) or None for the packaged "
     r"parameters$"),
    ({"model_path": 5}, r"^model_path = 5 must be the path of an MJCF file, or None for the packaged model$"),
    ({"model_path": "/no/such/ur5.xml"}, r"^model_path = '/no/such/ur5.xml': no such file \(an MJCF model, e.g. the "
                                         r"packaged ur5.xml\)$"),
])
def test_simulator_arguments_refused_by_name(kwargs, message):
    with pytest.raises(ParameterError, match=message):
        Simulator(**kwargs)
    assert Simulator(nthread=np.int64(2)).nthread == 2


def test_protective_stop_is_recorded_and_batch_goes_on():
    # a torque constant at 20 % with a heavy payload cannot follow: the run trips, the other does not
    runs = [RunSpec("ok", 0), RunSpec("weak", 0, (make_effect("torque_constant", "shoulder_lift_joint", scale=0.2),
                                                    make_effect("payload", mass_kg=5.0)))]
    res = Simulator().run(pick_and_place(), runs, duration_s=4.0)
    assert res.status[0] == "ok"
    assert res.status[1] == "protective_stop" and "joint 2" in res.reason[1]
    assert np.isnan(res["q_rad"][1, -1]).all() and np.isfinite(res["q_rad"][0, -1]).all()


def test_to_pandas_and_parquet_roundtrip(batch, tmp_path):
    import pandas as pd

    df = batch.to_pandas("bl_shoulder")
    for col in ("t_s", "q_set_rad_j1", "q_rad_j2", "q_FB_rad_j3", "q_M_rad_j1", "q_M_FB_rad_j6", "i_ref_A_j2",
                "i_FB_A_j2", "v_q_V_j4", "T_gear_Nm_j5", "T_f_Nm_j6", "i_a_A_j2", "tcp_x_m", "tcp_des_z_m"):
        assert col in df.columns, col
    assert "i_a_A_j1" not in df.columns  # DC-equivalent joints have no phase currents
    out = batch.to_parquet(tmp_path / "run.parquet", "bl_shoulder")
    back = pd.read_parquet(out)
    pd.testing.assert_frame_equal(back, df)


def test_setpoint_delay_shifts_the_motion_in_time():
    runs = [RunSpec("now", 2), RunSpec("late", 2, (make_effect("delay", delay_ms=5.0),))]
    res = Simulator().run(pick_and_place(), runs, duration_s=4.0)
    q0, q1 = res["q_rad"][0], res["q_rad"][1]
    moving = np.abs(np.gradient(q0[:, 1], 1e-3)) > 0.1
    assert moving.sum() > 200
    shifted = np.abs(q1[5:] - q0[:-5])[moving[5:]]  # 5 ms = 5 log samples
    unshifted = np.abs(q1 - q0)[moving]
    assert shifted.max() < 0.1 * unshifted.max()
