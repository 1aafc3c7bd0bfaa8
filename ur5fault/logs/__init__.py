"""Measured logs: readers (:mod:`.readers`) for UR RTDE CSV, the NIST layout and ur5fault's own
time series, defensive file access (:mod:`.source`) and plausibility checks (:mod:`.plausible`); the command
line's log options (:mod:`.options`) and the refusal of one recording given twice (:mod:`.same_samples`)."""

from .measured import MeasuredLog
from .readers import (
    NIST_PAYLOAD_KG,
    NIST_TOOL_OFFSET_M,
    READERS,
    UR_CURRENT_SIGN,
    read_log,
    read_nist,
    read_rtde,
    read_sim,
)

__all__ = ["MeasuredLog", "NIST_PAYLOAD_KG", "NIST_TOOL_OFFSET_M", "READERS", "UR_CURRENT_SIGN", "read_log",
           "read_nist", "read_rtde", "read_sim"]
