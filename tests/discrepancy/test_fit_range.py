"""A value the fit itself produces outside an effect's range is a dropped candidate with its reason,
never an exit (`link_mass.com_dz_m = 2.03 is out of range [-0.5, 0.5] m` ended `discrepancy` on the
first 10 s of the NIST log, its output folder empty)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from ur5fault.discrepancy.candidates import LibraryCandidate, TermCandidate

from conftest import REPO


def test_range_problem_names_the_value_and_the_range():
    com = TermCandidate("link_mass", 2, family="link_com", keys=("com_dz_m",), unit="m", local_=False)
    assert com.range_problem(np.array([0.2])) is None
    why = com.range_problem(np.array([2.03]))
    assert why == "fitted link_mass.com_dz_m = 2.03 is outside its valid range [-0.5, 0.5] m"
    assert com.values(np.array([2.03])) == {"com_dz_m": 2.03}  # reported as fitted, without validation
    hold = TermCandidate("torque_holding", 4, family="holding", keys=("torque_Nm",), unit="N*m",
                         fixed=(("speed_rad_s", 0.02),))
    assert "torque_holding.torque_Nm = 127.2 is outside its valid range [-30, 30] N*m" in hold.range_problem(
        np.array([127.2]))
    off = LibraryCandidate("current_sensor_offset", 1, param="offset_A", x0=0.0, probe=0.1)
    assert off.range_problem(np.array([np.nan])).startswith("fitted current_sensor_offset.offset_A = nan")


@pytest.mark.slow
def test_first_ten_seconds_of_the_nist_log_end_with_a_model(tmp_path, nist_path):
    """The issue's probe (about 4 min on 2 shared cores): exit 0, the centre-of-mass term whose fit
    leaves its range dropped with the reason, and a model written."""
    import gzip
    import json

    cut = tmp_path / "nist10.csv.gz"
    with gzip.open(nist_path, "rt") as src, gzip.open(cut, "wt") as dst:
        for i, line in enumerate(src):
            if i > 1250:
                break
            dst.write(line)
    r = subprocess.run([sys.executable, "-m", "ur5fault.cli", "discrepancy", str(cut), "--format", "nist", "--out",
                        str(tmp_path / "out"), "--quiet", "--jobs", "2"], capture_output=True, text=True,
                       timeout=1200, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert r.returncode == 0, r.stderr
    def refuse(token):
        raise AssertionError(f"summary.json holds {token}: not JSON outside Python")

    summ = json.loads((tmp_path / "out" / "summary.json").read_text(), parse_constant=refuse)
    reasons = [f["reason"] for f in summ["findings"] if not f["kept"]]
    assert all("is out of range" not in why for why in reasons)
    assert (tmp_path / "out" / "model.yaml").exists()
