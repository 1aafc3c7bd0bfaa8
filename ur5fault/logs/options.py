"""The command line's options for measured logs, shared by ``ur5fault identify``, ``discrepancy`` and
``monitor``: one or several log files, or a YAML manifest of logs, with their format, payload and tool.

A manifest (a ``.yaml`` / ``.yml`` file given in place of the logs) names the logs of one robot with
per-log options; paths are relative to the manifest::

    format: rtde                 # default of every log (the command line's --format when absent)
    payload_kg: 0                # defaults of the rtde logs (the command line's when absent)
    tcp_offset_m: [0, 0, 0]
    logs:
      - path: Movement_No1.csv.gz
      - {path: Movement_No2.csv.gz, payload_kg: 0.5}
      - {path: Movement_No3.csv.gz, payload_kg: unknown, tcp_offset_m: null}   # fitted (discrepancy, identify)
      - {path: TEST.csv.gz, hold_out: true}     # held out whole (discrepancy)

The payload of an rtde log with no ``payload_kg`` (here or on the command line), or with ``unknown``, is
unknown: ``ur5fault discrepancy`` and ``ur5fault identify`` fit it (mass, and its centre of mass where
``tcp_offset_m`` is not given either; :mod:`ur5fault.discrepancy.payload`, :mod:`ur5fault.identify.payload`) and
say so; the other commands refuse it with one line. A nist
or sim log carries its payload; ``unknown`` declares it unknown all the same (its tool offset too, unless
``tcp_offset_m`` is given).
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Sequence
from pathlib import Path

from ..errors import ParameterError
from ..util.checks import check_bool
from ..util.yamlsafe import read_yaml
from .measured import UNKNOWN_PAYLOAD, MeasuredLog
from .plausible import MinLength
from .readers import read_log

MANIFEST_SUFFIXES = (".yaml", ".yml")
MANIFEST_KEYS = ("format", "payload_kg", "tcp_offset_m", "logs")
LOG_KEYS = ("path", "format", "payload_kg", "tcp_offset_m", "hold_out")
#: the value of ``--payload-kg`` / ``payload_kg`` that declares a log's payload unknown (fitted by discrepancy
#: and identify)
UNKNOWN = "unknown"


def payload_kg_arg(text: str) -> float | str:
    """``--payload-kg``: a number of kilograms or ``unknown``."""
    if text.strip().lower() == UNKNOWN:
        return UNKNOWN
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is neither a number of kg nor 'unknown'") from None


def add_log_options(parser: argparse.ArgumentParser, formats: Sequence[str], *, several: bool = True,
                    hold_out: bool = False) -> None:
    """The log files (or a manifest), their ``--format`` (one of ``formats``) and what an RTDE file does not
    record; ``hold_out``: also ``--hold-out LOG ...`` (runs held out whole)."""
    parser.add_argument("log", nargs="+" if several else None,
                        help="measured log file(s) of one robot, or one YAML manifest of logs"
                        if several else "measured log file")
    parser.add_argument("--format", choices=tuple(formats), dest="fmt",
                        help="log format: " + ", ".join(formats) + " (required unless a manifest names it)")
    parser.add_argument("--payload-kg", type=payload_kg_arg,
                        help="payload held during the log(s) [kg], 0 for none, or 'unknown' (default: rtde: unknown, "
                             "which discrepancy and identify fit and say so and the other commands refuse; nist and "
                             "sim: the "
                             "log's own, unless declared 'unknown')")
    parser.add_argument("--tcp-offset-m", type=float, nargs=3,
                        help="tool offset (payload position) in the flange frame [m], 0 0 0 for the flange (default: "
                             "rtde: unknown, its centre of mass fitted with an unknown payload; nist and sim: the "
                             "log's own, and given only with --payload-kg unknown)")
    if hold_out:
        parser.add_argument("--hold-out", nargs="+", default=[], metavar="LOG",
                            help="further runs of the robot held out whole: scored, never fitted (default: none)")
    parser.set_defaults(log_formats=tuple(formats))


@dataclasses.dataclass(frozen=True)
class LogEntry:
    path: Path
    fmt: str
    payload_kg: float | str | None  # a number, UNKNOWN, or None (rtde: unknown; other formats: the log's own)
    tcp_offset_m: tuple[float, float, float] | None
    hold_out: bool = False

    @property
    def payload_unknown(self) -> bool:
        return self.payload_kg == UNKNOWN or (self.fmt == "rtde" and self.payload_kg is None)


def _check_payload_options(fmt: str, payload_kg, tcp_offset_m, where: str) -> None:
    if isinstance(payload_kg, str) and payload_kg.strip().lower() != UNKNOWN:
        raise ParameterError(f"{where}payload_kg = {payload_kg!r} is neither a number of kg nor 'unknown'")
    if fmt != "rtde" and payload_kg != UNKNOWN:
        for flag, value in (("--payload-kg", payload_kg), ("--tcp-offset-m", tcp_offset_m)):
            if value is not None:
                raise ParameterError(f"{where}{flag} applies to --format rtde only (or with --payload-kg unknown): a "
                                     f"{fmt} log carries its own payload and tool offset")


def _manifest(path: Path, args: argparse.Namespace) -> list[LogEntry]:
    data = read_yaml(path)
    where = f"{path.name}: "
    bad = sorted(set(data) - set(MANIFEST_KEYS))
    if bad:
        raise ParameterError(f"{where}unknown key {bad[0]!r} (keys: {', '.join(MANIFEST_KEYS)})")
    logs = data.get("logs")
    if not isinstance(logs, list) or not logs:
        raise ParameterError(f"{where}'logs' must be a list of at least one log ({{path: FILE, ...}} or FILE)")
    out = []
    for k, item in enumerate(logs):
        item = {"path": item} if isinstance(item, str) else item
        w = f"{path.name}: logs[{k}]: "
        if not isinstance(item, dict) or "path" not in item:
            raise ParameterError(f"{w}a log is a file name or a mapping with 'path'")
        bad = sorted(set(item) - set(LOG_KEYS))
        if bad:
            raise ParameterError(f"{w}unknown key {bad[0]!r} (keys: {', '.join(LOG_KEYS)})")
        fmt = item.get("format", data.get("format", args.fmt))
        if fmt not in args.log_formats:
            raise ParameterError(f"{w}format {fmt!r} is not one of: {', '.join(args.log_formats)}")
        rtde = fmt == "rtde"  # the manifest's and the command line's payload and tool are defaults of rtde logs
        payload = item.get("payload_kg", data.get("payload_kg", args.payload_kg) if rtde else None)
        payload = payload.strip().lower() if isinstance(payload, str) else payload
        tcp = item.get("tcp_offset_m", data.get("tcp_offset_m", args.tcp_offset_m) if rtde else None)
        if tcp is not None and (not isinstance(tcp, (list, tuple)) or len(tcp) != 3):
            raise ParameterError(f"{w}tcp_offset_m = {tcp!r} must be 3 numbers [m]")
        _check_payload_options(fmt, payload, tcp, w)
        out.append(LogEntry((path.parent / str(item["path"])), fmt, payload,
                            None if tcp is None else tuple(tcp),  # type: ignore[arg-type]
                            check_bool(item.get("hold_out", False), f"{w}hold_out")))
    return out


def log_entries(args: argparse.Namespace) -> list[LogEntry]:
    """The logs the command line names (files, or one manifest), and ``--hold-out``'s, in order."""
    paths = [args.log] if isinstance(args.log, str) else list(args.log)
    held = list(getattr(args, "hold_out", []) or [])
    if len(paths) == 1 and Path(paths[0]).suffix.lower() in MANIFEST_SUFFIXES:
        entries = _manifest(Path(paths[0]), args)
        return entries + [LogEntry(Path(p), args.fmt, args.payload_kg, _tcp(args), True) for p in held]
    if args.fmt is None:
        raise ParameterError("--format is required (or a YAML manifest of logs that names it)")
    _check_payload_options(args.fmt, args.payload_kg, args.tcp_offset_m, "")
    return [LogEntry(Path(p), args.fmt, args.payload_kg, _tcp(args), False) for p in paths] + \
        [LogEntry(Path(p), args.fmt, args.payload_kg, _tcp(args), True) for p in held]


def _tcp(args: argparse.Namespace):
    return None if args.tcp_offset_m is None else tuple(args.tcp_offset_m)


def read_entry(e: LogEntry, length: MinLength | None = None, *, allow_unknown: bool = False) -> MeasuredLog:
    """Read one log (at least ``length`` long, default what fitting needs). A log whose payload is unknown
    (:attr:`LogEntry.payload_unknown`) comes back with ``payload_kg`` ``None`` (and ``tcp_offset_m`` ``None``
    unless given) when ``allow_unknown`` (the caller fits it), else is refused with one line (after the file's own
    checks), never given a default; a stated payload without its position is refused either way."""
    if e.fmt == "rtde":
        payload = None if e.payload_unknown else e.payload_kg
        log = read_log(e.path, e.fmt, length, payload_kg=payload, tcp_offset_m=e.tcp_offset_m)
    else:
        log = read_log(e.path, e.fmt, length)
        if e.payload_unknown:
            log = dataclasses.replace(log, payload_kg=None, tcp_offset_m=e.tcp_offset_m)
    if log.payload_kg is not None and log.tcp_offset_m is None:
        raise ParameterError(f"{log.source}: --tcp-offset-m (tcp_offset_m) missing: a stated payload needs its "
                             "position (0 0 0 for a bare flange), or give --payload-kg unknown to fit both")
    if not log.payload_known and not allow_unknown:
        raise ParameterError(f"{log.source}: payload unknown (no --payload-kg): {UNKNOWN_PAYLOAD}")
    return log


def read_log_options(args: argparse.Namespace, *, allow_unknown: bool = False
                     ) -> tuple[list[MeasuredLog], list[MeasuredLog]]:
    """The logs to fit and the logs held out whole, read and checked; ``allow_unknown``: logs whose payload is
    unknown are returned as such (:func:`read_entry`), for a caller that fits it."""
    entries = log_entries(args)
    names = [e.path.name for e in entries]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ParameterError(f"log {dup[0]!r} given twice (a log is named by its file name)")
    logs = [(read_entry(e, allow_unknown=allow_unknown), e.hold_out) for e in entries]
    return [g for g, h in logs if not h], [g for g, h in logs if h]

