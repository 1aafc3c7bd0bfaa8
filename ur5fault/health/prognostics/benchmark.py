"""``ur5fault prognose DIR``: fit the RUL estimators on the training units of a life campaign, predict
at every inspection of the held-out units before their failure, judge the goals, and write ``metrics.json``
(every number), ``report.md`` (report.py) and the figures beside each other.  The table is read by life_table.py,
the estimators fitted and run by prediction.py."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ...errors import ConfigFileError
from ...util.io import write_figure_atomic, write_json_atomic, write_parquet_atomic, write_text_atomic
from ...util.results import check_new_output, present, result_folder
from ..diagnostics.report import clean
from . import metrics as M
from .figures import health_index_paths, rul_alpha_cone
from .life_store import life_stats
from .life_table import NEEDED, RECORDED_COLUMNS, check_recorded, load_inspections, refuse_other_folder
from .prediction import ESTIMATORS, predict
from .report import markdown
from .spec import Failure
from .twin_boundary import TwinSetup
from .twin_cache import RadiusCache
from .twin_choices import TWIN_FRICTION
from .wear import WEAR_KINDS

if TYPE_CHECKING:
    from ...config import Overlay

#: this module's :func:`run_prognose`; the rest re-exported where callers (and tests) have imported it from (the
#: benchmark calls ``load_inspections`` and ``predict`` through this module)
__all__ = ["BASELINE", "ESTIMATORS", "NEEDED", "RECORDED_COLUMNS", "RESULT_FILES", "TWIN", "TWIN_FRICTION",
           "load_inspections", "predict", "run_prognose"]

#: the estimator the issue's goals are judged on when the twin did not run (the others are shown beside it)
BASELINE = "wiener"
#: ... and when it ran: its only inputs per unit are the inspections' health features (clearance and friction maps
#: fitted on the training units), its simulator ur5fault's drive model, scored under model and wear-law error
#: in docs/prognostics.md
TWIN = "twin"


#: what a prognose benchmark writes into its report folder; one of them there is an earlier result
RESULT_FILES = ("report.md", "metrics.json")


def run_prognose(folder: Path, out: Path | None = None, *, seed: int = 0, twin: bool = False,
                 twin_model: Overlay | None = None, twin_calibration: str = "pooled",
                 twin_cache: Path | None = None, twin_friction: str = "learned",
                 replace: bool = True, progress: bool = False) -> dict[str, Any]:
    """The benchmark on a life-campaign folder; returns the metrics written to ``out/metrics.json`` (default ``out``:
    ``folder/benchmark``), and ``replaced``: whether they replaced an earlier report there (not in the file).
    ``twin_model``: the overlay the twin runs instead of the packaged model (a model error the twin carries);
    ``twin_calibration``: one of :data:`.twin_choices.CALIBRATIONS`; ``twin_cache``: the file of the twin's
    radii (twin_cache.py), default ``out/twin_radii.json``; ``twin_friction``: one of :data:`TWIN_FRICTION`;
    ``replace``: replace an earlier report in ``out`` (False: refused in one line before any work, as `ur5fault
    prognose` does without --replace; the twin's radius cache there is a cache, read and extended either way);
    ``progress``: report the twin's simulations on stderr (a bar on a terminal, lines elsewhere; `ur5fault prognose`
    without --quiet)."""
    if twin_friction not in TWIN_FRICTION:
        raise ConfigFileError(f"twin friction must be one of {', '.join(TWIN_FRICTION)}, not {twin_friction!r}")
    t0 = time.perf_counter()
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():  # before the output folder inside it is checked
        raise ConfigFileError(f"{folder}: a file, not a folder: give the folder a life campaign ran into")
    out = Path(out) if out is not None else folder / "benchmark"  # as `ur5fault benchmark DIR` writes DIR/benchmark
    refuse_other_folder(folder)  # a folder of another kind (a fault campaign's): its reason before a word on --out
    check_new_output(out, folder=True, results=RESULT_FILES, replace=replace)  # before reading or simulating
    df, manifest = load_inspections(folder)
    failure = Failure(**manifest["failure"]) if isinstance(manifest.get("failure"), dict) else Failure()
    check_recorded(folder, df, failure)  # what the labels and estimators read: no gap
    setup = None
    if twin:
        if "wear" not in manifest or "identity_inputs" not in manifest:
            raise ConfigFileError(f"{folder}/manifest.json: no wear law or identity inputs; --twin needs the manifest "
                                  "of a life campaign")
        worn = sorted({e.name for e in (twin_model.effects if twin_model else ())} & WEAR_KINDS)
        if worn:
            raise ConfigFileError(f"the twin's model overlay carries {', '.join(worn)}: the wear law sets those "
                                  "effects itself; give them as params instead")
        setup = TwinSetup.from_manifest(manifest, seed, twin_model)
    cache = RadiusCache(twin_cache if twin_cache is not None else out / "twin_radii.json") if twin else None
    try:
        pred, fitted, hi = predict(df, failure, seed, setup, twin_calibration, cache, twin_friction, progress)
    except ConfigFileError as exc:  # predict's own refusal (too few failed units) already says what to change
        beyond = manifest.get("n_censored_beyond_model") or 0
        raise ConfigFileError(f"{folder}: {exc}" + (
            f"; {beyond} unit(s) were censored where their wear left the simulator's effect ranges, which no longer "
            "max_cycles changes: lower the wear law's constants or life.failure.threshold" if beyond else "")) from None
    except ValueError as exc:  # the estimators' own "too few units or inspections to fit" (rul.py, twin_*.py)
        raise ConfigFileError(f"{folder}: {exc} (a larger fleet, shorter inspection intervals or a longer "
                              "max_cycles)") from None
    per_unit = df.groupby("unit_id").agg(split=("split", "first"), n=("inspection", "size"),
                                         eol=("eol_cycles", "first"))
    if set(per_unit[per_unit["split"] == "train"].index) & set(per_unit[per_unit["split"] == "test"].index):
        raise ConfigFileError(f"{folder}: a unit is on both sides of the split")  # cannot happen: one label per unit
    m: dict[str, Any] = {
        "source": str(folder),
        "dataset": {
            "n_units": int(len(per_unit)), "n_train_units": fitted["n_train_units"],
            "n_test_units": fitted["n_test_units"], "n_censored_units": int(per_unit["eol"].isna().sum()),
            "n_inspections": int(len(df)), "split_by": "unit",
            "inspections_per_unit": {"min": int(per_unit["n"].min()), "mean": float(per_unit["n"].mean()),
                                     "max": int(per_unit["n"].max())},
            "eol_cycles": life_stats(per_unit["eol"]),
            "failure": {"feature": failure.feature, "threshold": failure.threshold},
            "fleet_wall_s": manifest.get("wall_s_this_invocation"),
        },
        "alpha": M.ALPHA, "lambda": M.LAMBDA,
        "estimators": {name: M.summary(p) for name, p in pred.items()},
        "fitted": fitted,
    }
    judged = TWIN if TWIN in m["estimators"] else BASELINE
    w, n = m["estimators"][judged], m["estimators"]["naive"]
    m["goals"] = {
        "baseline": judged,
        "rmse_50_ratio_baseline_to_naive": w["rmse_cycles"]["0.5"] / n["rmse_cycles"]["0.5"],
        "rmse_50_at_most_half_of_naive": w["rmse_cycles"]["0.5"] <= 0.5 * n["rmse_cycles"]["0.5"],
        "alpha_lambda_at_least_0.8": w["alpha_lambda_accuracy"] >= 0.8,
        "by_estimator": {name: {"rmse_50_ratio_to_naive": (q := r["rmse_cycles"]["0.5"] / n["rmse_cycles"]["0.5"]),
                                "rmse_50_at_most_half_of_naive": q <= 0.5,
                                "alpha_lambda_at_least_0.8": r["alpha_lambda_accuracy"] >= 0.8}
                         for name, r in m["estimators"].items() if name != "naive"},
    }
    figures = {"rul_alpha_cone": rul_alpha_cone(pred), "health_index": health_index_paths(df, hi,
                                                                                        fitted["health_index"]
                                                                                        ["failure_level"])}
    replaced = bool(present(out / name for name in RESULT_FILES))  # with replace: said as replaced
    with result_folder(out, RESULT_FILES, replace):  # one set: a stop between files is marked
        names = []
        for name, fig in figures.items():
            write_figure_atomic(fig, out / f"{name}.png")  # its temporary file removed on any failure
            names.append(f"{name}.png")
        for name, p in pred.items():
            write_parquet_atomic(p, out / f"predictions_{name}.parquet")
        m["figures"] = names
        m["benchmark_wall_s"] = time.perf_counter() - t0
        m["out"] = str(out)
        m = clean(m)
        write_json_atomic(out / "metrics.json", m)
        write_text_atomic(out / "report.md", markdown(m))
    m["replaced"] = replaced
    return m
