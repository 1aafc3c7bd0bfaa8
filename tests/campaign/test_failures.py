"""What the world does to a running campaign: a full disk (a real one: a small tmpfs mounted in a
private mount namespace), a worker process killed, a reader that closes the pipe. Each ends in one
line (or silence for the pipe), nothing a later run cannot repair."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import REPO

EIGHT = """name: eight
trajectory: pick_and_place
duration_s: 0.3
log_period_s: 0.001
base: {seed: 0, payload_kg: 2.0}
sweep:
  backlash.joint: [2]
  backlash.backlash_deg: [0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4]
batch_size: 2
"""

CLI = [sys.executable, "-m", "ur5fault.cli"]


def _env():
    return {**os.environ, "PYTHONPATH": str(REPO)}


def _unshare_ok() -> bool:
    try:
        return subprocess.run(["unshare", "-rm", "true"], capture_output=True, timeout=10).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


needs_tmpfs = pytest.mark.skipif(not _unshare_ok(), reason="needs `unshare -rm` to mount a small tmpfs")


def _on_full_disk(tmp_path: Path, free_bytes: int, steps: str) -> subprocess.CompletedProcess:
    """Run shell ``steps`` with ``$D`` a 2 MB tmpfs filled up to ``free_bytes`` by ``$D/filler``."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    script = f"""set -u
D={mnt}
mount -t tmpfs -o size=2m tmpfs "$D" || exit 99
head -c 4000000 /dev/zero > "$D/filler" 2>/dev/null
truncate -s -{free_bytes} "$D/filler"
{steps}
"""
    return subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True, timeout=600,
                          env=_env(), cwd=tmp_path)


def _run(tmp_path: Path) -> str:
    f = tmp_path / "eight.yaml"
    f.write_text(EIGHT)
    return f"{' '.join(CLI)} campaign run {f} --out $D/out --jobs 2 --quiet"


@needs_tmpfs
@pytest.mark.parametrize("free_bytes", [0, pytest.param(60_000, marks=pytest.mark.slow)])  # none left, or a few runs
def test_full_disk_one_line_then_a_rerun_works(tmp_path, free_bytes):
    run = _run(tmp_path)
    r = _on_full_disk(tmp_path, free_bytes, f"""
{run}; echo "first=$?"
{' '.join(CLI)} campaign status $D/out > $D/../status.json 2>/dev/null
rm "$D/filler"
{run} >/dev/null 2>&1; echo "second=$?"
""")
    assert r.returncode != 99, r.stderr
    err = [line for line in r.stderr.splitlines() if not line.startswith("ur5fault: note:")]
    assert len(err) == 1 and err[0].startswith("ur5fault: error: ") and "No space left on device" in err[0], r.stderr
    assert "first=2" in r.stdout and "second=0" in r.stdout, r.stdout
    assert '"lock": null' in (tmp_path / "status.json").read_text()


@pytest.mark.slow
def test_killed_worker_is_one_line_and_the_rerun_finishes(tmp_path):
    f = tmp_path / "eight.yaml"
    # long enough that the workers are still simulating when one is killed (the compiled step loop runs 2 s of
    # simulated time in well under a second: the whole campaign could finish before the kill)
    f.write_text(EIGHT.replace("duration_s: 0.3", "duration_s: 20.0"))
    cmd = [*CLI, "campaign", "run", str(f), "--out", str(tmp_path / "out"), "--jobs", "2", "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    worker = None
    deadline = time.time() + 120
    while worker is None and time.time() < deadline and proc.poll() is None:
        time.sleep(0.5)
        worker = next(iter(_children(proc.pid)), None)
    assert worker is not None, "no worker process appeared"
    time.sleep(1)  # let it start simulating
    os.kill(worker, signal.SIGKILL)
    _, err = proc.communicate(timeout=300)
    lines = [line for line in err.splitlines() if not line.startswith("ur5fault: note:")]
    assert proc.returncode == 2 and len(lines) == 1, err
    assert lines[0].startswith("ur5fault: error: a worker process died"), err
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=_env())
    assert r.returncode == 0, r.stderr


def _children(pid: int) -> list[int]:
    out = []
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            out += [int(c) for c in (task / "children").read_text().split()]
        except OSError:
            pass
    # loky's workers only: a resource tracker, or a short-lived child such as the manifest's git call, may come
    # first (killing git instead of a worker let the campaign finish with exit 0 under load)
    return [c for c in out if "loky" in _cmdline(c) and "resource_tracker" not in _cmdline(c)]


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_text()
    except OSError:
        return ""


def test_status_into_a_closed_pipe_is_silent(tmp_path):
    """`ur5fault campaign status DIR | head`: no BrokenPipeError traceback when the reader leaves."""
    (tmp_path / "out" / "runs").mkdir(parents=True)
    r = subprocess.run(f"{' '.join(CLI)} campaign status {tmp_path / 'out'} | true; echo ${{PIPESTATUS[0]}} >&2",
                       shell=True, executable="/bin/bash", capture_output=True, text=True, timeout=120, env=_env())
    assert "Traceback" not in r.stderr and "BrokenPipe" not in r.stderr, r.stderr
    assert r.stderr.strip().splitlines()[-1] == str(128 + signal.SIGPIPE)
