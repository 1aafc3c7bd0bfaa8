"""What identify tells the user beside its table (ur5fault/identify/core.py): a stated payload its own check on UR's
torques contradicts, and why a torque constant was kept at the model's value."""

from __future__ import annotations

import types

import numpy as np

from ur5fault.identify import friction
from ur5fault.identify.core import K_VS_UR_NOTE_SHARE, _why_no_lever, stated_payload_notes
from ur5fault.identify.stats import Estimate

K, UR = "motor.torque_constant_Nm_per_A", "check.torque_constant_vs_UR_torque_Nm_per_A"


def test_a_torque_constant_that_ur_torques_contradict_is_noted():
    """A probe stated 3 kg for a run without a payload: the torque constant came out 0.1628 N*m/A where UR's own
    target torques gave 0.1075 (0.1065 with the right 0 kg), and identify said nothing."""
    wrong = [Estimate(K, 1, 0.1628, 0.160, 0.166, ""), Estimate(UR, 1, 0.1075, 0.1071, 0.1081, "")]
    notes = stated_payload_notes(wrong)
    assert len(notes) == 1 and notes[0].startswith("J2's torque constant") and "+51 %" in notes[0], notes
    assert "check the payload and tool stated" in notes[0]
    right = [Estimate(K, 1, 0.1065, 0.1059, 0.1073, ""), Estimate(UR, 1, 0.1075, 0.1071, 0.1081, "")]
    assert stated_payload_notes(right) == []  # as every real log of data/: within 3 %
    # far apart but not told apart by their intervals, or apart by less than the share: nothing said
    wide = [Estimate(K, 1, 0.14, 0.10, 0.18, ""), Estimate(UR, 1, 0.11, 0.10, 0.12, "")]
    assert stated_payload_notes(wide) == []
    near = 1.0 + 0.9 * K_VS_UR_NOTE_SHARE
    assert stated_payload_notes([Estimate(K, 1, 0.1 * near, 0.1 * near, 0.1 * near, ""),
                                 Estimate(UR, 1, 0.1, 0.1, 0.1, "")]) == []


def test_why_a_joint_does_not_carry_its_torque_constant_names_the_real_cause():
    """A 62.5 Hz log: the reason read "model torque spread 0.79, 9.18, 0.09 N*m < 2" although 9.18 is not below 2:
    that joint had the lever but too few moving samples."""
    moving = np.zeros((1000, 3), bool)
    moving[:300, 1] = True
    qd = np.zeros((1000, 3))
    qd[:300, 1] = 0.5
    fit = types.SimpleNamespace(ok=np.array([False, False, True]), moving=moving,
                                sig=types.SimpleNamespace(qd_target_rad_s=qd), lever_Nm=np.array([0.79, 9.18, 0.09]))
    assert _why_no_lever(fit, 1) == (f"J2 moves too little for the friction fit (300 moving samples up to 0.5 rad/s; "
                                     f"{friction.MIN_MOVING_SAMPLES} samples and {friction.MIN_TOP_SPEED_RAD_S:g} "
                                     "rad/s needed)")
    assert _why_no_lever(fit, 2) == "J3's model torque spreads 0.09 N*m (< 2)"


def test_a_coulomb_level_within_noise_of_zero_is_not_taken_for_currents_of_the_other_sign():
    """The review: a joint with next to no Coulomb friction (a simulated log at scale 0) fits a few mA either way,
    and a fit of -0.004 A was refused as "a log with currents of the other sign"."""
    import pytest

    from ur5fault.errors import LogFormatError
    from ur5fault.identify.core import SIGN_COULOMB_A, refuse_current_sign

    fit = types.SimpleNamespace(k_groups={3: [1], 1: []}, ok=np.array([True, True, False, False, False, False]),
                                ratio=np.full(6, 101.0))
    full = np.zeros((3, 6))
    full[0, 1] = 13.0  # K * ratio: positive
    full[1, :2] = [-0.004, 0.3]
    refuse_current_sign(fit, full, "near0.csv")  # not refused
    full[1, 0] = -2 * SIGN_COULOMB_A
    with pytest.raises(LogFormatError, match=r"near0.csv: the Coulomb friction of J1 \(-0.1 A\) come out negative"):
        refuse_current_sign(fit, full, "near0.csv")
