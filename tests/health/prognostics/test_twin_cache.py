"""The file of the twin's radii (twin_cache.py) written as the rays are simulated: a run stopped partway keeps the
groups it finished and its rerun simulates only the rest, to the same result; no simulation (the criterion in
closed form)."""

from __future__ import annotations

import json
import logging

import numpy as np
import pandas as pd
import pytest
from synthetic_wear import linear_wear_fleet

import ur5fault.health.prognostics.twin_boundary as TB
import ur5fault.health.prognostics.twin_cache as TC
from ur5fault.cli import main
from ur5fault.health.prognostics.spec import Failure
from ur5fault.health.prognostics.twin_boundary import Ray, TwinSetup
from ur5fault.health.prognostics.twin_cache import RadiusCache
from ur5fault.health.prognostics.wear import WearLaw
from ur5fault.util.io import checksum_path, verify_checksum

SETUP = TwinSetup(WearLaw(), Failure("tcp_dev_max_mm", 0.5))


def _closed_form(monkeypatch) -> list[int]:
    """The synthetic fleet's boundary (b2 + 5 b3 = 1 deg) in place of the simulation; returns the rays each
    search was given (one entry per (ray, radius) point's ray, by id)."""
    seen: list[int] = []

    def fake(setup, traj, pts, done=None):  # done: the progress, unused here
        seen.extend(id(ray) for ray, _ in pts)
        return np.array([0.5 * s * (ray.direction[1] + 5 * ray.direction[2]) for ray, s in pts])

    monkeypatch.setattr(TB, "_criteria", fake)
    return seen


def _stop_after(monkeypatch, n_groups: int) -> list[int]:
    """``failure_radii`` raising KeyboardInterrupt (a Ctrl-C) when asked for group ``n_groups + 1``; returns the
    size of each group it simulated."""
    real, sizes = TB.failure_radii, []

    def counted(setup, rays, progress=None):
        if len(sizes) == n_groups:
            raise KeyboardInterrupt
        sizes.append(len(rays))
        return real(setup, rays, progress)

    monkeypatch.setattr(TB, "failure_radii", counted)
    return sizes


def _rays(n: int) -> list[Ray]:
    """``n`` rays on two tasks, each its own direction in the shoulder-elbow plane."""
    out = []
    for i in range(n):
        d = np.array([0.0, np.cos(0.05 * i), np.sin(0.05 * i), 0.0, 0.0, 0.0])
        out.append(Ray("ab"[i % 2], 1.0, 25.0, tuple(d), 1e-7, 0.2))
    return out


def test_a_stopped_run_keeps_the_groups_it_finished_and_its_rerun_simulates_only_the_rest(monkeypatch, tmp_path):
    _closed_form(monkeypatch)
    rays = _rays(3 * TC.RAYS_PER_WRITE + 3)
    whole = RadiusCache(tmp_path / "whole.json").radii(SETUP, rays)  # uninterrupted
    path = tmp_path / "radii.json"
    real = TB.failure_radii
    sizes = _stop_after(monkeypatch, 2)
    with pytest.raises(KeyboardInterrupt):
        RadiusCache(path).radii(SETUP, rays)
    done = sum(sizes)
    assert len(sizes) == 2 and 0 < done < len(rays) and verify_checksum(path) is None
    monkeypatch.setattr(TB, "failure_radii", real)
    again = RadiusCache(path)
    assert len(again.entries) == done
    sizes = _stop_after(monkeypatch, 10**6)
    np.testing.assert_array_equal(again.radii(SETUP, rays), whole)
    assert sum(sizes) == len(rays) - done and (again.hits, again.misses) == (done, len(rays) - done)

def test_each_group_holds_rays_of_one_task_in_order():
    rays = _rays(2 * TC.RAYS_PER_WRITE + 2)
    groups = TC._groups(rays, range(len(rays)))
    assert sorted(i for g in groups for i in g) == list(range(len(rays)))
    for g in groups:
        assert len(g) <= TC.RAYS_PER_WRITE and len({rays[i].trajectory for i in g}) == 1 and g == sorted(g)


def test_a_torn_write_is_refused_with_a_note_and_simulated_again(monkeypatch, tmp_path, caplog):
    """A stop between the sidecar's rename and the file's (the sidecar is written first, util/io.py) leaves the
    new sidecar beside the older radii: never read as sound."""
    _closed_form(monkeypatch)
    rays = _rays(TC.RAYS_PER_WRITE + 1)
    path = tmp_path / "radii.json"
    whole = RadiusCache(path).radii(SETUP, rays)
    older = json.loads(path.read_text())
    older["radii"] = dict(list(older["radii"].items())[:1])
    path.write_text(json.dumps(older, indent=2))  # the older file, the newer sidecar
    with caplog.at_level(logging.WARNING):
        torn = RadiusCache(path)
    notes = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert torn.entries == {} and len(notes) == 1 and "\n" not in notes[0] and "simulated again" in notes[0]
    np.testing.assert_array_equal(torn.radii(SETUP, rays), whole)
    assert torn.misses == len(rays) and verify_checksum(path) is None and checksum_path(path).is_file()


def _fleet(tmp_path):
    """A synthetic fleet of two tasks (its clearances of joints 2 and 3 growing linearly) as a life campaign's
    folder holds it."""
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    df = linear_wear_fleet(24, 0, "a")
    odd = df["unit_id"].str[-3:].astype(int) % 2 == 1
    df = df.assign(split=np.where(df["unit_id"] < "a018", "train", "test"), failed=df["rul_cycles"] == 0,
                   censored=False, tcp_dev_max_mm=0.5 * (df["backlash_deg_j2"] + 5 * df["backlash_deg_j3"]),
                   payload_kg=1.0, temperature_C=25.0, trajectory=np.where(odd, "b", "a"))
    df.to_parquet(fleet / "inspections.parquet")
    (fleet / "manifest.json").write_text(json.dumps({"wear": {}, "identity_inputs": {},
                                                     "failure": {"feature": "tcp_dev_max_mm", "threshold": 0.5}}))
    return fleet


def test_prognose_stopped_partway_resumes_from_its_cache_to_the_uninterrupted_result(monkeypatch, tmp_path, capsys):
    _closed_form(monkeypatch)
    fleet = _fleet(tmp_path)
    args = ["prognose", str(fleet), "--twin", "--twin-friction", "law", "--out"]
    assert main([*args, str(tmp_path / "whole")]) == 0
    whole = json.loads((tmp_path / "whole" / "metrics.json").read_text())["fitted"]["twin"]["radius_cache"]
    n_rays = whole["simulated"]
    assert n_rays > 2 * TC.RAYS_PER_WRITE  # more than two groups: a stop after two leaves some to do
    real = TB.failure_radii
    sizes = _stop_after(monkeypatch, 2)
    assert main([*args, str(tmp_path / "bench")]) == 130  # Ctrl-C during the third group
    assert "interrupted" in capsys.readouterr().err
    done = sum(sizes)
    assert len(json.loads((tmp_path / "bench" / "twin_radii.json").read_text())["radii"]) == done
    monkeypatch.setattr(TB, "failure_radii", real)
    sizes = _stop_after(monkeypatch, 10**6)
    assert main([*args, str(tmp_path / "bench")]) == 0  # the rerun, no --replace: no report was written
    again = json.loads((tmp_path / "bench" / "metrics.json").read_text())["fitted"]["twin"]["radius_cache"]
    assert sum(sizes) == again["simulated"] == n_rays - done and again["hits"] == whole["hits"] + done
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "bench" / "predictions_twin.parquet"),
                                  pd.read_parquet(tmp_path / "whole" / "predictions_twin.parquet"))


@pytest.mark.parametrize("kind", ["folder", "unwritable"])
def test_prognose_refuses_a_cache_it_cannot_write_before_simulating_anything(monkeypatch, tmp_path, capsys, kind):
    def never(*args, **kwargs):
        raise AssertionError("simulated before the cache path was checked")

    monkeypatch.setattr(TB, "failure_radii", never)
    fleet = _fleet(tmp_path)
    if kind == "folder":
        cache = tmp_path / "cache"
        cache.mkdir()
    else:  # under a file: no file can be made there, whoever runs the test (a read-only folder does not stop root)
        (tmp_path / "plain").write_text("")
        cache = tmp_path / "plain" / "c.json"
    assert main(["prognose", str(fleet), "--twin", "--twin-friction", "law", "--twin-cache", str(cache),
                 "--out", str(tmp_path / "bench")]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(cache) in err and "--twin-cache" in err
    assert not (tmp_path / "bench" / "metrics.json").exists()


def test_a_complete_cache_is_read_where_it_cannot_be_written(monkeypatch, tmp_path):
    """The writability check comes before the first ray is simulated, not when the cache is opened: a cache that
    already holds every radius, in a read-only place, is read as before (it is never written then)."""
    cache = RadiusCache(tmp_path / "c.json")
    cache.entries = {"a": 0.1, "b": 0.2}

    def read_only(path):
        raise TC.OutputError(f"{path}: read-only")

    monkeypatch.setattr(TC, "check_writable", read_only)
    monkeypatch.setattr(TB, "failure_radii", lambda *a, **k: [0.3])
    monkeypatch.setattr(cache, "_keys", lambda setup, rays: ["a", "b"])
    np.testing.assert_array_equal(cache.radii(None, ["r1", "r2"]), [0.1, 0.2])
    monkeypatch.setattr(cache, "_keys", lambda setup, rays: ["a", "z"])
    with pytest.raises(TC.OutputError, match=r"read-only; give --twin-cache a file this user may read and write"):
        cache.radii(None, ["r1", "r2"])
