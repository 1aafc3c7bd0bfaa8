"""The paired change test (ur5fault/health/monitoring/paired.py) on synthetic residuals of a robot repeating its
task: the twin's error is large and repeats at the same points of the task, so a candidate fitted to a residual
alone absorbs it, while on the difference of residuals at the same point of the task it cancels. A known
current-sensor gain on a repeated task is found on its joint with its size; a healthy repeat is not a change."""

import dataclasses

import numpy as np

from tests.health.monitoring.test_monitoring import PERIOD, part
from tests.health.monitoring.test_task import cycle, jitter
from ur5fault.discrepancy.candidates import LibraryCandidate
from ur5fault.health.monitoring import assess, fit_baseline
from ur5fault.health.monitoring.paired import difference, estimates
from ur5fault.health.monitoring.task import reference

SIGMA_A = 0.02  # the current sensor's noise, the weights
LABEL = "shoulder_lift_joint: current_sensor_gain.gain"


def currents(target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The simulated motor current ``(n, 6)`` [A] of a commanded motion (gravity at the pose, inertia and
    friction at its speed) and the twin's error on it: a pose-dependent gravity error (0.5 A, three times the
    pose's frequency: what a candidate fitted alone cannot tell from the gain on a 5 s block) and 1 A where the
    target accelerates; both the same on every repeat of the motion."""
    qd = np.gradient(target, PERIOD, axis=0)
    qdd = np.gradient(qd, PERIOD, axis=0)
    sim = 2.0 * np.cos(target) + 0.8 * qdd + 0.5 * np.tanh(qd / 0.05)
    err = 0.5 * np.sin(3.0 * target) + 1.0 * np.tanh(qdd)
    return sim, err


def run(name: str, target: np.ndarray, seed: int, gain: float = 1.0):
    """A replayed run: the measured current ``gain`` x (the true current) + sensor noise, the true current the
    simulated one plus the twin's error; the library columns of a shoulder_lift current-sensor gain and offset
    (the simulated reading per unit coefficient, weighted by the noise)."""
    sim, err = currents(target)
    meas = gain * (sim + err) + np.random.default_rng(seed).normal(0.0, SIGMA_A, sim.shape)
    n = target.shape[0]
    X = np.zeros((2, n, 12))
    X[0, :, 1] = sim[:, 1] / SIGMA_A  # d(reading)/d(gain)
    X[1, :, 1] = 1.0 / SIGMA_A  # d(reading)/d(offset)
    e = np.zeros((n, 12))
    e[:, :6] = (meas - sim) / SIGMA_A
    cands = (LibraryCandidate("current_sensor_gain", 1, param="gain", x0=1.0, probe=1.1),
             LibraryCandidate("current_sensor_offset", 1, param="offset_A", x0=0.0, probe=0.1))
    speed = np.abs(np.gradient(target, PERIOD, axis=0))
    obs = part(name, meas - sim, speed=speed, cands=cands, X=X, e=e, target=jitter(target, seed))
    return dataclasses.replace(obs, current_sigma_A=np.full(6, SIGMA_A))


def test_the_paired_difference_reads_a_known_gain_and_cancels_the_repeated_model_error():
    base = [run(f"b{k}", cycle(4, lead_s=0.3 * k), 20 + k) for k in range(2)]
    refs = [(o.target_rad, np.where(o.logged[:, None], o.residual_A, np.nan)) for o in base]
    for gain in (1.0, 1.1):
        log = run("log", cycle(4, lead_s=0.2), 40, gain=gain)
        ref = reference(log.target_rad, refs, PERIOD)[0]
        _, on = difference(log, ref)
        assert on.mean() > 0.8  # all but the log's first and last second
        est = estimates(log, ref, log.logged)[LABEL]
        # the difference is (gain - 1) x the true current (simulated + the twin's error) + noise, the column the
        # simulated current: its least-squares coefficient on the paired samples, from the generating model
        sim, err = currents(cycle(4, lead_s=0.2))
        s = sim[on, 1]
        expected = (gain - 1.0) * float(np.sum((s + err[on, 1]) * s) / np.sum(s * s))
        assert abs(est.theta - expected) < 0.005, (est, expected)


def test_a_gain_on_a_repeated_task_is_changed_and_a_healthy_repeat_is_not():
    """Three healthy runs of one task (at other leads) as the baseline. A new run of the task with a 10 % gain on
    shoulder_lift's current sensor is "changed" there, read as 1.10 times the true current's share of the
    simulated one by the paired test; the healthy repeat is
    "consistent". The block test alone (the monitor before the paired test) misses the gain: its block estimates
    carry the twin's error."""
    base = [run(f"b{k}", cycle(5, lead_s=0.3 * k), 20 + k) for k in range(3)]
    b = fit_baseline(base, "sha")
    mean, var, k = b.paired_candidates[LABEL]
    assert k >= 10 and abs(mean) < 0.01  # healthy repeats paired with each other: no gain between them
    healthy = assess(b, run("healthy", cycle(5, lead_s=0.2), 40))
    assert healthy["verdict"] == "consistent", healthy
    out = assess(b, run("worn", cycle(5, lead_s=0.2), 41, gain=1.1))
    assert out["verdict"] == "changed", out
    (ch,) = out["changes"]
    assert ch["joint"] == "shoulder_lift_joint" and ch["reference"] == "paired"
    sim, err = (c[:, 1] for c in currents(cycle(5, lead_s=0.2)))
    expected = 1.0 + 0.1 * float(np.sum((sim + err) * sim) / np.sum(sim * sim))  # as read on the simulated current
    assert ch["effect"] == "current_sensor_gain" and abs(ch["value"] - expected) < 0.01, (ch, expected)
    assert abs(ch["baseline_value"] - 1.0) < 0.01
    before = assess(dataclasses.replace(b, paired_candidates={}), run("worn", cycle(5, lead_s=0.2), 41, gain=1.1))
    assert before["changes"] == [], before


def test_the_paired_statistics_survive_baseline_json(tmp_path):
    import json

    from ur5fault.health.monitoring.baseline import Baseline

    b = fit_baseline([run(f"b{k}", cycle(3, lead_s=0.3 * k), 20 + k) for k in range(2)], "sha")
    assert b.paired_candidates
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(b.to_json()))
    back = Baseline.load(path)
    assert back.paired_candidates == b.paired_candidates
    worn = run("worn", cycle(3, lead_s=0.2), 41, gain=1.2)
    assert assess(back, worn) == assess(b, worn)
