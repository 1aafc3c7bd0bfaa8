"""Events in the position channel (measured - simulated joint position, i.e. the measured tracking error less
the twin's): a pulse on one joint is an event there, named by its channel; a reading that flickers by one
quantum of its encoder is not; and on a simulated run a short external torque on one joint (a push, applied
through MuJoCo's passive-force callback, outside ur5fault's own effect code) is an event on that joint and
window, while the same run without it raises none (slow)."""

import numpy as np
import pytest

from tests.health.monitoring.test_monitoring import PERIOD, noise, part
from ur5fault.health.monitoring import assess, fit_baseline
from ur5fault.health.monitoring.events import CHANNELS

#: a position quantum of the Kufieta CB2 wrists' readings [rad] (data/kufieta-ur5: steps of 16.2e-6 rad)
QUANTUM_RAD = 16e-6


def test_a_position_pulse_is_an_event_of_the_position_channel_on_its_joint():
    """Baseline: current noise 0.1 A, position residual noise 5 urad. A 1 mrad deflection of shoulder_lift for
    0.3 s (the current unchanged) is one event there, named by the position channel, its peak about 1 mrad."""
    runs = [part(f"r{k}", noise(k), position=noise(50 + k, sigma=5e-6)) for k in range(3)]
    b = fit_baseline(runs, "sha")
    pos = noise(60, sigma=5e-6)
    pos[1000:1038, 1] += 1e-3  # 0.304 s from 8.0 s
    assert assess(b, part("pushed", noise(61), position=pos))["events"] == []  # the current alone, the default
    out = assess(b, part("pushed", noise(61), position=pos), CHANNELS)
    assert out["verdict"] == "anomaly" and len(out["events"]) == 1, out
    ev = out["events"][0]
    assert ev["joints"] == ["shoulder_lift_joint"] and ev["channels"] == ["position"]
    assert abs(ev["t_start_s"] - 8.0) < 0.1 and abs(ev["t_end_s"] - 8.3) < 0.1
    assert 0.85e-3 < ev["peak_rad"] < 1.15e-3
    assert ev["peak_A"] < 0.5  # the current's transient on that joint: its noise only


def flicker(seed: int, n: int = 2000, quantum: float = QUANTUM_RAD) -> np.ndarray:
    """A reading at rest that switches between two adjacent quantisation levels at random moments (about 4 times
    a second, held in between), on every joint, plus the twin's own 1 urad of noise."""
    rng = np.random.default_rng(seed)
    level = np.cumsum(rng.random((n, 6)) < 4 * PERIOD, axis=0) % 2
    return quantum * level + rng.normal(0.0, 1e-6, (n, 6))


def test_quantised_positions_raise_no_event():
    """Baseline runs at rest whose readings held one level (only the twin's 1 urad noise in the residual); a new
    run at rest whose readings flicker by one quantum (16 urad) on every joint is consistent, the quantum known
    from the readings. Without the quantum (a joint that never moved in any log) the same flicker is 16 times the
    baseline's noise and an event: the quantum is what keeps it quiet."""
    rng = np.random.default_rng(7)
    runs = [part(f"r{k}", noise(k, sigma=0.02), moving=False, position=rng.normal(0.0, 1e-6, (2000, 6)),
                 quantum_rad=QUANTUM_RAD) for k in range(3)]
    b = fit_baseline(runs, "sha")
    out = assess(b, part("flicker", noise(30, sigma=0.02), moving=False, position=flicker(31),
                         quantum_rad=QUANTUM_RAD), CHANNELS)
    assert out["events"] == [] and out["verdict"] == "consistent", out
    unknown = fit_baseline([part(f"r{k}", noise(k, sigma=0.02), moving=False, position=rng.normal(0.0, 1e-6,
                                                                                                 (2000, 6)))
                            for k in range(3)], "sha")
    out = assess(unknown, part("flicker", noise(30, sigma=0.02), moving=False, position=flicker(31)), CHANNELS)
    assert out["verdict"] == "anomaly" and all(e["channels"] == ["position"] for e in out["events"]), out


#: the simulated push: an external torque on the elbow [N*m] from PUSH_S[0] to PUSH_S[1] [s] of log time (about
#: what a hand pushing 0.3 m from the joint with 50 N exerts: 15 N*m; a push by hand of 1-2 A of motor current on
#: the real robot's J1-J3, docs/monitoring.md)
PUSH_NM, PUSH_JOINT, PUSH_S = 15.0, 2, (5.0, 5.3)


def simulated_log(tmp_path, seed: int, push: bool):
    """A run of the joint sweep (about 10 s) written as an RTDE file and read back as a user's log; ``push``: the
    external torque above, applied by MuJoCo's passive-force callback (the plain-loop stepper), which no effect
    of ur5fault's registry knows of."""
    import mujoco

    from tests.hidden_logs import PAYLOAD_KG, SIM_TCP_M, write_rtde
    from ur5fault import RunSpec, Simulator
    from ur5fault.logs import read_rtde
    from ur5fault.sim.trajectories import joint_sweep

    sim = Simulator(stepper="loop" if push else None)
    if push:
        def passive(m, d):
            if PUSH_S[0] <= d.time < PUSH_S[1]:
                d.qfrc_passive[PUSH_JOINT] += PUSH_NM

        mujoco.set_mjcb_passive(passive)
    try:
        res = sim.run(joint_sweep(payload_kg=PAYLOAD_KG), [RunSpec("measured", seed)], log_period_s=0.008)
    finally:
        mujoco.set_mjcb_passive(None)
    path = write_rtde(res, tmp_path / f"run{seed}{'_pushed' if push else ''}.csv")
    return read_rtde(path, payload_kg=PAYLOAD_KG, tcp_offset_m=SIM_TCP_M)


@pytest.mark.slow
def test_a_simulated_push_is_a_position_event_on_its_joint_and_the_same_run_without_it_is_quiet(tmp_path):
    """Baseline: three simulated runs of the joint sweep (sensor noise of seeds 1-3) replayed under the packaged
    model. The same motion with seed 4 and a 15 N*m push on the elbow from 5.0 to 5.3 s: the position channel
    alone finds it on the elbow, starting and ending within 0.5 s of the push; without the push (seed 4 again) it
    raises none."""
    from ur5fault.health.monitoring import observe

    base = fit_baseline([observe(simulated_log(tmp_path, s, False), kinds=()) for s in (1, 2, 3)], "sha")
    pushed = observe(simulated_log(tmp_path, 4, True), kinds=())
    out = assess(base, pushed, ("position",))
    assert out["verdict"] == "anomaly", out
    ev = [e for e in out["events"] if "elbow_joint" in e["joints"]]
    assert len(ev) == 1, out
    assert abs(ev[0]["t_start_s"] - PUSH_S[0]) <= 0.5 and abs(ev[0]["t_end_s"] - PUSH_S[1]) <= 0.5, ev
    assert ev[0]["channels"] == ["position"]
    quiet = assess(base, observe(simulated_log(tmp_path, 4, False), kinds=()), ("position",))
    assert quiet["events"] == [] and quiet["verdict"] == "consistent", quiet
