"""The speed benchmark runs (quick mode) and prints its JSON line; its figures are not asserted."""

import json
import subprocess
import sys

import pytest

from conftest import REPO

BENCH = REPO / "bench" / "bench_speed.py"


@pytest.mark.slow  # a benchmark harness, not a correctness check: `make test-fast` skips it
def test_bench_quick_prints_figures():
    r = subprocess.run([sys.executable, str(BENCH), "--quick"], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout.strip().splitlines()[-1])
    for key in ("a_bare_mj_step_us", "a_off_bare_mj_step_timers_off_us", "a0_bare_compiled_loop_us",
                "a0d_bare_compiled_damped_us", "b_one_run_us_per_step",
                "ratio_b_to_a_median", "ratio_b_to_a_off_median", "ratio_b_to_a0d_median", "ratio_c_batch32_to_a0d",
                "ratio_c_batch32_to_a0d_adjacent",
                "c_batch8_us_per_run_step", "c_batch32_us_per_run_step", "c_batch128_us_per_run_step",
                "ratio_c_best_to_a_per_core", "peak_MB_per_run_batch32"):
        assert key in out and out[key] > 0
