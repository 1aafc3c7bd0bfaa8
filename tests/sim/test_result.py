"""SimResult at its edge: a signal or a run looked up by a name that does not exist lists the ones that do, an index
out of range says the batch's size, and the writers refuse a file name whose suffix a reader would misread."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ur5fault import RunSpec, Simulator
from ur5fault.errors import ParameterError, UnknownNameError
from ur5fault.sim.trajectories import hold

SIGNALS = ("T_f_Nm, T_gear_Nm, i_FB_A, i_d_A, i_q_A, i_ref_A, q_FB_rad, q_M_FB_rad, q_M_rad, q_rad, v_d_V, v_q_V, "
           "w_M_FB_rad_s")


@pytest.fixture(scope="module")
def res():
    return Simulator().run(hold(seconds=0.1), [RunSpec("a", 1), RunSpec("b", 2)], duration_s=0.02)


def test_unknown_signal_lists_the_signals(res):
    with pytest.raises(UnknownNameError) as e:
        res["q_fb_rad"]
    assert str(e.value) == ("SimResult[...]: unknown signal 'q_fb_rad' (did you mean 'q_M_rad' or 'q_rad' or "
                            f"'q_FB_rad'?); valid: {SIGNALS}")
    assert isinstance(e.value, KeyError)  # as a dict's lookup was
    with pytest.raises(UnknownNameError) as e:
        res[0]
    assert str(e.value) == ("SimResult[...] takes a signal name (a run's table is to_pandas(0)): unknown signal 0; "
                            f"valid: {SIGNALS}")
    assert res["q_rad"].shape == (2, 20, 6)


def test_run_by_id_or_index(res):
    assert res.run_index("b") == 1 and res.run_index(1) == 1 and res.run_index(np.int64(1)) == 1
    assert res.run_index(-1) == 1 and res.run_index(-2) == 0
    pd.testing.assert_frame_equal(res.to_pandas("b"), res.to_pandas(np.int64(1)))
    assert res.run_metadata("b") == res.run_metadata(1) and res.run_metadata("b")["run_id"] == "b"
    assert res.summary("b") == res.summary(1)


def test_unknown_run_id_lists_the_run_ids(res):
    for call in (res.to_pandas, res.run_metadata, res.summary):
        with pytest.raises(UnknownNameError, match=r"^SimResult: unknown run_id 'c'; valid: a, b$"):
            call("c")


@pytest.mark.parametrize("run, message", [
    (2, r"^SimResult: run = 2 is out of range: the result holds 2 run\(s\), index 0..1 \(or -2..-1 from the end\) "
        r"or a run_id \('a', 'b'\)$"),
    (-3, r"^SimResult: run = -3 is out of range"),
    (1.5, r"^SimResult: run = 1.5 must be a run_id \(one of 'a', 'b'\) or an index 0..1$"),
    (True, r"^SimResult: run = True must be a run_id"),
    (None, r"^SimResult: run = None must be a run_id"),
])
def test_a_run_that_is_not_one_is_refused(res, run, message):
    for call in (res.to_pandas, res.run_metadata, res.summary):
        with pytest.raises(ParameterError, match=message):
            call(run)


@pytest.mark.parametrize("method, name, message", [
    ("to_parquet", "x.csv", r"ends in '.csv', not .parquet: give a .parquet file; SimResult.to_csv writes .csv files$"),
    ("to_parquet", "x", r"has no suffix, not .parquet: give a .parquet file$"),
    ("to_parquet", "x.pq", r"ends in '.pq', not .parquet: give a .parquet file$"),
    ("to_csv", "x.parquet", r"ends in '.parquet', not .csv: give a .csv file; SimResult.to_parquet writes .parquet "
                            r"files$"),
    ("to_csv", "x.csv.gz", r"ends in '.gz', not .csv: give a .csv file$"),
    ("to_csv", "x.txt", r"ends in '.txt', not .csv: give a .csv file$"),
])
def test_a_file_of_another_format_is_refused_before_writing(res, tmp_path, method, name, message):
    with pytest.raises(ParameterError, match=rf"^SimResult.{method}: path '{tmp_path / name}' {message}"):
        getattr(res, method)(tmp_path / name)
    assert list(tmp_path.iterdir()) == []


def test_writers_take_their_suffix_in_any_case_and_refuse_a_non_path(res, tmp_path):
    assert res.to_parquet(tmp_path / "r.PARQUET", "b") == tmp_path / "r.PARQUET"
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "r.PARQUET"), res.to_pandas("b"))
    assert res.to_csv(str(tmp_path / "r.csv")) == tmp_path / "r.csv"
    assert len(pd.read_csv(tmp_path / "r.csv")) == 20
    with pytest.raises(ParameterError, match=r"^SimResult.to_parquet: path = 5 must be a file path ending in "
                                             r".parquet$"):
        res.to_parquet(5)
    with pytest.raises(UnknownNameError, match=r"^SimResult: unknown run_id 'c'; valid: a, b$"):
        res.to_parquet(tmp_path / "c.parquet", "c")
