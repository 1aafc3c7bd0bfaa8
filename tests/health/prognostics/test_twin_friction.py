"""The friction rise the twin learns from the inspections (twin_friction.py) instead of assuming the wear law's:
constructed units whose friction rise is known, no simulation."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from synthetic_wear import linear_wear_fleet

import ur5fault.health.prognostics.twin_boundary as TB
from ur5fault.cli import main
from ur5fault.health.prognostics.clearance_rul import ClearanceRUL
from ur5fault.health.prognostics.spec import Failure
from ur5fault.health.prognostics.twin_boundary import Ray, TwinSetup
from ur5fault.health.prognostics.twin_cache import RadiusCache
from ur5fault.health.prognostics.twin_friction import FrictionRise, fit_rise, posterior
from ur5fault.health.prognostics.twin_rul import TwinRUL
from ur5fault.health.prognostics.wear import WearLaw

#: the constructed fleet's friction law (not the wear law's defaults, 5 /deg and 0.05 /Mcycle): the rise per
#: degree of clearance and per 10^6 cycles (the synthetic units live ~2e4 cycles, so the ageing term is large)
F_DEG, F_MCYCLE = 3.7, 2.0
#: sd of the friction-carrying feature's noise, in friction-rise units
F_NOISE = 0.005


def _with_friction(df, seed: int = 0):
    """The synthetic fleet (clearances of joints 2 and 3 growing linearly) with its measured friction factor
    ``1 + F_DEG b_j + F_MCYCLE N / 1e6`` per joint and a current feature that reads 4x the friction rise
    plus noise (the friction-carrying feature a robot's current gives)."""
    rng = np.random.default_rng(seed)
    out = df.copy()
    for j in range(1, 7):
        rise = F_DEG * out[f"backlash_deg_j{j}"] + F_MCYCLE * out["cycles"] * 1e-6
        out[f"friction_scale_j{j}"] = 1.0 + rise
        out[f"current_hf_energy_A2s_j{j}"] = 4.0 * (rise + F_NOISE * rng.standard_normal(len(out)))
    return out


def test_a_known_friction_rise_is_recovered_within_its_interval():
    # one constructed unit: six joints' clearances growing at different rates (one not at all), its friction
    # rise 3.7 /deg and 2 /Mcycle plus white noise of sd 0.01
    n = np.arange(0, 21) * 4e4
    rates = np.array([1.0, 3.0, 5.0, 0.5, 0.0, 0.2]) * 1e-8            # deg per cycle
    a = np.outer(n, rates)
    hits = 0
    for seed in range(40):
        y = F_DEG * a + F_MCYCLE * np.outer(n, np.ones(6)) * 1e-6 + 0.01 * np.random.default_rng(seed).normal(
            size=a.shape)
        b, cov, _ = fit_rise(n, a, y)
        z = np.abs(b - [F_DEG, F_MCYCLE]) / np.sqrt(np.diag(cov))
        hits += bool((z < 1.96).all())
        # the conjugate posterior under a vague prior centred elsewhere (the wear law's 5 and 0.05) is the fit
        m, c = posterior(np.array([5.0, 0.05]), np.diag([100.0, 100.0]), 1e-4, n, a, y)
        assert m == pytest.approx(b, abs=0.02 * np.sqrt(np.diag(cov)).max() + 1e-3)
    # 95 % intervals of two estimates: about 0.9 of the 40 units have both inside (binomial: >= 0.75 at 3 sd)
    assert hits >= 30


def test_the_friction_rise_is_learned_from_the_features_of_a_constructed_fleet():
    train = _with_friction(linear_wear_fleet(30, 0, "a"), 0)
    test = _with_friction(linear_wear_fleet(10, 1, "b"), 1)
    clear = ClearanceRUL().fit(train)
    fr = FrictionRise().fit(train, clear)
    # the training units' cross-fitted rises give a population estimate of the law the fleet was made with
    assert fr.prior_mean_[0] == pytest.approx(F_DEG, rel=0.05)
    assert fr.prior_mean_[1] == pytest.approx(F_MCYCLE, rel=0.15)
    # each held-out unit from its own features only (its friction columns are not read: removed)
    blind = test.drop(columns=[f"friction_scale_j{j}" for j in range(1, 7)] + [f"backlash_deg_j{j}" for j in
                                                                                 range(1, 7)])
    y, a = fr.rises(blind), clear.clearances(blind)
    for uid in blind["unit_id"].unique():
        rows = (blind["unit_id"] == uid).to_numpy()
        mean, cov = fr.unit(blind["cycles"].to_numpy(float)[rows], a[rows], y[rows])
        sd = np.sqrt(np.diag(cov))
        assert abs(mean[0] - F_DEG) < 3 * sd[0] + 0.05 * F_DEG, uid


def test_a_fleet_whose_friction_never_rises_learns_zero_not_nan():
    """A wear law with both friction rises 0 (valid): every training residual is exactly 0; the residual variance
    was 0 and each unit's posterior 0/0 = NaN, which the wear law then refused as out of range."""
    train = linear_wear_fleet(30, 0, "a")
    for j in range(1, 7):
        train[f"friction_scale_j{j}"] = 1.0
        train[f"current_hf_energy_A2s_j{j}"] = 0.01 * np.random.default_rng(j).standard_normal(len(train))
    clear = ClearanceRUL().fit(train)
    fr = FrictionRise().fit(train, clear)
    uid = train["unit_id"].iloc[0]
    rows = (train["unit_id"] == uid).to_numpy()
    mean, _ = fr.unit(train["cycles"].to_numpy(float)[rows], clear.clearances(train)[rows], fr.rises(train)[rows])
    assert np.all(np.isfinite(mean)) and np.allclose(mean, 0.0, atol=1e-6)
    from ur5fault.health.prognostics.twin_rul import _in_range

    assert _in_range("friction_per_deg", -0.3) == 0.0 and _in_range("friction_per_deg", 250.0) == 100.0


def test_a_fleet_without_measured_friction_cannot_learn_it():
    train = linear_wear_fleet(10, 0, "a")
    with pytest.raises(ValueError, match="--twin-friction law"):
        FrictionRise().fit(train, ClearanceRUL().fit(train))


def test_the_twin_runs_the_learned_rise_not_the_law_it_was_told(monkeypatch, tmp_path):
    """Rays carry each unit's learned rise; the radius file keys a ray by the law it runs, so a twin told
    another friction_per_deg simulates nothing new (the told constants are not used)."""
    train = _with_friction(linear_wear_fleet(30, 0, "a"), 0)
    test = _with_friction(linear_wear_fleet(6, 1, "b"), 1)
    clear = ClearanceRUL().fit(train)
    fr = FrictionRise().fit(train, clear)
    seen: list[tuple[float, float]] = []

    def fake(setup, traj, pts, done=None):  # done: the progress, unused here
        seen.extend((setup.wear.friction_per_deg, ray.law(setup.wear).friction_per_deg) for ray, _ in pts)
        return np.array([5.0 * s for _, s in pts])

    monkeypatch.setattr(TB, "_criteria", fake)
    y, a = fr.rises(test), clear.clearances(test)
    units = {}
    rises = {}
    for uid, g in test.groupby("unit_id"):
        ii = test.index.get_indexer(g.index)
        units[uid] = (("task", 1.0, 25.0), g["cycles"].to_numpy(float)[:-1], a[ii][:-1])
        rises[uid] = y[ii][:-1]
    cond = {u: ("task", 1.0, 25.0) for u in train["unit_id"].unique()}
    out = {}
    for told in (3.0, 8.0):
        setup = TwinSetup(WearLaw(friction_per_deg=told), Failure("tcp_dev_max_mm", 0.5))
        cache = RadiusCache(tmp_path / "radii.json")
        twin = TwinRUL(setup, clear, cache=cache, friction=fr).calibrate(cond)
        out[told] = twin.predict_units(units, rises)
        if told == 3.0:
            assert cache.misses > 0
            ran = np.array([r for _, r in seen])
            assert {t for t, _ in seen} == {3.0}               # told 3 ...
            assert ran == pytest.approx(F_DEG, rel=0.1)        # ... ran the learned ~3.7 on every ray
        else:
            assert cache.misses == 0 and cache.hits > 0        # told 8: the same laws run, read from the file
    assert out[3.0] == out[8.0]
    with pytest.raises(ValueError, match="friction-rise"):
        twin.predict_units(units)


def test_a_ray_without_a_rise_of_its_own_keeps_the_law_and_its_key():
    law = WearLaw(friction_per_deg=3.0)
    ray = Ray("t", 1.0, 25.0, (0.0, 0.6, 0.8, 0.0, 0.0, 0.0), 1e-7, 0.1)
    assert ray.law(law) is law
    own = dataclasses.replace(ray, friction_per_deg=4.5, friction_per_Mcycle=0.1)
    assert (own.law(law).friction_per_deg, own.law(law).friction_per_Mcycle, own.law(law).stiffness_loss_per_deg) == (
        4.5, 0.1, law.stiffness_loss_per_deg)


def test_twin_friction_without_twin_is_one_line_exit_2(tmp_path, capsys):
    assert main(["prognose", str(tmp_path), "--twin-friction", "law"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ur5fault: error:") and "--twin" in err[0]


def test_learning_on_a_fleet_without_friction_columns_is_one_line_exit_2(tmp_path, capsys):
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    df = linear_wear_fleet(12, 0, "a")
    df = df.assign(split=np.where(df["unit_id"] < "a009", "train", "test"), failed=df["rul_cycles"] == 0,
                   censored=False, tcp_dev_max_mm=0.5 * (df["backlash_deg_j2"] + 5 * df["backlash_deg_j3"]),
                   payload_kg=1.0, temperature_C=25.0)
    df.to_parquet(fleet / "inspections.parquet")
    (fleet / "manifest.json").write_text(json.dumps({"wear": {}, "identity_inputs": {},
                                                     "failure": {"feature": "tcp_dev_max_mm", "threshold": 0.5}}))
    assert main(["prognose", str(fleet), "--out", str(tmp_path / "bench"), "--twin"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ur5fault: error:") and "friction" in err[0]
    with pytest.raises(SystemExit) as exc:                     # argparse's own usage error: one line, exit 2
        main(["prognose", str(fleet), "--out", str(tmp_path / "bench"), "--twin", "--twin-friction", "bogus"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ur5fault: error:") and "bogus" in err[0]


def _fleet_dir(tmp_path):
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    df = _with_friction(linear_wear_fleet(24, 0, "a"), 0)
    df = df.assign(split=np.where(df["unit_id"] < "a018", "train", "test"), failed=df["rul_cycles"] == 0,
                   censored=False, tcp_dev_max_mm=0.5 * (df["backlash_deg_j2"] + 5 * df["backlash_deg_j3"]),
                   payload_kg=1.0, temperature_C=25.0)
    df.to_parquet(fleet / "inspections.parquet")
    (fleet / "manifest.json").write_text(json.dumps({"wear": {"friction_per_deg": 8.0}, "identity_inputs": {},
                                                     "failure": {"feature": "tcp_dev_max_mm", "threshold": 0.5}}))
    return fleet


@pytest.mark.parametrize("how", [None, "law"])
def test_prognose_twin_learns_the_rise_by_default_and_runs_the_law_when_asked(monkeypatch, tmp_path, how):
    ran: list[float] = []

    def fake(setup, traj, pts, done=None):  # the synthetic fleet's boundary, b2 + 5 b3 = 1 deg
        ran.extend(ray.law(setup.wear).friction_per_deg for ray, _ in pts)
        return np.array([0.5 * s * (ray.direction[1] + 5 * ray.direction[2]) for ray, s in pts])

    monkeypatch.setattr(TB, "_criteria", fake)
    out = tmp_path / "bench"
    assert main(["prognose", str(_fleet_dir(tmp_path)), "--out", str(out), "--twin",
                 *(["--twin-friction", how] if how else [])]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    fr = metrics["fitted"]["twin"]["friction"]
    assert metrics["goals"]["baseline"] == "twin"  # the goals are judged on the twin where it ran
    report = (out / "report.md").read_text()
    if how is None:                             # learned: the fleet's 3.7 /deg, not the manifest's 8
        assert fr["source"] == "learned" and fr["learned"]["friction_per_deg_mean"] == pytest.approx(F_DEG, rel=0.05)
        assert np.array(ran) == pytest.approx(F_DEG, rel=0.1)
        assert "learned per unit" in report
    else:
        assert fr["source"] == "law" and fr["learned"] is None and set(ran) == {8.0}
        assert "of the wear law" in report
    assert "the twin ran the packaged model, the fleet's own (--model: another)" in report


def test_the_report_names_the_model_the_twin_ran(monkeypatch, tmp_path):
    """`prognose --twin --model OVERLAY`: metrics.json recorded the overlay, report.md did not say which model the
    twin ran (a newcomer probe)."""
    monkeypatch.setattr(TB, "_criteria", lambda setup, traj, pts, done=None: np.array(
        [0.5 * s * (ray.direction[1] + 5 * ray.direction[2]) for ray, s in pts]))
    ov = tmp_path / "ov.yaml"
    ov.write_text("effects: [{effect: current_sensor_offset, joint: 1, offset_A: 0.05}]\n")
    out = tmp_path / "bench"
    assert main(["prognose", str(_fleet_dir(tmp_path)), "--out", str(out), "--twin", "--model", str(ov)]) == 0
    report = (out / "report.md").read_text()
    said = report.split("the twin ran a model overlay (--model): parameter groups none; effects ")[1]
    assert said.startswith("current_sensor_offset") and "0.05" in said.split(")")[0], said[:200]
