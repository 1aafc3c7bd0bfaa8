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
``tcp_offset_m`` is given). Logs of ``--hold-out`` beside a manifest take its defaults as its own logs do. A
command-line option that no log takes (the manifest states each log's own) and that differs from what they state
is refused with one line, never dropped; a manifest is the only log given, and lists logs only (another
manifest among its logs is refused as such).
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Sequence
from pathlib import Path

from ..errors import ParameterError, did_you_mean
from ..util.checks import check_bool
from ..util.yamlsafe import read_yaml
from .readers import check_payload_and_tool

MANIFEST_SUFFIXES = (".yaml", ".yml")
MANIFEST_KEYS = ("format", "payload_kg", "tcp_offset_m", "logs")
LOG_KEYS = ("path", "format", "payload_kg", "tcp_offset_m", "hold_out")
#: what a refused manifest's first words say it was taken for
READ_AS_MANIFEST = "read as a manifest of logs (a .yaml or .yml file among the logs is one)"
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
                        if several else "measured log file, or a YAML manifest of logs that names one")
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


#: what the command line's messages call a log's payload and tool offset, and where they apply
CLI_NAMES = ("--payload-kg", "--tcp-offset-m", "--format rtde only (or with --payload-kg unknown)")


def _check_payload_options(fmt: str, payload_kg, tcp_offset_m, where: str,
                           names: tuple[str, str, str] = CLI_NAMES) -> None:
    """A payload and tool offset given for a log of format ``fmt``; ``names``: what the messages call the payload
    and the tool offset (in full: a manifest's key paths, or the command line's flags, :data:`CLI_NAMES`), and the
    logs they apply to; ``where``: the place of a payload that is not a number."""
    if isinstance(payload_kg, str) and payload_kg.strip().lower() != UNKNOWN:
        raise ParameterError(f"{where}payload_kg = {payload_kg!r} is neither a number of kg nor 'unknown'")
    if fmt != "rtde" and payload_kg != UNKNOWN:
        for name, value in zip(names, (payload_kg, tcp_offset_m)):
            if value is not None:
                raise ParameterError(f"{name} applies to {names[2]}: a {fmt} log carries its own payload and tool "
                                     "offset")


#: the command line's options that are defaults of a manifest's logs: (attribute of the parsed arguments, flag,
#: key of the manifest and of a log)
CLI_DEFAULTS = (("fmt", "--format", "format"), ("payload_kg", "--payload-kg", "payload_kg"),
                ("tcp_offset_m", "--tcp-offset-m", "tcp_offset_m"))
#: the flag of each of them
CLI_FLAGS = {attr: flag for attr, flag, _ in CLI_DEFAULTS}


def _entry(item: dict, data: dict, args: argparse.Namespace, path: Path, w: str, used: set[str],
           top: str, top_used: set[str]) -> LogEntry:
    """One log of a manifest (``data``; ``item`` its own options, ``path`` its file): the log's own value of each
    option, else the manifest's, else the command line's; ``used`` collects the command-line options it took,
    ``top_used`` the manifest's defaults. ``w``: the log's place in the manifest, ``top``: the manifest's, for
    messages."""
    source: dict[str, str] = {}  # where each option's value came from, for its error message

    def value(attr: str, key: str):
        if key in item:
            source[key] = f"{w}{key}"
            return item[key]
        if key in data:
            source[key] = f"{w}{key} (from {top}{key})"
            top_used.add(key)
            return data[key]
        used.add(attr)
        source[key] = f"{w}{key} (from {CLI_FLAGS[attr]})"
        return getattr(args, attr)

    fmt = value("fmt", "format")
    if fmt not in args.log_formats:
        raise ParameterError(f"{source['format']}: {fmt!r} is not one of: {', '.join(args.log_formats)}"
                             if fmt is not None else
                             f"{w}no format: give --format or the manifest's 'format' ({', '.join(args.log_formats)})")
    rtde = fmt == "rtde"  # the manifest's and the command line's payload and tool are defaults of rtde logs
    payload = value("payload_kg", "payload_kg") if rtde or "payload_kg" in item else None
    payload = payload.strip().lower() if isinstance(payload, str) else payload
    tcp = value("tcp_offset_m", "tcp_offset_m") if rtde or "tcp_offset_m" in item else None
    if tcp is not None and (not isinstance(tcp, (list, tuple)) or len(tcp) != 3):
        raise ParameterError(f"{w}tcp_offset_m = {tcp!r} must be 3 numbers [m]")
    _check_payload_options(fmt, payload, tcp, w, (source.get("payload_kg", f"{w}payload_kg"),
                                                   source.get("tcp_offset_m", f"{w}tcp_offset_m"),
                                                   "rtde logs only (or with payload_kg: unknown)"))
    # the manifest's payload and tool in range, named by their key paths; values taken from the command line were
    # checked under the flags' names before any log was read (_resolve)
    def stated(key: str, value):
        from_cli = source.get(key, "").endswith(f"(from {CLI_FLAGS[key]})")
        return None if from_cli or value in (None, UNKNOWN) else value

    check_payload_and_tool(stated("payload_kg", payload), stated("tcp_offset_m", tcp),
                           payload_name=source.get("payload_kg", ""),
                           tcp_name=source.get("tcp_offset_m", "").replace("{", "{{").replace("}", "}}") + "[{k}]")
    return LogEntry(path, fmt, payload, None if tcp is None else tuple(tcp),  # type: ignore[arg-type]
                    check_bool(item.get("hold_out", False), f"{w}hold_out"))


def _shown(value) -> str:
    """An option's value as the command line writes it (None: a nist or sim log's own payload)."""
    if value is None:
        return "the log's own"
    return " ".join(f"{v:g}" for v in value) if isinstance(value, (list, tuple)) else str(value)


def _same(a, b) -> bool:
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return a == b


def _unknown_key(key: object, keys: Sequence[str]) -> str:
    """``unknown key 'payload' (did you mean 'payload_kg'?) (keys: ...)``: a manifest's key as the YAML validators
    name one."""
    return f"unknown key {key!r}{did_you_mean(key, keys, n=2)} (keys: {', '.join(keys)})"


def _manifest(path: Path, args: argparse.Namespace, held: Sequence[str], used: set[str]) -> list[LogEntry]:
    """The logs of the manifest ``path``, then the command line's ``held`` (``--hold-out``; paths as given, each
    with the manifest's defaults); ``used`` collects the command-line options some log took."""
    data = read_yaml(path)
    # a YAML without 'logs' (a campaign's, given by mistake) is told what it was read as; a manifest needs no telling
    where = f"{path.name}: " + ("" if isinstance(data, dict) and "logs" in data else f"{READ_AS_MANIFEST}: ")
    bad = sorted(set(data) - set(MANIFEST_KEYS))
    if bad:
        raise ParameterError(f"{where}{_unknown_key(bad[0], MANIFEST_KEYS)}")
    logs = data.get("logs")
    if not isinstance(logs, list) or not logs:
        raise ParameterError(f"{where}'logs' must be a list of at least one log ({{path: FILE, ...}} or FILE)")
    out: list[LogEntry] = []
    top_used: set[str] = set()
    for k, item in enumerate(logs):
        item = {"path": item} if isinstance(item, str) else item
        w = f"{path.name}: logs[{k}]: "
        if not isinstance(item, dict) or "path" not in item:
            raise ParameterError(f"{w}a log is a file name or a mapping with 'path'")
        bad = sorted(set(item) - set(LOG_KEYS))
        if bad:
            raise ParameterError(f"{w}{_unknown_key(bad[0], LOG_KEYS)}")
        if Path(str(item["path"])).suffix.lower() in MANIFEST_SUFFIXES:  # it was read as a log: "missing column"
            raise ParameterError(f"{w}{item['path']}: a manifest cannot list another manifest; list that manifest's "
                                 "logs here, or give it alone")
        file = path.parent / str(item["path"])
        out.append(_entry(item, data, args, file, w, used, f"{path.name}: ", top_used))  # the options first: they
        # need no file
        if not file.exists():
            raise ParameterError(f"{w}{item['path']}: no such file (a log's path is read from the manifest's folder, "
                                 f"{path.parent.resolve()})")
    out += [_entry({"hold_out": True}, data, args, Path(p), f"--hold-out {p}: ", used, f"{path.name}: ", top_used)
            for p in held]
    _refuse_unused_defaults(path, data, out, top_used)
    return out


#: a manifest's defaults of its logs, and the attribute of a log entry each sets
MANIFEST_DEFAULTS = {"format": "fmt", "payload_kg": "payload_kg", "tcp_offset_m": "tcp_offset_m"}


def _refuse_unused_defaults(path: Path, data: dict, entries: Sequence[LogEntry], top_used: set[str]) -> None:
    """A default at the top of the manifest that no log takes, and that differs from what the logs state, is refused
    as the command line's is (:func:`log_entries`): it would be dropped without a word (a ``payload_kg`` over nist
    logs, which carry their own; one over rtde logs that each state theirs)."""
    for key, attr in MANIFEST_DEFAULTS.items():
        given = data.get(key)
        if given is None or key in top_used:  # absent, or null: no default (as the command line's None)
            continue
        given = given.strip().lower() if isinstance(given, str) else given
        stated = [getattr(e, attr) for e in entries]
        if all(_same(given, s) for s in stated):
            continue
        if key != "format" and not any(e.fmt == "rtde" for e in entries):
            why = (f"its logs are {', '.join(sorted({e.fmt for e in entries}))} logs, which carry their own payload "
                   "and tool offset (a manifest's top-level payload_kg and tcp_offset_m are defaults of rtde logs; "
                   "state payload_kg: unknown on a log to have its payload fitted)")
        else:
            why = f"every log states its own {key} ({', '.join(sorted({_shown(s) for s in stated}))})"
        raise ParameterError(f"{path.name}: {key} {_shown(given)} applies to no log: {why}; drop it or edit the logs")


def _resolve(args: argparse.Namespace) -> tuple[list[LogEntry], set[str], Path | None]:
    """(the logs the command line names, the command-line options they take, the manifest or None)."""
    paths = [args.log] if isinstance(args.log, str) else list(args.log)
    held = list(getattr(args, "hold_out", []) or [])
    held_manifests = [p for p in held if Path(p).suffix.lower() in MANIFEST_SUFFIXES]
    if held_manifests:  # it was read as a log: "missing column 'timestamp'"
        raise ParameterError(f"--hold-out {held_manifests[0]}: a manifest cannot be held out; mark its logs "
                             "'hold_out: true' in one manifest, or give --hold-out log files")
    manifests = [p for p in paths if Path(p).suffix.lower() in MANIFEST_SUFFIXES]
    if manifests and len(paths) > 1:
        raise ParameterError(f"{manifests[0]}: a manifest of logs must be the only log given (list the others in "
                             "it, or give log files only)")
    if manifests:
        _check_cli_values(args)
        used: set[str] = set()
        return _manifest(Path(paths[0]), args, held, used), used, Path(paths[0])
    if args.fmt is None:
        group = getattr(args, "log_group", None)  # a command's other logs (a baseline): named, they lack it
        raise ParameterError((f"{group} {' '.join(map(str, paths))}: no format: give --format (a manifest's format "
                              "is its own logs')") if group else
                             "--format is required (or a YAML manifest of logs that names it)")
    _check_payload_options(args.fmt, args.payload_kg, args.tcp_offset_m, "")
    _check_cli_values(args)
    entries = [LogEntry(Path(p), args.fmt, args.payload_kg, _tcp(args), False) for p in paths] + \
        [LogEntry(Path(p), args.fmt, args.payload_kg, _tcp(args), True) for p in held]
    return entries, {attr for attr, _, _ in CLI_DEFAULTS}, None


def _check_cli_values(args: argparse.Namespace) -> None:
    """The command line's payload and tool offset in range, refused naming the flag (the reader's own checks name
    the API's keyword, which the user never typed)."""
    check_payload_and_tool(None if args.payload_kg == UNKNOWN else args.payload_kg, args.tcp_offset_m,
                           "--payload-kg", "--tcp-offset-m (value {k})")


def log_entries(args: argparse.Namespace, *others: argparse.Namespace) -> list[LogEntry]:
    """The logs the command line names (files, or one manifest), and ``--hold-out``'s, in order. ``others``: the
    command's other groups of logs (a baseline), which share the command line's options. An option that no log of
    any group takes (a manifest states each log's own) and that differs from what they state is refused: it would
    be dropped without a word."""
    entries, used, manifest = _resolve(args)
    if manifest is None:
        return entries
    for other in others:
        used |= _resolve(other)[1]
    for attr, flag, key in CLI_DEFAULTS:
        given = getattr(args, attr)
        stated = [getattr(e, attr) for e in entries]
        if given is not None and attr not in used and not all(_same(given, s) for s in stated):
            raise ParameterError(f"{manifest.name}: {flag} {_shown(given)} applies to no log: the manifest states "
                                 f"each log's {key} ({', '.join(sorted({_shown(s) for s in stated}))}); drop {flag} "
                                 "or edit the manifest")
    return entries


def _tcp(args: argparse.Namespace):
    return None if args.tcp_offset_m is None else tuple(args.tcp_offset_m)


def refuse_hold_out(entries: Sequence[LogEntry], where: str) -> None:
    """A command that uses every log it is given (``where``: e.g. "a monitor baseline") refuses a manifest's
    ``hold_out``, which would otherwise be dropped without a word."""
    held = [e.path.name for e in entries if e.hold_out]
    if held:
        raise ParameterError(f"{held[0]}: hold_out has no meaning in {where} (every log is used); remove it from "
                             "the manifest")
