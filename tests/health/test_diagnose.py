"""``ur5fault diagnose LOG`` (ur5fault/health/diagnosis/): a simulated log is replayed through its twin, cut
into windows as long as the detector's training runs and scored; the schema is written, a detector saved
without the window length (or on shuffled labels, or with inputs this version does not compute) is refused in
one line, and a current-sensor offset of known size on one joint comes out on that joint at that size.

The detector here is a stand-in trained on a synthetic table whose inputs are the six current-offset
projections and the known conditions (healthy rows near 0 A, and current-sensor offsets of 0.1-0.5 A on one
joint whose projection carries the size): it tests the plumbing from a log to the
saved classifiers; the size estimate is tested against the physics (a sensor offset adds itself to the
reading, because the current loop holds the true current where the motion needs it)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("sklearn")
pytest.importorskip("skops")

from ur5fault.cli import main  # noqa: E402
from ur5fault.errors import ConfigFileError  # noqa: E402
from ur5fault.health.diagnosis.score import COMPUTABLE, MAX_VIF, check_schema  # noqa: E402
from ur5fault.health.diagnostics import joint_kind  # noqa: E402
from ur5fault.health.diagnostics.calibration import fit_calibration  # noqa: E402
from ur5fault.health.diagnostics.data import load_dataset  # noqa: E402
from ur5fault.health.diagnostics.metrics import alarm_threshold  # noqa: E402
from ur5fault.health.diagnostics.models import fit_models  # noqa: E402
from ur5fault.health.diagnostics.saved import SCHEMA_FILE, save_models  # noqa: E402
from ur5fault.util.io import checksum_path  # noqa: E402

WINDOW_S = 2.5  # the stand-in detector's "training runs' duration"
LOG_S = 5.2  # two windows of 2.5 s after the first sample (a log reader takes at least 5 s)
OFFSET_A = 0.3  # injected current-sensor offset on wrist 1 (J4)
SMALL_OFFSET_A = 0.1  # a smaller one on the same joint: p(fault) must lie between the healthy robot's and 0.3 A's


def _synthetic_table(rng: np.random.Generator, n: int = 240) -> pd.DataFrame:
    # inputs: the six offset projections and the two known conditions (a subset of what diagnose computes)
    cols = [f"twin_est_current_offset_A_j{j}" for j in range(1, 7)]
    assert set(cols) <= COMPUTABLE
    rows = []
    for k in range(n):
        faulty = k % 2 == 1
        joint = int(rng.integers(1, 7)) if faulty else 0
        r = {c: float(rng.normal(0.0, 0.01)) for c in cols}
        r["payload_kg"], r["temperature_C"] = float(rng.uniform(0, 3)), float(rng.uniform(15, 45))
        size = float(rng.uniform(0.1, 0.5)) if faulty else float("nan")
        if faulty:
            r[f"twin_est_current_offset_A_j{joint}"] = size * rng.choice([-1.0, 1.0])
        r.update(fault="current_sensor_offset" if faulty else "healthy", fault_joint=joint,
                 fault_scope="joint" if faulty else "none", fault_size=size, status="ok",
                 split="test" if k % 4 >= 2 else "train", split_group=f"g{k % 4}:{k}")
        rows.append(r)
    return pd.DataFrame(rows)


def _save_stand_in(folder: Path, calibrated: bool, limit_calibration: dict | None = None,
                   twin_com_twins: bool = False) -> Path:
    ds = load_dataset(_synthetic_table(np.random.default_rng(0)), "twin")
    models = fit_models(ds, seed=0)
    healthy = (ds.test["fault"] == "healthy").to_numpy()
    joint_thr = alarm_threshold(joint_kind.fault_score(models.joint_kind, ds.test, ds.inputs), healthy)
    info = None
    if calibrated:
        models.calibrator, fit = fit_calibration(ds, seed=0)
        info = fit["info"]
    save_models(models, ds, "twin", 0.5, folder, window_s=WINDOW_S, log_period_s=1e-3, calibration=info,
                joint_kind_threshold=joint_thr, limit_calibration=limit_calibration, twin_com_twins=twin_com_twins)
    return folder


@pytest.fixture(scope="module")
def detector(tmp_path_factory) -> Path:
    return _save_stand_in(tmp_path_factory.mktemp("detector"), calibrated=False)


@pytest.fixture(scope="module")
def calibrated_detector(tmp_path_factory) -> Path:
    return _save_stand_in(tmp_path_factory.mktemp("calibrated"), calibrated=True)


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("logs")
    out = {}
    for name, extra in (("healthy", []),
                        ("offset", ["--effect", f"current_sensor_offset@wrist_1_joint:offset_A={OFFSET_A}"]),
                        ("small_offset",
                         ["--effect", f"current_sensor_offset@wrist_1_joint:offset_A={SMALL_OFFSET_A}"])):
        out[name] = folder / f"{name}.parquet"
        assert main(["simulate", "--duration-s", str(LOG_S), "--seed", "3", *extra, "--out", str(out[name])]) == 0
    return out


def _diagnose(log: Path, detector: Path, out: Path) -> dict:
    assert main(["diagnose", str(log), "--format", "sim", "--detector", str(detector), "--out", str(out),
                 "--quiet"]) == 0
    return json.loads((out / "diagnosis.json").read_text())


def test_healthy_log_runs_and_writes_the_schema(logs, detector, tmp_path):
    d = _diagnose(logs["healthy"], detector, tmp_path / "h")
    assert (tmp_path / "h" / "report.md").exists() and (tmp_path / "h" / "diagnosis.png").exists()
    assert d["n_windows"] == 2 and d["detector"]["window_s"] == WINDOW_S
    for w in d["windows"]:
        assert w["end_s"] - w["start_s"] == pytest.approx(WINDOW_S)
        assert 0.0 <= w["p_fault"] <= 1.0 and isinstance(w["flagged"], bool)
        assert [j["joint"] for j in w["joints"]] == [1, 2, 3, 4, 5, 6]
        assert max(j["p_fault_joint"] for j in w["joints"]) == pytest.approx(w["p_fault"])
        assert isinstance(w["flagged_run_level"], bool) and 0.0 <= w["p_fault_run_level"] <= 1.0
        for j in w["joints"]:
            # the window's current-noise ratio at rest: a healthy log's sensor is the twin's (null: too little rest)
            r = j["current_noise_ratio_rest"]
            assert r is None or 0.8 < r < 1.25, (j["joint"], r)
            for k in j["kinds"]:
                assert set(k) == {"kind", "p_given_fault", "size", "unit", "interval", "cannot_tell",
                                  "variance_inflation", "confounded", "same_signature_as"}
                assert k["same_signature_as"] == {"current_sensor_gain": ["torque_constant"],
                                                  "torque_constant": ["current_sensor_gain"]}.get(k["kind"], [])
    # the simulated log has motor encoders: nothing is blind for want of them
    assert not any("motor encoders" in r for w in d["windows"] for j in w["joints"] for r in j["cannot_tell"].values())


def test_current_offset_on_wrist_1_is_found_there_at_its_size(logs, detector, tmp_path):
    healthy = _diagnose(logs["healthy"], detector, tmp_path / "h")
    d = _diagnose(logs["offset"], detector, tmp_path / "o")
    told = clean = 0
    for w, wh in zip(d["windows"], healthy["windows"]):
        j4 = w["joints"][3]
        k = next(k for k in j4["kinds"] if k["kind"] == "current_sensor_offset")
        if k["cannot_tell"]:  # a window whose wrist-1 current hardly varies: no size, and said why
            assert k["size"] is None and "current_sensor_offset" in j4["cannot_tell"]
            continue
        told += 1
        assert w["flagged"]
        if wh["joints"][3]["p_fault_joint"] < 0.5:  # wrist 1 of the healthy robot looks healthy in this window
            # (in a window whose fit is confounded it may not: a spurious healthy estimate of -0.2 A that the
            # offset moves to +0.1 A; the classifier then cannot tell the offset there)
            clean += 1
            assert j4["p_fault_joint"] == max(j["p_fault_joint"] for j in w["joints"])
            assert j4["p_fault_joint"] > wh["joints"][3]["p_fault_joint"]
        # physics: the speed and position loops hold the true current where the motion needs it, so the
        # reading carries the offset: the projection moves by 0.3 A against the same robot without it (same
        # noise seeds, and the projection is linear in the residual; whatever the healthy window already
        # projects there, e.g. a confounded gain or Coulomb share, cancels)
        kh = next(k for k in wh["joints"][3]["kinds"] if k["kind"] == "current_sensor_offset")
        assert k["size"] - kh["size"] == pytest.approx(OFFSET_A, abs=0.01)
        if not k["confounded"]:
            assert k["size"] == pytest.approx(OFFSET_A, abs=0.03)
    assert told >= 1 and clean >= 1


#: largest current-offset estimate a healthy window may give [A]: under half the smallest offset of the upper half
#: of the diagnostics campaigns' range (0.005-0.5 A log-uniform: upper half from 0.05 A), so that no healthy
#: window reads as a fault of the sizes the benchmark's goals are set on
HEALTHY_OFFSET_A = 0.02


def _offsets(log_path: Path, com_twins: bool = False) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per 2.5 s window: the current-offset estimates of the six joints, their standard errors and VIFs."""
    from ur5fault.health.diagnosis import replay_twin
    from ur5fault.health.diagnosis.windows import window_features, window_length
    from ur5fault.logs import read_log

    log = read_log(log_path, "sim", window_length(WINDOW_S))
    ws = window_features(log, *replay_twin(log, com_twins=com_twins), WINDOW_S, {"payload_kg": float(log.payload_kg)})
    return [tuple(np.array([w.features[f"twin_est_current_offset_A{x}_j{j}"] for j in range(1, 7)])
                  for x in ("", "_se")) + (np.array([v["current_offset_A"] for v in w.vif]),) for w in ws]


def test_healthy_window_gives_no_current_offset_and_an_injected_one_comes_out(logs):
    # the simulated pick-and-place grips its 2 kg payload 1.7 s in; the twin used to hold it from the start, and
    # the first 2.5 s window gave offsets of 1.07 A on the shoulder and 0.52 A on wrist 2 (the gravity torque of
    # a payload the robot did not yet hold): the log now carries the gripper's schedule and the twin follows it
    from ur5fault.health.diagnosis.score import MAX_VIF

    healthy, small = _offsets(logs["healthy"]), _offsets(logs["small_offset"])
    for est, _, vif in healthy:  # where the offset is told apart from the other columns of its fit
        told = vif <= MAX_VIF
        assert told.sum() >= 2 and np.all(np.abs(est[told]) < HEALTHY_OFFSET_A), (est, vif)
    for (h, _, _), (s, _, vif) in zip(healthy, small):  # 0.1 A on wrist 1: there, and nowhere else
        assert s[3] - h[3] == pytest.approx(SMALL_OFFSET_A, abs=0.002)
        np.testing.assert_allclose(np.delete(s - h, 3), 0.0, atol=0.002)
        if vif[3] <= MAX_VIF:
            assert s[3] == pytest.approx(SMALL_OFFSET_A, abs=HEALTHY_OFFSET_A)


@pytest.mark.xfail(strict=True, reason="not found yet: the shoulder's first-window offset is 0.010 A at 3.6 standard "
                                       "errors (its fit confounded, VIF 43); every other estimate is within 3 "
                                       "(with the CoM twins of twin_com_twins every estimate is: the next test)")
def test_healthy_window_offsets_within_three_standard_errors_of_zero(logs):
    for est, se, _ in _offsets(logs["healthy"]):
        assert np.all(np.abs(est) <= 3.0 * se), (est, se)


def test_healthy_window_offsets_within_three_standard_errors_of_zero_with_com_twins(logs):
    # the same windows with the payload CoM columns from CoM-shifted noise-free twins (twin_com_twins)
    for est, se, _ in _offsets(logs["healthy"], com_twins=True):
        assert np.all(np.abs(est) <= 3.0 * se), (est, se)


def test_a_detector_trained_with_com_twins_has_them_replayed(logs, tmp_path_factory):
    # a campaign with twin_com_twins fits the payload CoM with columns from CoM-shifted noise-free twins: diagnose
    # replays them for such a detector, and refuses a twin replayed without them (its features would differ)
    from ur5fault.errors import ParameterError
    from ur5fault.health.diagnosis import diagnose, replay_twin
    from ur5fault.logs import read_log

    det = _save_stand_in(tmp_path_factory.mktemp("com_twins"), calibrated=False, twin_com_twins=True)
    log = read_log(logs["healthy"], "sim")
    plain = replay_twin(log)
    assert plain[1].com_A_per_m is None
    with pytest.raises(ParameterError, match="CoM twins"):
        diagnose(log, det, twin=plain)
    replay, rep = replay_twin(log, com_twins=True)
    assert rep.com_A_per_m.shape == (*rep.current_true_A.shape, 3)
    assert np.abs(rep.com_A_per_m[:, 1:5]).max() > 0  # J2-J5 carry the held payload's CoM torque
    out = diagnose(log, det, twin=(replay, rep))
    assert out["windows"] and all(np.isfinite(w["p_fault"]) for w in out["windows"])


def test_a_simulated_log_carries_the_grippers_schedule(logs):
    from ur5fault.logs import read_log
    from ur5fault.sim.trajectories import pick_and_place

    log = read_log(logs["healthy"], "sim")
    np.testing.assert_array_equal(log.payload_held, pick_and_place().gripped(log.t_s))
    assert log.payload_held.any() and not log.payload_held.all()  # the window holds a grip
    traj = log.to_trajectory()
    np.testing.assert_array_equal(traj.gripped(log.t_s - log.t_s[0]), log.payload_held)


def test_p_fault_is_the_calibrated_by_joint_score_and_grows_with_the_offset(logs, calibrated_detector, tmp_path):
    from ur5fault.health.diagnostics.calibration import apply
    from ur5fault.health.diagnostics.saved import load_models

    models, schema = load_models(calibrated_detector)
    runs = {name: _diagnose(logs[name], calibrated_detector, tmp_path / name)
            for name in ("healthy", "small_offset", "offset")}
    assert runs["offset"]["detector"]["calibrated"] is True
    thr = schema["joint_kind_threshold_5pct_false_alarms"]
    told = 0
    for wh, ws, wo in zip(*(runs[n]["windows"] for n in ("healthy", "small_offset", "offset"))):
        for w in (wh, ws, wo):  # the calibrated score of the kind classifier by joint, flagged at its threshold
            assert w["p_fault"] == pytest.approx(float(apply(models.calibrator, np.array([w["p_fault_score"]]))[0]))
            assert w["flagged"] == (w["p_fault_score"] > thr)
        if wo["joints"][3]["cannot_tell"].get("current_sensor_offset") or wh["joints"][3]["p_fault_joint"] >= 0.5:
            continue  # no offset estimate on wrist 1, or the healthy robot's wrist 1 already looks faulty here
        told += 1
        # monotone in the offset written into wrist 1's current sensor, 0 <= 0.1 A <= 0.3 A, on that joint and
        # in p(fault); 0.3 A flagged there
        p4 = [w["joints"][3]["p_fault_joint"] for w in (wh, ws, wo)]
        assert p4[0] <= p4[1] <= p4[2] and p4[0] < p4[2]
        assert wh["p_fault"] <= ws["p_fault"] <= wo["p_fault"]
        assert wo["flagged"] and max(wo["joints"], key=lambda j: j["p_fault_joint"])["joint"] == 4
    assert told >= 1


def test_the_console_line_says_which_number_is_p_fault_and_which_the_raw_score(logs, detector, calibrated_detector,
                                                                              tmp_path, capsys):
    """`diagnose` printed `p(fault) > 0.976` and, in a note, `the threshold 0.963` without saying that the first is
    the calibrated probability and the second the detector's raw score it is read at; the line names both."""
    for det, calibrated in ((calibrated_detector, True), (detector, False)):
        capsys.readouterr()
        d = _diagnose(logs["healthy"], det, tmp_path / str(calibrated))
        out = capsys.readouterr().out
        ft = d["flag_threshold"]
        scale = (f"the calibrated probability at the detector's raw-score threshold {ft['score']:.3f}" if calibrated
                 else "the detector's raw-score threshold itself (no calibration saved)")
        assert out.startswith(f"{d['log']}: {d['n_flagged']} of {d['n_windows']} windows of "
                              f"{d['detector']['window_s']:.3g} s flagged (p(fault) > {ft['p_fault']:.3f}, {scale}: "
                              "the training runs' 5 % false-alarm point); largest p(fault) "), out
        # two different numbers where calibrated (else the test could not tell them apart), one where not
        assert (f"{ft['p_fault']:.3f}" != f"{ft['score']:.3f}") == calibrated


def _rewrite_schema(src: Path, dst: Path, **changes) -> Path:
    import shutil

    shutil.copytree(src, dst)
    p = dst / "models" / SCHEMA_FILE
    schema = json.loads(p.read_text())
    for k, v in changes.items():
        if v is None:
            schema.pop(k, None)
        else:
            schema[k] = v
    p.write_text(json.dumps(schema))
    checksum_path(p).unlink(missing_ok=True)  # as saved before sidecars: edited, not damaged
    return dst


@pytest.mark.parametrize("changes, words", [
    ({"window_s": None}, "training runs' duration"),
    ({"shuffled_labels": True}, "shuffled labels"),
    ({"schema_format": 99}, "schema format"),
    ({"inputs": [{"name": "made_up_feature_j1", "unit": "-"}]}, "do not match"),
])
def test_detector_whose_schema_does_not_match_is_refused(logs, detector, tmp_path, capsys, changes, words):
    bad = _rewrite_schema(detector, tmp_path / "bad", **changes)
    rc = main(["diagnose", str(logs["healthy"]), "--format", "sim", "--detector", str(bad), "--out",
               str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.startswith("ur5fault: error:") and words in err and len(err.splitlines()) == 1
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("window_s", [True, "5", float("nan"), 0.0])
def test_a_schema_without_a_window_length_in_seconds_is_refused(window_s):
    """`window_s: true` in an edited schema.json passed as a window of 1 s (a bool counted as a number)."""
    from ur5fault.health.diagnostics.saved import SCHEMA_FORMAT

    schema = {"schema_format": SCHEMA_FORMAT, "classes": {"detector": {}}, "inputs": [{"name": sorted(COMPUTABLE)[0]}]}
    assert check_schema({**schema, "window_s": np.float64(5.0)}, "d") == 5.0
    with pytest.raises(ConfigFileError, match=r"^d: the schema does not say the training runs' duration \(window_s\)"):
        check_schema({**schema, "window_s": window_s}, "d")


@pytest.mark.parametrize("argv, words", [
    (["--format", "sim", "--payload-kg", "1"], "--payload-kg applies to --format rtde only"),
    (["--format", "nist"], ""),
    ([], "--format is required"),
])
def test_bad_input_is_one_line(logs, detector, tmp_path, capsys, argv, words):
    rc = main(["diagnose", str(logs["healthy"]), *argv, "--detector", str(detector), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.startswith("ur5fault: error:") and words in err and len(err.splitlines()) == 1


def test_missing_detector_and_too_short_log_are_one_line(logs, tmp_path, detector, capsys):
    rc = main(["diagnose", str(logs["healthy"]), "--format", "sim", "--detector", str(tmp_path / "none"),
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "no saved classifiers" in err and len(err.splitlines()) == 1
    long = _rewrite_schema(detector, tmp_path / "long", window_s=10.0)
    rc = main(["diagnose", str(logs["healthy"]), "--format", "sim", "--detector", str(long), "--out",
               str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "needs at least one window of 10 s" in err and len(err.splitlines()) == 1


def test_a_log_of_one_window_is_diagnosed_and_a_shorter_one_refused_naming_the_window(detector, tmp_path, capsys):
    # diagnose fits nothing: a log as long as one window (here 2.6 s, under the 5 s a fit needs) is enough
    short = tmp_path / "short.parquet"
    assert main(["simulate", "--duration-s", "2.6", "--seed", "4", "--out", str(short)]) == 0
    d = _diagnose(short, detector, tmp_path / "s")
    assert d["n_windows"] == 1 and d["duration_s"] < 5.0
    longer = _rewrite_schema(detector, tmp_path / "longer", window_s=3.0)
    capsys.readouterr()
    rc = main(["diagnose", str(short), "--format", "sim", "--detector", str(longer), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.startswith("ur5fault: error: short.parquet: 2.6 s")
    assert "one window of 3 s" in err and len(err.splitlines()) == 1 and not (tmp_path / "o").exists()
    # the fitting commands' reading still refuses it: they fit on a share of the log and judge the rest
    from ur5fault.errors import LogFormatError
    from ur5fault.logs.readers import read_log

    with pytest.raises(LogFormatError, match="fitting needs at least 5 s"):
        read_log(short, "sim")


def test_a_detector_near_chance_on_its_own_test_split_is_said_so(logs, detector, tmp_path):
    """A detector whose benchmark scored AUC 0.54 flagged 10 of 12 healthy NIST windows and the report said nothing of
    how good it was (a newcomer probe): the metrics.json beside the saved classifiers is read for a note."""
    import shutil

    from ur5fault.health.diagnostics.saved import detector_test_auc

    bench = tmp_path / "bench"
    shutil.copytree(detector, bench)
    assert detector_test_auc(bench) is None  # no report beside it: no note
    (bench / "metrics.json").write_text(json.dumps({"detection_by_joint": {"auc_all": 0.54}}))
    models = next(p.parent for p in bench.rglob("schema.json"))
    assert detector_test_auc(bench) == 0.54 and detector_test_auc(models) == 0.54
    d = _diagnose(logs["healthy"], bench, tmp_path / "h")
    said = "by-joint detection AUC on its own campaign's test split is 0.54 (0.5 is chance; "
    assert sum(said in n for n in d["notes"]) == 1
    (bench / "metrics.json").write_text(json.dumps({"detection_by_joint": {"auc_all": 0.93}}))
    assert not any("chance" in n for n in _diagnose(logs["healthy"], bench, tmp_path / "h2")["notes"])


def test_classifiers_saved_without_calibration_load_and_say_so(logs, detector, tmp_path):
    d = _diagnose(logs["healthy"], detector, tmp_path / "h")  # the stand-in detector is saved uncalibrated
    assert d["detector"]["calibrated"] is False
    assert any("without a calibration" in n for n in d["notes"])
    # nor with the detection limits' calibration (its table has no SE columns): the limits are left out, said so
    assert d["detection_limit_z"] is None
    assert not any("detection_limits" in j for w in d["windows"] for j in w["joints"])
    assert sum("without the detection-limit calibration" in n for n in d["notes"]) == 1
    assert all(w["p_fault"] == w["p_fault_score"] for w in d["windows"])
    assert d["detector"]["p_fault_at_threshold"] == d["detector"]["threshold_5pct_false_alarms"]


def test_detection_limits_are_z_spread_se_of_each_window_or_cannot_tell_with_why(logs, tmp_path):
    from ur5fault.health.diagnostics.limits import DEFAULT_Z, ESTIMATE_OF, ESTIMATES, LimitCalibration

    spread = 2.0  # a hand-set calibration: every estimate's healthy t values spread twice their SE
    cal = LimitCalibration({e: (spread,) * 6 for e in ESTIMATES}, {e: (50,) * 6 for e in ESTIMATES})
    det = _save_stand_in(tmp_path / "det", calibrated=False, limit_calibration=cal.to_dict())
    d = _diagnose(logs["healthy"], det, tmp_path / "h")
    assert d["detection_limit_z"] == DEFAULT_Z
    n_finite = 0
    for w, (_, se, _) in zip(d["windows"], _offsets(logs["healthy"]), strict=True):
        for j in w["joints"]:
            assert set(j["detection_limits"]) == set(ESTIMATE_OF)
            lim = j["detection_limits"]["current_sensor_offset"]
            assert lim["unit"] == "A"
            if "current_sensor_offset" in j["cannot_tell"]:  # the window's own rule wins, with its reason
                assert lim["detectable_from"] is None
                assert lim["cannot_tell"] == j["cannot_tell"]["current_sensor_offset"]
            else:
                assert lim["detectable_from"] == pytest.approx(DEFAULT_Z * spread * se[j["joint"] - 1], rel=1e-9)
                n_finite += 1
            for k, v in j["detection_limits"].items():  # null exactly where a reason is given
                assert (v["detectable_from"] is None) == ("cannot_tell" in v), (k, v)
    assert n_finite >= 6
    assert "Smallest fault each joint's motion could show" in (tmp_path / "h" / "report.md").read_text()


def test_a_log_sampled_a_whole_number_of_times_faster_is_taken_at_the_training_rate(detector, tmp_path):
    """A log at 0.5 ms against a detector trained on 1 ms logs was scored with features off its scale (a note
    only): every 2nd sample is what a 1 ms logger writes, so diagnose keeps those and says so; its windows and
    features are then those of the 1 ms log of the same run."""
    fast, slow = tmp_path / "fast.parquet", tmp_path / "slow.parquet"
    for path, period in ((fast, "0.0005"), (slow, "0.001")):
        assert main(["simulate", "--duration-s", str(LOG_S), "--seed", "3", "--log-period-s", period, "--out",
                     str(path), "--quiet"]) == 0
    d = _diagnose(fast, detector, tmp_path / "f")
    assert d["log_period_s"] == pytest.approx(0.001)
    assert any("every 2nd sample kept, as the detector's training runs were logged every 1 ms" in n
               for n in d["notes"]), d["notes"]
    assert not any("not on the scale the detector learned" in n for n in d["notes"]), d["notes"]
    ref = _diagnose(slow, detector, tmp_path / "s")  # the same run logged every 1 ms: the same samples, p(fault)
    assert [w["p_fault"] for w in d["windows"]] == pytest.approx([w["p_fault"] for w in ref["windows"]], abs=1e-9)


NIST_LOG = Path(__file__).resolve().parents[2] / "data" / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"


def test_real_nist_log_few_seconds_diagnosed_without_motor_encoders(detector, tmp_path):
    # a real UR5 log (CB3, 125 Hz, no motor encoders): its first 5.3 s, two windows of the stand-in detector
    head = tmp_path / "nist_head.csv.gz"
    pd.read_csv(NIST_LOG).head(int(5.3 / 0.008) + 1).to_csv(head, index=False)
    assert main(["diagnose", str(head), "--format", "nist", "--detector", str(detector), "--out",
                 str(tmp_path / "n")]) == 0
    d = json.loads((tmp_path / "n" / "diagnosis.json").read_text())
    assert d["n_windows"] == 2 and d["log_period_s"] == pytest.approx(0.008)
    assert any("no motor encoders" in n for n in d["notes"]) and any("every 8 ms" in n for n in d["notes"])
    for w in d["windows"]:
        assert 0.0 <= w["p_fault"] <= 1.0
        for j in w["joints"]:  # what lives in the encoder mismatch is "cannot tell" on every joint, and why
            for k in ("backlash", "resolver_offset", "gear_stiffness"):
                assert "motor encoders" in j["cannot_tell"][k]
            # each kind says its own physics (the position loop holds a resolver offset's reading on the setpoint)
            assert len({j["cannot_tell"][k] for k in ("backlash", "resolver_offset", "gear_stiffness")}) == 3
            assert "holds the offset reading on the setpoint" in j["cannot_tell"]["resolver_offset"]
            est = next(k for k in j["kinds"] if k["kind"] == "current_sensor_offset")
            # A: within the sensor's plausible range where the window tells the offset from the joint's other
            # columns; where it does not (variance inflation above MAX_VIF: the shoulder and elbow, whose current is
            # a near-constant gravity load in a 2.5 s window, VIF ~1e5-1e6) the point estimate can sit anywhere in
            # its standard error, and the diagnosis must say so. (With the noisy twin's current as the regressor,
            # before twin format 3, its noise kept the VIF lower and the estimate near 0 by attenuation:
            # docs/diagnostics.md, "Regressors free of the twin's noise")
            if est["size"] is not None and abs(est["size"]) >= 1.0:
                assert est["confounded"] and est["variance_inflation"] > MAX_VIF


def test_a_campaign_folder_given_as_the_detector_points_at_its_benchmark(tmp_path):
    """`--detector DIR` of a campaign folder whose DIR/benchmark holds the classifiers said only "no saved
    classifiers ...; run ur5fault benchmark" (a newcomer probe)."""
    from ur5fault.health.diagnostics.saved import CLASSIFIERS_FILE, MODELS_DIR, load_models

    models = tmp_path / "camp" / "benchmark" / MODELS_DIR
    models.mkdir(parents=True)
    with pytest.raises(ConfigFileError, match="run `ur5fault benchmark`"):
        load_models(tmp_path / "camp")
    for name in (CLASSIFIERS_FILE, SCHEMA_FILE):
        (models / name).write_text("{}")
    with pytest.raises(ConfigFileError, match=f"did you mean {tmp_path / 'camp' / 'benchmark'} "):
        load_models(tmp_path / "camp")


def test_a_wrong_detector_is_refused_before_an_earlier_report(logs, tmp_path, capsys):
    """The input's refusal first, with its real reason; the --out/--replace check after (a newcomer probe)."""
    out = tmp_path / "o"
    out.mkdir()
    (out / "report.md").write_text("earlier")
    (tmp_path / "camp").mkdir()  # an existing folder of the wrong kind (a missing one: the --out check first)
    rc = main(["diagnose", str(logs["healthy"]), "--format", "sim", "--detector", str(tmp_path / "camp"),
               "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "no saved classifiers" in err and "earlier result" not in err, err


def test_a_shuffled_label_control_given_as_the_detector_is_named(tmp_path, capsys):
    """`--detector` of a `benchmark --shuffle-labels` folder said only "no saved classifiers" (a newcomer probe)."""
    (tmp_path / "metrics.json").write_text(json.dumps({"shuffled_labels": True}))
    from ur5fault.errors import ConfigFileError
    from ur5fault.health.diagnostics.saved import load_models

    with pytest.raises(ConfigFileError, match="a shuffled-label control .* saves no classifiers"):
        load_models(tmp_path)
    (tmp_path / "metrics.json").write_text(json.dumps({"shuffled_labels": False}))
    with pytest.raises(ConfigFileError, match="no saved classifiers"):
        load_models(tmp_path)
