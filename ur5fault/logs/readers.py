"""Measured logs: UR RTDE CSV, the NIST layout, and ur5fault's own time series.

Every reader returns a :class:`MeasuredLog` in SI units and ur5fault's sign conventions
(motor current positive when it drives the joint positive).  UR's controller configuration
lists joint directions ``[1, 1, -1, 1, 1, 1]``, but in the NIST log the elbow current has the
*same* sign as UR's own elbow torque (-1.35 A for -18.4 N*m at the start, 13.6 N*m/A like
J1-J2, and it rises with elbow speed), so no sign is flipped there; ``UR_CURRENT_SIGN`` is
where a log with the other convention would be corrected.

Files are sniffed and streamed (:mod:`.source`) and checked for plausibility (:mod:`.plausible`)
before a log is returned; every problem is one :class:`~ur5fault.errors.LogFormatError` line.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import LogFormatError, ParameterError, UnknownNameError
from ..sim.effects import REGISTRY
from ..util.checks import check_number
from . import plausible, regular
from .columns import have, joint_numbers, layout_hint, match_case, require, stack
from .measured import MeasuredLog
from .rest_target import rest_target_style
from .source import check_log_memory, read_columns, sniff
from .wrap import unwrap_joints

#: sign of the reported motor current w.r.t. joint torque (all +1 in the NIST log, see above)
UR_CURRENT_SIGN = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
NIST_TOOL_OFFSET_M = (-0.001, -0.001, 0.1856)  # fitted on the NIST log (tests/sim/test_nist_fk.py)
NIST_PAYLOAD_KG = 0.726  # 1.6 lb, from the NIST run name


def _assemble(src: str, t: NDArray, required: Mapping[str, NDArray], optional: Mapping[str, NDArray | None],
              declared: str, labels: tuple[str, str] = ("target_q", "actual_q"),
              length: plausible.MinLength | None = None, notes: Sequence[str] = (),
              columns: Mapping[str, Sequence[str]] | None = None, **fields) -> MeasuredLog:
    """Checks, optional columns completed (:func:`.regular.complete_optional`), the rows put on the controller
    tick grid (:func:`.regular.on_ticks`), and the log. ``required``: target positions ``"target_q"``, actual
    positions ``"actual_q"`` (both already in radians) and ``"actual_current"``; ``optional``: ``"target_qd"``,
    ``"actual_qd"`` (rad/s, for the unit check only), ``"target_current"``, ``"temperature"``, ``"tcp"``,
    ``"target_torque"``; ``notes``: the reader's own (:func:`_have`'s), said before the assembly's; ``columns``: the
    file's columns of ``"time"`` and of each required array, named where a value is NaN (a few rows of NaN in
    a required array are interpolated and marked not logged: :func:`.regular.unreadable_rows`)."""
    plausible.check_finite(src, {"time": t}, columns)
    notes = list(notes)
    required = dict(required)
    for k, label in zip(("target_q", "actual_q"), labels):  # before anything interpolates across a wrap
        fin = np.isfinite(required[k]).all(axis=1)  # a row without a value is filled after (unreadable_rows)
        q = np.array(required[k], dtype=float)
        q[fin], wrapped = unwrap_joints(q[fin]) if fin.any() else (q[fin], [])
        required[k] = q
        if wrapped:
            joints = ", ".join(str(j + 1) for j in wrapped)
            notes.append(f"{src}: {label} of joint(s) {joints} wrap around (a jump of a whole turn between two rows): "
                         "made continuous")
    # a few rows without a required value: interpolated in place, marked not logged on the tick grid (on_ticks)
    upto, required, unread = regular.unreadable_rows(src, t, required, columns, plausible.MAX_GAP_TICKS,
                                                     length or plausible.FIT_LENGTH, notes)
    t, required = t[upto], {k: v[upto] for k, v in required.items()}
    optional = {k: None if v is None else v[upto] for k, v in optional.items()}
    rows, opt = regular.complete_optional(src, t, optional, notes)
    t = t[rows]
    req = {k: v[rows] for k, v in required.items()}
    opt = {k: None if v is None else v[rows] for k, v in opt.items()}
    unread = None if unread is None or not unread[rows].any() else unread[rows]
    plausible.check_increasing(src, t)
    opt["temperature"] = regular.unrecorded_temperature(src, opt["temperature"], notes)
    plausible.check_temperature_units(src, opt["temperature"])
    plausible.check_range(src, req["actual_q"], t, opt["actual_qd"], declared)  # a value no joint takes: any length
    plausible.check_enough_rows(src, t, length)  # too few rows: said as such, not as a current that never changes
    plausible.check_current_alive(src, req["actual_current"])
    plausible.check_sampling(src, t, length)
    plausible.check_units(src, t, req["target_q"], opt["target_qd"], labels[0], declared)
    plausible.check_units(src, t, req["actual_q"], opt["actual_qd"], labels[1], declared)
    rest_target = rest_target_style(t, req["target_q"], req["actual_q"], opt["target_qd"])
    if rest_target == "reading":
        notes.append(f"{src}: at rest (every target speed 0) the logged target is the previous measured position, "
                     "as a CB2 controller logs it: the twin is commanded there to the robot's own reading, not to the "
                     "pose the robot holds (ur5fault's docs/validation.md, \"A CB2 log's target at rest\")")
    arrays = {**req, **{k: v for k, v in opt.items() if k not in ("target_qd", "actual_qd")}}
    grid, a, logged = regular.on_ticks(src, t, arrays, notes, unread)
    cur_t = a["target_current"]
    return _checked(MeasuredLog(
        source=src, t_s=grid, q_target_rad=a["target_q"], q_actual_rad=a["actual_q"],
        current_A=a["actual_current"] * UR_CURRENT_SIGN,
        target_current_A=None if cur_t is None else cur_t * UR_CURRENT_SIGN, temperature_C=a["temperature"],
        tcp_m=a["tcp"], target_torque_Nm=a["target_torque"], logged=logged, notes=tuple(notes),
        rest_target=rest_target, **fields))


def _checked(log: MeasuredLog) -> MeasuredLog:
    """The checks of a whole log every reader makes (read directly or through :func:`read_log`): current units, a
    current that carries the torque, its sign against UR's target current, and (a real robot's) following error."""
    plausible.check_current_units(log.source, {"current": log.current_A, "target current": log.target_current_A})
    plausible.check_current_carries_torque(log.source, log.current_A, log.target_current_A)
    plausible.check_current_sign(log.source, log.current_A, log.target_current_A)
    if not log.simulated:  # a simulated fault may carry the twin up to its own protective stop
        plausible.check_following_error(log.source, log.t_s, log.q_target_rad, log.q_actual_rad)
    return log


def read_nist(path: str | Path, length: plausible.MinLength | None = None) -> MeasuredLog:
    """Read the NIST UR5 layout (positions in degrees, velocities in rad/s; see
    data/nist-ur5/README.md). The layout names its payload and tool offset (:data:`NIST_PAYLOAD_KG`,
    :data:`NIST_TOOL_OFFSET_M`), so the caller gives neither."""
    path = Path(path)
    src = path.name
    layout = sniff(path, src)
    cols = layout.columns
    pos_t = [f"ROBOT_TARGET_JOINT_POSITIONS (J{j})" for j in range(1, 7)]
    pos_a = [f"ROBOT_ACTUAL_JOINT_POSITIONS (J{j})" for j in range(1, 7)]
    cur_a = [f"ROBOT_ACTUAL_JOINT_CURRENT (J{j})" for j in range(1, 7)]
    require(cols, ["ROBOT_TIME", *pos_t, *pos_a, *cur_a], src, "nist")
    plausible.check_joint_count(src, joint_numbers(cols, r"ROBOT_ACTUAL_JOINT_POSITIONS \(J(\d+)\)"), 1)
    part: list[str] = []
    cur_t = have(cols, [f"ROBOT_TARGET_JOITN_CURRENT (J{j})" for j in range(1, 7)], part, src)
    temp = have(cols, [f"ROBOT_JOINT_TEMP (J{j})" for j in range(1, 7)], part, src)
    tcp = have(cols, [f"ROBOT_CARTESIAN_COORD_TOOL ({a})" for a in "xyz"], part, src)
    vel_t = have(cols, [f"ROBOT_TARGET_JOINT_VELOCITIES (J{j})" for j in range(1, 7)], part, src)
    vel_a = have(cols, [f"ROBOT_ACTUAL_JOINT_VELOCITIES (J{j})" for j in range(1, 7)], part, src)
    torq = have(cols, [f"ROBOT_TARGET_JOINT_TORQUES (J{j})" for j in range(1, 7)], part, src)
    d = read_columns(path, src, layout,
                     ["ROBOT_TIME", *pos_t, *pos_a, *cur_a, *cur_t, *temp, *tcp, *vel_t, *vel_a, *torq])
    required = {"target_q": np.radians(stack(d, pos_t)), "actual_q": np.radians(stack(d, pos_a)),
                "actual_current": stack(d, cur_a)}
    optional = {"target_qd": stack(d, vel_t), "actual_qd": stack(d, vel_a), "target_current": stack(d, cur_t),
                "temperature": stack(d, temp), "tcp": stack(d, tcp), "target_torque": stack(d, torq)}
    columns = {"time": ["ROBOT_TIME"], "target_q": pos_t, "actual_q": pos_a, "actual_current": cur_a}
    return _assemble(src, d["ROBOT_TIME"], required, optional, "degrees",
                     ("target positions", "actual positions"), length, part, columns, payload_kg=NIST_PAYLOAD_KG,
                     tcp_offset_m=NIST_TOOL_OFFSET_M)


#: names of the time column an RTDE-style log may carry (UR's recorder writes ``timestamp``; older
#: tools and the CB2 recordings of data/kufieta-ur5 ``time``); the first present is used
RTDE_TIME_COLUMNS = ("timestamp", "time")
#: the largest tool offset a log may state, per axis [m] (a plausibility bound: the UR5 reaches 0.85 m)
TCP_OFFSET_LIMIT_M = 2.0


def check_payload_and_tool(payload_kg: float | None, tcp_offset_m, payload_name: str = "payload_kg",
                           tcp_name: str = "tcp_offset_m[{k}]") -> tuple[float | None, tuple[float, ...] | None]:
    """A stated payload [kg] and tool offset [m] (either None: not stated) in range, each refused in one line under
    its name (``tcp_name`` formatted with the axis ``k``, 1..3): the API's keywords by default, the command line's
    flags from ``ur5fault`` commands."""
    if payload_kg is not None:
        mass = REGISTRY["payload"].param("mass_kg")
        payload_kg = check_number(payload_kg, payload_name, mass.lo, mass.hi, mass.unit)
    if tcp_offset_m is not None:
        tcp_offset_m = tuple(check_number(v, tcp_name.format(k=k + 1), -TCP_OFFSET_LIMIT_M, TCP_OFFSET_LIMIT_M, "m")
                             for k, v in enumerate(tcp_offset_m))
    return payload_kg, tcp_offset_m


def read_rtde(path: str | Path, payload_kg: float | None = None,
              tcp_offset_m: tuple[float, float, float] | None = None,
              length: plausible.MinLength | None = None) -> MeasuredLog:
    """Read a UR RTDE CSV as the ``rtde`` recorder writes it (radians, amperes, metres), comma-,
    tab-, semicolon- or space-separated, plain or gzip, with or without a UTF-8 byte-order mark.

    Column names match whatever their case (``TIME``, ``ACTUAL_Q_0``), unless two differ only in case.
    Required columns: ``timestamp`` (or ``time``), ``target_q_0..5``, ``actual_q_0..5``,
    ``actual_current_0..5``; optional: ``target_current_0..5``, ``joint_temperatures_0..5``,
    ``actual_TCP_pose_0..5``, ``target_moment_0..5`` (UR's target torque), and
    ``target_qd_0..5`` / ``actual_qd_0..5`` (rad/s, used to check the position units).
    The payload and tool offset are not in the recording: given by the caller, or ``None`` = unknown
    (the workflows fit an unknown payload and say so).
    """
    path = Path(path)
    src = path.name
    if tcp_offset_m is not None and len(tcp_offset_m) != 3:
        raise LogFormatError(f"tcp_offset_m = {tcp_offset_m!r} must be 3 numbers [m]")
    payload_kg, tcp_offset_m = check_payload_and_tool(payload_kg, tcp_offset_m)  # type: ignore[assignment]
    layout = sniff(path, src)
    qt = [f"target_q_{j}" for j in range(6)]
    qa = [f"actual_q_{j}" for j in range(6)]
    ia = [f"actual_current_{j}" for j in range(6)]
    groups = ("target_current", "joint_temperatures", "actual_TCP_pose", "target_qd", "actual_qd", "target_moment")
    rename = match_case(layout.columns, [*RTDE_TIME_COLUMNS, *qt, *qa, *ia,
                                          *(f"{name}_{j}" for name in groups for j in range(6))], src)
    cols = tuple(rename.get(c, c) for c in layout.columns)  # names as the reader knows them
    time_col = next((c for c in RTDE_TIME_COLUMNS if c in cols), None)
    if time_col is None:
        raise LogFormatError(f"{src}: missing required column {RTDE_TIME_COLUMNS[0]!r} (or "
                             f"{' or '.join(repr(c) for c in RTDE_TIME_COLUMNS[1:])}): the time [s]"
                             + layout_hint(layout.columns, "rtde"))
    require(cols, [*qt, *qa, *ia], src, "rtde")
    plausible.check_joint_count(src, joint_numbers(cols, r"actual_q_(\d+)"), 0)
    part: list[str] = []
    ct = have(cols, [f"target_current_{j}" for j in range(6)], part, src)
    temp = have(cols, [f"joint_temperatures_{j}" for j in range(6)], part, src)
    tcp = have(cols, [f"actual_TCP_pose_{j}" for j in range(3)], part, src)
    vt = have(cols, [f"target_qd_{j}" for j in range(6)], part, src)
    va = have(cols, [f"actual_qd_{j}" for j in range(6)], part, src)
    tm = have(cols, [f"target_moment_{j}" for j in range(6)], part, src)
    in_file = {v: k for k, v in rename.items()}
    wanted = [time_col, *qt, *qa, *ia, *ct, *temp, *tcp, *vt, *va, *tm]
    d = read_columns(path, src, layout, [in_file.get(c, c) for c in wanted])
    d = {rename.get(c, c): v for c, v in d.items()}
    required = {"target_q": stack(d, qt), "actual_q": stack(d, qa), "actual_current": stack(d, ia)}
    optional = {"target_qd": stack(d, vt), "actual_qd": stack(d, va), "target_current": stack(d, ct),
                "temperature": stack(d, temp), "tcp": stack(d, tcp), "target_torque": stack(d, tm)}
    columns = {"time": [time_col], "target_q": qt, "actual_q": qa, "actual_current": ia}
    columns = {k: [in_file.get(c, c) for c in v] for k, v in columns.items()}  # as the file spells them
    return _assemble(src, d[time_col], required, optional, "radians", length=length, notes=part, columns=columns,
                     payload_kg=payload_kg, tcp_offset_m=tcp_offset_m)


#: what to do about a run's time series that fails its checksum
RESIMULATE = ("simulate it again: run its campaign again into its folder (the bad file is named and re-simulated), "
              "or `ur5fault simulate` it")


def read_sim(path: str | Path, length: plausible.MinLength | None = None) -> MeasuredLog:
    """Read a time series written by ``ur5fault simulate`` (or a campaign's ``timeseries/``).

    Uses ``q_set_rad_j*`` as target, ``q_FB_rad_j*`` as the measured position, ``i_FB_A_j*`` as the
    current, and ``q_M_FB_rad_j*`` (motor encoders) when present.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ..util.io import check_stored

    path = Path(path)
    src = path.name
    if path.suffix.lower() == ".csv" or path.name.lower().endswith(".csv.gz"):
        raise LogFormatError(f"{src}: the sim format reads the Parquet file `ur5fault simulate --out FILE.parquet` "
                             "writes; a CSV of it has no place for the run's payload, tool and temperatures (a robot's "
                             "CSV log: --format rtde, or nist for the NIST layout)")
    if path.is_file():  # a campaign's time series carries its checksum: a changed byte is refused, not fitted
        check_stored(path, RESIMULATE)
    try:
        pf = pq.ParquetFile(path)
        schema, n_rows = pf.schema_arrow, pf.metadata.num_rows
    except (OSError, ValueError, pa.ArrowException) as exc:
        raise LogFormatError(f"{src}: cannot read as Parquet ({' '.join(str(exc).split())[:160]})") from None
    names = schema.names
    cols = lambda name: [f"{name}_j{j}" for j in range(1, 7)]  # noqa: E731
    require(names, ["t_s", *cols("q_set_rad"), *cols("q_FB_rad"), *cols("i_FB_A")], src)
    plausible.check_joint_count(src, joint_numbers(names, r"q_FB_rad_j(\d+)"), 1)
    tcp = have(names, ["tcp_x_m", "tcp_y_m", "tcp_z_m"])
    qm = have(names, cols("q_M_FB_rad"))
    wanted = ["t_s", *cols("q_set_rad"), *cols("q_FB_rad"), *cols("i_FB_A"), *tcp, *qm]
    check_log_memory(src, n_rows, len(wanted))
    try:
        table = pf.read(columns=wanted)
        d = {c: table.column(c).to_numpy().astype(float) for c in wanted}
    except (OSError, ValueError, TypeError, pa.ArrowException) as exc:
        raise LogFormatError(f"{src}: cannot read its columns ({' '.join(str(exc).split())[:160]})") from None
    if n_rows == 0:
        raise LogFormatError(f"{src}: no samples")
    t = d["t_s"]
    arrays = {"q_set_rad": stack(d, cols("q_set_rad")), "q_FB_rad": stack(d, cols("q_FB_rad")),
              "i_FB_A": stack(d, cols("i_FB_A"))}
    plausible.check_finite(src, {"time": t, **arrays}, {"time": ["t_s"], **{k: cols(k) for k in arrays}})
    plausible.check_increasing(src, t)
    plausible.check_range(src, arrays["q_FB_rad"])
    plausible.check_sampling(src, t, length)
    meta = _sim_metadata(schema, src)
    temp = meta.get("joint_temperature_C")
    try:
        temp_arr = None if temp is None else np.tile(np.asarray(temp, float).reshape(6), (t.size, 1))
        payload = float(meta.get("payload_kg", 0.0) or 0.0)
        offset = tuple(float(x) for x in meta.get("tcp_offset_m", (0.0, 0.0, 0.15)))
        if len(offset) != 3 or not np.all(np.isfinite(offset)) or not np.isfinite(payload):
            raise ValueError("tcp_offset_m or payload_kg")
        held = None  # files written before the schedule was recorded: held throughout, as any log
        if "payload_events" in meta:
            held = np.full(t.size, bool(meta.get("payload_gripped_at_start", False)))
            for te, g in meta["payload_events"]:
                held = np.where(t >= float(te), bool(g), held)
    except (TypeError, ValueError) as exc:
        raise LogFormatError(f"{src}: malformed ur5fault metadata ({exc})") from None
    return _checked(MeasuredLog(
        source=src, t_s=t, q_target_rad=arrays["q_set_rad"], q_actual_rad=arrays["q_FB_rad"],
        current_A=arrays["i_FB_A"], tcp_m=stack(d, tcp), q_motor_rad=stack(d, qm), temperature_C=temp_arr,
        payload_kg=payload, tcp_offset_m=offset, payload_held=held, simulated=True,  # type: ignore[arg-type]
    ))


def _sim_metadata(schema, src: str) -> dict:
    raw = (schema.metadata or {}).get(b"ur5fault", b"{}")
    try:
        meta = json.loads(raw)
    except ValueError:
        raise LogFormatError(f"{src}: malformed ur5fault metadata (not JSON)") from None
    if not isinstance(meta, dict):
        raise LogFormatError(f"{src}: malformed ur5fault metadata (not a mapping)")
    return meta


READERS = {"nist": read_nist, "rtde": read_rtde, "sim": read_sim}


def check_log_file(path: str | Path) -> Path:
    """``path`` as a Path when it is a file; else one line: no such file, or not a file."""
    p = Path(path)
    if not p.exists():
        raise LogFormatError(f"{p}: no such file")
    if not p.is_file():
        raise LogFormatError(f"{p}: not a file")
    return p


def read_log(path: str | Path, fmt: str, length: plausible.MinLength | None = None, **kwargs) -> MeasuredLog:
    """Read a log in one of the formats of :data:`READERS` (``nist``, ``rtde``, ``sim``); ``payload_kg`` and
    ``tcp_offset_m`` are for ``rtde`` only (the other formats carry their own) and are refused elsewhere;
    ``length``: the least the log must cover (default :data:`.plausible.FIT_LENGTH`, what fitting needs)."""
    if fmt not in READERS:
        raise UnknownNameError("log format", fmt, READERS)
    given = [k for k, v in kwargs.items() if v is not None]
    if fmt != "rtde" and given:
        raise ParameterError(f"{given[0]} applies to the rtde format only: a {fmt} log carries its own payload and "
                             "tool offset")
    unknown = set(kwargs) - {"payload_kg", "tcp_offset_m"}
    if unknown:
        raise ParameterError(f"read_log: unknown option {sorted(unknown)[0]!r} (payload_kg, tcp_offset_m)")
    p = check_log_file(path)
    return READERS[fmt](p, length=length, **{k: v for k, v in kwargs.items() if v is not None})
