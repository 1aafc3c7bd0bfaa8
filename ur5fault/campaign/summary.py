"""Campaign summaries from the feature table: which fault size each swept effect took, a feature by fault
joint x fault size for any effect, the paper's TCP-deviation table and the acceptable backlash per joint.

The fault size of a run is read from the ``fault_size`` / ``fault_size_unit`` columns when the table has
them, otherwise from the column of the swept parameter (``<effect>_<param>``; ``backlash_deg_swept`` for
backlash).  The swept parameter is kept even with a ``fault_size`` column when its values lie on both sides
of the effect's "absent" value (a friction scale of 0.5 and 1.5 both have size 0.5).  Healthy runs are the
rows whose ``fault`` is ``healthy``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
import pandas as pd

from ..errors import UnknownNameError
from ..sim.axes import JOINT_NAMES, N_JOINTS
from ..sim.effect_types import EffectKey
from ..sim.effects import REGISTRY

HEALTHY = "healthy"


@dataclasses.dataclass(frozen=True)
class EffectSweep:
    """The successful runs of a campaign that carry one swept effect alone.

    Attributes:
        effect: registry name, e.g. ``"backlash"``.
        param: the parameter that is the fault size (``"fault_size"`` when the table has that column).
        unit: unit of the size.
        per_joint: the effect sits on one joint (runs are grouped by ``fault_joint``).
        rows: the runs (status ``ok``), with the size in column ``size``.
        n_not_ok: runs of this effect whose status is not ``ok`` (left out of ``rows``).
    """

    effect: str
    param: str
    unit: str
    per_joint: bool
    rows: pd.DataFrame
    n_not_ok: int

    @property
    def label(self) -> str:
        """Axis label, e.g. ``backlash_deg [deg]``."""
        name = self.param if self.param != "fault_size" else f"{self.effect} size"
        return f"{name} [{self.unit}]"


def swept_effects(swept_keys: Sequence[str]) -> dict[str, list[str]]:
    """Swept keys grouped by effect: ``{"backlash": ["backlash_deg"], ...}`` (the joint key left out)."""
    out: dict[str, list[str]] = {}
    for key in swept_keys:
        ek = EffectKey.parse(key)
        if ek is not None and ek.effect in REGISTRY:
            params = out.setdefault(ek.effect, [])
            if ek.param != "joint":
                params.append(ek.param)
    return out


def _size_column(features: pd.DataFrame, effect: str, param: str) -> str | None:
    for col in (f"{effect}_{param}", f"{param}_swept", param):
        if col in features.columns:
            return col
    return None


def effect_sweep(features: pd.DataFrame, effect: str, params: Sequence[str] | None = None) -> EffectSweep | str:
    """The runs of ``effect`` with their fault size, or a one-line reason why they cannot be shown.

    Args:
        features: the campaign's feature table.
        effect: a registry name.
        params: the effect's swept parameters (from the manifest's ``swept_keys``); ``None``: every registered
            parameter of the effect that has a column in the table.
    """
    if effect not in REGISTRY:
        raise UnknownNameError("effect", effect, REGISTRY)
    reg = REGISTRY[effect]
    mine = features[features["fault"] == effect]
    ok = mine[mine["status"] == "ok"]
    n_bad = len(mine) - len(ok)
    if ok.empty:
        why = f"{n_bad} run(s), none ok" if n_bad else "no run carries it alone (only combined with others?)"
        return f"effect {effect!r}: {why}"
    if params is None:
        params = [p.name for p in reg.params if _size_column(features, effect, p.name)]
    col = _size_column(features, effect, params[0]) if len(params) == 1 else None
    if "fault_size" in features.columns:
        absent = reg.param(params[0]).absent if col is not None else None
        if absent is not None and (ok[col] < absent).any() and (ok[col] > absent).any():
            # |value - absent| would fold both directions onto one axis: keep the signed parameter
            return EffectSweep(effect, params[0], reg.param(params[0]).unit, reg.per_joint, ok.assign(size=ok[col]),
                               n_bad)
        units = sorted(set(ok.get("fault_size_unit", pd.Series(["-"])).astype(str)))
        return EffectSweep(effect, "fault_size", "/".join(units), reg.per_joint, ok.assign(size=ok["fault_size"]),
                           n_bad)
    if not params:
        return f"effect {effect!r}: no swept size parameter (only its joint?) and no fault_size column"
    if len(params) > 1:
        return (f"effect {effect!r}: {len(params)} parameters swept together ({', '.join(params)}); a severity "
                "axis needs one (or a fault_size column)")
    if col is None:
        return f"effect {effect!r}: the feature table has no column for its parameter {params[0]!r}"
    return EffectSweep(effect, params[0], reg.param(params[0]).unit, reg.per_joint, ok.assign(size=ok[col]), n_bad)


#: above this many distinct fault sizes an effect's sizes were sampled, not swept: one run each, on its own motion
#: and conditions (``campaign run`` prints no grid of them; the severity figure joins no line through them)
MANY_SIZES = 20


def joint_feature(df: pd.DataFrame, feature: str) -> pd.Series:
    """Values of ``feature`` per row: a column of the table, or a per-joint feature given without its
    ``_j{j}`` suffix (``current_spike_max_A``), read on each row's ``fault_joint`` (the maximum over the
    joints for rows without one, e.g. healthy or robot-level faults)."""
    known = health_features(df.columns)  # not a label, condition or timing column (fault_joint, wall_s_batch)
    if feature in known:
        return df[feature].astype(float)
    cols = [f"{feature}_j{j}" for j in range(1, N_JOINTS + 1)]
    if not all(c in known for c in cols):
        generic = {c[:-3] for c in known if c[-3:-1] == "_j" and c[-1].isdigit()}
        raise UnknownNameError("feature", feature, sorted(set(known) | generic))
    values = df[cols].to_numpy(float)
    fj = pd.to_numeric(df.get("fault_joint", pd.Series(0, index=df.index)), errors="coerce").fillna(0).astype(int)
    fj = fj.to_numpy()
    on_joint = (fj >= 1) & (fj <= N_JOINTS)
    out = np.where(on_joint, values[np.arange(len(df)), np.clip(fj - 1, 0, N_JOINTS - 1)], values.max(axis=1))
    return pd.Series(out, index=df.index, name=feature)


def health_features(columns: Sequence[str]) -> list[str]:
    """The health features among a feature table's ``columns``: the paper's and the twin residuals'."""
    from ..health.features import FEATURE_UNITS
    from ..health.twin_features import FEATURE_UNITS as TWIN_UNITS

    return [c for c in columns if c in FEATURE_UNITS or c in TWIN_UNITS]


def joint_label(j: int) -> str:
    """``"2 shoulder_lift_joint"`` for joint 2 (1-based)."""
    return f"{j} {JOINT_NAMES[j - 1]}"


def severity_table(sweep: EffectSweep, feature: str = "tcp_dev_max_mm") -> pd.DataFrame:
    """Largest ``feature`` per fault joint (rows; one row ``robot`` for robot-level effects) x fault size."""
    rows = sweep.rows.assign(value=joint_feature(sweep.rows, feature))
    group = rows["fault_joint"].map(joint_label) if sweep.per_joint else pd.Series("robot", index=rows.index)
    table = rows.pivot_table(index=group, columns="size", values="value", aggfunc="max")
    table.columns.name = sweep.label
    table.index.name = "fault joint" if sweep.per_joint else None
    return table


def tcp_table(features: pd.DataFrame, swept_keys: Sequence[str] | None = None) -> pd.DataFrame:
    """Maximum TCP deviation [mm] per fault joint (rows) x backlash level [deg] (columns), the healthy
    runs in column 0.  Empty when the campaign has no successful backlash runs."""
    params = swept_effects(swept_keys).get("backlash") if swept_keys is not None else None
    sweep = effect_sweep(features, "backlash", params)
    if isinstance(sweep, str):
        return pd.DataFrame()
    table = severity_table(sweep, "tcp_dev_max_mm")
    healthy = features[(features["fault"] == HEALTHY) & (features["status"] == "ok")]["tcp_dev_max_mm"]
    table[0.0] = healthy.max() if len(healthy) else np.nan
    table = table[sorted(table.columns)]
    table.columns.name = None
    table.index.name = None
    return table


def acceptable_backlash(features: pd.DataFrame, threshold_mm: float,
                        swept_keys: Sequence[str] | None = None) -> pd.Series:
    """Largest simulated backlash [deg] per joint whose max TCP deviation stays within the threshold."""
    table = tcp_table(features, swept_keys)
    out = {}
    for joint, row in table.iterrows():
        ok = [lvl for lvl, v in row.items() if np.isfinite(v) and v <= threshold_mm]
        bad = [lvl for lvl, v in row.items() if np.isfinite(v) and v > threshold_mm]
        below = [lvl for lvl in ok if not bad or lvl < min(bad)]
        out[joint] = max(below) if below else np.nan
    return pd.Series(out, name=f"max_backlash_deg_within_{threshold_mm:g}mm")


def acceptable_backlash_text(acceptable: pd.Series, table: pd.DataFrame) -> pd.Series:
    """:func:`acceptable_backlash` as a reader takes it: where only the healthy level (0) stays within the
    threshold, ``< SMALLEST`` (the smallest backlash simulated already exceeds it; a bare 0 read as "no backlash
    allowed" or as a missing figure); where no level does, ``none``."""
    sizes = sorted(float(c) for c in table.columns if float(c) > 0)
    return pd.Series({j: ("none" if not np.isfinite(v) else f"< {sizes[0]:g}" if v == 0 and sizes else f"{v:g}")
                      for j, v in acceptable.items()}, name=acceptable.name, dtype=object)
