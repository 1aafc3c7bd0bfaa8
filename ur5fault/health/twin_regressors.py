"""The twin fits' signal regressors from noise-free twins: shapes free of the twin's own noise.

The twin fits (:mod:`ur5fault.health.twin_features`) project the residual (measured - twin reading) onto the
shapes a fault would give it: the motor current (a gain or torque-constant error), its time derivative (the
setpoint latency) and the gear torque (a flank change, a compliance error).  Taken from the noisy twin itself,
those shapes carry the closed loops' answer to the twin's own sensor noise, which is correlated with the twin's
reading that the residual subtracts: an errors-in-variables bias, large where a joint carries almost no current
(wrist 2 without a payload: 98 % of its twin current is that answer; docs/diagnostics.md, "Wrist 2's gain
estimate on healthy runs").  The residual keeps the noisy twin's reading (a noise-free twin's reading is biased
itself: quantisation, the loops' nonlinearities; "A noise-free twin, measured"); the regressors come from the
same twin simulated with its sensor noise off (effect ``sensor_noise`` at scale 0, :data:`NOISE_FREE`).

A closed form from the commanded motion (inverse dynamics + friction at the commanded speed + rotor inertia,
over ``K_t N``) was measured first and is not used: wrist 2 stands still in the pick-and-place motions, its
load below the breakaway, so the LuGre bristles carry a history-dependent share of it that no function of the
commanded motion gives (correlation with the noise-free twin's wrist-2 current 0.06-0.30; a torque constant of
0.8 at 2 kg read -0.05 for +0.25; docs/diagnostics.md, "Regressors free of the twin's noise").

A campaign's batch shares one commanded motion but its runs differ in payload mass and temperature.  Rather
than one noise-free twin per run (about +44 % of the diagnostics campaign's stepping), the batch simulates them
on a grid of payload masses :data:`GRID_STEP_KG` apart (:func:`payload_grid`), at the model's friction reference
temperature, and a run takes (:meth:`RegressorGrid.signals`) the linear interpolation between the two grid masses
around its own (the multiples of the step just below and above: they do not depend on the other runs of the
batch), plus the viscous friction's change with temperature in closed form: ``f_v(T)`` times the commanded
speed, which the current carries over ``K_t N`` and the gear torque by its link-side share ``1 - s`` (the drive
of :mod:`ur5fault.sim.drive.kernel` in steady tracking; of the model only the viscous friction depends on the
temperature).  ``ur5fault diagnose`` replays one log at one payload: its noise-free twin is exact
(:func:`ur5fault.health.diagnosis.replay_twin`).

With the campaign option ``twin_com_twins`` (twin residuals format 4, now 6) the payload centre-of-mass columns of the
current fit come from noise-free twins too:
at every grid mass above zero, three more noise-free twins with the payload's centre of mass moved by
:data:`COM_STEP_M` along the flange's x, y and z (:func:`com_effects`); a column is the difference of the shifted
twin's motor current from the unshifted one's, per metre (:meth:`RegressorGrid.com_columns`, interpolated in the
mass like the other regressors; zero at 0 kg, where a shift moves no mass).  The closed form of the CoM's gravity
torque (:func:`ur5fault.health.twin_fit.com_columns`) misses what matters on wrist 2: gravity puts no torque on it
while the tool points down (its axis meets the tool's), so its current is the payload's inertial torque, which a
shift along the tool scales - a current gain's signature - and the loops and wrist 2's static friction pass only
a share of it to the current; the simulated columns carry both (docs/diagnostics.md, "The unknown payload CoM
from the other joints").
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError
from ..sim.drive.friction import viscous_coefficient
from ..sim.effects import NOISE_FREE, EffectSpec, make_effect
from ..sim.params import RobotParams

#: spacing of the payload grid of a batch's noise-free twins [kg] (assumption, checked: at 1 kg the interpolated
#: wrist-2 current correlates with the exact noise-free twin's at r = 0.953 / 0.995 / 0.994 for 0.5 / 1.5 / 2.5 kg
#: and a torque constant of 0.8 reads +0.189 / +0.279 against +0.201 / +0.289 with the exact one:
#: docs/diagnostics.md, "Regressors free of the twin's noise")
GRID_STEP_KG = 1.0
#: prefix of a noise-free grid twin's run id (never stored: its signals only feed its batch's twin features)
REGRESSOR_PREFIX = "regressor-"
#: what the regressor twins add to a twin's effects: its sensors' white noise off
REGRESSOR_EFFECTS = (NOISE_FREE,)
#: the payload centre-of-mass shift of the CoM regressor twins along each flange axis [m] (assumption: within the
#: diagnostics campaign's nuisance range, +-3 cm sideways and 0-8 cm along the tool; wrist 2's response is not
#: linear: a shift along the tool reads +0.028 of its gain per cm at 1 cm and +0.033 per cm at 5 cm - noise-free
#: twins, motion seed 3, 2 kg, 4 s, a scratch run - so a finite step reads the slope over the range, not at zero)
COM_STEP_M = 0.03
#: flange axes of the CoM regressor twins, in the columns' order
COM_AXES = ("x", "y", "z")


def com_effects() -> tuple[tuple[EffectSpec, ...], ...]:
    """What each CoM regressor twin adds to a noise-free twin's effects: the payload's centre of mass moved by
    :data:`COM_STEP_M` along one flange axis, in :data:`COM_AXES` order."""
    out = []
    for k in range(len(COM_AXES)):
        shift = [0.0, 0.0, 0.0]
        shift[k] = COM_STEP_M
        out.append((make_effect("payload_com", dx_m=shift[0], dy_m=shift[1], dz_m=shift[2]),))
    return tuple(out)


def com_difference(shifted_i_A: NDArray, reference_i_A: NDArray) -> NDArray:
    """CoM columns ``(n, 6, 3)`` [A/m] from the motor currents of the three shifted twins ``(3, n, 6)`` and the
    unshifted one ``(n, 6)``: their differences over :data:`COM_STEP_M`."""
    return np.moveaxis((np.asarray(shifted_i_A) - np.asarray(reference_i_A)[None]) / COM_STEP_M, 0, -1)


def payload_grid(payloads_kg: Iterable[float], step_kg: float = GRID_STEP_KG) -> tuple[float, ...]:
    """The grid masses [kg] that bracket every payload of ``payloads_kg``: the multiples of ``step_kg`` just
    below and above each (a payload on a multiple gives itself only), sorted."""
    out: set[float] = set()
    for m in payloads_kg:
        m = float(m)
        if not math.isfinite(m) or m < 0:
            raise ParameterError(f"payload mass {m!r} kg: expected a finite mass >= 0")
        lo, hi = math.floor(m / step_kg) * step_kg, math.ceil(m / step_kg) * step_kg
        out.update((round(lo, 9), round(hi, 9)))
    return tuple(sorted(out))


@dataclasses.dataclass(frozen=True)
class RegressorGrid:
    """Noise-free twins of one commanded motion at payload masses ``payloads_kg`` ``(g,)`` [kg] and joint
    temperature ``temperature_C``: their motor currents ``i_A`` and gear torques ``T_gear_Nm`` ``(g, n, 6)``;
    ``qd`` the commanded speed ``(n, 6)`` [rad/s]; ``params`` the twins' model (friction, motor, gear);
    ``com_A_per_m`` ``(g, n, 6, 3)``: the payload centre-of-mass columns at each grid mass (:func:`com_difference`;
    zero at 0 kg), None where the CoM twins were not simulated."""

    payloads_kg: NDArray
    temperature_C: float
    i_A: NDArray
    T_gear_Nm: NDArray
    qd: NDArray
    params: RobotParams
    com_A_per_m: NDArray | None = None

    def __post_init__(self) -> None:
        g = np.asarray(self.payloads_kg).shape[0]
        if g < 1 or np.any(np.diff(self.payloads_kg) <= 0):
            raise ValueError(f"grid masses {list(self.payloads_kg)}: expected one or more, increasing")
        if self.i_A.shape != self.T_gear_Nm.shape or self.i_A.shape[0] != g or self.i_A.shape[1:] != self.qd.shape:
            raise ValueError(f"grid signals {self.i_A.shape}, {self.T_gear_Nm.shape} do not match {g} masses and "
                             f"a motion of shape {self.qd.shape}")
        if self.com_A_per_m is not None and self.com_A_per_m.shape != (*self.i_A.shape, len(COM_AXES)):
            raise ValueError(f"CoM columns {self.com_A_per_m.shape} do not match the grid signals {self.i_A.shape}")

    def _bracket(self, payload_kg: float) -> tuple[int, float]:
        """The grid index below ``payload_kg`` and the interpolation weight of the one above (0 on a grid of one
        mass); a mass outside the grid is refused (the grid is built from the batch's masses)."""
        m, grid = float(payload_kg), np.asarray(self.payloads_kg, float)
        tol = 1e-9
        if not grid[0] - tol <= m <= grid[-1] + tol:
            raise ValueError(f"payload {m:g} kg outside the regressor grid {grid[0]:g}..{grid[-1]:g} kg")
        if grid.size == 1:
            return 0, 0.0
        k = int(np.clip(np.searchsorted(grid, m, side="right") - 1, 0, grid.size - 2))
        return k, float(np.clip((m - grid[k]) / (grid[k + 1] - grid[k]), 0.0, 1.0))

    def com_columns(self, payload_kg: float) -> NDArray:
        """The current fit's payload centre-of-mass columns ``(n, 6, 3)`` [A/m] at ``payload_kg``, interpolated
        between the grid masses around it (module docstring)."""
        if self.com_A_per_m is None:
            raise ValueError("this regressor grid has no centre-of-mass twins")
        k, w = self._bracket(payload_kg)
        return self.com_A_per_m[k] if w == 0.0 else (1.0 - w) * self.com_A_per_m[k] + w * self.com_A_per_m[k + 1]

    def signals(self, payload_kg: float, temperature_C: float) -> tuple[NDArray, NDArray]:
        """``(i_A, T_gear_Nm)`` ``(n, 6)`` of a noise-free twin with payload ``payload_kg`` at ``temperature_C``:
        interpolated between the grid masses around it, the viscous friction moved to its temperature (module
        docstring).  A mass outside the grid is refused (the grid is built from the batch's masses)."""
        k, w = self._bracket(payload_kg)
        if w == 0.0:
            i_a, torque = self.i_A[k], self.T_gear_Nm[k]
        else:
            i_a = (1.0 - w) * self.i_A[k] + w * self.i_A[k + 1]
            torque = (1.0 - w) * self.T_gear_Nm[k] + w * self.T_gear_Nm[k + 1]
        fr, p = self.params.friction, self.params
        dfv = (viscous_coefficient(fr.viscous_Nms_per_rad, fr.viscous_temp_coeff_per_K, temperature_C,
                                   fr.reference_temp_C)
               - viscous_coefficient(fr.viscous_Nms_per_rad, fr.viscous_temp_coeff_per_K, self.temperature_C,
                                     fr.reference_temp_C))
        d_torque = dfv * self.qd  # (n, 6) [N*m]
        per_amp = np.asarray(p.motor.torque_constant_Nm_per_A) * np.asarray(p.gear.ratio)
        link = 1.0 - np.asarray(fr.motor_side_share)
        return i_a + d_torque / per_amp, torque + link * d_torque


__all__ = ["COM_AXES", "COM_STEP_M", "GRID_STEP_KG", "REGRESSOR_EFFECTS", "REGRESSOR_PREFIX", "RegressorGrid",
           "com_difference", "com_effects", "payload_grid"]
