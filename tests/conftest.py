"""Shared test constants (paths, the UR5's joint names) and fixtures: the real NIST log (in the repository's data/:
a failure, not a skip, when absent) and cached simulations reused by several physics tests.

Test modules import the constants with ``from conftest import ...`` (``tests/`` is on the path through
``pythonpath`` in pyproject.toml, which also makes ``reference_ur5`` importable)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

#: the repository checkout; its data/ folder holds the real logs (data/*/README.md)
REPO = Path(__file__).resolve().parents[1]
NIST_LOG = REPO / "data" / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"
#: the nine runs of a second real UR5 (CB2, 125 Hz, no temperatures; data/kufieta-ur5/README.md)
KUFIETA_DIR = REPO / "data" / "kufieta-ur5"
KUFIETA_RUNS = tuple(sorted(KUFIETA_DIR.glob("*.csv.gz")))
#: the MJCF of the checkout, read directly by the tests of the model file
MODEL_XML = REPO / "ur5fault" / "models" / "ur5.xml"
CAMPAIGNS = REPO / "campaigns"
#: the UR5's joints in DH order as the MJCF names them; typed here, not taken from the package, so the model
#: tests check the MJCF against the reference on their own (test_kinematics checks the package agrees)
JOINT_NAMES = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)


def as_numpy(data):
    """``data`` (nested dicts and lists) with every Python number and bool made the numpy scalar a notebook's arrays
    give (``np.float64``, ``np.int64``, ``np.bool_``): a mapping built from numpy results, as the API may be given."""
    if isinstance(data, dict):
        return {k: as_numpy(v) for k, v in data.items()}
    if isinstance(data, list):
        return [as_numpy(v) for v in data]
    if isinstance(data, bool):
        return np.bool_(data)
    if isinstance(data, int):
        return np.int64(data)
    return np.float64(data) if isinstance(data, float) else data


@pytest.fixture(scope="session")
def nist_path() -> Path:
    if not NIST_LOG.exists():  # part of the repository: a missing log is a broken checkout, not a skip
        pytest.fail(f"real UR5 log missing at {NIST_LOG} (data/ of the repository)")
    return NIST_LOG


@pytest.fixture(scope="session")
def shoulder_backlash_batch():
    """Pick-and-place: healthy twin and shoulder backlash 0.05, 0.1, 0.2 deg, same noise seed."""
    from ur5fault import RunSpec, Simulator, make_effect, pick_and_place

    alphas = (0.0, 0.05, 0.1, 0.2)
    runs = [RunSpec(f"a{a}", 7, (make_effect("backlash", "shoulder_lift_joint", backlash_deg=a),) if a else ())
            for a in alphas]
    return alphas, Simulator().run(pick_and_place(), runs)


def torque_reversal_times(t_s: np.ndarray, torque: np.ndarray, min_gap_s: float = 0.2) -> np.ndarray:
    """Times where a (noisy) torque changes sign, hysteresis of 0.5 N*m against chatter."""
    out, state, last = [], np.sign(torque[0]), -np.inf
    for t, v in zip(t_s, torque):
        if state >= 0 and v < -0.5 or state <= 0 and v > 0.5:
            if t - last > min_gap_s:
                out.append(t)
            state, last = np.sign(v), t
    return np.array(out)
