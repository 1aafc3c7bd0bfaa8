"""Identification in code (ur5fault.identify).

Three kinds of test:

* the estimators against synthetic data with known truth (fast);
* the whole chain against the simulator: a replay of the NIST trajectory simulated with known
  friction and torque constant is identified back (slow);
* the real NIST log: ``ur5fault identify`` re-derives every ``[nist]`` value of
  ``ur5fault/data/ur5_drive.yaml`` within the tolerance stated below, so the tags cannot drift
  from the data (slow: the bandwidth sweep replays the first 32 s of the log four times).
"""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest
import yaml

from ur5fault.cli import main
from ur5fault.config import Overlay
from ur5fault.identify import friction, loop, sensors, stats
from ur5fault.identify.signals import LogSignals
from ur5fault.sim.axes import JOINT_NAMES
from ur5fault.sim.params import DEFAULT_PARAMS_PATH, load_params

DT = 0.008


def _signals(n: int, **arrays) -> LogSignals:
    zeros = np.zeros((n, 6))
    base = dict(period_s=DT, q_target_rad=zeros, qd_target_rad_s=zeros, qdd_target_rad_s2=zeros, q_actual_rad=zeros,
                qd_actual_rad_s=zeros, current_A=zeros, temperature_C=np.full((n, 6), 28.0), model_torque_Nm=zeros,
                target_torque_Nm=None)
    base.update(arrays)
    return LogSignals(**base)


# ----------------------------------------------------------------------------------------- estimators, synthetic truth
def test_position_quantum_recovers_the_encoder_step():
    rng = np.random.default_rng(3)
    quantum = 2 * np.pi / 2**19
    q = np.round(np.cumsum(rng.normal(0, 2.5 * quantum, (4000, 6)), axis=0) / quantum) * quantum + 0.3
    found, _ = sensors.position_quantum(q)
    assert found == pytest.approx(quantum, rel=1e-9)


PRIOR_NOISE = {"sensors.current_noise_A": np.full(6, 0.5), "sensors.resolver_noise_rad": np.full(6, 7e-3)}


def test_noise_without_rest_keeps_the_model_value_and_one_segment_gives_no_interval():
    """A robot that never rests (three of the second UR5's runs): the model's value, marked, never a
    traceback; one rest segment: the value, but no zero-width 'interval' from resampling it alone."""
    rng = np.random.default_rng(6)
    n = 3000
    moving = _signals(n, qd_target_rad_s=np.full((n, 6), 0.3), current_A=rng.normal(0, 0.01, (n, 6)))
    est = sensors.noise_at_rest(moving, n_boot=50, seed=0, prior=PRIOR_NOISE)
    assert len(est) == 12 and not any(e.identifiable for e in est)
    assert {e.value for e in est} == {0.5, 7e-3}
    assert all("no settled rest segment" in e.note for e in est)
    qd = np.zeros((n, 6))
    qd[n // 2:] = 0.3  # one rest segment, then motion
    once = _signals(n, qd_target_rad_s=qd, current_A=rng.normal(0, 0.01, (n, 6)),
                    q_actual_rad=rng.normal(0, 2e-5, (n, 6)))
    est = sensors.noise_at_rest(once, n_boot=50, seed=0, prior=PRIOR_NOISE)
    assert all(e.identifiable and np.isnan(e.lo) and np.isnan(e.hi) and "no interval" in e.note for e in est)


def test_resolution_of_a_robot_that_did_not_move_is_the_model_value_marked():
    sig = _signals(1000, q_actual_rad=np.full((1000, 6), 0.3))
    est = sensors.resolver_resolution(sig, n_boot=20, seed=0, prior_counts=2.0**19)
    assert len(est) == 6 and all(not e.identifiable and e.value == 2.0**19 and "never change" in e.note for e in est)


def test_noise_at_rest_recovers_white_noise_sigma_and_ignores_a_creeping_trend():
    rng = np.random.default_rng(4)
    n = 3000
    qd = np.zeros((n, 6))
    qd[(np.arange(n) // 250) % 2 == 1] = 0.3  # rest 2 s, move 2 s, ...
    sigma_A = np.array([0.012, 0.010, 0.013, 0.008, 0.009, 0.0087])
    trend = np.linspace(0, 0.2, n)[:, None]  # a holding current winding up slowly is not noise
    sig = _signals(n, qd_target_rad_s=qd, current_A=trend + rng.normal(0, 1, (n, 6)) * sigma_A,
                   q_actual_rad=rng.normal(0, 2.3e-5, (n, 6)))
    est = sensors.noise_at_rest(sig, n_boot=100, seed=0, prior=PRIOR_NOISE)
    cur = np.array([e.value for e in est if e.key == "sensors.current_noise_A"])
    np.testing.assert_allclose(cur, sigma_A, rtol=0.06)
    for e in est:
        assert e.lo < e.value < e.hi


def test_friction_fit_recovers_torque_constant_coulomb_viscous_and_offset():
    rng = np.random.default_rng(5)
    p = load_params()
    n = 6000
    t = np.arange(n) * DT
    w = 0.5 * np.sin(2 * np.pi * t / 6.0)[:, None] * np.ones(6)
    w[:, 4:] *= 0.1  # wrists 2 and 3 barely move: not identifiable
    grav = np.zeros((n, 6))
    grav[:, 1] = -30 + 18 * np.cos(2 * np.pi * t / 17.0)  # shoulder gravity: the torque lever
    temp = 26.0 + 2 * np.sin(t / 20.0)[:, None] * np.ones(6)
    k_joint = 12.6
    fc = np.array([0.5, 0.54, 0.48, 0.14, 0.1, 0.1])
    fv = np.array([1.4, 1.3, 1.05, 0.31, 0.3, 0.3])
    c = np.array([0.0, 0.0, 0.15, 0.19, 0.0, 0.0])  # offsets where the torque constant is not fitted
    theta = np.exp(-0.02 * (temp - 28.0))
    k = np.array([k_joint] * 3 + [9.898] * 3)
    i = grav / k + fc * np.sign(w) + fv * w * theta + c + rng.normal(0, 0.05, (n, 6))
    sig = _signals(n, qd_target_rad_s=w, qd_actual_rad_s=w, current_A=i, temperature_C=temp, model_torque_Nm=grav)
    fit = friction.FrictionFit(sig, p)
    assert fit.k_groups == {1: [], 3: [1]}
    out = fit(np.arange(n))
    assert out[0, 0] == pytest.approx(k_joint, rel=0.01)
    np.testing.assert_allclose(out[1, :4], fc[:4], atol=0.01)
    np.testing.assert_allclose(out[2, :4], fv[:4], rtol=0.02)
    np.testing.assert_allclose(out[3, :4], c[:4], atol=0.01)
    assert np.all(np.isnan(out[1:, 4:]))
    # with an offset on the shoulder too, only the variant that fits it gets K right
    i2 = i + np.array([0, 0.2, 0, 0, 0, 0])
    sig2 = dataclasses.replace(sig, current_A=i2)
    assert friction.FrictionFit(sig2, p, k_offset_term=True)(np.arange(n))[0, 1] == pytest.approx(k_joint, rel=0.01)
    assert friction.FrictionFit(sig2, p)(np.arange(n))[0, 1] != pytest.approx(k_joint, rel=0.01)


def test_ur_model_read_back_from_its_predicted_current():
    from ur5fault.identify import urmodel

    n = 3000
    t = np.arange(n) * DT
    w = 0.4 * np.sin(2 * np.pi * t / 5.0)[:, None] * np.ones(6)
    tq = 20 * np.cos(2 * np.pi * t / 13.0)[:, None] * np.ones(6)
    k_ur = np.array([11.6, 11.6, 11.4, 8.5, 8.5, 8.5])
    it = tq / k_ur + 0.4 * np.sign(w) + 1.7 * w
    sig = _signals(n, qd_target_rad_s=w, qd_actual_rad_s=w, target_torque_Nm=tq, target_current_A=it)
    est = urmodel.ur_model(friction.FrictionFit(sig, load_params()))
    kt = [e.value for e in est if e.key == "check.UR_model_torque_constant_Nm_per_A"]
    np.testing.assert_allclose(kt, k_ur[:6] / 101, rtol=1e-9)
    assert all(e.value == pytest.approx(0.4) for e in est if e.key == "check.UR_model_coulomb_A")


def test_tracking_lag_and_feedforward():
    rng = np.random.default_rng(6)
    n = 5000
    w = 0.4 * np.sin(np.arange(n) * DT)[:, None] * np.ones(6)
    w[:, 5] = 0.0
    lag = np.array([4e-4, 2.5e-4, 2.4e-4, 3.8e-4, 1e-5, 0.0])
    e = lag * w + rng.normal(0, 5e-5, (n, 6))
    sig = _signals(n, qd_target_rad_s=w, q_target_rad=e)
    est, ok = loop.tracking_lag(sig, n_boot=50, seed=0)
    assert list(ok) == [True, True, True, True, False, False]  # 1e-5 s x 0.4 rad/s is far below the noise
    for j in range(4):
        assert est[j].lo < lag[j] < est[j].hi
    assert loop.feedforward(4.107e-4, 1.5) == pytest.approx(0.99613, abs=1e-5)


def test_bootstrap_is_reproducible_and_about_as_wide_as_the_normal_interval():
    rng = np.random.default_rng(7)
    x = rng.normal(0, 1, 2000)
    groups = stats.block_indices(x.size, 20)
    boot1 = stats.bootstrap(lambda idx: np.array(x[idx].mean()), groups, 300, seed=1)
    boot2 = stats.bootstrap(lambda idx: np.array(x[idx].mean()), groups, 300, seed=1)
    np.testing.assert_array_equal(boot1, boot2)
    lo, hi = stats.interval(boot1)
    assert (hi - lo) == pytest.approx(2 * 1.96 / np.sqrt(x.size), rel=0.25)


# ----------------------------------------------------------------------- the whole chain against the simulator
@pytest.mark.slow
def test_identify_recovers_the_parameters_of_a_simulated_replay(nist_path):
    """The simulator replays 32 s of the NIST trajectory with known friction (no Stribeck hump:
    static = Coulomb) and torque constant; identification gets them back.  Independent of the
    regression: the currents come from the full drive chain and MuJoCo's forward dynamics."""
    from ur5fault import RunSpec, Simulator
    from ur5fault.identify import identify
    from ur5fault.logs import MeasuredLog, read_nist

    real = read_nist(nist_path).window(0.0, 32.0)
    truth_A = np.array([0.45, 0.55, 0.40, 0.14, 0.14, 0.14])
    visc_A = np.array([1.5, 1.3, 1.1, 0.3, 0.3, 0.3])
    kt = np.array([0.13, 0.13, 0.13, 0.098, 0.098, 0.098])
    k = kt * 101
    over = {"tcp_offset_m": list(real.tcp_offset_m), "joint_temperature_C": 28.0,
            "motor": {"torque_constant_Nm_per_A": kt.tolist()},
            "friction": {"coulomb_Nm": (truth_A * k).tolist(), "static_Nm": (truth_A * k).tolist(),
                         "viscous_Nms_per_rad": (visc_A * k).tolist()}}
    p = load_params(overrides=over)
    res = Simulator(p).run(real.to_trajectory(), [RunSpec("sim", 2)], log_period_s=real.period_s)
    n = res.t_s.size
    sim_log = MeasuredLog("simulated", res.t_s, real.q_target_rad[1 : n + 1], res["q_FB_rad"][0], res["i_FB_A"][0],
                          temperature_C=np.full((n, 6), 28.0), payload_kg=real.payload_kg,
                          tcp_offset_m=real.tcp_offset_m)
    ident = identify(sim_log, p, sweep=False, n_boot=50)
    assert ident.get("motor.torque_constant_Nm_per_A", 1).value == pytest.approx(0.13, rel=0.03)
    for j in range(4):
        assert ident.get("friction.coulomb_A", j).value == pytest.approx(truth_A[j], rel=0.1), j
        assert ident.get("friction.viscous_A_s_per_rad", j).value == pytest.approx(visc_A[j], rel=0.1), j
    for j in range(6):
        assert ident.get("sensors.resolver_counts_per_rev", j).value == pytest.approx(2**19, rel=1e-3), j


# --------------------------------------------------------------------------------------------- the real NIST log
#: the ``[nist]`` keys of ur5_drive.yaml and the estimate (in current units where K matters) that checks each
NIST_KEYS = {
    "friction.coulomb_Nm": "friction.coulomb_A",
    "friction.static_Nm": "friction.breakaway_A",
    "friction.viscous_Nms_per_rad": "friction.viscous_A_s_per_rad",
    "motor.torque_constant_Nm_per_A": "motor.torque_constant_Nm_per_A",
    "controller.position_bw_Hz": "controller.position_bw_Hz",
    "controller.velocity_feedforward": "controller.velocity_feedforward",
    "sensors.resolver_noise_rad": "sensors.resolver_noise_rad",
    "sensors.resolver_counts_per_rev": "sensors.resolver_counts_per_rev",
    "sensors.current_noise_A": "sensors.current_noise_A",
}
#: stated tolerance: the yaml value lies in the estimate's 95 % interval widened by this share of the
#: estimate (the yaml rounds to 2-3 significant digits); values the log cannot give must equal the
#: stated fallback to the same tolerance
REL_TOL = 0.05


def nist_tagged_keys(text: str) -> set[str]:
    """``section.key`` of every yaml entry tagged [nist] on its line or in the comment block above it."""
    keys, pending, section = set(), "", ""
    for line in text.splitlines():
        if not line.strip():
            pending = ""
            continue
        if line.lstrip().startswith("#"):
            pending += line
            continue
        m = re.match(r"^(\s*)([A-Za-z_]\w*):", line)
        if not m:
            continue
        if not m.group(1):
            section = m.group(2)
        tagged = "[nist]" in line or "[nist]" in pending
        pending = ""
        if tagged:
            keys.add(f"{section}.{m.group(2)}" if m.group(1) else m.group(2))
    return keys


@pytest.fixture(scope="module")
def nist_identified(nist_path, tmp_path_factory):
    out = tmp_path_factory.mktemp("identify")
    rc = main(["identify", str(nist_path), "--format", "nist", "--out", str(out / "params.yaml"),
               "--json", str(out / "identify.json"), "--quiet"])
    assert rc == 0
    return out, json.loads((out / "identify.json").read_text())


def _estimate(summary: dict, key: str, joint) -> dict:
    """The estimate of ``key`` on ``joint`` (0-based index, or None) from identify's JSON, which names joints."""
    name = None if joint is None else JOINT_NAMES[joint]
    for e in summary["estimates"]:
        if e["key"] == key and e["joint"] == name:
            return e
    raise KeyError((key, joint))


def test_every_nist_tag_has_a_check():
    from test_friction_choice import REPLAY_KEYS  # the choices only a replay of the log decides

    assert nist_tagged_keys(DEFAULT_PARAMS_PATH.read_text()) == set(NIST_KEYS) | set(REPLAY_KEYS)


@pytest.mark.slow
def test_yaml_nist_values_are_what_the_log_gives(nist_identified):
    _, summ = nist_identified
    p = load_params()
    k_joint = np.asarray(p.motor.torque_constant_Nm_per_A) * np.asarray(p.gear.ratio)
    bad = []
    for yaml_key, est_key in NIST_KEYS.items():
        section, field = yaml_key.split(".")
        values = np.atleast_1d(np.asarray(getattr(getattr(p, section), field), float))
        if est_key.startswith("friction."):
            values = values / k_joint  # friction is checked in current units, where it was measured
        joints = [None] if est_key == "controller.position_bw_Hz" else range(6)
        for j, v in zip(joints, values):
            e = _estimate(summ, est_key, j)
            ref = e["value"]
            if e["identifiable"]:
                lo, hi = e["lo"] - REL_TOL * abs(ref), e["hi"] + REL_TOL * abs(ref)
                ok = lo <= v <= hi
            else:
                ok = abs(v - ref) <= REL_TOL * abs(ref)
                lo = hi = ref
            if not ok:
                bad.append(f"{yaml_key}[{j}] = {v:.4g}, identified {ref:.4g} [{lo:.4g}, {hi:.4g}]")
    assert not bad, "\n".join(bad)


@pytest.mark.slow
def test_issue_figures_for_the_base_joint(nist_identified):
    """Issue 10 by hand: J1 on moving samples 0.50 A and 1.49 A*s/rad (at the log's ~24.8 degC)."""
    _, summ = nist_identified
    assert _estimate(summ, "friction.coulomb_A", 0)["value"] == pytest.approx(0.50, abs=0.015)
    visc_28 = _estimate(summ, "friction.viscous_A_s_per_rad", 0)["value"]
    assert visc_28 * np.exp(0.02 * (28.0 - 24.8)) == pytest.approx(1.49, abs=0.03)


@pytest.mark.slow
def test_bandwidth_sweep_picks_the_yaml_value(nist_identified):
    _, summ = nist_identified
    sw = summ["sweep"]
    assert sw["window_s"] == pytest.approx(32.0, abs=0.01)
    assert sw["bandwidths_Hz"][int(np.argmin(sw["scores"]))] == load_params().controller.position_bw_Hz[0]


@pytest.mark.slow
def test_overlay_is_accepted_by_simulate(nist_identified, tmp_path):
    out, _ = nist_identified
    overlay = Overlay.load(out / "params.yaml")
    assert set(overlay.params) == {"motor", "friction", "sensors", "controller"}
    rc = main(["simulate", "--model", str(out / "params.yaml"), "--duration-s", "0.02", "--quiet",
               "--out", str(tmp_path / "run.parquet")])
    assert rc == 0
    text = (out / "params.yaml").read_text()
    assert "95 %" in text and "not identifiable" in text
    data = yaml.safe_load(text)
    # parameters, plus the motor-angle ripples the log shows (docs/validation.md: wrist_2's is 3 per motor turn)
    assert data.keys() == {"params", "effects"}
    assert {e["effect"] for e in data["effects"]} == {"motor_harmonic"}
    assert {e["joint"]: e["periods_per_rev"] for e in data["effects"]}["wrist_2_joint"] == 3.0


def test_identify_cli_errors(tmp_path, capsys):
    assert main(["identify", str(tmp_path / "missing.csv"), "--format", "nist", "--out", str(tmp_path / "p.yaml")]) == 2
    assert "no such file" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["identify", "x.csv", "--format", "sim", "--out", "p.yaml"])
    assert exc.value.code == 2
    assert main(["identify", "x.csv", "--format", "nist", "--out", "p.yaml", "--bootstrap", "3"]) == 2
    assert "--bootstrap = 3 must be 20..10000 resamples" in capsys.readouterr().err
    # no bound was there: 10^8 resamples ran on until stopped by hand
    assert main(["identify", "x.csv", "--format", "nist", "--out", "p.yaml", "--bootstrap", "100000000"]) == 2
    assert "--bootstrap = 100000000 must be 20..10000 resamples" in capsys.readouterr().err


def test_rtde_log_gives_the_same_estimates_as_its_nist_original(nist_path, tmp_path):
    """The RTDE path (radians, payload and tool from the command line) on the NIST data rewritten as RTDE."""
    import pandas as pd

    from ur5fault.logs import read_nist

    log = read_nist(nist_path).window(0.0, 40.0)
    cols = {"timestamp": log.t_s}
    for j in range(6):
        cols[f"target_q_{j}"] = log.q_target_rad[:, j]
        cols[f"actual_q_{j}"] = log.q_actual_rad[:, j]
        cols[f"actual_current_{j}"] = log.current_A[:, j]
        cols[f"joint_temperatures_{j}"] = log.temperature_C[:, j]
        cols[f"target_moment_{j}"] = log.target_torque_Nm[:, j]
    pd.DataFrame(cols).to_csv(tmp_path / "rtde.csv", index=False)
    args = ["--no-sweep", "--bootstrap", "20", "--quiet"]
    assert main(["identify", str(tmp_path / "rtde.csv"), "--format", "rtde", "--payload-kg", str(log.payload_kg),
                 "--tcp-offset-m", *map(str, log.tcp_offset_m), "--out", str(tmp_path / "rtde.yaml"), *args]) == 0
    from ur5fault.identify import identify

    ref = identify(log, sweep=False, n_boot=20)
    got = Overlay.load(tmp_path / "rtde.yaml").params
    want = ref.overlay(load_params())["params"]
    assert got["friction"] == want["friction"] and got["motor"] == want["motor"]
    assert got["sensors"] == want["sensors"]


def test_presliding_written_per_joint_with_the_models_value_where_not_identified():
    from types import SimpleNamespace

    from ur5fault.identify import report

    ident = report.Identification("x", 1.0, tuple(
        stats.Estimate("friction.presliding_stiffness_Nm_per_rad", j, 9e4 + j, 8e4, 1e5, "m") for j in range(3)))
    params = SimpleNamespace(friction=SimpleNamespace(**{report.PRESLIDING_FIELD: (1e4,) * 6}))
    np.testing.assert_array_equal(report._presliding(ident, params), [9e4, 9e4 + 1, 9e4 + 2, 1e4, 1e4, 1e4])


def test_estimate_contains_and_json():
    e = stats.Estimate("k", 0, 1.0, 0.9, 1.1, "m")
    assert e.contains(1.14, rel_tol=0.05) and not e.contains(1.16, rel_tol=0.05)
    assert e.to_json() == {**dataclasses.asdict(e), "joint": "shoulder_pan_joint"}  # joints named, as every output
    assert stats.Estimate("k", None, 1.0, 0.9, 1.1, "m").to_json()["joint"] is None  # robot-wide


def test_quantised_log_gets_a_consistent_noise_and_resolution_pair():
    """The second UR5 (CB2) logs positions that are identical at rest and step by about 9.5 urad on J1-J3 and
    16.3 urad on its wrists (read here from the CSV itself; no power of two): identify writes a noise of exactly 0
    with each joint's own counts per revolution, whose step matches the log's, and the pair still weighs the
    position residual (by the step)."""
    import pandas as pd

    from ur5fault.identify import identify
    from ur5fault.logs import read_rtde
    from ur5fault.twin.replay import residual_sigma

    from conftest import KUFIETA_DIR

    raw = pd.read_csv(KUFIETA_DIR / "Movement_No1.csv.gz")[[f"actual_q_{j}" for j in range(6)]].to_numpy()
    steps = np.abs(np.diff(raw, axis=0))
    # one quantum as printed (to 1 urad): J2 steps by 9 or 10 urad, J5 by 16 or 17 (and multiples)
    shoulder_step = float(np.mean(steps[:, 1][(steps[:, 1] > 8.5e-6) & (steps[:, 1] < 10.5e-6)]))
    wrist_step = float(np.mean(steps[:, 4][(steps[:, 4] > 15.5e-6) & (steps[:, 4] < 17.5e-6)]))
    logs = [read_rtde(KUFIETA_DIR / name, payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))
            for name in ("Movement_No1.csv.gz", "Movement_No10_Standstill_WDist.csv.gz")]
    logs[1] = logs[1].window(12.0, 60.0)  # its only constant-target stretch, after the last push
    p = load_params()
    sensors_out = identify(logs, p, sweep=False, n_boot=20).overlay(p)["params"]["sensors"]
    assert sensors_out["resolver_noise_rad"] == [0.0] * 6
    counts = np.asarray(sensors_out["resolver_counts_per_rev"], float)
    assert 2 * np.pi / counts[1] == pytest.approx(shoulder_step, rel=0.05)  # printed to 1 urad: 10 % of it
    assert 2 * np.pi / counts[4] == pytest.approx(wrist_step, rel=0.05)
    sigma = residual_sigma(load_params(overrides={"sensors": sensors_out}), ["position_rad"])
    assert np.all(sigma > 0) and np.all(sigma < shoulder_step)
