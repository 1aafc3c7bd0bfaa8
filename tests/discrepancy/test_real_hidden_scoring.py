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
    return types.SimpleNamespace(findings_=found, effects_=[f for f in found if f.kept], base_effects_=tuple(base))


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
