"""The least-squares fits behind the twin features' size estimates: regressors for nuisance the robot does not
know, and standard errors that survive correlated residuals.

Two kinds of nuisance put a current residual on a healthy robot that its twin cannot predict, because the
robot does not know them (docs/diagnostics.md): its payload's centre of mass and its setpoint latency.

* **Payload centre of mass.**  A CoM shifted by ``delta`` (flange frame, [m]) from where the twin puts it
  moves the gravity torque of joint ``j`` by ``-(z_j x R delta) . (m g)`` (``z_j`` the joint's axis and ``R``
  the flange's rotation in the base frame, ``m`` the configured payload mass, ``g`` gravity): linear in
  ``delta``, with one column per flange axis, and independent of where the payload sits on the tool (the
  moment arm cancels in the derivative).  Divided by ``K_t N`` it is motor current, so its coefficient is the
  shift in metres.  On the wrists it is nearly constant while the tool keeps pointing down - the shape of a
  current-sensor offset - but it is the SAME shift on every joint: on the parallel axes J2, J3 and J4 a
  sideways shift adds the same torque to all three, while a sensor offset sits on one joint.  Fitted over
  all joints at once, the two are told apart.
  The gear torque the twin's mismatch fit reads (its backlash flank and windup columns, the flank share) is the
  twin's with this shift fed back (:func:`com_corrected_torque`): the robot does not know its payload's CoM, and
  on wrist 2, whose torque is small and set mostly by it, the twin otherwise puts the gear on the wrong flank.
* **Latency.**  Setpoints that arrive ``tau`` late give a measured current ``i(t - tau) ~ i(t) - tau di/dt``:
  one column ``-di_twin/dt`` shared by all joints, whose coefficient is ``tau`` in seconds.

Standard errors: the residual of a 1 ms log is correlated from sample to sample (the loops filter the noise,
and model error is smooth), so the textbook ``s^2 (X'X)^-1`` is too small.  They are heteroskedasticity- and
autocorrelation-consistent (Newey and West, Econometrica 55, 1987: Bartlett weights over
:func:`bartlett_lag` lags, the usual ``4 (n/100)^(2/9)``), summing the joints of one instant before the lags,
so that joints moving together count once.  On white noise this is the ordinary standard error and
``estimate / SE`` is standard normal (tests/health/test_twin_fit.py).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS
from ..sim.params import RobotParams
from ..sim.trajectories.ik import model_path
from ..util.robust import robust_spread

#: a fit's columns (scaled to unit norm) are well enough apart when their smallest singular value is at least
#: ``rcond`` of the largest; below it the last column in the weakest direction is left out, and so on.  The
#: current fit, whose nuisance columns can mix with the joints' offsets (a CoM torque that stays constant in a
#: window), uses this (at 1e-4 a coefficient's standard error is already inflated some 10^4 times: it says
#: nothing); the mismatch fit keeps the default 1e-8, whose flank column may differ from a constant in a few
#: samples only - the few reversals that show a backlash
RCOND_NUISANCE = 1e-4
#: a payload CoM component is fed back into the twin's gear torque (:func:`com_corrected_torque`) where its estimate
#: stands at least this many standard errors out of zero (two-sided, about 95 %); one the fit cannot identify - the
#: shift along a tool that points down, whose column is zero (estimate 0, SE and t undefined) - or that stands within
#: the noise stays at the twin's own value, zero
COM_FEEDBACK_MIN_T = 2.0
#: a column whose norm is below this share of the largest column's is zero up to rounding (e.g. the payload
#: CoM shift along a tool axis that stays parallel to gravity: its torque is zero but for the last bits)
ZERO_COLUMN = 1e-9


@dataclasses.dataclass(frozen=True)
class Fit:
    """Coefficients of a least-squares fit and their standard errors (NaN for a column the data cannot
    identify: zero, or a mix of the others; its coefficient is then 0)."""

    coef: NDArray
    se: NDArray

    @property
    def t(self) -> NDArray:
        """``coef / se`` (NaN where the standard error is NaN or zero)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.se > 0, self.coef / self.se, np.nan)


def bartlett_lag(n: int) -> int:
    """Newey-West's rule for the lags of the Bartlett kernel: ``floor(4 (n / 100)^(2/9))``."""
    return int(math.floor(4.0 * (max(n, 1) / 100.0) ** (2.0 / 9.0)))


def noise_scale(r: NDArray) -> NDArray:
    """Per column of ``r`` ``(n, m)``, the white-noise standard deviation read from first differences
    (1.4826 MAD of ``diff(r)`` over sqrt 2: smooth signal content, a fault's or the model's, barely enters);
    NaN samples left out, 1 where nothing is left or the differences are all zero."""
    _, spread, _ = robust_spread(np.diff(r, axis=0))
    s = spread / math.sqrt(2.0)
    return np.where(np.isfinite(s) & (s > 0), s, 1.0)


def hac_fit(x: NDArray, y: NDArray, rcond: float = 1e-8) -> Fit:
    """Least squares of ``y`` ``(n, m)`` on ``x`` ``(n, m, p)``: ``n`` instants of ``m`` rows (e.g. joints)
    sharing ``p`` coefficients, with Newey-West standard errors over the instants (module docstring).
    A row with a NaN is left out; a column that is zero or not identified gets coefficient 0 and SE NaN (of
    columns that the data mix, the last ones are left out first: put the nuisance columns last)."""
    n, m, p = x.shape
    ok = np.isfinite(y) & np.all(np.isfinite(x), axis=2)
    xz = np.where(ok[..., None], x, 0.0)
    yz = np.where(ok, y, 0.0)
    coef, se = np.zeros(p), np.full(p, np.nan)
    flat = xz.reshape(n * m, p)
    scale = np.sqrt(np.sum(flat**2, axis=0))
    live = scale > ZERO_COLUMN * scale.max(initial=0.0)
    if int(ok.sum()) <= int(live.sum()) or not live.any():
        return Fit(coef, se)
    a_all = flat / np.where(live, scale, 1.0)
    # one Householder QR of [columns | y] (backward stable): the columns of R are the columns of A rotated, so
    # any subset of them has A's singular values, and |A_live b - y| = |R_live b - R_y|.  The singular values
    # are then resolved down to rounding (~1e-16 of the largest), where the normal matrix A'A resolves only
    # its eigenvalues, the squares: at ``rcond`` 1e-8 a column the data cannot tell from the others (e.g. a
    # flank column that is a constant because the gear torque never reverses) was kept or left out by the
    # last bits of the BLAS kernel's sums (docs/diagnostics.md, "The same campaign on another machine")
    r_aug = np.linalg.qr(np.column_stack([a_all, yz.reshape(-1)]), mode="r")
    r_cols, r_y = r_aug[:, :p], r_aug[:, p]
    while True:
        u, sv, vt = np.linalg.svd(r_cols[:, live], full_matrices=False)
        if sv[-1] > rcond * sv[0]:
            break
        # the motion mixes columns: leave out the last one in the weakest direction (callers put nuisance last)
        weak = np.abs(vt[-1]) > 1e-3 * np.abs(vt[-1]).max()
        live[np.flatnonzero(live)[np.flatnonzero(weak)[-1]]] = False
        if not live.any():
            return Fit(coef, se)
    a = a_all[:, live]
    bread = (vt.T / sv**2) @ vt  # (A'A)^-1
    b_scaled = vt.T @ ((u.T @ r_y) / sv)
    resid = (yz.reshape(-1) - a @ b_scaled).reshape(n, m)
    g = (a.reshape(n, m, -1) * resid[..., None]).sum(axis=1)  # score of each instant, (n, p_live)
    meat = g.T @ g
    for lag in range(1, bartlett_lag(n) + 1):
        w = 1.0 - lag / (bartlett_lag(n) + 1.0)
        c = g[lag:].T @ g[:-lag]
        meat += w * (c + c.T)
    n_obs, k = int(ok.sum()), int(live.sum())
    cov = bread @ meat @ bread * n_obs / max(n_obs - k, 1)  # small-sample factor of the ordinary estimate
    coef[live] = b_scaled / scale[live]
    se[live] = np.sqrt(np.maximum(np.diag(cov), 0.0)) / scale[live]
    return Fit(coef, se)


@functools.lru_cache(maxsize=1)
def _kinematic_model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(model_path())


def flange_kinematics(q_rad: NDArray) -> tuple[NDArray, NDArray]:
    """The joints' axes ``(n, 6, 3)`` and the flange's rotation ``(n, 3, 3)`` in the base frame at the joint angles
    ``q_rad`` ``(n, 6)`` (``mj_kinematics`` of the kinematic model per row): what :func:`com_columns` needs of the
    motion, the same for every run of one commanded trajectory."""
    model = _kinematic_model()
    data = mujoco.MjData(model)
    flange = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "tool")
    n = q_rad.shape[0]
    axes = np.empty((n, N_JOINTS, 3))
    rot = np.empty((n, 3, 3))
    for t in range(n):
        data.qpos[:] = q_rad[t]
        mujoco.mj_kinematics(model, data)
        axes[t] = data.xaxis[:N_JOINTS]
        rot[t] = data.xmat[flange].reshape(3, 3)
    return axes, rot


def com_columns(q_rad: NDArray, payload_kg: float, params: RobotParams, held: NDArray | None = None,
                kinematics: Callable[[], tuple[NDArray, NDArray]] | None = None) -> NDArray:
    """Motor current per metre of payload centre-of-mass shift, ``(n, 6, 3)``: joint by flange axis x, y, z
    (module docstring), at the joint angles ``q_rad`` ``(n, 6)``; zero where the payload is not held
    (``held`` ``(n,)``, None: held throughout) or its mass is zero.  ``kinematics``: gives
    :func:`flange_kinematics` of ``q_rad`` when called (a batch's runs share it); None: computed here."""
    n = q_rad.shape[0]
    out = np.zeros((n, N_JOINTS, 3))
    hold = np.ones(n, bool) if held is None else np.asarray(held, bool)
    if payload_kg <= 0 or not hold.any():
        return out
    axes, rot = kinematics() if kinematics is not None else flange_kinematics(q_rad)
    if axes.shape != (n, N_JOINTS, 3):
        raise ValueError(f"kinematics of {axes.shape[0]} samples given for {n} joint-angle rows")
    force = payload_kg * np.asarray(_kinematic_model().opt.gravity)
    per_amp = 1.0 / (np.asarray(params.motor.torque_constant_Nm_per_A) * np.asarray(params.gear.ratio))
    for k in range(3):
        moment = np.cross(axes, rot[:, None, :, k])  # z_j x R e_k, (n, 6, 3)
        out[:, :, k] = -(moment @ force) * per_amp
    return out * hold[:, None, None]


def com_corrected_torque(torque_Nm: NDArray, com_A_per_m: NDArray, estimate_m: NDArray, se_m: NDArray,
                         params: RobotParams) -> NDArray:
    """The twin's gear torque ``torque_Nm`` ``(n, 6)`` with the payload centre-of-mass shift the current fit found
    fed back: ``torque + K_t N (com_A_per_m @ delta)``, ``com_A_per_m`` ``(n, 6, 3)`` the current fit's CoM columns
    [A/m] and ``delta`` the estimates ``estimate_m`` ``(3,)`` [m] (standard errors ``se_m``) of the components that
    stand :data:`COM_FEEDBACK_MIN_T` standard errors out of zero (the others 0).  A column of motor current per
    metre times ``K_t N`` is link torque per metre (the closed-form columns are exactly that; a CoM twin's current
    difference also carries the loops' share).  ``torque_Nm`` itself where no component qualifies."""
    c, e = np.asarray(estimate_m, dtype=float), np.asarray(se_m, dtype=float)
    with np.errstate(invalid="ignore"):
        use = np.isfinite(c) & np.isfinite(e) & (e > 0) & (np.abs(c) >= COM_FEEDBACK_MIN_T * e)
    if not use.any():
        return torque_Nm
    per_amp = np.asarray(params.motor.torque_constant_Nm_per_A) * np.asarray(params.gear.ratio)
    return torque_Nm + (np.asarray(com_A_per_m)[:, :, use] @ c[use]) * per_amp


def payload_com_columns(q_set_rad: NDArray, twin: dict[str, NDArray], params: RobotParams, payload_kg: float,
                        payload_held: NDArray | None = None,
                        kinematics: Callable[[], tuple[NDArray, NDArray]] | None = None) -> NDArray:
    """The current fit's payload centre-of-mass columns ``(n, 6, 3)`` [A/m] (``twin_features.current_fit``): the
    twin's ``com_A_per_m`` where given (zero without a payload), else the CoM's gravity torque in closed form
    (:func:`com_columns`; ``kinematics`` as it takes it)."""
    com = twin.get("com_A_per_m")
    if com is None:  # the CoM's gravity torque in closed form (no CoM twins given)
        return com_columns(q_set_rad, payload_kg, params, payload_held, kinematics)
    return np.zeros_like(com) if payload_kg <= 0 else com


def fed_back_torque(q_set_rad: NDArray, twin: dict[str, NDArray], params: RobotParams, features: dict[str, float],
                    payload_kg: float = 0.0, payload_held: NDArray | None = None,
                    kinematics: Callable[[], tuple[NDArray, NDArray]] | None = None) -> NDArray:
    """The gear torque ``twin_features`` read for the mismatch fit and the flank shares, rebuilt from the CoM
    estimates and t values in its ``features`` (SE = |estimate / t|), for a caller that needs the same columns
    (``ur5fault diagnose``'s variance inflation); the other arguments as ``twin_features`` took them."""
    est = np.array([features[f"twin_est_payload_com_{a}_m"] for a in "xyz"], dtype=float)
    t = np.array([features[f"twin_est_payload_com_{a}_m_t"] for a in "xyz"], dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        se = np.abs(est / t)
    com = payload_com_columns(q_set_rad, twin, params, payload_kg, payload_held, kinematics)
    return com_corrected_torque(twin["T_gear_Nm"], com, est, se, params)


def latency_column(i_twin_A: NDArray, dt_s: float) -> NDArray:
    """``-di_twin/dt`` ``(n, 6)`` [A/s]: the current residual per second of setpoint latency."""
    return -np.gradient(i_twin_A, dt_s, axis=0)


__all__ = ["COM_FEEDBACK_MIN_T", "RCOND_NUISANCE", "Fit", "bartlett_lag", "com_columns", "com_corrected_torque",
           "fed_back_torque", "flange_kinematics", "hac_fit", "latency_column", "noise_scale", "payload_com_columns"]
