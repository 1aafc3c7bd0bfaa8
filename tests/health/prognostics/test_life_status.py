"""``ur5fault campaign status`` on a life-campaign folder, and a life campaign on Dask."""

from __future__ import annotations

import json

import pyarrow.parquet as pq
import pytest

from ur5fault.cli import main
from ur5fault.health.prognostics.fleet import run_life
from ur5fault.health.prognostics.spec import build_life

from tiny_fleet import TINY, run_tables


def _status(folder, capsys):
    rc = main(["campaign", "status", str(folder)])
    return rc, json.loads(capsys.readouterr().out)


@pytest.mark.slow
def test_status_of_a_life_folder_interrupted_complete_and_damaged(tmp_path, capsys):
    camp = build_life({**TINY, "life": {**TINY["life"], "units": 2}}, "tiny")
    run_life(camp, tmp_path, jobs=1, progress=False, note=None, max_rounds=2)
    rc, info = _status(tmp_path, capsys)
    assert rc == 0 and info["kind"] == "life" and info["state"] == "interrupted"  # "running" in the manifest
    assert info["units"] == {"expected": 2, "finished": 0, "running": 2}
    assert info["inspections"]["ok"] == 4 and info["inspections"]["bad"] == 0
    assert info["inspections_table"] == {"state": "not expected yet"}
    assert "n_runs_expected" not in info and "campaign_error" not in info   # no `life:` unknown-key complaint
    assert info["sound"] is True and "resumes it (the inspections made are kept)" in info["advice"]

    m = run_life(camp, tmp_path, jobs=1, progress=False, note=None)
    rc, info = _status(tmp_path, capsys)
    assert rc == 0 and info["state"] == "complete" and info["problems"] == []
    assert info["sound"] is True and info["advice"] is None
    assert info["units"]["finished"] == 2 and info["units"]["running"] == 0
    assert info["inspections"]["ok"] == m["n_inspections"]
    assert info["inspections_table"] == {"state": "ok", "rows": m["n_inspections"]}

    # a stray file is listed and ignored; a damaged inspection is a problem (exit 1), and the files of its
    # unit after it cannot be reached any more, nor does the consolidated table match the folder
    (tmp_path / "runs" / "notes.parquet").write_bytes(b"x")
    (tmp_path / "runs" / "u00001_i0001.parquet").write_bytes(b"PAR1 cut")
    rc, info = _status(tmp_path, capsys)
    assert rc == 1
    assert info["inspections"]["bad"] == 1 and info["inspections"]["stray"] == 1
    assert info["problems"][0].startswith("runs/u00001_i0001.parquet: bad:")
    assert "runs/notes.parquet: not an inspection of this fleet (stray)" in info["ignored"]
    later = len(list((tmp_path / "runs").glob("u00001_i*.parquet"))) - 2
    assert info["inspections"]["not_reachable"] == later
    assert info["inspections_table"]["state"] == "stale"
    assert info["state"] == "complete" and info["sound"] is False
    assert info["advice"].startswith("1 damaged inspection file(s): `ur5fault campaign run` on the campaign again")
    assert "the inspections table does not hold the stored inspections" in info["advice"]

    # a damaged reference run is named as itself (it was named as the unit's sound first inspection)
    (tmp_path / "runs" / "u00001_i0001.parquet").unlink()
    ref = tmp_path / "reference" / "u00000.parquet"
    b = bytearray(ref.read_bytes())
    b[len(b) // 2] ^= 0x01
    ref.write_bytes(bytes(b))
    rc, info = _status(tmp_path, capsys)
    assert rc == 1 and info["problems"][0].startswith("reference/u00000.parquet: bad: its bytes differ"), info


@pytest.mark.slow
def test_life_campaign_on_dask_equals_loky(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    tiny = {**TINY, "life": {**TINY["life"], "units": 2}}
    camp = build_life(tiny, "tiny")
    local = run_life(camp, tmp_path / "loky", jobs=1, progress=False, note=None)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        dask = run_life(camp, tmp_path / "dask", backend="dask", scheduler=cluster.scheduler_address,
                        progress=False, note=None)
    assert dask["state"] == local["state"] == "complete" and dask["backend"] == "dask"
    a, b = run_tables(tmp_path / "loky"), run_tables(tmp_path / "dask")
    assert a.keys() == b.keys() and len(a) == local["n_inspections"]
    for name in a:
        assert a[name].equals(b[name]), name
    assert pq.read_table(tmp_path / "loky" / "inspections.parquet").equals(
        pq.read_table(tmp_path / "dask" / "inspections.parquet"))
