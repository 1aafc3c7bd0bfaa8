"""numba's on-disk cache verified on read (``ur5fault/sim/jitcache.py``): a damaged cache file is compiled again,
never a traceback in every later process and never machine code other than was compiled.  Each case runs a tiny
cached function in fresh processes (the cache is read only when a process first calls the function)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODULE = '''import sys
from numba import njit

@njit(cache=True)
def f(x):
    return x * 2.5 + 1.0
{protect}
'''
PROBE = "import m; print(m.f(2.0), m.f.stats.cache_hits.get(m.f.signatures[0], 0) if m.f.signatures else 0)"


def _run(folder: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": f"{folder}{os.pathsep}{ROOT}", "NUMBA_CACHE_DIR": str(folder / "cache")}
    return subprocess.run([sys.executable, "-c", PROBE], cwd=folder, env=env, capture_output=True, text=True,
                          timeout=300)


def _module(folder: Path, protected: bool) -> None:
    line = ("from ur5fault.sim.jitcache import protect\nprotect(sys.modules[__name__])" if protected else "")
    (folder / "m.py").write_text(MODULE.format(protect=line))


def _files(folder: Path, pattern: str) -> list[Path]:
    return sorted((folder / "cache").rglob(pattern))


def _damage(paths: list[Path], how: str) -> None:
    for p in paths:
        b = bytearray(p.read_bytes())
        if how == "flip":
            b[len(b) // 2] ^= 0xFF
        else:
            del b[10:]
        p.write_bytes(bytes(b))


def test_plain_numba_cache_truncated_stops_every_later_process(tmp_path):
    """The premise, measured: numba alone raises on a truncated cache file, in every process until it is
    deleted by hand."""
    _module(tmp_path, protected=False)
    assert _run(tmp_path).returncode == 0
    _damage(_files(tmp_path, "*.nbc"), "truncate")
    for _ in range(2):
        r = _run(tmp_path)
        assert r.returncode != 0 and "pickle data was truncated" in r.stderr


def test_a_flipped_code_file_then_a_truncated_index_are_compiled_again(tmp_path):
    _module(tmp_path, protected=True)
    assert _run(tmp_path).stdout.split() == ["6.0", "0"]  # 2 * 2.5 + 1, compiled
    for pattern, how in (("*.nbc", "flip"), ("*.nbi", "truncate")):
        _damage(_files(tmp_path, pattern), how)
        r = _run(tmp_path)
        assert r.returncode == 0 and r.stdout.split() == ["6.0", "0"], r.stderr  # not read: compiled again
        assert _run(tmp_path).stdout.split() == ["6.0", "1"]  # and rewritten sound


@pytest.mark.slow
@pytest.mark.parametrize("pattern, how", [("*.nbc", "flip"), ("*.nbc", "truncate"), ("*.nbi", "flip"),
                                          ("*.nbi", "truncate")])
def test_a_damaged_checked_cache_is_compiled_again_and_rewritten(tmp_path, pattern, how):
    _module(tmp_path, protected=True)
    first = _run(tmp_path)
    assert first.returncode == 0, first.stderr
    assert first.stdout.split() == ["6.0", "0"]  # 2 * 2.5 + 1, compiled
    assert _run(tmp_path).stdout.split() == ["6.0", "1"]  # read from the cache
    files = _files(tmp_path, pattern)
    assert files and all(".sha256." in p.name for p in files)  # the checked files, not numba's plain ones
    _damage(files, how)
    r = _run(tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["6.0", "0"]  # not read: compiled again
    assert _run(tmp_path).stdout.split() == ["6.0", "1"]  # and the cache rewritten sound
