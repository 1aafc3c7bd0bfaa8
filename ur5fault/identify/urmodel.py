"""What UR's own controller model assumes, read back from its logged prediction.

UR logs, beside the measured current, the current its controller model predicts
(NIST ``ROBOT_TARGET_JOITN_CURRENT``, RTDE ``target_current``) and the inverse-dynamics torque
behind it (``target_moment``).  On moving samples the prediction is, to a few milliamperes,

    i_UR = tau_UR / K_UR + F_c,UR * sign(w) + F_v,UR * w

so a least-squares fit recovers UR's own torque constants and friction: an independent
reference for ours (reported as checks, never written).  Its ratio of size-1 to size-3
torque constants is the one piece of evidence this log gives on the wrists' K.
"""

from __future__ import annotations

import numpy as np

from .friction import FrictionFit
from .stats import Estimate

#: UR's prediction counts as read back when the fit leaves less than this RMS [A]
MAX_RESIDUAL_A = 0.02


def ur_model(fit: FrictionFit) -> list[Estimate]:
    """UR's torque constant [N*m/A, motor side], Coulomb [A] and viscous [A*s/rad] per moving joint."""
    sig = fit.sig
    if sig.target_current_A is None or sig.target_torque_Nm is None:
        return []
    out = []
    w = sig.qd_target_rad_s
    for j in np.flatnonzero(fit.ok):
        r = np.flatnonzero(fit.moving[:, j])
        a = np.column_stack([sig.target_torque_Nm[r, j], np.sign(w[r, j]), w[r, j]])
        y = sig.target_current_A[r, j]
        coef = np.linalg.lstsq(a, y, rcond=None)[0]
        rms = float(np.sqrt(np.mean((y - a @ coef) ** 2)))
        if rms > MAX_RESIDUAL_A or coef[0] <= 0:
            continue
        how = (f"UR's own model read back from its predicted current ({r.size} moving samples, "
               f"residual {1e3 * rms:.1f} mA; no interval: a deterministic model)")
        nan = float("nan")
        kt = 1.0 / coef[0] / fit.ratio[j]
        out += [Estimate("check.UR_model_torque_constant_Nm_per_A", int(j), kt, nan, nan, how),
                Estimate("check.UR_model_coulomb_A", int(j), float(coef[1]), nan, nan, how),
                Estimate("check.UR_model_viscous_A_s_per_rad", int(j), float(coef[2]), nan, nan, how)]
    return out
