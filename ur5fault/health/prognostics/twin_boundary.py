"""The failure boundary as the digital twin computes it: along a direction of clearance growth, the
clearance radius at which the unit's own duty cycle (its task, payload and cell temperature) first
meets the failure criterion.

A point at radius ``s`` along the unit direction ``d`` is the wear state ``alpha = s d`` [deg per joint],
with the friction and stiffness the wear law couples to it (wear.py: ``friction_scale``,
``stiffness_scale``; the lubricant-ageing term at the cycles ``s / speed`` the unit needs to get there),
simulated on the duty cycle exactly as a fleet inspection is (life_inspection.inspect_batch: the same simulator,
stepper, drive, log period and duration); the criterion is the campaign's failure feature of that run
against the twin's run of the same unit with no wear (the healthy reference), a run that stops or
diverges counting as failed, as in the fleet.  The twin is the model the fleet was generated with: the
boundary it finds is exact up to the sensor noise (both runs share one noise seed here, the fleet's
inspections and references do not: < 0.01 mm, docs/prognostics.md) -- a perfect-model assumption
stated wherever its results are.

Search per ray: the criterion at :data:`COARSE` multiples of a guess of the radius (:data:`BELOW` or
:data:`ABOVE` too where the crossing lies outside them), then :data:`REFINE` evenly spaced points inside
the first bracket that crosses; the radius is interpolated
linearly inside the final bracket (so a jump of the criterion is located to 1/(REFINE + 1) of the
coarse step).  Rays of one task run in lockstep batches of :data:`BATCH` runs.
"""

from __future__ import annotations

import dataclasses
import json
import logging
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .spec import Failure
from .wear import WearLaw, wear_effects

if TYPE_CHECKING:
    from ...config import Overlay

#: coarse search, in multiples of the guessed radius (assumption: the kernel boundary's guess is within
#: -30 %/+70 % of the twin's; outside, :data:`BELOW` or :data:`ABOVE` extend the search; a ray that does not
#: fail by the last is reported at that radius, a lower bound)
COARSE = (0.7, 0.85, 1.0, 1.15, 1.35, 1.7)
BELOW = (0.3, 0.45, 0.6)
ABOVE = (2.2, 3.0, 4.0)
#: points inside the crossing bracket (a 0.15 x guess bracket is narrowed to 0.04 x guess)
REFINE = 3
#: runs per lockstep batch (as the fleet's default batch_size)
BATCH = 32
#: the search's stages per ray (coarse, extended, refined): each is a third of a ray's share of the progress
STAGES = 3

_log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class TwinSetup:
    """What the twin needs from a life campaign: its wear law, failure criterion, log period and duration;
    ``model``: the overlay of the robot model the twin runs (``None``: the packaged model, the one the fleet was
    simulated with, i.e. a perfect model)."""

    wear: WearLaw
    failure: Failure
    log_period_s: float = 1e-3
    duration_s: float | None = None
    seed: int = 0
    model: Overlay | None = None

    @classmethod
    def from_manifest(cls, manifest: Mapping[str, Any], seed: int = 0, model: Overlay | None = None) -> TwinSetup:
        ids = manifest.get("identity_inputs", {})
        return cls(WearLaw.from_mapping(manifest.get("wear")), Failure(**manifest["failure"]),
                   float(ids.get("log_period_s", 1e-3)), ids.get("duration_s"), seed, model)


@dataclasses.dataclass(frozen=True)
class Ray:
    """One unit's direction of clearance growth: its task (trajectory JSON), payload and cell
    temperature, the unit vector ``direction`` (6,), its growth ``speed`` [deg per cycle], a guess of
    the failure radius [deg] and, where learned, the unit's friction rise."""

    trajectory: str
    payload_kg: float
    temperature_C: float
    direction: tuple[float, ...]
    speed: float
    guess: float
    #: the unit's own friction rise per degree of clearance and per 10^6 cycles (twin_friction.py), in place
    #: of the wear law's; ``None``: the law's
    friction_per_deg: float | None = None
    friction_per_Mcycle: float | None = None

    def law(self, wear: WearLaw) -> WearLaw:
        """The wear law along this ray: ``wear`` with the ray's own friction rise where it has one."""
        own = {k: v for k, v in (("friction_per_deg", self.friction_per_deg),
                                 ("friction_per_Mcycle", self.friction_per_Mcycle)) if v is not None}
        return dataclasses.replace(wear, **own) if own else wear


def _criteria(setup: TwinSetup, trajectory: str, points: Sequence[tuple[Ray, float]],
              done: Callable[[int], None] | None = None) -> NDArray:
    """The failure feature of each (ray, radius) point, its own reference run beside it; NaN-free:
    a run that stops or diverges reads +inf (failed).  ``done``: called with the points of each batch simulated."""
    from ...campaign.identity import DRIVE, STEPPER
    from ...config import parse_trajectory
    from ...sim.effects import make_effect
    from ...sim.engine import Simulator
    from ...sim.params import load_params
    from ...sim.runspec import RunSpec
    from ..features import run_features

    traj = parse_trajectory(json.loads(trajectory), "trajectory")
    model = setup.model
    sim = Simulator(load_params(overrides=dict(model.params) if model else None), stepper=STEPPER, drive=DRIVE)
    extra = model.effects if model else ()
    ratio = np.asarray(sim.params.gear.ratio)
    out = np.full(len(points), np.inf)
    refs: dict[tuple[float, float], np.ndarray] = {}
    todo = list(range(len(points)))
    while todo:
        specs, at_ref, at_point = [], {}, {}      # spec index of each new reference and of each point
        for i in todo:
            ray, s = points[i]
            key = (ray.payload_kg, ray.temperature_C)
            cond = extra + (make_effect("payload", mass_kg=ray.payload_kg),
                            make_effect("temperature", temperature_C=ray.temperature_C))
            if len(specs) + (key not in refs and key not in at_ref) + 1 > BATCH:
                break
            if key not in refs and key not in at_ref:
                at_ref[key] = len(specs)
                specs.append(RunSpec(f"ref{len(specs)}", setup.seed, cond))
            at_point[i] = len(specs)
            a = s * np.asarray(ray.direction)
            specs.append(RunSpec(f"p{i}", setup.seed, wear_effects(ray.law(setup.wear), a, s / ray.speed) + cond))
        res = sim.run(traj, specs, log_period_s=setup.log_period_s, duration_s=setup.duration_s)
        for key, k in at_ref.items():
            refs[key] = res.tcp_m[k]
        for i, k in at_point.items():
            ray = points[i][0]
            if res.status[k] != "ok":
                continue
            f = run_features(res.t_s, res.q_set_rad, res["q_FB_rad"][k], res["q_M_FB_rad"][k], res["i_FB_A"][k], ratio,
                             res.tcp_m[k], res.tcp_des_m[k], refs[(ray.payload_kg, ray.temperature_C)])
            out[i] = float(f.get(setup.failure.feature, np.inf))
        todo = todo[len(at_point):]
        if done is not None:
            done(len(at_point))
    return out


def _crossing(scales: NDArray, values: NDArray, threshold: float) -> tuple[float, float, float, float] | None:
    """The first bracket (s_lo, v_lo, s_hi, v_hi) in which ``values`` reach ``threshold`` (scale 0 reads 0)."""
    s = np.concatenate([[0.0], scales])
    v = np.concatenate([[0.0], values])
    hit = np.flatnonzero(v >= threshold)
    if hit.size == 0:
        return None
    k = int(hit[0])
    return float(s[k - 1]), float(v[k - 1]), float(s[k]), float(v[k])


def failure_radii(setup: TwinSetup, rays: Sequence[Ray], progress: Callable[[float], None] | None = None) -> NDArray:
    """The clearance radius [deg] at which each ray first meets the failure criterion on its duty cycle
    (the last radius searched, a lower bound, where it never does).  ``progress``: called with the rays' worth
    of search done since its last call (a share of the task's rays per batch simulated; ``len(rays)`` in all),
    e.g. a progress bar's ``update`` (util/progress.py)."""
    by_task: dict[str, list[int]] = {}
    for i, ray in enumerate(rays):
        by_task.setdefault(ray.trajectory, []).append(i)
    out = np.zeros(len(rays))
    for traj, idx in by_task.items():
        out[idx] = _TaskSearch(setup, traj, [rays[i] for i in idx], progress).radii()
    return out


class _TaskSearch:
    """The radius search of the rays of one task, each stage one batched simulation."""

    def __init__(self, setup: TwinSetup, trajectory: str, rays: Sequence[Ray],
                 progress: Callable[[float], None] | None = None) -> None:
        self.setup, self.trajectory, self.rays = setup, trajectory, list(rays)
        self.seen: list[tuple[list[float], list[float]]] = [([], []) for _ in rays]
        self.progress = progress

    def search(self, plan: dict[int, NDArray]) -> None:
        """One of the :data:`STAGES` stages: the criterion at the radii ``plan`` gives per ray."""
        pts = [(self.rays[i], float(s)) for i, ss in plan.items() for s in ss]
        share = len(self.rays) / STAGES  # this stage's worth of the progress, spread over its points
        # the simulation told of each batch it finishes only where progress is reported
        kw = {} if self.progress is None else {"done": lambda k: self.progress(share * k / len(pts))}
        val = _criteria(self.setup, self.trajectory, pts, **kw) if pts else np.zeros(0)
        if self.progress is not None and not pts:
            self.progress(share)
        k = 0
        for i, ss in plan.items():
            self.seen[i][0].extend(float(s) for s in ss)
            self.seen[i][1].extend(val[k : k + len(ss)])
            k += len(ss)

    def bracket(self, i: int) -> tuple[float, float, float, float] | None:
        s, v = np.asarray(self.seen[i][0]), np.asarray(self.seen[i][1])
        o = np.argsort(s)
        return _crossing(s[o], v[o], self.setup.failure.threshold)

    def radii(self) -> NDArray:
        n = len(self.rays)
        guess = np.array([r.guess for r in self.rays])
        self.search({i: np.asarray(COARSE) * guess[i] for i in range(n)})
        extend = {}
        for i in range(n):
            b = self.bracket(i)
            if b is None:
                extend[i] = np.asarray(ABOVE) * guess[i]
            elif b[0] == 0.0:
                extend[i] = np.asarray(BELOW) * guess[i]
        self.search(extend)
        out, refine = np.zeros(n), {}
        for i in range(n):
            b = self.bracket(i)
            if b is None:
                out[i] = max(self.seen[i][0])
            else:
                refine[i] = np.linspace(b[0], b[2], REFINE + 2)[1:-1]
        self.search(refine)
        for i in refine:
            lo_s, lo_v, hi_s, hi_v = self.bracket(i)
            # linear inside the last bracket; a stopped run (inf) gives its middle
            frac = (self.setup.failure.threshold - lo_v) / (hi_v - lo_v) if np.isfinite(hi_v) and hi_v > lo_v else 0.5
            out[i] = lo_s + frac * (hi_s - lo_s)
        if _log.isEnabledFor(logging.DEBUG):
            for i in range(n):
                self.log_search(i, out[i])
        return out

    def log_search(self, i: int, radius: float) -> None:
        """DEBUG: ray ``i``'s direction, the criterion at every radius searched (sorted) and the radius found;
        where the criterion jumps across the threshold, the radius is set by the jump, not by smooth growth
        (docs/prognostics.md, "The twin with a model error")."""
        s, v = np.asarray(self.seen[i][0]), np.asarray(self.seen[i][1])
        o = np.argsort(s)
        pairs = " ".join(f"{a:.4f}:{b:.3f}" for a, b in zip(s[o], v[o], strict=True))
        _log.debug("twin ray direction %s: radius [deg]:criterion %s -> radius %.4f",
                   np.round(self.rays[i].direction, 3).tolist(), pairs, radius)
