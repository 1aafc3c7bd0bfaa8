"""The issue's four failure cases on hidden-effect logs made from the REAL NIST log (``real_hidden.py`` says how
each effect enters the measured current).  Expected sizes are the injected ones; on a joint where the clean log
already names the same effect, the injected size is the change against the clean log's fit."""

from __future__ import annotations

import pytest
from real_hidden import busy_angle_deg, inject

from ur5fault.discrepancy import DiscrepancyModel, sentence
from ur5fault.logs.readers import read_log

JOBS = 2


@pytest.fixture(scope="module")
def nist(nist_path):
    return read_log(nist_path, "nist")


@pytest.fixture(scope="module")
def clean(nist):
    return DiscrepancyModel(jobs=JOBS).fit(nist)


def _estimate(model, effect: str, joint: int, as_gain: bool = False):
    """The kept library estimate of ``effect`` on ``joint`` (or of an alternative listed with a kept finding);
    a torque constant k read as the current gain 1/k when ``as_gain``."""
    for f in model.effects_:
        for c, th in [(f.candidate, f.theta), *f.alternatives]:
            if c.source != "library" or c.joint != joint:
                continue
            if c.effect == effect:
                return c.value(th)
            if as_gain and c.effect == "torque_constant":
                return 1.0 / c.value(th)
    return None


def _no_term_on(model, joint: int):
    assert not [f for f in model.terms_ if f.candidate.joint == joint], [sentence(f) for f in model.findings_]


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="issue 18 goal not met (measured, each effect in its own log, by "
                   "bench/discrepancy_real_hidden.py; docs/discrepancy.md): the shoulder_lift gain is named +0.208 "
                   "against +0.12 injected (limit 25 % of 0.12); the base friction x 1.79 is named at -6 % in its "
                   "own log since a dropped finding gives its joint's place back (this combined log not re-measured)")
def test_gain_on_shoulder_lift_and_base_friction_are_named_not_free_shapes(nist, clean):
    """Cases 1 and 2: the current reading x 1.12 on shoulder_lift (mostly gravity there: a gain and a cos q
    torque look alike) and the base's Coulomb friction x 1.79, in one log."""
    log = inject(inject(nist, "current_sensor_gain", 1, gain=1.12), "coulomb_friction", 0, scale=1.79)
    m = DiscrepancyModel(jobs=JOBS).fit(log)
    g0 = _estimate(clean, "current_sensor_gain", 1, as_gain=True) or 1.0
    g = _estimate(m, "current_sensor_gain", 1, as_gain=True)
    assert g is not None, [sentence(f) for f in m.findings_]
    assert abs((g / g0 - 1.0) - 0.12) <= 0.25 * 0.12, (g, g0)
    s0 = _estimate(clean, "coulomb_friction", 0) or 1.0
    s = _estimate(m, "coulomb_friction", 0)
    assert s is not None, [sentence(f) for f in m.findings_]
    assert abs((s - s0) - 0.79) <= 0.25 * 0.79, (s, s0)
    _no_term_on(m, 0)
    _no_term_on(m, 1)


@pytest.mark.slow
def test_a_base_friction_rise_is_named_when_the_term_that_displaced_it_is_dropped(nist, clean):
    """Case 2 alone: the base's Coulomb friction x 1.79.  Discovery puts a Stribeck-like term in the Coulomb
    scale's place, the final check drops the term; the joint's place is then given back and the Coulomb scale
    named (rescreen.py)."""
    m = DiscrepancyModel(jobs=JOBS).fit(inject(nist, "coulomb_friction", 0, scale=1.79))
    s0 = _estimate(clean, "coulomb_friction", 0) or 1.0
    s = _estimate(m, "coulomb_friction", 0)
    assert s is not None, [sentence(f) for f in m.findings_]
    assert abs((s - s0) - 0.79) <= 0.25 * 0.79, (s, s0)
    _no_term_on(m, 0)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="issue 18 goal not met (measured on this log by the bench): wrist_1's 8 % "
                   "gain appears only as an alternative at -10.8 % (34 % off; an offset and a gain are nearly one "
                   "column on that joint) and the elbow offset is missed")
def test_two_faults_on_two_joints_beside_the_models_own_error(nist, clean):
    """Case 3: wrist_1's current reading 8 % low and the elbow's offset by -0.15 A."""
    log = inject(inject(nist, "current_sensor_gain", 3, gain=0.92), "current_sensor_offset", 2, offset_A=-0.15)
    m = DiscrepancyModel(jobs=JOBS).fit(log)
    g0 = _estimate(clean, "current_sensor_gain", 3, as_gain=True) or 1.0
    g = _estimate(m, "current_sensor_gain", 3, as_gain=True)
    assert g is not None, [sentence(f) for f in m.findings_]
    assert abs((g / g0 - 1.0) + 0.08) <= 0.25 * 0.08, (g, g0)
    o0 = _estimate(clean, "current_sensor_offset", 2) or 0.0
    o = _estimate(m, "current_sensor_offset", 2)
    assert o is not None, [sentence(f) for f in m.findings_]
    assert abs((o - o0) + 0.15) <= 0.25 * 0.15, (o, o0)


@pytest.mark.slow
def test_a_worn_region_of_the_elbow_is_reported_where_it_is(nist):
    """Case 4: a friction rise of 0.25 A over 10 deg of the elbow's travel, centred where the elbow moves
    most: reported as unexplained in that region (never 'nothing better than noise')."""
    centre = busy_angle_deg(nist, 2)
    m = DiscrepancyModel(jobs=JOBS).fit(inject(nist, "local_friction", 2, amplitude_A=0.25, centre_deg=centre,
                                               width_deg=10.0))
    hits = [u for u in m.unexplained_ if u["joint"] == "elbow_joint" and u["signal"] == "current_A"]
    assert hits, m.unexplained_
    reg = hits[0]["angle_region"]
    assert reg is not None and reg["from_deg"] <= centre <= reg["to_deg"], hits[0]
