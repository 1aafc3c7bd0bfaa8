"""A finished campaign folder as one object: its feature table, its manifest (threshold, swept keys) and
its runs' time series, read from ``OUT/timeseries`` or re-simulated when the campaign did not save them
(the simulator is deterministic, so they are the same runs).  Concise ``repr`` and an HTML table for
notebooks."""

from __future__ import annotations

import dataclasses
import logging
import tempfile
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from ..errors import ConfigFileError, StoredResultError, UnknownNameError, Ur5FaultError
from ..sim.effects import REGISTRY
from ..util import provenance
from ..util.io import read_json_stored, read_parquet_stored
from .store import (
    REBUILD_FEATURES,
    check_manifest_fields,
    check_table_of_manifest,
    check_timeseries_file,
    recorded_run_identities,
    timeseries_path,
)
from .summary import (
    EffectSweep,
    acceptable_backlash,
    acceptable_backlash_text,
    effect_sweep,
    severity_table,
    swept_effects,
    tcp_table,
)

_log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True, repr=False, eq=False)
class CampaignResult:
    """A campaign output folder.  Build it with :meth:`load`.

    Attributes:
        out: the folder.
        features: ``features.parquet``, one row per run.
        manifest: ``manifest.json`` (provenance, ``threshold_mm``, ``swept_keys``, the campaign text).
    """

    out: Path
    features: pd.DataFrame
    manifest: Mapping[str, Any]
    _series: dict[str, pd.DataFrame] = dataclasses.field(default_factory=dict)  # time series read or re-simulated

    @classmethod
    def load(cls, out: str | Path) -> CampaignResult:
        """Read ``OUT/features.parquet`` and ``OUT/manifest.json``."""
        out = Path(out)
        if not out.exists():
            raise ConfigFileError(f"{out}: no such campaign folder (give the folder `ur5fault campaign run` wrote, "
                                  "its --out)")
        if out.is_file():  # e.g. a run's time series given to `ur5fault plot`
            raise ConfigFileError(f"{out}: a file, not a campaign folder (`ur5fault plot` and CampaignResult read "
                                  "the folder a campaign ran into; `ur5fault show` draws one run's file)")
        if not (out / "features.parquet").exists() and (out / "inspections.parquet").exists():
            raise ConfigFileError(f"{out}: a life campaign (inspections.parquet, no features.parquet): its results "
                                  f"are read by ur5fault prognose {out}")
        for name in ("features.parquet", "manifest.json"):
            if not (out / name).exists():
                raise ConfigFileError(f"{out}: no {name} (run the campaign to its end first)")
        features = read_parquet_stored(out / "features.parquet", REBUILD_FEATURES)
        manifest = read_json_stored(out / "manifest.json", REBUILD_FEATURES)
        check_manifest_fields(out / "manifest.json", manifest)
        check_table_of_manifest(out / "features.parquet", REBUILD_FEATURES, manifest)
        return cls(out, features, manifest)

    # ------------------------------------------------------------------ what the campaign was
    @property
    def name(self) -> str:
        return str(self.manifest.get("name", self.out.name))

    @property
    def threshold_mm(self) -> float:
        """The campaign's TCP acceptability threshold [mm]."""
        return float(self.manifest["threshold_mm"])

    @property
    def swept_keys(self) -> tuple[str, ...]:
        return tuple(self.manifest.get("swept_keys", ()))

    def sweeps(self) -> tuple[dict[str, EffectSweep], dict[str, str]]:
        """Every swept effect (a ``swept_keys`` entry, or a single-effect ``fault`` label, e.g. of a sampled
        campaign): its runs and sizes, or (second dict) why they cannot be shown."""
        effects: dict[str, list[str] | None] = dict(swept_effects(self.swept_keys))
        for fault in sorted(set(self.features["fault"].astype(str))):
            if fault in REGISTRY and fault not in effects:
                effects[fault] = None  # its size from fault_size, or any registered parameter with a column
        shown, skipped = {}, {}
        for effect, params in effects.items():
            sweep = effect_sweep(self.features, effect, params)
            if isinstance(sweep, str):
                skipped[effect] = sweep
            else:
                shown[effect] = sweep
        return shown, skipped

    # ------------------------------------------------------------------ summaries
    def tcp_table(self) -> pd.DataFrame:
        """Max TCP deviation [mm], fault joint x backlash [deg] (the paper's table)."""
        return tcp_table(self.features, self.swept_keys)

    def acceptable_backlash(self, threshold_mm: float | None = None) -> pd.Series:
        """Largest backlash [deg] per joint keeping the TCP within ``threshold_mm`` (default: the campaign's)."""
        thr = self.threshold_mm if threshold_mm is None else threshold_mm
        return acceptable_backlash(self.features, thr, self.swept_keys)

    def severity_tables(self, feature: str = "tcp_dev_max_mm") -> dict[str, pd.DataFrame]:
        """``feature`` by fault joint x fault size, one table per swept effect."""
        return {effect: severity_table(sweep, feature) for effect, sweep in self.sweeps()[0].items()}

    # ------------------------------------------------------------------ time series
    def run(self, run_id: str) -> pd.Series:
        """The feature row of one run."""
        hit = self.features[self.features["run_id"] == run_id]
        if hit.empty:
            raise UnknownNameError("run_id", run_id, self.features["run_id"], str(self.out))
        return hit.iloc[0]

    def time_series(self, run_ids: Iterable[str]) -> dict[str, pd.DataFrame]:
        """Wide time-series tables of ``run_ids`` (see docs/outputs.md): saved ones read, the others re-simulated."""
        ids = list(dict.fromkeys(run_ids))
        for r in ids:
            self.run(r)  # an unknown id is an error naming the valid ones
        identities = recorded_run_identities(self.out / "features.parquet")
        for r in ids:
            path = timeseries_path(self.out, r)
            if r in self._series or not path.exists():
                continue
            # as `campaign status` checks it: checksum, and the identity of this run (a file left by a run of other
            # settings - e.g. after --replace-changed without --save-timeseries - or another run's is not this run's)
            check = check_timeseries_file(path, identities.get(r, ""), None)
            if check.state == "ok":
                self._series[r] = pd.read_parquet(path)
            else:
                _log.warning("%s: %s: %s; re-simulating the run instead", path, check.state,
                             check.detail or "not this run's")
        missing = [r for r in ids if r not in self._series]
        if missing:
            try:
                self._series.update(self._resimulate(missing, identities))
            except StoredResultError:
                raise
            except Ur5FaultError as exc:  # not the user's input now: the stored campaign cannot be run again
                raise StoredResultError(f"{self.out}: the time series of {', '.join(missing)} can be neither read nor "
                                        f"simulated again: {exc}") from exc
        return {r: self._series[r] for r in ids}

    def _resimulate(self, run_ids: list[str], recorded: dict[str, str]) -> dict[str, pd.DataFrame]:
        """Simulate ``run_ids`` again; ``recorded``: run_id -> identity as the feature table records them."""
        from ..sim.engine import DEFAULT_MODEL_PATH
        from .execute import plan_batches, run_batch
        from .identity import Identities, file_sha256
        from .manifest import recorded_campaign

        camp = recorded_campaign(self.manifest, self.out)
        if camp is None:
            raise ConfigFileError(f"{self.out}: manifest.json does not record its campaign; its runs cannot be "
                                  "simulated again")
        then = (self.manifest.get("ur5fault_version"), self.manifest.get("model_sha256"))
        now = (provenance.package_version(), file_sha256(DEFAULT_MODEL_PATH))
        if then != now:
            _log.warning("%s was run with ur5fault %s and model %s; re-simulating with %s and model %s may not give "
                         "the same runs", self.out, then[0], str(then[1])[:12], now[0], now[1][:12])
        by_id = {rc.run_id: rc for rc in camp.runs}
        # a run this ur5fault simulates otherwise than the stored one (e.g. a trajectory's grip schedule changed):
        # its features were computed from another run than the series about to be drawn
        ids = Identities(camp)
        other = [r for r in run_ids if recorded.get(r) and recorded[r] != ids.identity(by_id[r])]
        if other:
            _log.warning("%s: %s stored under other settings than this ur5fault simulates them with (the run's "
                         "identity differs); the re-simulated time series may not be the run its features were "
                         "computed from: `ur5fault campaign run` with --replace-changed simulates them again",
                         self.out, ", ".join(other))
        _log.info("re-simulating %d run(s) whose time series were not saved: %s", len(run_ids), ", ".join(run_ids))
        got: dict[str, pd.DataFrame] = {}
        with tempfile.TemporaryDirectory() as tmp:
            for batch in plan_batches(camp, [by_id[r] for r in run_ids]):  # twins added: features need them
                run_batch(camp, batch, tmp)
                got.update({rc.run_id: pd.read_parquet(Path(tmp) / f"{rc.run_id}.parquet") for rc in batch})
        return got

    # ------------------------------------------------------------------ notebooks
    def _headline(self) -> str:
        counts = self.features["status"].value_counts().to_dict()
        status = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
        stored = (self.out / "timeseries").is_dir() and any((self.out / "timeseries").glob("*.parquet"))
        saved = ("saved" if stored and self.manifest.get("save_timeseries") else
                 "saved for some runs (the others re-simulated on demand)" if stored else
                 "not saved (re-simulated on demand)")
        return (f"campaign {self.name!r} in {self.out}: {len(self.features)} runs ({status}); swept "
                f"{', '.join(self.swept_keys) or 'nothing'}; threshold {self.threshold_mm:g} mm; time series {saved}")

    def __repr__(self) -> str:
        return f"<CampaignResult {self._headline()}>"

    def _repr_html_(self) -> str:
        import html

        parts = [f"<p><b>CampaignResult</b> {html.escape(self._headline())}</p>"]
        fmt = lambda v: f"{v:.3g}"  # noqa: E731
        for effect, table in self.severity_tables().items():
            parts.append(f"<p>max TCP deviation from the healthy twin [mm], {html.escape(effect)}:</p>")
            parts.append(table.to_html(float_format=fmt, na_rep="-"))
        acc = self.acceptable_backlash()
        if not acc.empty:
            parts.append(f"<p>largest backlash keeping the TCP within {self.threshold_mm:g} mm [deg]:</p>")
            parts.append(acceptable_backlash_text(acc, tcp_table(self.features, self.swept_keys)).to_frame().to_html())
        _, skipped = self.sweeps()
        parts += [f"<p>{html.escape(why)}</p>" for why in skipped.values()]
        return "\n".join(parts)
