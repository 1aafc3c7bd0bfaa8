"""Which health features need which logged signal.

A Universal Robots log (RTDE, the NIST and Kufieta recordings) carries the joint-side position, the motor
current, the setpoints and the joint temperatures, but no motor-side encoder: every feature of the encoder
mismatch ``q_M,FB / N - q_FB`` is then unknown.  One list, used by a campaign that simulates such logs
(``motor_encoders: false``) and by ``ur5fault diagnose`` on a log without motor encoders, so that the two
compute the same inputs.
"""

from __future__ import annotations

#: name fragments of the features computed from the motor encoder (the paper's encoder-mismatch features and
#: the twin residual features of the mismatch fit: its residual, offset, backlash and compliance estimates)
MOTOR_ENCODER_MARKERS = ("enc_mismatch_", "twin_mismatch_", "twin_est_mismatch_offset", "twin_est_backlash",
                         "twin_est_compliance")


def needs_motor_encoders(name: str) -> bool:
    """Whether the feature ``name`` is computed from the motor encoder."""
    return any(m in name for m in MOTOR_ENCODER_MARKERS)


__all__ = ["MOTOR_ENCODER_MARKERS", "needs_motor_encoders"]
