"""A run is the same on every machine's BLAS: the small products and solves of the setup code
(ur5fault/util/portable.py) against numpy's own, and whole runs simulated under different OpenBLAS kernels
(``OPENBLAS_CORETYPE``, read when the library loads: one process each), compared bit for bit.

Before the setup code went through util/portable.py, 20 motions of ``random_pick_and_place`` gave four different
setpoint hashes under five kernels, and a 7.4 s run's quantised current readings differed by a step from 2.4 s on
under Prescott against Haswell (docs/diagnostics.md, "The same campaign on another machine")."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import numpy as np
import pytest

from ur5fault.util.portable import matmul, solve_spd, sq_norm


def test_matmul_and_norm_against_numpy():
    rng = np.random.default_rng(3)
    for shape in ((3, 3, 3), (4, 4, 4), (6, 2, 5), (1, 6, 1)):
        a, b = rng.normal(size=shape[:2]), rng.normal(size=shape[1:])
        np.testing.assert_allclose(matmul(a, b), a @ b, rtol=1e-13, atol=1e-14)
    v = rng.normal(size=7)
    assert sq_norm(v) == pytest.approx(float(np.dot(v, v)), rel=1e-14)


def test_solve_spd_against_numpy_and_refuses_an_indefinite_matrix():
    rng = np.random.default_rng(4)
    j = rng.normal(size=(6, 6))
    a = j @ j.T + 1e-4 * np.eye(6)  # the IK's damped normal matrix
    b = rng.normal(size=6)
    x = solve_spd(a, b)
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-9)
    np.testing.assert_allclose(a @ x, b, atol=1e-10)
    with pytest.raises(np.linalg.LinAlgError, match="positive definite"):
        solve_spd(np.array([[1.0, 2.0], [2.0, 1.0]]), np.ones(2))


# kernels every x86-64 machine with AVX2 runs (newer ones need AVX-512 or AMX)
KERNELS = ("Prescott", "Haswell")
SETPOINTS = """
import hashlib
from ur5fault.sim.trajectories import get_trajectory
h = hashlib.sha256()
for seed in range(6):
    for tilt in (0, 20):
        h.update(get_trajectory("random_pick_and_place", seed=seed, tool_tilt_deg=tilt).q_set_rad.tobytes())
print(h.hexdigest())
"""
RUN = """
import hashlib, numpy as np
from ur5fault import RunSpec, Simulator, get_trajectory, make_effect
traj = get_trajectory("random_pick_and_place", seed=7, tool_tilt_deg=20)
res = Simulator().run(traj, [RunSpec("r", seed=3, effects=(make_effect("payload", mass_kg=1.5),))])
h = hashlib.sha256()
for name in sorted(res.signals):
    h.update(name.encode()); h.update(np.ascontiguousarray(res.signals[name]).tobytes())
h.update(np.ascontiguousarray(res.tcp_m).tobytes())
print(h.hexdigest())
"""


def _under(kernel: str, code: str) -> str:
    env = {**os.environ, "OPENBLAS_CORETYPE": kernel}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip().splitlines()[-1]


def _openblas_x86() -> bool:
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    cfg = np.show_config(mode="dicts") or {}
    return "openblas" in str(cfg.get("Build Dependencies", {}).get("blas", {})).lower()


needs_openblas = pytest.mark.skipif(not _openblas_x86(), reason="OPENBLAS_CORETYPE: numpy's OpenBLAS on x86-64 only")


@needs_openblas
def test_motion_setpoints_the_same_under_every_blas_kernel():
    assert len({_under(k, SETPOINTS) for k in KERNELS}) == 1


@needs_openblas
@pytest.mark.slow
def test_a_whole_run_the_same_under_every_blas_kernel():
    assert len({_under(k, RUN) for k in KERNELS}) == 1


TWIN_FEATURES = """
import json, sys, tempfile
import pandas as pd
from ur5fault.campaign import build_campaign, run_campaign
spec = {"name": "twins", "duration_s": 2.0, "batch_size": 16, "twin_residuals": True,
        "sample": {"n": 6, "seed": 5, "faults": {"healthy": {}, "backlash": {"size": {"log": [0.05, 0.5]}}},
                   "conditions": {"payload_kg": [0.5, 3.0],
                                  "trajectory": {"name": "random_pick_and_place", "seed": {"integers": [0, 2]}}}},
        "split": {"test_fraction": 0.5}}
with tempfile.TemporaryDirectory() as out:
    run_campaign(build_campaign(spec, "twins.yaml", out=out), out, jobs=1, progress=False, note=None)
    df = pd.read_parquet(out + "/features.parquet").sort_values("run_id").set_index("run_id")
cols = [c for c in df.columns if c.startswith("twin_est_")]
print(json.dumps(df[cols].to_dict(orient="index")))
"""


@needs_openblas
@pytest.mark.slow
def test_twin_feature_estimates_the_same_under_every_blas_kernel():
    # the twin fits still sum through BLAS, so well-determined estimates may differ in their last bits; what must
    # not differ is which columns a fit keeps: before the fits decided it by singular values (health/twin_fit.py),
    # a column the motion cannot tell from the others (a backlash flank column on a joint whose gear torque never
    # reverses) was kept under one kernel and left out under another (917 of 2,546 runs of the diagnostics
    # campaign), with t values up to 9 where it was kept
    import json
    import math

    a, b = (json.loads(_under(k, TWIN_FEATURES)) for k in KERNELS)
    assert a.keys() == b.keys() and len(a) >= 6
    for run in a:
        for col, x in a[run].items():
            y = b[run][col]
            assert (x is None or math.isnan(x)) == (y is None or math.isnan(y)), (run, col, x, y)
            if x is not None and not math.isnan(x):
                assert x == pytest.approx(y, rel=1e-6, abs=1e-12), (run, col)
