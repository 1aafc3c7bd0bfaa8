"""RUL where a unit's extrapolated clearance growth meets the failure boundary the digital twin computes on
the unit's own duty cycle: the failure criterion as the robot would compute it from its estimated state.

The clearances, their growth line and its posterior are :class:`~.clearance_rul.ClearanceRUL`'s (each
joint's clearance from its own features; a line from the new robot with the task's prior).  The failure
radius along the unit's direction of growth is not learned from the training units but simulated
(twin_boundary.py: the unit's task, payload and cell temperature, the wear law's friction and stiffness
at each clearance), so a failure mode the training units of its task rarely showed (an elbow-led unit
meeting the jump of the TCP deviation that elbow clearance causes on one task) is found where the twin
finds it.  A unit's boundary is simulated along the direction estimated at its inspections
:data:`CHECKPOINTS` (and used until the next): each simulation costs ~10 duty cycles, and the direction's
error falls as the history grows (on the default fleet: median 7.5 deg after one interval, 3 deg after 8,
1.8 deg at half-life).

Calibration on up to :data:`CALIBRATION_UNITS` failed training units (every m-th by name; their
cross-fitted estimates, as a held-out unit's), at each of :data:`CHECKPOINTS` a unit lived past: the
direction the unit's history up to that inspection gave, the twin's radius along it, and the log ratio of
the radius the unit's growth line had reached along that direction when it failed (``(r . d) N_f``) to the
twin's; per checkpoint, its mean corrects the twin's radius and its sd (which carries the direction's
error at that point of life) is the boundary's uncertainty in every RUL distribution of a ray simulated
at that checkpoint.

``calibration`` (:data:`CALIBRATIONS`): "pooled" (the default; the above over all tasks together, on
:data:`CALIBRATION_UNITS` units), "task" (on :data:`CALIBRATION_UNITS_PER_TASK` units per task, each task's
mean shrunk towards all tasks', twin_calibration.task_calibration) or "direction" (the task's corrected by its
calibration units of nearby directions of growth, twin_calibration.direction_bias): a model error in the twin
moves where along a direction its criterion jumps, so the twin's error depends on the task and the direction
(docs/prognostics.md, "The twin with a model error").

Friction (``friction``, twin_friction.py; ``prognose --twin-friction learned``, the default): each ray carries
the unit's friction rise per degree of clearance and per 10^6 cycles learned from its inspections up to the
ray's checkpoint, and the twin runs it in place of the wear law's two constants (the calibration units' rays
theirs), so the boundary does not rest on a friction rise nobody measured to failure.

Prediction: draws of the growth rate from the posterior, the speed along the direction ``r . d``, the
crossing ``N* = rho_twin exp(bias + sd eps) / (r . d)``, the RUL rounded up to the inspection grid and at
least one interval (median and 5-95 % interval).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .clearance_rul import ClearanceRUL
from .rul import N_DRAWS, Q_HI, Q_LO, grid_rul
from .twin_boundary import Ray, TwinSetup, failure_radii
from .twin_calibration import TaskCalibration, direction_bias, task_calibration
from .twin_choices import CALIBRATIONS
from .wear import WearLaw

if TYPE_CHECKING:
    from .twin_cache import RadiusCache
    from .twin_friction import FrictionRise

#: inspections at which a unit's boundary is simulated along its current direction estimate (assumption:
#: powers of 4, so at most 4-5 searches per unit; measured on the default fleet: the task-0 training units'
#: failure radius grows from 0.073 to 0.12 deg between directions 42 and 63 deg in the shoulder-elbow
#: plane, ~2.4 % per degree, while the direction's error falls from ~7.5 deg after one interval to ~3 after 8)
CHECKPOINTS = (1, 4, 16, 64, 256)
#: training units the twin is calibrated on (assumption: enough for the mean and sd of a log ratio to
#: ~0.25 sd; each costs ~10 simulated duty cycles per checkpoint it lived past)
CALIBRATION_UNITS = 16
#: calibration units per task of the "task" and "direction" calibrations (assumption: the 12 failed training
#: units of the default fleet's smallest task, so that its two elbow-led units are among them; each costs ~10
#: simulated duty cycles per checkpoint it lived past)
CALIBRATION_UNITS_PER_TASK = 12

#: (trajectory JSON, payload [kg], cell temperature [degC]) of a unit
Conditions = tuple[str, float, float]


def _in_range(name: str, value: float) -> float:
    """A learned wear-law constant clipped into the law's valid range (a unit's posterior mean can fall below 0
    or, far from its data, above the range the law accepts)."""
    lo, hi, _ = WearLaw.RANGES[name]
    return float(np.clip(float(value), lo, hi))


def _unit_direction(v: NDArray, fallback: NDArray) -> tuple[NDArray, float]:
    v = np.maximum(np.asarray(v, float), 0.0)
    if np.linalg.norm(v) <= 0:
        v = np.maximum(np.asarray(fallback, float), 0.0)
    speed = float(np.linalg.norm(v))
    return v / speed, speed


@dataclasses.dataclass
class TwinRUL:
    """RUL at the twin's failure boundary along the unit's estimated direction of clearance growth."""

    setup: TwinSetup
    clearance: ClearanceRUL
    seed: int = 0
    #: one of :data:`CALIBRATIONS` (twin_calibration.py)
    calibration: str = "pooled"
    cache: RadiusCache | None = None
    #: calibration units per task (every m-th of the task's failed training units); 0: :data:`CALIBRATION_UNITS`
    #: of all tasks together (every m-th by name)
    units_per_task: int = 0
    #: the friction rise learned per unit (twin_friction.py), used in place of the wear law's; ``None``: the law's
    friction: FrictionRise | None = None
    #: report the boundary's simulations (minutes) on stderr: a bar on a terminal, lines elsewhere (util/progress.py)
    progress: bool = False

    def __post_init__(self) -> None:
        if self.calibration not in CALIBRATIONS:
            raise ValueError(f"calibration must be one of {', '.join(CALIBRATIONS)}, not {self.calibration!r}")

    def _radii(self, rays: Sequence[Ray], what: str) -> NDArray:
        """The twin's failure radius along each ray, the rays simulated (not cached) counted on a progress bar."""
        from ...util import progress

        n = self.cache.missing(self.setup, rays) if self.cache is not None else len(rays)
        on = self.progress and n > 0
        with progress.bar(n, f"prognose: twin boundary, {what}", "ray", enabled=on,
                          bar_format=progress.PERCENT_FORMAT) as pbar:  # counted in thirds of a ray
            tick = pbar.update if on else None
            if self.cache is not None:
                return self.cache.radii(self.setup, rays, tick)
            return failure_radii(self.setup, rays, tick)

    def _ray(self, cond: Conditions, d: NDArray, speed: float, task: str, n: NDArray, a: NDArray,
             rises: NDArray | None) -> Ray:
        """The ray of a unit seen at cycles ``n`` with clearance estimates ``a`` (and friction-rise estimates
        ``rises``, with :attr:`friction`) along ``d``; the unit's learned friction rise, its posterior mean
        (never negative: friction does not fall with wear), rides on the ray."""
        traj, payload, temp = cond
        ray = Ray(traj, payload, temp, tuple(d), speed, self.clearance.radius(task, d))
        if self.friction is None or rises is None:
            return ray
        mean, cov = self.friction.unit(n, a, rises)
        self.friction_rays_.append((float(mean[0]), float(cov[0, 0]) ** 0.5, float(mean[1]), float(cov[1, 1]) ** 0.5))
        return dataclasses.replace(ray, friction_per_deg=_in_range("friction_per_deg", mean[0]),
                                   friction_per_Mcycle=_in_range("friction_per_Mcycle", mean[1]))

    def calibrate(self, conditions: Mapping[str, Conditions]) -> TwinRUL:
        """Simulate the boundary along the directions the failed training units' histories gave at each
        checkpoint (``conditions``: per training unit, its task conditions) and compare it with where each
        unit failed."""
        units = sorted(self.clearance.train_units_.items())
        if self.units_per_task:
            by_task: dict[str, list] = {}
            for item in units:
                by_task.setdefault(self.clearance.task_key(item[1][0]), []).append(item)
            units = sorted(x for g in by_task.values() for x in g[:: max(1, -(-len(g) // self.units_per_task))])
        else:
            units = units[:: max(1, -(-len(units) // CALIBRATION_UNITS))]
        rays, log_reached, at, tasks = [], [], [], []
        self.friction_rays_: list[tuple[float, float, float, float]] = []
        for uid, (task, r, n_f) in units:
            if np.linalg.norm(r) <= 0 or uid not in conditions:
                continue
            n, a = self.clearance.train_history_[uid]
            traj = conditions[uid][0]
            y = self.friction.train_rises_[uid] if self.friction is not None else None
            prior = self.clearance.prior_[self.clearance.task_key(task)][0]
            for c in CHECKPOINTS:
                if c > len(n) - 2:       # the unit failed before this inspection could be a sound one
                    break
                d, speed = _unit_direction(self.clearance.posterior(task, n[: c + 1], a[: c + 1])[0], prior)
                rays.append(self._ray(conditions[uid], d, speed, task, n[: c + 1], a[: c + 1],
                                      None if y is None else y[: c + 1]))
                log_reached.append(np.log(max(float(np.maximum(r, 0.0) @ d), 1e-12) * n_f))
                at.append(c)
                tasks.append(self.clearance.task_key(traj))
        if len(rays) < 2:
            raise ValueError("the twin estimator needs at least two calibration directions: failed training units "
                             f"sound at inspection {CHECKPOINTS[0]} or later")
        resid = np.asarray(log_reached) - np.log(self._radii(rays, "calibration"))
        at_arr, task_arr = np.asarray(at), np.asarray(tasks)
        self.calibration_residuals_ = list(zip(tasks, at, resid.tolist(), strict=True))
        self.calibration_directions_ = np.array([r.direction for r in rays])
        self._resid, self._at, self._tasks = resid, at_arr, task_arr
        self.task_calibration_: dict[int, TaskCalibration] = {}
        self.calibration_: dict[int, tuple[float, float, int]] = {}   # checkpoint -> (bias, sd, rays)
        for c in CHECKPOINTS:
            e = resid[at_arr == c]
            if len(e) >= 2:
                self.calibration_[c] = (float(np.mean(e)), float(np.std(e, ddof=1)), len(e))
                self.task_calibration_[c] = task_calibration(e, task_arr[at_arr == c])
        if not self.calibration_:  # no checkpoint with two units: one calibration for all
            self.calibration_[CHECKPOINTS[0]] = (float(np.mean(resid)), float(np.std(resid, ddof=1)), len(resid))
            self.task_calibration_[CHECKPOINTS[0]] = task_calibration(resid, task_arr)
        self.calibration_friction_ = self.friction_rays_
        self.n_calibration_units_ = len({u for u, _ in units})
        self.n_calibration_rays_ = len(rays)
        return self

    def _calibration_at(self, checkpoint: int, task: str, direction: NDArray) -> tuple[float, float]:
        """(bias, sd) of the log radius for a ray of duty ``task`` along ``direction`` simulated at
        ``checkpoint``: that checkpoint's, else the latest calibrated one before it (the earliest when there
        is none)."""
        known = sorted(self.calibration_)
        c = max([k for k in known if k <= checkpoint], default=known[0])
        if self.calibration == "pooled":
            return self.calibration_[c][:2]
        bias, sd = self.task_calibration_[c].at(task)
        if self.calibration == "direction":
            pick = (self._tasks == task) & (self._at == c)
            bias = direction_bias(bias, self._resid[pick], self.calibration_directions_[pick], direction,
                                  self.clearance.kappa_)
        return bias, sd

    def predict_units(self, units: Mapping[str, tuple[Conditions, NDArray, NDArray]],
                      rises: Mapping[str, NDArray] | None = None) -> dict[str, list[tuple]]:
        """Per unit (``units``: its conditions, cycles ``n`` and clearance estimates ``a`` of its inspections
        so far; ``rises``: its friction-rise estimates, needed with :attr:`friction`), the (median, 5 %, 95 %)
        RUL [cycles] after each inspection k >= 1 (list index k - 1)."""
        if self.friction is not None and rises is None:
            raise ValueError("a twin with a learned friction rise needs each unit's friction-rise estimates")
        plan: dict[str, list[tuple[int, int, NDArray, NDArray]]] = {}
        rays: list[Ray] = []
        ray_checkpoint: list[int] = []
        self.friction_rays_ = []
        for uid, ((traj, payload, temp), n, a) in units.items():
            plan[uid], current = [], None
            prior = self.clearance.prior_[self.clearance.task_key(traj)][0]
            for k in range(1, len(n)):
                mean, cov = self.clearance.posterior(traj, n[: k + 1], a[: k + 1])
                d, speed = _unit_direction(mean, prior)
                if current is None or k in CHECKPOINTS:
                    rays.append(self._ray((traj, payload, temp), d, speed, traj, n[: k + 1], a[: k + 1],
                                          None if rises is None else rises[uid][: k + 1]))
                    ray_checkpoint.append(k)
                    current = len(rays) - 1
                plan[uid].append((k, current, mean, cov))
        radii = self._radii(rays, "test units") if rays else np.zeros(0)
        self.n_twin_rays_ = len(rays)
        out: dict[str, list[tuple]] = {}
        for uid, steps in plan.items():
            n = units[uid][1]
            out[uid] = []
            for k, ray_i, mean, cov in steps:
                rng = np.random.default_rng([self.seed, k])
                d = np.asarray(rays[ray_i].direction)
                r = rng.multivariate_normal(mean, cov, N_DRAWS, method="eigh")
                speed = np.maximum(np.maximum(r, 0.0) @ d, 1e-3 * rays[ray_i].speed)  # clearances do not shrink
                bias, sd = self._calibration_at(ray_checkpoint[ray_i], self.clearance.task_key(units[uid][0][0]), d)
                rho = radii[ray_i] * np.exp(bias + sd * rng.standard_normal(N_DRAWS))
                t = grid_rul(rho / speed - n[k], n[k] - n[k - 1])
                lo, med, hi = np.quantile(t, [Q_LO, 0.5, Q_HI])
                out[uid].append((float(med), float(lo), float(hi)))
        return out
