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
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError
from ..sim.drive.friction import viscous_coefficient
from ..sim.effects import NOISE_FREE
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
    ``qd`` the commanded speed ``(n, 6)`` [rad/s]; ``params`` the twins' model (friction, motor, gear)."""

    payloads_kg: NDArray
    temperature_C: float
    i_A: NDArray
    T_gear_Nm: NDArray
    qd: NDArray
    params: RobotParams

    def __post_init__(self) -> None:
        g = np.asarray(self.payloads_kg).shape[0]
        if g < 1 or np.any(np.diff(self.payloads_kg) <= 0):
            raise ValueError(f"grid masses {list(self.payloads_kg)}: expected one or more, increasing")
        if self.i_A.shape != self.T_gear_Nm.shape or self.i_A.shape[0] != g or self.i_A.shape[1:] != self.qd.shape:
            raise ValueError(f"grid signals {self.i_A.shape}, {self.T_gear_Nm.shape} do not match {g} masses and "
                             f"a motion of shape {self.qd.shape}")

    def signals(self, payload_kg: float, temperature_C: float) -> tuple[NDArray, NDArray]:
        """``(i_A, T_gear_Nm)`` ``(n, 6)`` of a noise-free twin with payload ``payload_kg`` at ``temperature_C``:
        interpolated between the grid masses around it, the viscous friction moved to its temperature (module
        docstring).  A mass outside the grid is refused (the grid is built from the batch's masses)."""
        m, grid = float(payload_kg), np.asarray(self.payloads_kg, float)
        tol = 1e-9
        if not grid[0] - tol <= m <= grid[-1] + tol:
            raise ValueError(f"payload {m:g} kg outside the regressor grid {grid[0]:g}..{grid[-1]:g} kg")
        k = int(np.clip(np.searchsorted(grid, m, side="right") - 1, 0, max(grid.size - 2, 0)))
        if grid.size == 1:
            i_a, torque = self.i_A[0], self.T_gear_Nm[0]
        else:
            w = float(np.clip((m - grid[k]) / (grid[k + 1] - grid[k]), 0.0, 1.0))
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


__all__ = ["GRID_STEP_KG", "REGRESSOR_EFFECTS", "REGRESSOR_PREFIX", "RegressorGrid", "payload_grid"]
