"""The motor currents a payload adds to a log's motion, as columns linear in its unknowns, and the record of what
a log's payload was (stated or fitted: :class:`PayloadRecord`, written by ``discrepancy`` and ``identify``).

A payload held at the flange is a point mass ``m`` at ``c`` in the flange frame (plus the solid cube's
inertia the simulator gives every payload, :func:`ur5fault.sim.multibody.payload_inertia`). The joint torque
it adds, gravity and inertia of the logged motion, is linear in ``(m, m*cx, m*cy, m*cz)`` up to the term
``m c c^T`` (the point mass's inertia about the flange: at ``|c| = 0.1 m`` and 1 kg, 0.01 kg*m^2, a tenth of
the wrists' own link inertia; taken at the linearisation point, not fitted). The columns are MuJoCo's inverse
dynamics of the simulator's own model (``ur5fault/models/ur5.xml``) with the payload body set as the simulator
sets it, at the log's *target* motion (speeds and accelerations by central differences, as
:mod:`ur5fault.identify.signals` takes them), divided by each joint's torque constant and gear ratio to give
motor current: the current loop delivers the torque the motion needs.

``com_m`` given: only the mass is unknown, at that centre of mass (one column); ``None``: mass and centre of
mass unknown (four columns, linearised at the flange). :func:`payload_torque_columns` gives the same columns in
joint torque, for a fit whose torque constants are unknowns themselves (``ur5fault identify``).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..sim.effects import REGISTRY
from ..sim.inverse_dynamics import inverse_dynamics_Nm, place_payload
from ..sim.params import RobotParams

#: names of the payload's linear unknowns, in column order (mass, then its first moments)
UNKNOWNS = ("mass_kg", "mass_x_kg_m", "mass_y_kg_m", "mass_z_kg_m")
#: half-step of the central difference that takes a first moment's column [m] (the columns are linear in the
#: first moment, so the step only sets rounding: 5 cm, about a gripper's reach)
MOMENT_STEP_M = 0.05


def _inverse(m: mujoco.MjModel, mass_kg: float, pos_m: NDArray, q: NDArray, qd: NDArray, qdd: NDArray) -> NDArray:
    """Joint torques ``(n, 6)`` of the motion with a payload of ``mass_kg`` at ``pos_m`` (flange frame)."""
    place_payload(m, mass_kg, pos_m)
    return inverse_dynamics_Nm(m, q, qd, qdd)


def payload_torque_columns(model: mujoco.MjModel, q_rad: NDArray, qd_rad_s: NDArray, qdd_rad_s2: NDArray,
                           com_m: tuple[float, float, float] | None = None) -> NDArray:
    """Joint torque per unit of each payload unknown, ``(k, n, 6)`` [N*m per kg, N*m per kg*m].

    Args:
        model: the MuJoCo model (its payload body is set and left at the last column's set-up).
        q_rad, qd_rad_s, qdd_rad_s2: the motion ``(n, 6)``.
        com_m: the payload's centre of mass when known (``k = 1``), else ``None`` (``k = 4``, :data:`UNKNOWNS`).
    """
    q, qd, qdd = (np.asarray(a, dtype=float) for a in (q_rad, qd_rad_s, qdd_rad_s2))
    c0 = np.zeros(3) if com_m is None else np.asarray(com_m, dtype=float)
    empty = _inverse(model, 0.0, c0, q, qd, qdd)
    cols = [_inverse(model, 1.0, c0, q, qd, qdd) - empty]
    if com_m is None:
        for axis in range(3):
            step = np.zeros(3)
            step[axis] = MOMENT_STEP_M
            up = _inverse(model, 1.0, c0 + step, q, qd, qdd)
            down = _inverse(model, 1.0, c0 - step, q, qd, qdd)
            cols.append((up - down) / (2.0 * MOMENT_STEP_M))
    return np.array(cols)


def payload_current_columns(params: RobotParams, q_target_rad: NDArray, period_s: float,
                            com_m: tuple[float, float, float] | None = None) -> NDArray:
    """Motor current per unit of each payload unknown, ``(k, n, 6)`` [A per kg, A per kg*m]:
    :func:`payload_torque_columns` of the target motion divided by each joint's torque constant and gear ratio.

    Args:
        params: the model (torque constants, gear ratios).
        q_target_rad: the log's target positions ``(n, 6)`` (one log: differentiated as one motion).
        period_s: its sample period.
        com_m: the payload's centre of mass when known (``k = 1``: the mass only), else ``None`` (``k = 4``:
            mass and first moments, :data:`UNKNOWNS`).
    """
    from ..sim.engine import Simulator

    q = np.asarray(q_target_rad, dtype=float)
    qd = np.gradient(q, period_s, axis=0)
    qdd = np.gradient(qd, period_s, axis=0)
    cols = payload_torque_columns(Simulator(params).model, q, qd, qdd, com_m)
    per_amp = np.asarray(params.motor.torque_constant_Nm_per_A, float) * np.asarray(params.gear.ratio, float)
    return cols / per_amp


def com_in_range(c) -> bool:
    """A centre of mass within the payload_com effect's range on every axis (the flange frame)."""
    return all(REGISTRY["payload_com"].param(k).lo <= x <= REGISTRY["payload_com"].param(k).hi
               for k, x in zip(("dx_m", "dy_m", "dz_m"), c))


def share_explained(a: NDArray, nuisance: NDArray) -> float:
    """Share of the column ``a`` ``(m,)`` that the columns ``nuisance`` ``(m, q)`` explain by least squares, r^2
    (uncentred: a constant is explained only where the nuisances hold one). The separability test of a payload's
    mass column (``ur5fault discrepancy`` and ``ur5fault identify``)."""
    fit = nuisance @ np.linalg.lstsq(nuisance, a, rcond=None)[0]
    tot = float(a @ a)
    return float(1.0 - np.sum((a - fit) ** 2) / tot) if tot > 0 else 1.0


@dataclasses.dataclass(frozen=True)
class PayloadRecord:
    """What a log's payload was: stated (``known``) or fitted, with the values its replays use."""

    log: str
    known: bool
    mass_kg: float
    com_m: tuple[float, float, float] | None
    interval_kg: tuple[float, float] | None = None
    com_interval_m: tuple[tuple[float, float], ...] | None = None
    com_fitted: bool = False
    fitted_on: str = ""
    r2_nuisance: float | None = None
    separable: bool | None = None
    replayed_kg: float = 0.0
    replayed_com_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    notes: tuple[str, ...] = ()
    #: the mass and its interval with every joint's current gain and offset fitted beside it [kg] (the test of
    #: separability: how far the torque constants could move it)
    gains_free_kg: tuple[float, float, float] | None = None
    #: the JSON key of ``r2_nuisance``: what the mass column was regressed on (each command fits its own nuisances)
    r2_key: str = "r2_mass_vs_gain_offset_drift"

    def to_json(self) -> dict:
        out: dict = {"known": self.known, "mass_kg": self.mass_kg, "com_m": self.com_m}
        if not self.known:
            out.update({"interval_kg": self.interval_kg, "com_fitted": self.com_fitted,
                        "com_interval_m": self.com_interval_m, "fitted_on": self.fitted_on,
                        self.r2_key: self.r2_nuisance, "separable": self.separable,
                        "gains_free_kg": None if self.gains_free_kg is None else {
                            "mass_kg": self.gains_free_kg[0], "interval_kg": list(self.gains_free_kg[1:])},
                        "replayed_kg": self.replayed_kg, "replayed_com_m": self.replayed_com_m,
                        "notes": list(self.notes)})
        return out

    def line(self) -> str:
        """One line for the user."""
        if self.known:
            return f"payload of {self.log}: {self.mass_kg:g} kg at {_vec(self.com_m)} m (stated)"
        lo, hi = self.interval_kg or (np.nan, np.nan)
        if self.com_m is None:
            where = "centre of mass not determined"
        else:
            where = f"centre of mass {_vec(self.com_m)} m ({'fitted' if self.com_fitted else 'stated'})"
        text = (f"payload of {self.log} unknown: fitted {self.mass_kg:.3g} kg (95 % {lo:.3g}..{hi:.3g}), {where}, "
                f"on {self.fitted_on}")
        return "; ".join([text, *self.notes])


def _vec(v) -> str:
    return "(" + ", ".join(f"{x:.3g}" for x in v) + ")"
