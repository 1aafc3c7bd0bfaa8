"""How ``bench/discrepancy_real_hidden.py`` scores an injected effect on a joint where the clean log's own fit
already names the same effect (docs/discrepancy.md, *Traced misses*): per log, the change against the clean
fit's estimate; with ``--baseline``, the faulty log is fitted from the clean fit's model, so its finding is the
change itself.  Fitted models are stood in for by their findings; the expected sizes are written by hand."""

from __future__ import annotations

import importlib.util
import types

import numpy as np
import pytest

from ur5fault.discrepancy.candidates import LibraryCandidate
from ur5fault.discrepancy.judging import Finding

from conftest import REPO


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("discrepancy_real_hidden",
                                                  REPO / "bench" / "discrepancy_real_hidden.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _offset(joint: int, amps: float, kept: bool = True) -> Finding:
    c = LibraryCandidate("current_sensor_offset", joint, param="offset_A", x0=0.0, probe=0.1)
    return Finding(c, np.array([amps]), np.array([0.005]), None, kept=kept)


def _model(*findings: Finding, base=()):
    found = list(findings)
    return types.SimpleNamespace(findings_=found, effects_=[f for f in found if f.kept], base_effects_=tuple(base),
                                 unexplained_=[])


def test_per_log_score_is_the_change_against_the_clean_fit(bench):
    # the real NIST log's elbow: the clean fit names +0.072 A; a fault of -0.15 A leaves -0.078 A
    clean = _model(_offset(2, 0.072))
    est, alt = bench.named_change(_model(_offset(2, -0.078)), clean, "current_sensor_offset", 2)
    assert est == pytest.approx(-0.150) and not alt


def test_a_clean_finding_that_vanishes_is_not_read_as_a_change_per_log(bench):
    # wrist_2: the clean fit names -0.057 A; +0.05 A injected leaves -0.007 A, which the faulty log's fit
    # rightly does not name, so its report says nothing about wrist_2
    clean = _model(_offset(4, -0.057))
    assert bench.named_change(_model(), clean, "current_sensor_offset", 4) == (None, False)


def test_from_the_clean_model_a_finding_is_the_change_itself(bench):
    clean = _model(_offset(4, -0.057), _offset(0, -0.08, kept=False))
    start = bench.baseline_of(clean)
    # the clean fit's kept findings, not its dropped ones, make the starting model
    got = [(e.name, e.joint_index, dict(e.values)["offset_A"]) for e in start]
    assert got == [("current_sensor_offset", 4, -0.057)]
    est, _ = bench.named_change(_model(_offset(4, 0.05), base=start), None, "current_sensor_offset", 4)
    assert est == pytest.approx(0.05)


def _rows(log) -> set[bytes]:
    return {r.tobytes() for r in np.hstack([log.q_actual_rad, log.q_target_rad])}


@pytest.mark.parametrize("name", ["nist", "Movement_No1", "Movement_No3_Acc"])
def test_the_engineers_baseline_is_never_fitted_on_the_run_the_fault_is_injected_into(bench, name):
    # ``--engineer``: every fit the bench makes is recorded; the first (the baseline) must share no sample with the
    # run the fault is then injected into, and the injected run must be fitted from the baseline's model
    calls = []
    start = _model(_offset(3, 0.04))

    def fit(logs, base_effects, params=None):
        calls.append((list(logs) if isinstance(logs, list) else [logs], tuple(base_effects)))
        return start if len(calls) == 1 else _model()

    cases = [(ci, effects) for ci, (n, effects) in enumerate(bench.CASES) if n == name][:1]
    items = list(bench.engineer_fits(name, cases, fit))
    assert [i[0] for i in items] == ["baseline", "clean", cases[0][0]] and len(calls) == 3
    healthy, (clean_run,), (injected_run,) = calls[0][0], calls[1][0], calls[2][0]
    suspect = _rows(injected_run)
    assert suspect == _rows(clean_run) and suspect <= _rows(bench.read(name))  # the injected run is the suspect run
    shared = suspect & set().union(*(_rows(lg) for lg in healthy))
    # (q_actual, q_target) rows: a run begins or ends at a home pose another run may hold to the last bit
    assert len(shared) < 0.01 * len(suspect)
    assert calls[0][1] == () and calls[1][1] == calls[2][1] == bench.baseline_of(start)
    assert all(lg.source != injected_run.source for lg in healthy) or name == "nist"
