"""The twin's calibration per duty cycle (twin_calibration.py) and the file of its radii (twin_cache.py):
closed-form cases, no simulation."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from synthetic_wear import LEVER, linear_wear_fleet

import ur5fault.health.prognostics.twin_boundary as TB
from ur5fault.cli import main
from ur5fault.config import Overlay
from ur5fault.errors import ConfigFileError
from ur5fault.health.prognostics.clearance_rul import ClearanceRUL
from ur5fault.health.prognostics.spec import Failure
from ur5fault.health.prognostics.twin_boundary import Ray, TwinSetup
from ur5fault.health.prognostics.twin_cache import RadiusCache
from ur5fault.health.prognostics.twin_calibration import task_calibration
from ur5fault.health.prognostics.twin_rul import TwinRUL
from ur5fault.health.prognostics.wear import WearLaw

SETUP = TwinSetup(WearLaw(), Failure("tcp_dev_max_mm", 0.5))


def test_a_biased_task_keeps_its_own_bias_and_the_pooled_mean_sits_between():
    rng = np.random.default_rng(0)
    # task b's twin boundary 0.3 (log) too near, task a's right; scatter 0.02 about each, 30 rays each
    e = np.concatenate([0.02 * rng.standard_normal(30), 0.3 + 0.02 * rng.standard_normal(30)])
    cal = task_calibration(e, ["a"] * 30 + ["b"] * 30)
    assert cal.mu == pytest.approx(0.15, abs=0.01)        # the pooled calibration: wrong by 0.15 on both tasks
    assert cal.at("a")[0] == pytest.approx(0.0, abs=0.01)
    assert cal.at("b")[0] == pytest.approx(0.3, abs=0.01)
    assert cal.at("a")[1] == pytest.approx(0.02, abs=0.006)  # the scatter about the task, not the tasks' spread
    # a task without calibration units: the pooled mean, with the spread of the tasks in its sd
    assert cal.at("c")[0] == pytest.approx(0.15, abs=0.01) and cal.at("c")[1] > 0.15


def test_tasks_that_do_not_differ_are_pooled():
    rng = np.random.default_rng(1)
    e = 0.1 + 0.05 * rng.standard_normal(40)
    t = np.repeat(["a", "b", "c", "d"], 10)
    cal = task_calibration(e, t)
    for k in "abcd":
        bias, sd = cal.at(k)
        # shrunk to (or near) the pooled mean: far closer than the task's own mean scatters (0.05 / sqrt(10))
        assert abs(bias - cal.mu) < 0.5 * abs(e[t == k].mean() - cal.mu) + 1e-12
        assert sd == pytest.approx(0.05, abs=0.015)


def test_a_task_with_one_unit_is_shrunk_towards_the_pooled_mean():
    rng = np.random.default_rng(2)
    e = np.concatenate([0.05 * rng.standard_normal(10), 0.2 + 0.05 * rng.standard_normal(10), [0.6]])
    cal = task_calibration(e, ["a"] * 10 + ["b"] * 10 + ["c"])
    bias_c, sd_c = cal.at("c")
    assert cal.mu < bias_c < 0.6                         # between the pooled mean and its one residual
    assert sd_c > cal.at("a")[1]                         # and less certain than a task of ten


def _twin_on(monkeypatch, scale_b: float) -> list[int]:
    """The twin replaced by the synthetic fleet's closed-form criterion, ``scale_b`` times too large on task b
    (a model error that moves task b's boundary alone: its radius is 1/scale_b of the true one)."""
    calls: list[int] = []

    def fake(setup, traj, pts, done=None):  # done: the progress, unused here
        calls.append(len(pts))
        k = scale_b if traj == "b" else 1.0
        return np.array([k * 0.5 * s * (LEVER[2] * r.direction[1] + LEVER[3] * r.direction[2]) for r, s in pts])

    monkeypatch.setattr(TB, "_criteria", fake)
    return calls


def _two_task_fleet(n: int, seed: int, prefix: str):
    df = linear_wear_fleet(n, seed, prefix)
    odd = df["unit_id"].str[-3:].astype(int) % 2 == 1
    return df.assign(trajectory=np.where(odd, "b", "a"))


def test_per_task_calibration_corrects_a_boundary_biased_on_one_task(monkeypatch):
    _twin_on(monkeypatch, 1.3)
    train, test = _two_task_fleet(48, 0, "a"), _two_task_fleet(30, 1, "t")
    clear = ClearanceRUL(ridge=1e-8).fit(train)
    cond = {u: (g["trajectory"].iloc[0], 1.0, 25.0) for u, g in train.groupby("unit_id")}
    errs = {}
    for how in ("task", "pooled"):
        twin = TwinRUL(SETUP, clear, calibration=how).calibrate(cond)
        last = twin.task_calibration_[max(twin.task_calibration_)]
        assert last.at("b")[0] == pytest.approx(np.log(1.3), abs=0.06)
        assert last.at("a")[0] == pytest.approx(0.0, abs=0.06)
        units, truth = {}, {}
        for uid, g in test[test["trajectory"] == "b"].groupby("unit_id"):
            g = g.sort_values("cycles")
            k = int(np.argmin(np.abs(g["cycles"] / g["eol_cycles"] - 0.5)))
            units[uid] = (("b", 1.0, 25.0), g["cycles"].to_numpy()[: k + 1], clear.clearances(g)[: k + 1])
            truth[uid] = (g["rul_cycles"].iloc[k], g["eol_cycles"].iloc[0])
        est = twin.predict_units(units)
        errs[how] = np.array([(est[u][-1][0] - t) / eol for u, (t, eol) in truth.items()])
    # pooled: task b's boundary is corrected by about half its error (log 1.3 / 2), so its RULs come out ~13 %
    # of life early (measured -0.13); per task: no bias left (measured -0.003, RMSE 0.036 against 0.134)
    assert errs["pooled"].mean() < -0.04
    assert abs(errs["task"].mean()) < 0.02
    assert np.sqrt(np.mean(errs["task"] ** 2)) < 0.5 * np.sqrt(np.mean(errs["pooled"] ** 2))


def _rays() -> list[Ray]:
    return [Ray("t", 1.0, 25.0, (0.0, 0.6, 0.8, 0.0, 0.0, 0.0), 1e-7, g) for g in (0.05, 0.1)]


def test_the_radius_cache_simulates_each_ray_once_per_model_and_setup(monkeypatch, tmp_path):
    calls = []

    def fake(setup, traj, pts, done=None):  # done: the progress, unused here
        calls.append(len(pts))
        return np.array([5.0 * s for _, s in pts])

    monkeypatch.setattr(TB, "_criteria", fake)
    path = tmp_path / "radii.json"
    first = RadiusCache(path).radii(SETUP, _rays())
    assert first == pytest.approx([0.1, 0.1]) and calls
    n = len(calls)
    again = RadiusCache(path)                   # a second run reads the file: no simulation
    assert np.array_equal(again.radii(SETUP, _rays()), first) and len(calls) == n and again.hits == 2
    # another model, another failure threshold, another ray: simulated, never read from the first's entries
    soft = dataclasses.replace(SETUP, model=Overlay({"gear": {"stiffness_Nm_per_rad": [6e4] * 6}}))
    for setup in (soft, dataclasses.replace(SETUP, failure=Failure("tcp_dev_max_mm", 0.4))):
        c = RadiusCache(path)
        c.radii(setup, _rays())
        assert c.misses == 2 and len(calls) > n
        n = len(calls)
    c = RadiusCache(path)
    c.radii(SETUP, [dataclasses.replace(_rays()[0], payload_kg=2.0)])
    assert c.misses == 1


def test_a_file_that_is_not_a_radius_cache_is_refused(tmp_path):
    bad = tmp_path / "radii.json"
    bad.write_text("{not json")
    with pytest.raises(ConfigFileError, match="not a twin radius cache"):
        RadiusCache(bad)
    bad.write_text('{"radii": {not json')
    with pytest.raises(ConfigFileError, match="remove it"):
        RadiusCache(bad)
    bad.write_text(json.dumps({"version": 99, "radii": {}}))
    with pytest.raises(ConfigFileError, match="version"):
        RadiusCache(bad)


def test_a_file_of_ur5fault_that_is_not_a_cache_is_never_overwritten(tmp_path):
    """`prognose --twin --twin-cache res/fleet/manifest.json` (or a detector's schema.json) replaced the file with a
    radius cache and exited 0 (a newcomer probe): a file of ur5fault's with a sound sidecar was taken for a cache of
    another version, one with a changed byte for a damaged cache. Both are refused and left as they were."""
    from ur5fault.util.io import write_json_atomic

    manifest = write_json_atomic(tmp_path / "manifest.json", {"name": "fleet", "kind": "life"}, checksum=True)
    before = manifest.read_bytes()
    with pytest.raises(ConfigFileError, match="not a twin radius cache .* would be overwritten"):
        RadiusCache(manifest)
    manifest.write_bytes(before.replace(b"fleet", b"fleat"))  # its sidecar no longer matches
    with pytest.raises(ConfigFileError, match="not a twin radius cache"):
        RadiusCache(manifest)
    assert manifest.read_bytes() == before.replace(b"fleet", b"fleat")
    # the word alone is no cache: a file of another shape that mentions radii (a verifier's variant)
    other = write_json_atomic(tmp_path / "m2.json", {"name": "radii", "kind": "life"}, checksum=True)
    with pytest.raises(ConfigFileError, match="not a twin radius cache"):
        RadiusCache(other)
    bad = write_json_atomic(tmp_path / "r.json", {"version": 1, "radii": {"a": "x"}}, checksum=True)
    with pytest.raises(ConfigFileError, match="a radius that is not a number"):
        RadiusCache(bad)


@pytest.mark.parametrize("flag", [["--twin-calibration", "pooled"], ["--twin-cache", "x.json"]])
def test_twin_options_without_twin_are_one_line_exit_2(tmp_path, capsys, flag):
    assert main(["prognose", str(tmp_path), *flag]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ur5fault: error:") and "--twin" in err[0]


def test_an_unknown_calibration_is_refused():
    with pytest.raises(ValueError, match="calibration"):
        TwinRUL(SETUP, ClearanceRUL(), calibration="per-unit")


def test_the_direction_correction_follows_the_calibration_units_of_nearby_directions():
    from ur5fault.health.prognostics.twin_calibration import direction_bias

    def unit(deg):   # a direction in the shoulder-elbow plane, deg from the shoulder axis
        return np.array([0.0, np.cos(np.radians(deg)), np.sin(np.radians(deg)), 0.0, 0.0, 0.0])

    # the twin's jump misplaced on elbow-led directions only: log ratio +0.25 there, 0 on shoulder-led ones
    dirs = np.array([unit(a) for a in (10, 15, 20, 25, 70, 72, 75)])
    e = np.array([0.0, 0.0, 0.0, 0.0, 0.25, 0.25, 0.25])
    task = float(e.mean())                                      # 0.107: wrong on both kinds of unit
    kappa = 300.0                                               # the default fleet's kernel (docs/prognostics.md)
    elbow = direction_bias(task, e, dirs, unit(72), kappa)
    shoulder = direction_bias(task, e, dirs, unit(18), kappa)
    assert elbow == pytest.approx(task + (0.25 - task) * 0.7, abs=0.03)   # three near units and one pseudo-unit
    assert 0.0 < shoulder < 0.5 * task                                     # most of the way to its units' 0
    # far from every calibration unit (the wrist): the task's bias; no kernel width: every unit counts alike
    assert direction_bias(task, e, dirs, np.eye(6)[4], kappa) == pytest.approx(task, abs=1e-9)
    assert direction_bias(task, e, dirs, unit(72), 0.0) == pytest.approx(task, abs=1e-9)
    assert direction_bias(task, e[:0], dirs[:0], unit(72), kappa) == task


def test_the_direction_calibration_corrects_a_twin_error_that_depends_on_the_direction(monkeypatch):
    """The twin's criterion 1.3 x too large on elbow-led directions only (a model error that moves the elbow's
    jump): one bias per task leaves the elbow-led units early and the shoulder-led ones late (measured -0.077
    and +0.088 of life at half-life), the direction calibration removes both (-0.002, +0.004)."""
    def fake(setup, traj, pts, done=None):  # done: the progress, unused here
        return np.array([(1.3 if r.direction[2] > r.direction[1] else 1.0) * 0.5 * s
                         * (LEVER[2] * r.direction[1] + LEVER[3] * r.direction[2]) for r, s in pts])

    monkeypatch.setattr(TB, "_criteria", fake)
    train, test = linear_wear_fleet(48, 0, "a"), linear_wear_fleet(40, 1, "t")
    clear = ClearanceRUL(ridge=1e-8).fit(train)
    cond = {u: ("task", 1.0, 25.0) for u in train["unit_id"].unique()}
    units, truth = {}, {}
    for uid, g in test.groupby("unit_id"):
        g = g.sort_values("cycles")
        k = int(np.argmin(np.abs(g["cycles"] / g["eol_cycles"] - 0.5)))
        units[uid] = (("task", 1.0, 25.0), g["cycles"].to_numpy()[: k + 1], clear.clearances(g)[: k + 1])
        last = g[["backlash_deg_j2", "backlash_deg_j3"]].to_numpy()[-1]
        truth[uid] = (g["rul_cycles"].iloc[k], g["eol_cycles"].iloc[0], bool(last[1] > last[0]))
    out = {}
    for how in ("task", "direction"):
        est = TwinRUL(SETUP, clear, calibration=how, units_per_task=48).calibrate(cond).predict_units(units)
        e = {u: (est[u][-1][0] - t) / eol for u, (t, eol, _) in truth.items()}
        out[how] = {grp: np.array([e[u] for u in e if truth[u][2] == grp]) for grp in (True, False)}
    assert out["task"][True].mean() < -0.04 and out["task"][False].mean() > 0.04
    for grp in (True, False):
        assert abs(out["direction"][grp].mean()) < 0.025
        assert np.sqrt(np.mean(out["direction"][grp] ** 2)) < 0.75 * np.sqrt(np.mean(out["task"][grp] ** 2))
