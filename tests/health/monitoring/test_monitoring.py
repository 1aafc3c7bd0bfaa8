"""Monitoring's pieces: event thresholds from the baseline's own residuals, events on the right joint and time,
the baseline file round trip; and on the real NIST log (slow) a healthy part consistent with the first part and
an injected current gain named on its joint with its size."""

import dataclasses
import json

import numpy as np
import pytest

from ur5fault.errors import ParameterError
from ur5fault.health.monitoring import Observed, assess, fit_baseline
from ur5fault.health.monitoring.baseline import Baseline, overlay_sha256
from ur5fault.health.monitoring.events import SETTLE_S, smooth

PERIOD = 0.008


def part(name: str, residual: np.ndarray, moving: bool = True) -> Observed:
    n = residual.shape[0]
    return Observed(name, PERIOD, np.arange(n) * PERIOD, residual, np.full((n, 6), moving), np.ones(n, bool), (),
                    np.zeros((0, n, 12)), np.zeros((n, 12)))


def noise(seed: int, n: int = 2000, sigma: float = 0.1) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, sigma, (n, 6))


def test_threshold_is_the_largest_smoothed_deviation_of_any_baseline_run():
    runs = [part(f"r{k}", noise(k)) for k in range(3)]
    b = fit_baseline(runs, "sha")
    skip = int(round(SETTLE_S / PERIOD))
    for j in range(6):
        sm = [smooth(r.residual_A, PERIOD)[skip:, j] for r in runs]
        med = np.median(np.concatenate(sm))
        assert b.threshold_A[j, 1] == pytest.approx(max(np.abs(s - med).max() for s in sm))
    # no baseline sample at rest: the joint's moving threshold stands in
    np.testing.assert_array_equal(b.threshold_A[:, 0], b.threshold_A[:, 1])


def test_a_pulse_is_an_event_on_its_joint_and_time_and_noise_is_not():
    b = fit_baseline([part(f"r{k}", noise(k)) for k in range(3)], "sha")
    quiet = assess(b, part("quiet", noise(10) * 0.8))
    assert quiet == {"log": "quiet", "verdict": "consistent", "changes": [], "events": []}
    r = noise(11) * 0.8
    r[1000:1060, 2] += 1.0  # 1 A for 0.48 s on the elbow
    out = assess(b, part("pushed", r))
    assert out["verdict"] == "anomaly" and len(out["events"]) == 1
    ev = out["events"][0]
    assert ev["joints"] == ["elbow_joint"]
    assert abs(ev["t_start_s"] - 8.0) < 0.1 and abs(ev["t_end_s"] - 8.472) < 0.1
    assert 0.9 < ev["peak_A"] < 1.1


def test_baseline_round_trip_and_refusals(tmp_path):
    b = fit_baseline([part("a", noise(1)), part("b", noise(2))], overlay_sha256({}, ()))
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(b.to_json()))
    back = Baseline.load(path)
    np.testing.assert_array_equal(back.threshold_A, b.threshold_A)
    np.testing.assert_array_equal(back.median_A, b.median_A)
    assert back.segments == ("a", "b") and back.overlay_sha256 == b.overlay_sha256
    path.write_text(json.dumps({**b.to_json(), "threshold_A": 3}))
    with pytest.raises(ParameterError, match="not a valid monitor baseline"):
        Baseline.load(path)
    with pytest.raises(ParameterError, match="sample period"):
        assess(b, dataclasses.replace(part("x", noise(3)), period_s=0.002))


@pytest.mark.slow
def test_nist_rest_and_an_injected_gain_on_its_joint(nist_path):
    """Baseline: the first FIT_FRACTION of the real NIST log under the packaged model; the rest with the logged
    shoulder_lift current times 1.3 (a current-sensor gain fault) is 'changed' on that joint, the gain read as
    about the injected one relative to the baseline's own estimate."""
    from ur5fault.health.monitoring import observe
    from ur5fault.logs import read_log
    from ur5fault.twin.residuals import FIT_FRACTION

    log = read_log(nist_path, "nist")
    span = float(log.t_s[-1] - log.t_s[0])
    split = FIT_FRACTION * span
    b = fit_baseline([observe(log, part_s=(0.0, split), jobs=2)], overlay_sha256({}, ()))
    cur = log.current_A.copy()
    cur[:, 1] *= 1.3
    out = assess(b, observe(dataclasses.replace(log, current_A=cur), part_s=(split, span + 1), jobs=2))
    assert out["verdict"] == "changed"
    ch = [c for c in out["changes"] if c["joint"] == "shoulder_lift_joint"]
    assert ch, out["changes"]
    c = ch[0]
    gains = [x for x in [c, *c["alternatives"]] if (x["effect"], x["parameter"]) == ("current_sensor_gain", "gain")]
    assert gains, c
    # read relative to what the baseline part itself gives on that joint (the model's own gain error there)
    assert gains[0]["value"] / gains[0]["baseline_value"] == pytest.approx(1.3, abs=0.06)
