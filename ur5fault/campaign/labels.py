"""ML labels of a campaign's feature rows: what fault a run carries, on which joint, how large
(with its unit), and on which side of the train/test split it falls.

Columns (docs/outputs.md has the table):

* ``fault``: ``healthy``, the effect name, or several joined with ``+``.
* ``fault_scope``: ``none`` (healthy), ``joint`` (one per-joint effect), ``robot`` (one whole-robot
  effect, e.g. ``delay``), ``multi`` (several effects).
* ``fault_joint``: 1..6 for a joint fault, 0 for healthy, -1 for a robot-level fault; for ``multi``,
  the common joint if all effects sit on one, else -1.
* ``fault_size`` / ``fault_size_unit``: the magnitude of the deviation from the effect's "absent"
  value, ``|value - absent|``, in the parameter's unit; dimensionless factors (scale, gain, whose
  absent value is 1) give a ``fraction`` of nominal (0.2 = 20 %).  Effects with several parameters:
  the Euclidean norm over the registry's size parameters (:meth:`Effect.size_parameters`: a harmonic's
  amplitude, ``link_mass``'s mass, every axis of ``payload_com``).  Healthy: 0 with unit ``""``;
  ``multi``: NaN with unit ``""``.
* ``<effect>_joint``, ``<effect>_<param>``: the values of the effects the run carries (joint
  1-based; ``backlash.backlash_deg`` is ``backlash_deg_swept``), NaN in rows that do not carry that
  effect, so a healthy row never keeps a leftover sweep value; ``backlash_deg`` is the run's alpha
  or 0.
* ``split`` (``train``/``test``) and ``split_group``: runs are grouped by :class:`SplitRule`'s key;
  the sorted groups are permuted by ``numpy.random.default_rng(seed)`` and the first
  ``round(test_fraction * n_groups)`` (at least one and at most ``n_groups - 1`` when there are two
  or more) are ``test``.  A run and its healthy twin share their conditions, hence their group.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import ParameterError, UnknownNameError
from ..sim.effect_types import EffectKey
from ..sim.effects import REGISTRY, EffectSpec
from ..util.checks import is_integer, is_real

SPLIT_KEYS = ("by", "test_fraction", "seed")
#: group keys of the split: the trajectory's seed option (runs on a fixed trajectory are grouped by its
#: whole spec), the whole trajectory spec, or the noise seed
SPLIT_BY = ("trajectory_seed", "trajectory", "seed")
FRACTION_UNIT = "fraction"


@dataclasses.dataclass(frozen=True)
class SplitRule:
    """Train/test split of a campaign by groups (campaign key ``split``)."""

    by: str = "trajectory_seed"
    test_fraction: float = 0.25
    seed: int = 0


def parse_split(data: Any, where: str) -> SplitRule:
    """``split: {by: trajectory_seed, test_fraction: 0.25, seed: 0}`` -> :class:`SplitRule` (absent: defaults)."""
    if data is None:
        return SplitRule()
    if not isinstance(data, Mapping):
        raise ParameterError(f"{where}: split must be a mapping with keys {', '.join(SPLIT_KEYS)}")
    for key in data:
        if key not in SPLIT_KEYS:
            raise UnknownNameError("key", key, SPLIT_KEYS, f"{where}: split")
    by = data.get("by", SplitRule.by)
    if by not in SPLIT_BY:
        raise UnknownNameError("split group", by, SPLIT_BY, f"{where}: split.by")
    frac = data.get("test_fraction", SplitRule.test_fraction)
    if not is_real(frac) or not 0.0 <= frac < 1.0:
        raise ParameterError(f"{where}: split.test_fraction = {frac!r} must be a number in [0, 1)")
    seed = data.get("seed", SplitRule.seed)
    if not is_integer(seed) or seed < 0:
        raise ParameterError(f"{where}: split.seed = {seed!r} must be a non-negative integer")
    return SplitRule(str(by), float(frac), int(seed))


def split_group(cond: Mapping[str, Any], by: str) -> str:
    """The group a run's conditions fall in under the rule's ``by``."""
    if by == "seed":
        return str(cond["seed"])
    traj = cond["trajectory"]
    if by == "trajectory_seed" and isinstance(traj, Mapping) and "seed" in traj:
        return f"{traj['name']}:{traj['seed']}"
    return traj if isinstance(traj, str) else json.dumps(traj, sort_keys=True)


def assign_splits(rule: SplitRule, conditions: Iterable[Mapping[str, Any]]) -> dict[str, str]:
    """Group -> ``"train"`` / ``"test"`` for every group among ``conditions`` (see the module docstring)."""
    groups = sorted({split_group(c, rule.by) for c in conditions})
    n = len(groups)
    n_test = round(rule.test_fraction * n)
    if n >= 2 and rule.test_fraction > 0:
        n_test = min(max(n_test, 1), n - 1)
    order = np.random.default_rng(rule.seed).permutation(n)
    test = {groups[k] for k in order[:n_test]}
    return {g: ("test" if g in test else "train") for g in groups}


def effect_size(spec: EffectSpec) -> tuple[float, str]:
    """Size of one effect ``(|value - absent|, unit)`` (see the module docstring)."""
    params = REGISTRY[spec.name].size_parameters()  # of one unit: the registry checks it
    devs = [abs(spec.value(p.name) - (p.absent or 0.0)) for p in params]
    unit = params[0].unit
    return float(math.hypot(*devs)) if len(devs) > 1 else float(devs[0]), FRACTION_UNIT if unit == "-" else unit


def fault_labels(effects: Sequence[EffectSpec]) -> dict[str, Any]:
    """``fault``, ``fault_scope``, ``fault_joint``, ``fault_size``, ``fault_size_unit`` of a run's faults."""
    if not effects:
        return {"fault": "healthy", "fault_scope": "none", "fault_joint": 0, "fault_size": 0.0, "fault_size_unit": ""}
    joints = {e.joint for e in effects}
    joint = (joints.pop() + 1) if len(joints) == 1 and None not in joints else -1
    if len(effects) > 1:
        return {"fault": "+".join(e.name for e in effects), "fault_scope": "multi", "fault_joint": joint,
                "fault_size": math.nan, "fault_size_unit": ""}
    size, unit = effect_size(effects[0])
    return {"fault": effects[0].name, "fault_scope": "joint" if effects[0].joint is not None else "robot",
            "fault_joint": joint, "fault_size": size, "fault_size_unit": unit}


def fault_columns(effects: Sequence[EffectSpec]) -> dict[str, Any]:
    """``backlash_deg`` and the ``<effect>_joint`` / ``<effect>_<param>`` values of the carried effects."""
    backlash = next((e for e in effects if e.name == "backlash"), None)
    out: dict[str, Any] = {"backlash_deg": backlash.value("backlash_deg") if backlash else 0.0}
    for e in effects:
        if e.joint is not None:
            out[f"{e.name}_joint"] = e.joint + 1
        for par, v in e.values:
            out["backlash_deg_swept" if (e.name, par) == ("backlash", "backlash_deg") else f"{e.name}_{par}"] = v
    return out


def condition_column(key: str) -> str:
    """Column of a condition key: as is, or ``<effect>.<param>`` -> ``<effect>_<param>`` without a
    repeated prefix (``delay.delay_ms`` -> ``delay_ms``, ``payload_com.dz_m`` -> ``payload_com_dz_m``)."""
    ek = EffectKey.parse(key)
    if ek is None:
        return key
    return ek.param if ek.param.startswith(ek.effect + "_") else f"{ek.effect}_{ek.param}"


def condition_columns(cond: Mapping[str, Any]) -> dict[str, Any]:
    """The run's conditions as feature-table columns (a trajectory with options as JSON)."""
    return {condition_column(k): (json.dumps(v, sort_keys=True) if isinstance(v, Mapping) else v)
            for k, v in cond.items()}


def row_labels(cond: Mapping[str, Any], effects: Sequence[EffectSpec], rule: SplitRule,
               splits: Mapping[str, str]) -> dict[str, Any]:
    """Every label column of one feature row (conditions, fault labels and values, split)."""
    group = split_group(cond, rule.by)
    return {**fault_labels(effects), **fault_columns(effects), **condition_columns(cond),
            "split": splits[group], "split_group": group}


def refresh_labels(features, rule: SplitRule, runs: Iterable[Any]):
    """``(features, changed)``: the table with its label columns recomputed from the campaign's rule and runs
    (``run_id``, ``cond`` and ``fault_effects()`` of each): ``split`` and ``split_group``, so an edited ``split``
    applies to rows made before it, and the fault labels (:func:`fault_labels`), so rows stored by an earlier
    version carry the sizes this version gives (labels are not results: nothing is simulated again)."""
    runs = list(runs)
    splits = assign_splits(rule, (rc.cond for rc in runs))
    group = {rc.run_id: split_group(rc.cond, rule.by) for rc in runs}
    new = {"split_group": features["run_id"].map(group)}
    new["split"] = new["split_group"].map(splits)
    labels = {rc.run_id: fault_labels(rc.fault_effects()) for rc in runs}
    for col in ("fault", "fault_scope", "fault_joint", "fault_size", "fault_size_unit"):
        new[col] = features["run_id"].map({rid: lab[col] for rid, lab in labels.items()})
        if col in features:
            new[col] = new[col].astype(features[col].dtype)
    if all(col in features and new[col].equals(features[col]) for col in new):
        return features, False
    return features.assign(**new), True
