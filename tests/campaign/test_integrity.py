"""A campaign folder survives damage: a full disk while taking the lock, two processes racing for a
lock left by a killed one, and flipped or overwritten bytes in stored run files (found by their
checksums, named, and simulated again, never read into features.parquet)."""

from __future__ import annotations

import errno
import multiprocessing as mp
import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from test_campaign import _results, tiny

from ur5fault.campaign import FolderLockedError, Lock, load_campaign, run_campaign, status
from ur5fault.campaign.store import BadRunFilesError, check_run_file, consolidate
from ur5fault.util import lock as lock_mod
from ur5fault.util.io import OutputError

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.fixture(scope="module")
def done(tmp_path_factory):
    d = tmp_path_factory.mktemp("integrity")
    run_campaign(load_campaign(tiny(d)), d / "out", jobs=1, progress=False, note=None)
    return d


def _copy(done, tmp_path):
    shutil.copytree(done / "out", tmp_path / "out")
    return tmp_path / "out"


# ----------------------------------------------------------------------------- the lock
def test_lock_survives_a_full_disk(tmp_path, monkeypatch):
    """No space left while writing the holder's pid: one error, and the next campaign takes the lock."""
    out = tmp_path / "out"

    def enospc(fd, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(lock_mod.os, "write", enospc)
    with pytest.raises(OutputError, match="No space left on device"):
        Lock(out).__enter__()
    monkeypatch.undo()
    assert status_lock(out) is None
    with Lock(out):
        assert status_lock(out) is not None


def test_empty_or_foreign_lock_file_is_not_a_lock(tmp_path, done):
    """An empty .lock (a failed write on a full disk) or one naming a live pid that does not hold it
    (a killed campaign whose pid was reused) stops nothing, and status says no one holds it."""
    out = _copy(done, tmp_path)
    for text in ("", f"{os.uname().nodename} {os.getpid()}\n"):
        (out / ".lock").write_text(text)
        assert status(out)["lock"] is None
        run_campaign(load_campaign(tiny(tmp_path)), out, jobs=1, progress=False, note=None)
        assert not (out / ".lock").exists()


def status_lock(out):
    return lock_mod.lock_holder(out)


def _contend(out, barrier, held, hold_s):
    barrier.wait()
    try:
        with Lock(out):
            t0 = time.monotonic()
            time.sleep(hold_s)
            held.put((t0, time.monotonic()))
    except FolderLockedError:
        held.put(None)


def test_two_processes_never_both_take_a_stale_lock(tmp_path):
    """Four processes start together on a folder whose .lock was left by a dead process: in every
    one of 25 trials exactly one takes it (the issue found two in 6 of 150 trials)."""
    ctx = mp.get_context("fork")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    for trial in range(25):
        out = tmp_path / f"t{trial}"
        out.mkdir()
        (out / ".lock").write_text(f"{os.uname().nodename} {dead}\n")
        barrier, held = ctx.Barrier(4), ctx.Queue()
        procs = [ctx.Process(target=_contend, args=(out, barrier, held, 0.2)) for _ in range(4)]
        for p in procs:
            p.start()
        for p in procs:
            p.join(30)
        got = [held.get(timeout=5) for _ in procs]
        spans = sorted(g for g in got if g is not None)
        assert len(spans) >= 1
        for a, b in zip(spans, spans[1:]):
            assert b[0] >= a[1], f"trial {trial}: two processes held the lock at once"
        assert not (out / ".lock").exists()


def test_status_names_the_holder(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    with Lock(out):
        info = status(out)
    assert info["lock"] == {"held": True, "host": os.uname().nodename, "pid": os.getpid()}
    assert status(out)["lock"] is None


# ----------------------------------------------------------------------------- checksums
@pytest.mark.parametrize("stride", [
    97,  # the probe: one byte in every 97
    pytest.param(1, marks=pytest.mark.slow),  # every byte (about 4 min)
])
def test_every_flipped_byte_of_a_run_file_is_detected(tmp_path, done, stride):
    """Flip bytes of a real run file one at a time: every flip makes the file bad (never ok, never
    'made under other settings', which would stop a rerun instead of repairing it)."""
    src = sorted((done / "out" / "runs").glob("r*.parquet"))[0]
    path = tmp_path / "runs" / src.name
    path.parent.mkdir()
    shutil.copy(src, path)
    shutil.copy(src.with_name(src.name + ".sha256"), path.with_name(src.name + ".sha256"))
    clean = path.read_bytes()
    assert check_run_file(path).state == "ok"
    states = {}
    flipped = range(0, len(clean), stride)
    for i in flipped:
        path.write_bytes(clean[:i] + bytes([clean[i] ^ 0x01]) + clean[i + 1:])
        state = check_run_file(path).state
        states[state] = states.get(state, 0) + 1
    assert states == {"bad": len(flipped)}, states


def test_corrupted_run_file_is_named_and_simulated_again(tmp_path, done):
    """Bytes overwritten in the middle of a run file: status exits 1 naming it; a rerun notes it,
    simulates it again and gives the clean feature table."""
    out = _copy(done, tmp_path)
    ref = pd.read_parquet(out / "features.parquet")
    victim = sorted((out / "runs").glob("r*.parquet"))[1]
    data = bytearray(victim.read_bytes())
    mid = len(data) // 2
    data[mid:mid + 16] = b"\x00" * 16
    victim.write_bytes(bytes(data))
    info = status(out)
    assert info["runs"]["bad"] == 1 and info["state"] == "complete" and info["sound"] is False
    assert info["advice"] == ("1 damaged run file(s): `ur5fault campaign run` on the campaign again simulates them; "
                              f"the command: `ur5fault campaign run {done / 't.yaml'} --out {out}`")
    assert any(victim.name in p and "checksum" in p for p in info["problems"]), info["problems"]
    r = subprocess.run([sys.executable, "-m", "ur5fault.cli", "campaign", "status", str(out)], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 1
    notes = []
    run_campaign(load_campaign(tiny(tmp_path)), out, jobs=1, progress=False, note=notes.append)
    assert any(victim.name in n and "simulating it again" in n for n in notes), notes
    pd.testing.assert_frame_equal(_results(pd.read_parquet(out / "features.parquet")), _results(ref))
    assert status(out)["runs"]["ok"] == 3 and status(out)["sound"] is True and status(out)["advice"] is None


def test_run_file_damaged_after_the_scan_is_simulated_again(tmp_path, done, monkeypatch):
    """A file that goes bad between the check at the start and the gathering at the end (the
    issue's 'Couldn't deserialize thrift' from consolidate): simulated again, not a traceback."""
    from ur5fault.campaign import execute
    from ur5fault.campaign.verify import Scan

    out = _copy(done, tmp_path)
    ref = pd.read_parquet(out / "features.parquet")
    victim = sorted((out / "runs").glob("r*.parquet"))[0]
    real_scan = execute.scan

    def scan_then_damage(*args, **kw):
        found = real_scan(*args, **kw)
        victim.write_bytes(victim.read_bytes()[:40] + b"\xff" * 64 + victim.read_bytes()[104:])
        return Scan(ok=found.ok)

    monkeypatch.setattr(execute, "scan", scan_then_damage)
    records = {}
    with pytest.raises(BadRunFilesError):  # consolidate alone: one line naming the file
        camp = load_campaign(tiny(tmp_path))
        ids = execute.Identities(camp)
        records = {rc.run_id: ids.record(rc) for rc in camp.runs}
        scan_then_damage(out, camp, ids)
        consolidate(out, records)
    notes = []
    run_campaign(load_campaign(tiny(tmp_path)), out, jobs=1, progress=False, note=notes.append)
    assert any(victim.name in n for n in notes), notes
    pd.testing.assert_frame_equal(_results(pd.read_parquet(out / "features.parquet")), _results(ref))


def test_corrupted_feature_table_is_reported(tmp_path, done):
    out = _copy(done, tmp_path)
    path = out / "features.parquet"
    data = bytearray(path.read_bytes())
    data[len(data) // 3] ^= 0x10
    path.write_bytes(bytes(data))
    assert status(out)["features"]["state"] == "bad"


def test_a_changed_feature_table_is_never_read_and_a_rerun_rebuilds_it(tmp_path, done, capsys):
    """The consolidated table read back (CampaignResult, `ur5fault benchmark`) is verified first: a flipped
    byte is one line naming the file and the command to re-run, and the re-run rebuilds it from the runs."""
    from ur5fault.campaign import CampaignResult
    from ur5fault.cli import main
    from ur5fault.util.io import StoredFileError

    out = _copy(done, tmp_path)
    path = out / "features.parquet"
    ref = pd.read_parquet(path)
    data = bytearray(path.read_bytes())
    data[len(data) // 3] ^= 0x10
    path.write_bytes(bytes(data))
    with pytest.raises(StoredFileError, match="features.parquet: its bytes differ.*campaign run"):
        CampaignResult.load(out)
    assert main(["benchmark", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "features.parquet: its bytes differ" in err and "campaign run" in err
    run_campaign(load_campaign(tiny(tmp_path)), out, jobs=1, progress=False, note=None)
    pd.testing.assert_frame_equal(CampaignResult.load(out).features, ref)


def test_run_files_deleted_from_a_finished_campaign_are_said(tmp_path, done):
    """Every run file deleted by hand, their checksum sidecars left: the feature table still holds the rows (the
    folder stays sound), but the advice says the files are gone and the sidecars are listed, not passed over. A
    sidecar is not a run: each run is counted once, as missing (it was also counted as a stray)."""
    out = _copy(done, tmp_path)
    for p in (out / "runs").glob("*.parquet"):
        p.unlink()
    info = status(out)
    assert info["state"] == "complete" and info["runs"]["missing"] == 3 and info["runs"]["stray"] == 0
    assert len(info["ignored"]) == 3
    assert info["sound"] is True and info["features"]["state"] == "ok"
    assert info["advice"].startswith("3 run file(s) of the finished campaign are gone")
    assert all(line.endswith(".parquet.sha256: a checksum whose run file is gone") for line in info["ignored"])


def test_a_changed_manifest_is_reported_by_status_and_repaired_by_a_rerun(tmp_path, done):
    out = _copy(done, tmp_path)
    path = out / "manifest.json"
    assert path.with_name("manifest.json.sha256").is_file()
    path.write_text(path.read_text().replace('"threshold_mm": ', '"threshold_mm": 9', 1))  # valid JSON, wrong
    info = status(out)
    assert info["manifest"]["state"] == "bad" and "checksum" in info["manifest"]["detail"]
    r = subprocess.run([sys.executable, "-m", "ur5fault.cli", "campaign", "status", str(out)], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 1
    run_campaign(load_campaign(tiny(tmp_path)), out, jobs=1, progress=False, note=None)
    info = status(out)
    assert "manifest" not in info and info["runs"]["ok"] == 3 and info["features"]["state"] == "ok"


def test_a_killed_writers_temporaries_are_cleared_by_the_next_run(tmp_path, done):
    out = _copy(done, tmp_path)
    left = [out / ".features.parquet.x1.tmp", out / "runs" / ".r0.parquet.x2.tmp", out / ".manifest.json.x3.tmp"]
    for p in left:
        p.write_bytes(b"PAR1 half")
    run_campaign(load_campaign(tiny(tmp_path)), out, jobs=1, progress=False, note=None)
    assert not any(p.exists() for p in left)


def test_a_damaged_time_series_is_never_read_as_a_log_or_drawn(tmp_path, capsys):
    """A campaign's time series carries its checksum: read as a log (`diagnose`, `identify`, `discrepancy`,
    `monitor` with --format sim) or drawn by `show`, a changed byte is refused in one line, as the campaign's own
    readers refuse it, never fitted or drawn."""
    from ur5fault.cli import main
    from ur5fault.logs import read_sim
    from ur5fault.util.io import StoredFileError

    run_campaign(load_campaign(tiny(tmp_path, dur=6.0)), tmp_path / "out", jobs=1, progress=False, note=None,
                 save_timeseries=True)  # 6 s: longer than the 5 s a log must hold to be fitted
    f = sorted((tmp_path / "out" / "timeseries").glob("*.parquet"))[0]
    assert read_sim(f).t_s.size > 100  # sound: read
    b = bytearray(f.read_bytes())
    b[len(b) // 2] ^= 0x01
    f.write_bytes(bytes(b))
    with pytest.raises(StoredFileError, match=r"its bytes differ from the checksum .*; simulate it again"):
        read_sim(f)
    assert main(["show", str(f), "--out", str(tmp_path / "s.png")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "differ from the checksum" in err and not (tmp_path / "s.png").exists()


def test_time_series_of_other_settings_or_another_run_are_never_read_as_this_runs(tmp_path, caplog, monkeypatch):
    """CampaignResult.time_series (what `plot` and `show --campaign` draw) read any file under timeseries/ whose
    sidecar matched: after `--replace-changed` without saved time series the earlier settings' files were drawn as
    the new runs (a 2 s campaign drawn from 1 s files), and a run's file copied over another's (no sidecar) was drawn
    under the other's name. Now each is checked as `campaign status` checks it (checksum, this run's identity);
    one that fails is simulated again, and a rerun that does not save time series removes the ones it makes stale."""
    from ur5fault.campaign import CampaignResult

    out = tmp_path / "out"
    run_campaign(load_campaign(tiny(tmp_path, dur=0.3)), out, jobs=1, progress=False, note=None,
                 save_timeseries=True)
    ids = sorted(p.stem for p in (out / "timeseries").glob("*.parquet"))
    a, b = ids[0], ids[1]
    saved_a = pd.read_parquet(out / "timeseries" / f"{a}.parquet")
    # another run's file (and no sidecar) in a's place: simulated again (the same run, deterministic), not read
    shutil.copyfile(out / "timeseries" / f"{b}.parquet", out / "timeseries" / f"{a}.parquet")
    (out / "timeseries" / f"{a}.parquet.sha256").unlink()
    res = CampaignResult.load(out)
    own = res.time_series([a])[a]
    assert f"{a}.parquet: bad: no checksum recorded" in caplog.text and "re-simulating the run instead" in caplog.text
    pd.testing.assert_frame_equal(own, saved_a)
    # with its sidecar, another run's file is told by its identity
    shutil.copyfile(out / "timeseries" / f"{b}.parquet.sha256", out / "timeseries" / f"{a}.parquet.sha256")
    caplog.clear()
    pd.testing.assert_frame_equal(CampaignResult.load(out).time_series([a])[a], saved_a)
    assert f"{a}.parquet: changed: time series of a run made under other settings" in caplog.text
    # a run missing (killed before its run file) re-simulated without saving time series: its sound file is kept
    (out / "runs" / f"{b}.parquet").unlink()
    run_campaign(load_campaign(tiny(tmp_path, dur=0.3)), out, jobs=1, progress=False, note=None)
    assert (out / "timeseries" / f"{b}.parquet").is_file()
    # the campaign changed (0.2 s runs), simulated again without saving time series: the 0.3 s files are gone
    run_campaign(load_campaign(tiny(tmp_path, dur=0.2)), out, jobs=1, progress=False, note=None,
                 replace_changed=True)
    assert not list((out / "timeseries").glob("*.parquet*"))
    res = CampaignResult.load(out)
    assert res.time_series([a])[a]["t_s"].max() < 0.21
    assert "not saved" in repr(res)
    assert "stored under other settings than this ur5fault simulates" not in caplog.text
    # a run this ur5fault simulates otherwise than the stored run (its identity differs, as a hold campaign's after
    # the grip schedule changed): re-simulated with a warning, not drawn as if it were the run of its features
    from ur5fault.campaign import identity

    monkeypatch.setattr(identity.Identities, "identity", lambda self, rc: "another")
    caplog.clear()
    CampaignResult.load(out).time_series([a])
    assert f"{a} stored under other settings than this ur5fault simulates them with" in caplog.text


def test_status_says_when_the_manifest_is_gone_or_unreadable(tmp_path, done):
    """`campaign status` said "sound" (exit 0) for a folder of runs whose manifest.json was deleted or not JSON,
    while every reader refused the folder."""
    out = _copy(done, tmp_path)
    (out / "manifest.json.sha256").unlink()
    (out / "manifest.json").write_text("{")
    info = status(out)
    assert info["sound"] is False and info["manifest"]["state"] == "bad"
    assert "rewrites it" in info["advice"]
    (out / "manifest.json").write_text('{"name": "t"}')  # readable, but not which campaign the runs are
    info = status(out)
    assert info["sound"] is False and info["manifest"]["state"] == "bad" and "rewrites it" in info["advice"]
    (out / "manifest.json").unlink()
    info = status(out)
    assert info["sound"] is False and info["manifest"] == {"state": "missing", "detail": "absent"}
    run_campaign(load_campaign(tiny(tmp_path)), out, jobs=1, progress=False, note=None)
    info = status(out)
    assert info["sound"] is True and "manifest" not in info


@pytest.mark.parametrize("edit, message", [
    (lambda m: m.pop("threshold_mm"), "threshold_mm None is not a positive number"),
    (lambda m: m.update(threshold_mm="abc"), "threshold_mm 'abc' is not a positive number"),
    (lambda m: m.update(swept_keys="backlash.joint"), "swept_keys 'backlash.joint' is not a list"),
])
def test_a_hand_edited_manifest_without_its_sidecar_is_refused_in_one_line(tmp_path, done, edit, message):
    """A manifest without its sidecar is read unverified; one lacking what the result reads crashed `plot` and
    CampaignResult with a KeyError / ValueError traceback."""
    import json

    from ur5fault.campaign import CampaignResult
    from ur5fault.errors import ConfigFileError

    out = _copy(done, tmp_path)
    (out / "manifest.json.sha256").unlink()
    m = json.loads((out / "manifest.json").read_text())
    edit(m)
    (out / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(ConfigFileError, match=f"manifest.json: {message}"):
        CampaignResult.load(out)
    info = status(out)  # said sound, exit 0, while every reader refused it
    assert info["sound"] is False and info["manifest"]["state"] == "bad" and message in info["manifest"]["detail"]
    (out / "manifest.json").write_text("[1]")
    with pytest.raises(ConfigFileError, match="not a campaign manifest"):
        CampaignResult.load(out)


def test_temporary_files_of_a_stopped_writer_are_listed_until_the_next_run_removes_them(tmp_path, done):
    """A writer killed mid-write leaves `.<name>.<random>.tmp` files; `campaign status` passed over them. They are
    listed under "ignored" (the folder stays sound: no stored result is damaged), and the next run removes them."""
    out = _copy(done, tmp_path)
    made = [out / ".features.parquet.x1.tmp", out / "runs" / ".r.parquet.x2.tmp"]
    for p in made:
        p.write_bytes(b"partial")
    info = status(out)
    assert info["sound"] is True
    temps = [line for line in info["ignored"] if "temporary file of a writer stopped mid-write" in line]
    assert sorted(t.split(":")[0] for t in temps) == [".features.parquet.x1.tmp", "runs/.r.parquet.x2.tmp"], info
    run_campaign(load_campaign(tiny(tmp_path)), out, jobs=1, progress=False, note=None)
    assert not any(p.exists() for p in made)
    assert not [line for line in status(out).get("ignored", []) if "temporary" in line]


def test_status_advice_repeats_the_command_with_its_quick_trial_options(tmp_path, capsys):
    """A campaign run with --duration-s (a quick trial) and a damaged run: the advice said "`ur5fault campaign run` on
    the campaign again", and the command without --duration-s is another campaign, refused. It now ends with the
    exact command, which repairs the folder."""
    import json

    from ur5fault.cli import main

    path = tiny(tmp_path)
    out = tmp_path / "out"
    assert main(["campaign", "run", str(path), "--out", str(out), "--duration-s", "0.2", "--quiet"]) == 0
    capsys.readouterr()
    assert json.loads((out / "manifest.json").read_text())["command_options"] == {"duration_s": 0.2}
    f = sorted((out / "runs").glob("*.parquet"))[0]
    f.write_bytes(f.read_bytes()[:-9])
    info = status(out)
    assert info["sound"] is False
    command = info["advice"].rsplit("the command: ", 1)[1].strip("`")
    assert command == f"ur5fault campaign run {path.resolve()} --out {out} --duration-s 0.2", info["advice"]
    assert main(shlex.split(command)[1:] + ["--quiet"]) == 0
    assert status(out)["sound"] is True


def test_the_advised_command_carries_yes_where_the_campaign_needed_it():
    """A 2,546-run campaign's status advice ended with a command that is refused ("needs --yes to start")."""
    from ur5fault.campaign.limits import CONFIRM_RUN_STEPS, CONFIRM_RUNS
    from ur5fault.campaign.verify import rerun_command

    base = {"campaign_file": "/c/d.yaml", "n_runs": CONFIRM_RUNS, "n_steps_total": int(CONFIRM_RUN_STEPS)}
    assert rerun_command(base, Path("out")) == "ur5fault campaign run /c/d.yaml --out out"
    assert rerun_command({**base, "n_runs": CONFIRM_RUNS + 1}, Path("out")).endswith(" --out out --yes")
    assert rerun_command({**base, "n_steps_total": int(CONFIRM_RUN_STEPS) + 1}, Path("out")).endswith(" --yes")


def test_the_advised_command_of_a_life_campaign_carries_yes_as_campaign_run_asks_it():
    """A life manifest records no run or step count: `campaign status` advised the command without --yes for every
    fleet, which `campaign run` refuses for one over 1000 runs or 2e9 steps (an empty `life:` section's default)."""
    from ur5fault.campaign.verify import rerun_command

    from tiny_fleet import TINY

    for data, yes in ((TINY, False), ({"name": "empty", "life": {}}, True), ({"name": "none", "life": None}, True),
                      ({"name": "bad", "life": {"units": "many"}}, False), ("not a campaign", False)):
        manifest = {"kind": "life", "campaign_file": "/c/life.yaml", "campaign_data": data}
        assert rerun_command(manifest, Path("out")).endswith(" --yes") is yes, data


def test_a_feature_table_without_its_checksum_is_refused_where_status_calls_it_bad(tmp_path, done):
    """After `rm features.parquet.sha256`, `campaign status` said bad (exit 1) while `plot` and CampaignResult read
    the table without a word: the readers now refuse it too, and a rerun rewrites it."""
    from ur5fault.campaign import CampaignResult
    from ur5fault.health.diagnostics.data import load_features
    from ur5fault.util.io import StoredFileError

    out = _copy(done, tmp_path)
    (out / "features.parquet.sha256").unlink()
    assert status(out)["features"]["state"] == "bad"
    for read in (CampaignResult.load, load_features):
        with pytest.raises(StoredFileError, match=r"features.parquet: no checksum recorded beside it \(its write was "
                                                  r"cut short, or the checksum file was deleted\)"):
            read(out)
    run_campaign(load_campaign(tiny(tmp_path)), out, jobs=1, progress=False, note=None)
    assert status(out)["sound"] is True and len(CampaignResult.load(out).features) == 3


def test_the_recorded_campaign_is_rebuilt_from_its_data_or_an_older_manifests_text(done):
    """One path rebuilds the campaign a manifest records (the edited-campaign scan, verify, a re-simulation): from
    the validated mapping, or from the YAML text of a manifest written before the mapping was recorded; None where
    it holds neither; a campaign this ur5fault cannot validate raises its one line."""
    import json

    from ur5fault.campaign.manifest import recorded_campaign
    from ur5fault.errors import Ur5FaultError

    manifest = json.loads((done / "out" / "manifest.json").read_text())
    camp = recorded_campaign(manifest)
    assert [rc.run_id for rc in camp.runs] == [rc.run_id for rc in load_campaign(tiny(done)).runs]
    older = {k: v for k, v in manifest.items() if k != "campaign_data"}
    assert [rc.run_id for rc in recorded_campaign(older).runs] == [rc.run_id for rc in camp.runs]
    assert recorded_campaign({"name": "x"}) is None
    with pytest.raises(Ur5FaultError, match="manifest.json"):
        recorded_campaign({**manifest, "campaign_data": {**manifest["campaign_data"], "duration_s": -1}})
