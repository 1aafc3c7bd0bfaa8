"""Fault campaigns: a YAML sweep expanded into runs, run in lockstep batches spread over
processes (joblib; Dask for clusters), written atomically, resumable.

Campaign YAML (see campaigns/default.yaml)::

    name: default
    out: results/default            # output folder (``--out`` overrides)
    trajectory: pick_and_place      # name or {name: ..., speed_scale: ...}; may also be swept
    base: {seed: 0, payload_kg: 2.0, temperature_C: 28.0, effects: [], params: {}}
    sweep:                          # Cartesian product of every key's list
      backlash.joint: [1, 2, 3, 4, 5, 6]
      backlash.backlash_deg: [0, 0.02, 0.05, 0.1, 0.2, 0.5]
    zip:                            # groups whose lists vary together (one axis per group)
      - {payload_kg: [1.0, 2.0], temperature_C: [25.0, 40.0]}
    threshold_mm: 0.5               # TCP acceptability threshold of the summary
    batch_size: 32                  # runs stepped in lockstep per batch
    log_period_s: 0.001
    save_timeseries: false

Sweep keys: ``seed``, ``payload_kg``, ``temperature_C``, ``trajectory`` (conditions), and
``<effect>.<parameter>`` / ``<effect>.joint`` for any entry of the effect registry (faults).
Each run is compared with its *healthy twin*: the run with the same conditions and no swept
fault, which the campaign adds and simulates in the same batch.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import os
import socket
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from .axes import JOINT_NAMES, joint_index
from .config import check_keys, parse_effects, parse_trajectory
from .effects import REGISTRY, EffectSpec, make_effect
from .errors import ConfigFileError, ParameterError, UnknownNameError, Ur5FaultError
from .params import deep_merge, load_params, read_yaml
from .result import write_parquet_atomic

CAMPAIGN_KEYS = ("name", "out", "trajectory", "base", "sweep", "zip", "threshold_mm", "batch_size",
                 "log_period_s", "save_timeseries", "duration_s")
BASE_KEYS = ("seed", "payload_kg", "temperature_C", "effects", "params")
CONDITION_KEYS = ("seed", "payload_kg", "temperature_C", "trajectory")


class CampaignLockedError(Ur5FaultError, RuntimeError):
    """Another campaign process is writing the same output folder."""


# ----------------------------------------------------------------------------- specification
@dataclasses.dataclass(frozen=True)
class RunConfig:
    """One run of a campaign, fully specified (hashable, JSON-able)."""

    conditions: tuple[tuple[str, Any], ...]  # seed, payload_kg, temperature_C, trajectory
    faults: tuple[tuple[str, Any], ...]  # swept fault keys -> values, sorted

    @property
    def cond(self) -> dict[str, Any]:
        return dict(self.conditions)

    def is_healthy(self) -> bool:
        return not self.fault_effects()

    def fault_effects(self) -> tuple[EffectSpec, ...]:
        """Effects of the swept faults; those at their 'absent' value are dropped."""
        by_effect: dict[str, dict[str, Any]] = {}
        for key, v in self.faults:
            name, _, par = key.partition(".")
            by_effect.setdefault(name, {})[par] = v
        out = []
        for name, vals in sorted(by_effect.items()):
            joint = vals.pop("joint", None)
            spec = make_effect(name, joint, **vals)
            absent = all(REGISTRY[name].param(k).absent == v for k, v in spec.values)
            if not absent:
                out.append(spec)
        return tuple(out)

    def twin(self) -> RunConfig:
        return RunConfig(self.conditions, ())

    @property
    def run_id(self) -> str:
        """Stable identifier: a hash of the run's conditions and (effective) faults."""
        eff = [(e.name, e.joint, e.values) for e in self.fault_effects()]
        key = json.dumps([sorted(self.conditions), eff], sort_keys=True, default=str)
        return "r" + hashlib.sha1(key.encode()).hexdigest()[:12]


@dataclasses.dataclass(frozen=True)
class Campaign:
    """A validated campaign file."""

    name: str
    path: Path | None
    text: str
    out: Path
    base_effects: tuple[EffectSpec, ...]
    base_params: Mapping[str, Any]
    runs: tuple[RunConfig, ...]  # unique, twins included
    swept_keys: tuple[str, ...]
    threshold_mm: float
    batch_size: int
    log_period_s: float
    save_timeseries: bool
    duration_s: float | None

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()


def _as_list(value: Any, where: str) -> list:
    if not isinstance(value, list) or not value:
        raise ParameterError(f"{where}: expected a non-empty list of values")
    return value


def _check_value(key: str, value: Any, where: str) -> Any:
    """Validate one swept value now, before any simulation starts."""
    if key == "seed":
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ParameterError(f"{where}: seed = {value!r} must be a non-negative integer")
        return value
    if key == "payload_kg":
        make_effect("payload", where=where, mass_kg=value)
        return float(value)
    if key == "temperature_C":
        make_effect("temperature", where=where, temperature_C=value)
        return float(value)
    if key == "trajectory":
        parse_trajectory(value, where)
        return value if isinstance(value, str) else dict(value)
    name, dot, par = key.partition(".")
    if not dot or name not in REGISTRY:
        valid = list(CONDITION_KEYS) + [f"{e}.<param>" for e in REGISTRY]
        raise UnknownNameError("sweep key", key, valid, where)
    eff = REGISTRY[name]
    if par == "joint":
        if not eff.per_joint:
            raise ParameterError(f"{where}: effect {name!r} acts on the whole robot and takes no joint")
        return joint_index(value, where) + 1
    p = eff.param(par)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not p.lo <= float(value) <= p.hi:
        raise ParameterError(f"{where}: {key} = {value!r} is out of range [{p.lo:g}, {p.hi:g}] {p.unit}")
    return float(value)


def load_campaign(path: str | Path, out: str | Path | None = None, overlay: str | Path | None = None) -> Campaign:
    """Read and validate a campaign file; every error names the file and key path.

    ``overlay``: a model overlay YAML (``params`` and ``effects``, e.g. written by ``ur5fault
    discrepancy``) merged into the campaign's ``base``: its parameters under the campaign's own, its
    effects before them.  The merged text is what the manifest records.
    """
    path = Path(path)
    data = read_yaml(path)
    text = path.read_text()
    if overlay is not None:
        from .config import Overlay

        ov_path = Path(overlay)
        Overlay.load(ov_path)  # validated with its own file name in messages
        ov = read_yaml(ov_path)
        base = dict(data.get("base") or {})
        base["params"] = deep_merge(dict(ov.get("params") or {}), dict(base.get("params") or {}))
        base["effects"] = list(ov.get("effects") or []) + list(base.get("effects") or [])
        data = {**data, "base": base}
        text = yaml.safe_dump(dict(data), sort_keys=False)
    return build_campaign(data, path.name, text, path, out)


def build_campaign(data: Mapping[str, Any], where: str, text: str = "", path: Path | None = None,
                   out: str | Path | None = None) -> Campaign:
    check_keys(data, CAMPAIGN_KEYS, where)
    base = data.get("base") or {}
    if not isinstance(base, Mapping):
        raise ParameterError(f"{where}: base must be a mapping")
    check_keys(base, BASE_KEYS, f"{where}: base")
    params = dict(base.get("params") or {})
    load_params(overrides=params)  # validate robot overrides now
    base_effects = parse_effects(base.get("effects"), f"{where}: base.effects")
    cond0 = {
        "seed": _check_value("seed", base.get("seed", 0), f"{where}: base.seed"),
        "payload_kg": _check_value("payload_kg", base.get("payload_kg", 2.0), f"{where}: base.payload_kg"),
        "temperature_C": _check_value("temperature_C", base.get("temperature_C", 28.0),
                                      f"{where}: base.temperature_C"),
        "trajectory": _check_value("trajectory", data.get("trajectory", "pick_and_place"), f"{where}: trajectory"),
    }
    axes: list[list[dict[str, Any]]] = []
    swept: list[str] = []
    sweep = data.get("sweep") or {}
    if not isinstance(sweep, Mapping):
        raise ParameterError(f"{where}: sweep must be a mapping of key -> list of values")
    for key, values in sweep.items():
        loc = f"{where}: sweep.{key}"
        vals = [_check_value(key, v, loc) for v in _as_list(values, loc)]
        axes.append([{key: v} for v in vals])
        swept.append(key)
    zips = data.get("zip") or []
    if not isinstance(zips, list):
        raise ParameterError(f"{where}: zip must be a list of groups (mappings of key -> list)")
    for g, group in enumerate(zips):
        loc = f"{where}: zip[{g}]"
        if not isinstance(group, Mapping) or not group:
            raise ParameterError(f"{loc}: expected a mapping of key -> list of values")
        lists = {k: _as_list(v, f"{loc}.{k}") for k, v in group.items()}
        lengths = {len(v) for v in lists.values()}
        if len(lengths) != 1:
            raise ParameterError(f"{loc}: zipped lists must have equal lengths, got {sorted(lengths)}")
        axes.append([{k: _check_value(k, lists[k][i], f"{loc}.{k}[{i}]") for k in lists}
                     for i in range(lengths.pop())])
        swept.extend(lists)
    if len(set(swept)) != len(swept):
        dup = sorted({k for k in swept if swept.count(k) > 1})
        raise ParameterError(f"{where}: key swept twice: {', '.join(dup)}")
    _check_fault_keys(swept, where)
    runs: dict[str, RunConfig] = {}
    for combo in itertools.product(*axes) if axes else [()]:
        values: dict[str, Any] = {}
        for part in combo:
            values.update(part)
        cond = {**cond0, **{k: v for k, v in values.items() if k in CONDITION_KEYS}}
        faults = tuple(sorted((k, v) for k, v in values.items() if k not in CONDITION_KEYS))
        rc = RunConfig(tuple(sorted(cond.items(), key=lambda kv: kv[0])), faults)
        rc.fault_effects()  # validate the combination (e.g. joint present)
        for r in (rc, rc.twin()):
            runs.setdefault(r.run_id, r)
    thr = data.get("threshold_mm", 0.5)
    if isinstance(thr, bool) or not isinstance(thr, (int, float)) or thr <= 0:
        raise ParameterError(f"{where}: threshold_mm = {thr!r} must be a positive number of mm")
    bs = data.get("batch_size", 32)
    if isinstance(bs, bool) or not isinstance(bs, int) or not 1 <= bs <= 1024:
        raise ParameterError(f"{where}: batch_size = {bs!r} must be an integer in [1, 1024]")
    lp = data.get("log_period_s", 1e-3)
    if isinstance(lp, bool) or not isinstance(lp, (int, float)) or lp <= 0:
        raise ParameterError(f"{where}: log_period_s = {lp!r} must be a positive number of seconds")
    dur = data.get("duration_s")
    if dur is not None and (isinstance(dur, bool) or not isinstance(dur, (int, float)) or dur <= 0):
        raise ParameterError(f"{where}: duration_s = {dur!r} must be a positive number of seconds")
    name = str(data.get("name") or (path.stem if path else "campaign"))
    out_dir = Path(out) if out is not None else Path(data.get("out") or Path("results") / name)
    return Campaign(name, path, text or yaml.safe_dump(dict(data)), out_dir, base_effects, params,
                    tuple(runs.values()), tuple(swept), float(thr), int(bs), float(lp),
                    bool(data.get("save_timeseries", False)), None if dur is None else float(dur))


def _check_fault_keys(swept: Sequence[str], where: str) -> None:
    """A per-joint effect that is swept needs its joint swept (or a single joint) too."""
    effects = {k.partition(".")[0] for k in swept if "." in k}
    for name in effects:
        if REGISTRY[name].per_joint and f"{name}.joint" not in swept:
            raise ParameterError(f"{where}: sweep of effect {name!r} needs '{name}.joint' (list of joints 1..6)")


# ----------------------------------------------------------------------------- execution
def _effects_of(camp: Campaign, rc: RunConfig) -> tuple[EffectSpec, ...]:
    c = rc.cond
    return camp.base_effects + rc.fault_effects() + (
        make_effect("payload", mass_kg=c["payload_kg"]),
        make_effect("temperature", temperature_C=c["temperature_C"]),
    )


def plan_batches(camp: Campaign, todo: Sequence[RunConfig], n_workers: int = 1) -> list[list[RunConfig]]:
    """Group runs by trajectory, cut into lockstep batches (at most ``batch_size`` runs, and at
    least ``n_workers`` batches when there are enough runs), and add each batch's missing twins."""
    by_traj: dict[str, list[RunConfig]] = {}
    for rc in todo:
        by_traj.setdefault(json.dumps(rc.cond["trajectory"], sort_keys=True), []).append(rc)
    batches = []
    for runs in by_traj.values():
        runs = sorted(runs, key=lambda r: (json.dumps(r.conditions, default=str), r.run_id))
        size = max(1, min(camp.batch_size - 1, -(-len(runs) // max(1, n_workers))))
        for i in range(0, len(runs), size):
            chunk = runs[i : i + size]
            ids = {r.run_id for r in chunk}
            for r in list(chunk):
                t = r.twin()
                if t.run_id not in ids:
                    chunk.append(t)
                    ids.add(t.run_id)
            batches.append(chunk)
    return batches


def run_batch(camp: Campaign, batch: Sequence[RunConfig], ts_dir: str | None) -> list[dict[str, Any]]:
    """Simulate one lockstep batch; return one feature row per run (twins included)."""
    from .engine import RunSpec, Simulator
    from .features import run_features

    traj_spec = batch[0].cond["trajectory"]
    traj = parse_trajectory(traj_spec, "trajectory")
    sim = Simulator(load_params(overrides=dict(camp.base_params)))
    specs = [RunSpec(rc.run_id, int(rc.cond["seed"]), _effects_of(camp, rc)) for rc in batch]
    t0 = time.perf_counter()
    res = sim.run(traj, specs, log_period_s=camp.log_period_s, duration_s=camp.duration_s)
    wall = time.perf_counter() - t0
    index = {rc.run_id: i for i, rc in enumerate(batch)}
    ratio = np.asarray(sim.params.gear.ratio)
    rows = []
    for i, rc in enumerate(batch):
        twin_i = index[rc.twin().run_id]
        ok = res.status[i] == "ok" and res.status[twin_i] == "ok"
        feats = run_features(res.t_s, res.q_set_rad, res["q_FB_rad"][i], res["q_M_FB_rad"][i], res["i_FB_A"][i],
                             ratio, res.tcp_m[i], res.tcp_des_m[i], res.tcp_m[twin_i] if ok else None)
        if ts_dir is not None:
            res.to_parquet(Path(ts_dir) / f"{rc.run_id}.parquet", i)
        eff = rc.fault_effects()
        backlash = next((e for e in eff if e.name == "backlash"), None)
        fault_joint = (eff[0].joint + 1) if eff and eff[0].joint is not None else 0
        row: dict[str, Any] = {
            "run_id": rc.run_id,
            "fault_joint": fault_joint,
            "fault": "+".join(e.name for e in eff) or "healthy",
            "backlash_deg": backlash.value("backlash_deg") if backlash else 0.0,
            **{k: (json.dumps(v) if isinstance(v, dict) else v) for k, v in rc.cond.items()},
            **{_column(k): v for k, v in rc.faults},
            "twin_run_id": rc.twin().run_id,
            "status": res.status[i] if res.status[i] != "ok" or ok else "ok",
            "reason": res.reason[i] or ("" if ok else f"twin: {res.reason[twin_i]}"),
            "effects": "; ".join(e.describe() for e in eff),
            "wall_s_batch": wall,
            "batch_size": len(batch),
            **feats,
        }
        rows.append(row)
    return rows


def _column(key: str) -> str:
    name, _, par = key.partition(".")
    if key == "backlash.backlash_deg":
        return "backlash_deg_swept"
    return f"{name}_{par}" if par != "joint" else f"{name}_joint"


def runs_dir(out: Path) -> Path:
    return out / "runs"


def done_ids(out: Path) -> set[str]:
    d = runs_dir(out)
    return {p.stem for p in d.glob("r*.parquet")} if d.exists() else set()


class _Lock:
    """``OUT/.lock`` holding the owner's host and pid; a stale lock (dead pid) is taken over."""

    def __init__(self, out: Path) -> None:
        self.path = out / ".lock"

    def __enter__(self) -> _Lock:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        me = f"{socket.gethostname()} {os.getpid()}"
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
                os.write(fd, me.encode())
                os.close(fd)
                return self
            except FileExistsError:
                owner = self.path.read_text().split() if self.path.exists() else []
                if len(owner) == 2 and owner[0] == socket.gethostname() and not _alive(int(owner[1])):
                    self.path.unlink(missing_ok=True)  # stale: its process is gone
                    continue
                raise CampaignLockedError(
                    f"{self.path.parent}: another campaign is writing this folder (host {owner[0] if owner else '?'}, "
                    f"pid {owner[1] if len(owner) > 1 else '?'}); wait for it or choose another --out"
                ) from None
        raise CampaignLockedError(f"{self.path}: could not take the lock")

    def __exit__(self, *exc) -> None:
        self.path.unlink(missing_ok=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _file_sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def run_campaign(camp: Campaign, out: Path | None = None, *, jobs: int | None = None, backend: str = "loky",
                 scheduler: str | None = None, progress: bool | Callable[[int, int, float], None] = True,
                 save_timeseries: bool | None = None) -> dict[str, Any]:
    """Run every run of ``camp`` not yet done in ``out``; return the manifest.

    Args:
        jobs: worker processes (default: all cores).
        backend: ``"loky"`` (local processes) or ``"dask"`` (``scheduler`` address required).
        progress: print a progress line to stderr, or a callback ``(done, total, eta_s)``.
    """
    import joblib

    from . import __version__
    from .engine import DEFAULT_MODEL_PATH

    out = Path(out) if out is not None else camp.out
    jobs = jobs or os.cpu_count() or 1
    if backend not in ("loky", "dask"):
        raise ParameterError(f"backend = {backend!r} is not valid; choose one of: loky, dask")
    if backend == "dask" and not scheduler:
        raise ParameterError("--backend dask needs --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)")
    save_ts = camp.save_timeseries if save_timeseries is None else save_timeseries
    with _Lock(out):
        runs_dir(out).mkdir(parents=True, exist_ok=True)
        ts_dir = out / "timeseries" if save_ts else None
        if ts_dir is not None:
            ts_dir.mkdir(exist_ok=True)
        already = done_ids(out)
        todo = [rc for rc in camp.runs if rc.run_id not in already]
        batches = plan_batches(camp, todo, jobs)
        total, done = len(camp.runs), len(camp.runs) - len(todo)
        report = _progress(progress, total)
        report(done, 0.0)
        t0 = time.perf_counter()
        if batches:
            if backend == "dask":
                from dask.distributed import Client

                client = Client(scheduler)
                ctx = joblib.parallel_backend("dask", wait_for_workers_timeout=60)
            else:
                client, ctx = None, joblib.parallel_backend("loky")
            try:
                with ctx:
                    par = joblib.Parallel(n_jobs=jobs if backend == "loky" else -1, return_as="generator_unordered")
                    gen = par(joblib.delayed(run_batch)(camp, b, str(ts_dir) if ts_dir else None) for b in batches)
                    for rows in gen:
                        for row in rows:
                            if row["run_id"] not in already:
                                write_parquet_atomic(pd.DataFrame([row]), runs_dir(out) / f"{row['run_id']}.parquet")
                                already.add(row["run_id"])
                                done += 1
                        report(done, time.perf_counter() - t0)
            finally:
                if client is not None:
                    client.close()
        features = consolidate(out, camp)
        p = load_params(overrides=dict(camp.base_params))
        import mujoco

        duration = camp.duration_s if camp.duration_s else _duration(camp)
        manifest = {
            "name": camp.name,
            "campaign_file": str(camp.path) if camp.path else None,
            "campaign_sha256": camp.sha256,
            "campaign_text": camp.text,
            "model_file": str(DEFAULT_MODEL_PATH),
            "model_sha256": _file_sha256(DEFAULT_MODEL_PATH),
            "params_sha256": hashlib.sha256(json.dumps(p.to_dict(), sort_keys=True).encode()).hexdigest(),
            "ur5fault_version": __version__,
            "mujoco_version": mujoco.__version__,
            "numpy_version": np.__version__,
            "python": sys.version.split()[0],
            "n_runs": int(len(features)),
            "physics_dt_s": p.physics_dt_s,
            "duration_s": duration,
            "n_steps_total": int(len(features) * round(duration / p.physics_dt_s)),
            "threshold_mm": camp.threshold_mm,
            "swept_keys": list(camp.swept_keys),
            "wall_s_this_invocation": time.perf_counter() - t0,
            "backend": backend,
            "jobs": jobs,
            "status_counts": features["status"].value_counts().to_dict(),
            "feature_units": _units(),
        }
        _write_json_atomic(out / "manifest.json", manifest)
        return manifest


def _duration(camp: Campaign) -> float:
    traj = parse_trajectory(camp.runs[0].cond["trajectory"], "trajectory")
    return traj.duration_s


def _units() -> dict[str, str]:
    from .features import FEATURE_UNITS

    return dict(FEATURE_UNITS)


def consolidate(out: Path, camp: Campaign | None = None) -> pd.DataFrame:
    """Gather the per-run files into ``OUT/features.parquet`` (atomic), ordered by run_id."""
    files = sorted(runs_dir(out).glob("r*.parquet"))
    if not files:
        raise ConfigFileError(f"{out}: no finished runs")
    df = pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)
    if camp is not None:
        wanted = {rc.run_id for rc in camp.runs}
        df = df[df["run_id"].isin(wanted)]
    df = df.sort_values("run_id", kind="stable").reset_index(drop=True)
    write_parquet_atomic(df, out / "features.parquet")
    return df


def _write_json_atomic(path: Path, data: Mapping[str, Any]) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, indent=2, default=str))
    os.replace(tmp, path)


def _progress(progress, total: int) -> Callable[[int, float], None]:
    if callable(progress):
        return lambda done, el: progress(done, total, _eta(done, total, el))
    if not progress:
        return lambda done, el: None
    state = {"start_done": None}

    def show(done: int, elapsed: float) -> None:
        if state["start_done"] is None:
            state["start_done"] = done
        new = done - state["start_done"]
        left = (total - done) * elapsed / new if new > 0 else float("nan")
        bar = "#" * int(30 * done / max(total, 1))
        tail = f"~{left:5.0f} s left" if left == left else "estimating..."
        end = "\n" if done >= total or not sys.stderr.isatty() else "\r"
        sys.stderr.write(f"campaign [{bar:<30}] {done}/{total} runs  {elapsed:6.1f} s  {tail}{end}")
        sys.stderr.flush()

    return show


def _eta(done: int, total: int, elapsed: float) -> float:
    return (total - done) * elapsed / done if done else float("nan")


# ----------------------------------------------------------------------------- summaries
def tcp_table(features: pd.DataFrame) -> pd.DataFrame:
    """Maximum TCP deviation [mm] per fault joint (rows) x backlash level [deg] (columns)."""
    bl = features[(features["fault"].isin(["backlash", "healthy"])) & (features["status"] == "ok")]
    rows = {}
    healthy = bl[bl["fault_joint"] == 0]["tcp_dev_max_mm"].max() if (bl["fault_joint"] == 0).any() else np.nan
    for j in range(1, 7):
        sub = bl[bl["fault_joint"] == j]
        if sub.empty:
            continue
        row = sub.groupby("backlash_deg")["tcp_dev_max_mm"].max()
        row.loc[0.0] = healthy
        rows[f"{j} {JOINT_NAMES[j - 1]}"] = row.sort_index()
    return pd.DataFrame(rows).T


def acceptable_backlash(features: pd.DataFrame, threshold_mm: float) -> pd.Series:
    """Largest simulated backlash [deg] per joint whose max TCP deviation stays within the threshold."""
    table = tcp_table(features)
    out = {}
    for joint, row in table.iterrows():
        ok = [lvl for lvl, v in row.items() if np.isfinite(v) and v <= threshold_mm]
        bad = [lvl for lvl, v in row.items() if np.isfinite(v) and v > threshold_mm]
        below = [lvl for lvl in ok if not bad or lvl < min(bad)]
        out[joint] = max(below) if below else np.nan
    return pd.Series(out, name=f"max_backlash_deg_within_{threshold_mm:g}mm")


def status(out: Path) -> dict[str, Any]:
    """What is in a campaign folder: runs done, statuses, whether a process holds the lock."""
    out = Path(out)
    if not out.exists():
        raise ConfigFileError(f"{out}: no such campaign folder")
    manifest = json.loads((out / "manifest.json").read_text()) if (out / "manifest.json").exists() else {}
    done = done_ids(out)
    lock = (out / ".lock").read_text() if (out / ".lock").exists() else None
    info: dict[str, Any] = {"folder": str(out), "runs_done": len(done), "n_runs_expected": None, "lock": lock}
    if manifest.get("campaign_text"):
        try:
            camp = build_campaign(yaml.safe_load(manifest["campaign_text"]), "manifest", manifest["campaign_text"])
            info["n_runs_expected"] = len(camp.runs)
        except Ur5FaultError:
            pass
    if (out / "features.parquet").exists():
        df = pd.read_parquet(out / "features.parquet")
        info["status_counts"] = df["status"].value_counts().to_dict()
    return info
