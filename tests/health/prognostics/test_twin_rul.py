"""The twin-boundary RUL estimator: its radius search against a criterion known in closed form (no
simulation), and the whole path on a tiny simulated fleet (slow)."""

from __future__ import annotations

import dataclasses
import json
import logging

import numpy as np
import pandas as pd
import pytest
from synthetic_wear import LEVER, linear_wear_fleet

import ur5fault.health.prognostics.twin_boundary as TB
from ur5fault.cli import main
from ur5fault.health.prognostics.clearance_rul import ClearanceRUL, line_rates
from ur5fault.health.prognostics.fleet import run_life
from ur5fault.health.prognostics.spec import Failure, build_life
from ur5fault.health.prognostics.twin_boundary import Ray, TwinSetup, failure_radii
from ur5fault.health.prognostics.twin_rul import TwinRUL
from ur5fault.health.prognostics.wear import WearLaw

from tiny_fleet import TINY

SETUP = TwinSetup(WearLaw(), Failure("tcp_dev_max_mm", 0.5))


def _ray(d2: float, d3: float, guess: float, traj: str = "task") -> Ray:
    d = np.array([0.0, d2, d3, 0.0, 0.0, 0.0])
    return Ray(traj, 1.0, 25.0, tuple(d / np.linalg.norm(d)), 1e-7, guess)


def _closed_form(monkeypatch, crit) -> list[int]:
    """Replace the simulation by ``crit(ray, radius)``; return the batch sizes asked for."""
    calls: list[int] = []

    def fake(setup, traj, pts, done=None):  # done: the progress, unused here
        calls.append(len(pts))
        return np.array([crit(ray, s) for ray, s in pts])

    monkeypatch.setattr(TB, "_criteria", fake)
    return calls


def test_radius_of_a_linear_criterion_is_found_exactly(monkeypatch):
    # criterion = 0.5 mm x (s d2 + 5 s d3) / 0.1: meets 0.5 mm at s = 0.1 / (d2 + 5 d3), linear: interpolation exact
    _closed_form(monkeypatch, lambda ray, s: 5.0 * s * (ray.direction[1] + 5 * ray.direction[2]))
    rays = [_ray(1, 1, 0.03), _ray(2, 1, 0.05), _ray(1, 2, 0.01)]
    expect = [0.1 / (r.direction[1] + 5 * r.direction[2]) for r in rays]
    assert failure_radii(SETUP, rays) == pytest.approx(expect, rel=1e-9)


def test_a_jump_is_located_within_the_refined_bracket_and_far_guesses_are_extended(monkeypatch):
    # smooth growth to 0.4 mm at s = 0.1, then a jump to 0.7 mm at s = 0.1 exactly (the elbow's cliff)
    calls = _closed_form(monkeypatch, lambda ray, s: 4.0 * s if s < 0.1 else 0.7)
    # the guess right, 2.5x too far (searched below the coarse grid), 2.5x too near (searched above it); the
    # radius lies within the refined bracket: the crossing coarse bracket's width / (REFINE + 1)
    for guess, grid in ((0.1, TB.COARSE), (0.25, TB.BELOW + TB.COARSE[:1]), (0.04, TB.COARSE[-1:] + TB.ABOVE)):
        r = failure_radii(SETUP, [_ray(1, 1, guess)])[0]
        s = np.asarray(grid) * guess
        k = int(np.searchsorted(s, 0.1))
        step = (s[k] - s[k - 1]) / (TB.REFINE + 1)
        assert 0.1 - step <= r <= 0.1 + step, guess
    assert max(calls) <= len(TB.COARSE)


def test_a_ray_that_never_fails_reports_its_last_radius_as_a_bound(monkeypatch):
    _closed_form(monkeypatch, lambda ray, s: 0.0)
    assert failure_radii(SETUP, [_ray(1, 1, 0.1)])[0] == pytest.approx(max(TB.ABOVE) * 0.1)


def test_the_search_reports_its_progress_a_ray_at_a_time(monkeypatch, tmp_path, capsys):
    """`prognose --twin` ran its boundary simulations for minutes without a word off a terminal: the search now
    reports each simulated batch as a share of its rays (a third of a ray per stage), on a bar or plain lines,
    the rays in the radius cache not counted."""
    from ur5fault.health.prognostics.twin_cache import RadiusCache
    from ur5fault.util import progress

    batches = []

    def fake(setup, traj, pts, done=None):
        batches.append(done is not None)
        if done is not None:
            done(len(pts))
        return np.array([5.0 * s for _, s in pts])

    monkeypatch.setattr(TB, "_criteria", fake)
    rays = [_ray(1, 1, 0.03), _ray(2, 1, 0.05), _ray(1, 2, 0.01, traj="other")]
    steps = []
    radii = failure_radii(SETUP, rays, steps.append)
    assert sum(steps) == pytest.approx(len(rays)) and all(0 < s <= 2 / TB.STAGES for s in steps)
    assert np.array_equal(failure_radii(SETUP, rays), radii) and batches[-1] is False  # no callback: none asked for
    monkeypatch.setattr(progress, "LINE_INTERVAL_S", 0.0)  # every update a line (captured stderr: no terminal)
    train = linear_wear_fleet(40, 0, "a")
    clear = ClearanceRUL(ridge=1e-8).fit(train)
    cond = {u: ("task", 1.0, 25.0) for u in train["unit_id"].unique()}
    cache = RadiusCache(tmp_path / "radii.json")
    twin = TwinRUL(SETUP, clear, cache=cache, progress=True).calibrate(cond)
    lines = capsys.readouterr().err.splitlines()
    n = twin.n_calibration_rays_
    assert lines[0].startswith("prognose: twin boundary, calibration: ") and f"/{n} rays (" in lines[0]
    assert lines[-1].startswith(f"prognose: twin boundary, calibration: {n}/{n} rays (100 %), ")
    assert all("\r" not in ln and "\x1b" not in ln for ln in lines)
    TwinRUL(SETUP, clear, cache=cache, progress=True).calibrate(cond)  # every ray cached: nothing to report
    TwinRUL(SETUP, clear, cache=RadiusCache(tmp_path / "other.json")).calibrate(cond)  # progress off
    assert capsys.readouterr().err == ""


def test_twin_rul_of_a_linear_drift_with_a_known_boundary(monkeypatch):
    # the twin replaced by the synthetic fleet's own criterion, 0.5 mm x (b2 + 5 b3): its boundary is exact, so
    # the calibration finds no bias, and the RUL errs only by the growth line's estimate (closed-form truth)
    calls = _closed_form(monkeypatch, lambda ray, s: 0.5 * s * (LEVER[2] * ray.direction[1]
                                                                + LEVER[3] * ray.direction[2]))
    train, test = linear_wear_fleet(40, 0, "a"), linear_wear_fleet(30, 1, "t")
    clear = ClearanceRUL(ridge=1e-8).fit(train)
    twin = TwinRUL(SETUP, clear).calibrate({u: ("task", 1.0, 25.0) for u in train["unit_id"].unique()})
    cal = [twin.calibration_[c] for c in sorted(twin.calibration_)]
    assert len(cal) >= 2 and all(abs(bias) < 0.03 and n_rays >= 2 for bias, _, n_rays in cal)
    # the spread carries the direction's error, which the history shrinks: largest after one interval
    sds = [sd for _, sd, _ in cal]
    assert sds == sorted(sds, reverse=True) and sds[-1] < 0.05
    units, truth = {}, {}
    for uid, g in test.groupby("unit_id"):
        g = g.sort_values("cycles")
        k = int(np.argmin(np.abs(g["cycles"] / g["eol_cycles"] - 0.5)))
        units[uid] = (("task", 1.0, 25.0), g["cycles"].to_numpy()[: k + 1], clear.clearances(g)[: k + 1])
        truth[uid] = (g["rul_cycles"].iloc[k], g["eol_cycles"].iloc[0])
    est = twin.predict_units(units)
    err = np.array([(est[u][-1][0] - t) / eol for u, (t, eol) in truth.items()])
    inside = np.mean([est[u][-1][1] <= t <= est[u][-1][2] for u, (t, _) in truth.items()])
    assert np.sqrt(np.mean(err**2)) < 0.05 and abs(err.mean()) < 0.02
    assert 0.75 <= inside <= 1.0
    assert calls  # the boundary came from the (replaced) twin, not from the kernel


def test_twin_without_a_life_manifest_is_one_line_exit_2(tmp_path, capsys):
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    df = linear_wear_fleet(6, 0, "a").assign(split="train", failed=False, censored=False)
    df.to_parquet(fleet / "inspections.parquet")
    assert main(["prognose", str(fleet), "--out", str(tmp_path / "bench"), "--twin"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ur5fault: error:") and "--twin" in err[0]


def test_setup_from_a_manifest():
    m = {"wear": {"friction_per_deg": 3.0}, "failure": {"feature": "tcp_dev_rms_mm", "threshold": 0.2},
         "identity_inputs": {"log_period_s": 0.002, "duration_s": 1.5}}
    s = TwinSetup.from_manifest(m, seed=4)
    assert (s.wear.friction_per_deg, s.failure.threshold, s.log_period_s, s.duration_s, s.seed) == (3.0, 0.2, 0.002,
                                                                                                   1.5, 4)


@pytest.mark.slow
def test_tiny_fleet_prognose_with_the_twin(tmp_path):
    """A tiny fleet simulated, benchmarked with --twin: every estimator predicts every held-out inspection,
    and the twin's radius along a unit's own true direction of growth brackets where that unit failed."""
    spec = {**TINY, "life": {**TINY["life"], "units": 6}, "split": {"test_fraction": 0.34, "seed": 0}}
    camp = build_life(spec, "tiny6")
    run_life(camp, tmp_path / "fleet", jobs=1, progress=False, note=None)
    assert main(["prognose", str(tmp_path / "fleet"), "--out", str(tmp_path / "bench"), "--twin"]) == 0
    m = json.loads((tmp_path / "bench" / "metrics.json").read_text())
    assert {"twin", "clearance", "wiener", "naive"} <= set(m["estimators"])
    df = pd.read_parquet(tmp_path / "fleet" / "inspections.parquet")
    test_rows = int(((df["split"] == "test") & (df["rul_cycles"] > 0)).sum())
    assert len(pd.read_parquet(tmp_path / "bench" / "predictions_twin.parquet")) == test_rows
    # calibrated per task and direction from the first run's radii (a fleet this small calibrates on every
    # training unit either way): the same rays, read from the file, none simulated
    cache = tmp_path / "bench" / "twin_radii.json"
    assert m["fitted"]["twin"]["radius_cache"]["simulated"] > 0 and cache.is_file()
    assert main(["prognose", str(tmp_path / "fleet"), "--out", str(tmp_path / "bench2"), "--twin",
                 "--twin-calibration", "direction", "--twin-cache", str(cache)]) == 0
    m2 = json.loads((tmp_path / "bench2" / "metrics.json").read_text())
    assert m2["fitted"]["twin"]["radius_cache"]["simulated"] == 0 and m2["fitted"]["twin"]["calibration"] == "direction"
    assert len(pd.read_parquet(tmp_path / "bench2" / "predictions_twin.parquet")) == test_rows
    # the twin alone, along the true direction of one unit: the radius lies between its clearance radius at
    # its last sound inspection and at its failed one (to the search's resolution and the noise seeds)
    manifest = json.loads((tmp_path / "fleet" / "manifest.json").read_text())
    setup = TwinSetup.from_manifest(manifest)
    b = [f"backlash_deg_j{j}" for j in range(1, 7)]
    g = df[df["unit_id"] == df["unit_id"].iloc[0]].sort_values("cycles")
    n, a = g["cycles"].to_numpy(float), g[b].to_numpy()
    r = line_rates(n, a)
    d = r / np.linalg.norm(r)
    ray = Ray(str(g["trajectory"].iloc[0]), float(g["payload_kg"].iloc[0]), float(g["temperature_C"].iloc[0]),
              tuple(d), float(np.linalg.norm(r)), float(np.linalg.norm(a[-1])))
    rho = failure_radii(setup, [ray])[0]
    before, after = np.linalg.norm(a[-2]) if len(a) > 1 else 0.0, np.linalg.norm(a[-1])
    assert 0.9 * before <= rho <= 1.1 * after
    # rays of other payloads in the same batches (each against its own reference run) change nothing
    heavy = dataclasses.replace(ray, payload_kg=ray.payload_kg + 1.0)
    both = failure_radii(setup, [heavy, ray, heavy])
    assert both[1] == rho and both[0] == both[2] == failure_radii(setup, [heavy])[0]


def test_the_twin_runs_its_model_overlay():
    """The twin's model overlay reaches its simulations: a shoulder gear of half the packaged stiffness moves
    the failure feature at the same clearance (the fleet's own model: None)."""
    from ur5fault.config import Overlay

    setup = TwinSetup(WearLaw(), Failure(), log_period_s=0.002, duration_s=2.0)
    soft = dataclasses.replace(setup, model=Overlay({"gear": {"stiffness_Nm_per_rad": [6.7e4, 5.5e4, 6.7e4, 1.25e4,
                                                                                       1.25e4, 1.25e4]}}))
    ray = Ray(json.dumps("pick_and_place"), 1.0, 28.0, (0.0, 1.0, 0.0, 0.0, 0.0, 0.0), 1e-7, 0.1)
    packaged = TB._criteria(setup, ray.trajectory, [(ray, 0.1)])
    softer = TB._criteria(soft, ray.trajectory, [(ray, 0.1)])
    assert np.isfinite(packaged).all() and np.isfinite(softer).all()
    assert abs(softer[0] - packaged[0]) > 1e-3 * packaged[0]


def test_a_twin_model_with_wear_effects_is_one_line_exit_2(tmp_path, capsys):
    ov = tmp_path / "ov.yaml"
    ov.write_text("effects: [{effect: backlash, joint: 2, backlash_deg: 0.1}]\n")
    assert main(["prognose", str(tmp_path), "--model", str(ov)]) == 2
    assert "--twin" in capsys.readouterr().err
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    df = linear_wear_fleet(6, 0, "a").assign(split="train", failed=False, censored=False)
    df.to_parquet(fleet / "inspections.parquet")
    (fleet / "manifest.json").write_text(json.dumps({"wear": {}, "identity_inputs": {}, "failure": {}}))
    assert main(["prognose", str(fleet), "--out", str(tmp_path / "bench"), "--twin", "--model", str(ov)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ur5fault: error:") and "backlash" in err[0]


def test_the_search_values_of_each_ray_are_logged_at_debug(monkeypatch, caplog):
    # the elbow's cliff of the jump test: the log shows the criterion below (0.4 x) and above (0.7) the jump
    _closed_form(monkeypatch, lambda ray, s: 4.0 * s if s < 0.1 else 0.7)
    with caplog.at_level(logging.DEBUG, logger=TB.__name__):
        r = failure_radii(SETUP, [_ray(1, 1, 0.1)])[0]
    lines = [m for m in caplog.messages if m.startswith("twin ray direction")]
    assert len(lines) == 1
    pairs = [tuple(map(float, p.split(":"))) for p in lines[0].split("criterion ")[1].split(" -> ")[0].split()]
    assert len(pairs) == len(TB.COARSE) + TB.REFINE
    assert [s for s, _ in pairs] == sorted(s for s, _ in pairs)
    # printed to 4 and 3 decimals: each value is the smooth growth at its radius or the cliff's 0.7
    assert all(v == pytest.approx(4.0 * s, abs=2e-3) or v == pytest.approx(0.7) for s, v in pairs)
    assert {v == pytest.approx(0.7) for _, v in pairs} == {True, False}
    assert lines[0].endswith(f"radius {r:.4f}")
