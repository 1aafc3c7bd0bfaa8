"""The logs an option set names (:func:`.options.log_entries`) read and checked: each under its name among the
group's files, a payload that is unknown returned as such where the command fits it and refused in one line where
it does not (before any log is read when the options alone say so)."""

from __future__ import annotations

import argparse
import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path

from ..errors import LogFormatError, ParameterError
from .measured import UNKNOWN_PAYLOAD, MeasuredLog
from .options import LogEntry, log_entries
from .plausible import MinLength
from .readers import check_log_file, read_log
from .same_samples import refuse_same_samples
from .source import PARQUET_HINT


def refuse_unknown_payload(entries: Sequence[LogEntry]) -> None:
    """For a command that does not fit a payload: :func:`read_entry`'s refusals of a log whose payload is unknown, or
    (an rtde log's, which the file does not carry) stated without its position, said from the options alone, before
    any log is read or model loaded (they came after seconds of work). A log that would be refused so and is no file
    is said to be none instead (a newcomer's misspelt log was told to state its payload); other missing logs are
    the readers' to say, after the commands' checks of their output folder."""
    for e in entries:
        unknown = e.payload_unknown
        if not (unknown or (e.fmt == "rtde" and e.tcp_offset_m is None)):
            continue
        check_log_file(e.path)
        raise ParameterError(_unknown_payload(str(e.path)) if unknown else _no_position(str(e.path),
                                                                                        allow_unknown=False))


def _unknown_payload(src: str) -> str:
    return (f"{src}: payload unknown (no --payload-kg nor a manifest's payload_kg, or either given as unknown): "
            f"{UNKNOWN_PAYLOAD}")


def _no_position(src: str, allow_unknown: bool) -> str:
    """A stated payload without its position; the alternative of an unknown payload only where the command fits
    one."""
    return (f"{src}: --tcp-offset-m missing (a manifest's tcp_offset_m): a stated payload needs its position (0 0 0 "
            "for a bare flange)" + (", or give --payload-kg unknown to fit both" if allow_unknown else ""))


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
        raise ParameterError(_no_position(log.source, allow_unknown))
    if not log.payload_known and not allow_unknown:
        raise ParameterError(_unknown_payload(log.source))
    return log


def names_of(paths: Sequence[Path]) -> dict[Path, str]:
    """Each log's name: its file name, or where files of one name lie in several folders, as many of its last
    folders as tell them apart (``day1/robot.csv.gz``, ``day2/robot.csv.gz``): recorders often write one file name
    per session folder."""
    full = {p: Path(os.path.abspath(p)).parts[1:] for p in paths}  # as given: a link keeps its own name
    distinct = set(full.values())  # one file given twice (or by two spellings) is one name
    out = {}
    for p, parts in full.items():
        k = 1
        while k < len(parts) and sum(q[-k:] == parts[-k:] for q in distinct) > 1:
            k += 1
        out[p] = "/".join(parts[-k:])
    return out


def _named(log: MeasuredLog, name: str) -> MeasuredLog:
    """``log`` named ``name`` (its notes too), where its file name alone is not its name (:func:`names_of`)."""
    if name == log.source:
        return log
    notes = tuple(name + n[len(log.source):] if n.startswith(log.source + ":") else n for n in log.notes)
    return dataclasses.replace(log, source=name, notes=notes)


def _read_named(e: LogEntry, name: str, allow_unknown: bool, length: MinLength | None) -> MeasuredLog:
    """:func:`read_entry`, its refusal naming the log by ``name`` (:func:`names_of`), not its bare file name."""
    try:
        return read_entry(e, length, allow_unknown=allow_unknown)
    except (ParameterError, LogFormatError) as exc:  # messages that start with the file's name
        text = str(exc)
        if name == e.path.name or not text.startswith(e.path.name):
            raise
        raise type(exc)(name + text[len(e.path.name):]) from None


def read_log_options(args: argparse.Namespace, *, allow_unknown: bool = False,
                     others: Sequence[argparse.Namespace] = (), role: str = "fitted",
                     length: MinLength | None = None) -> tuple[list[MeasuredLog], list[MeasuredLog]]:
    """The logs to fit and the logs held out whole, read and checked; ``allow_unknown``: logs whose payload is
    unknown are returned as such (:func:`read_entry`), for a caller that fits it; ``others``: as
    :func:`log_entries`'s; ``length``: as :func:`read_entry`'s (default what fitting needs). The logs are named
    among this group's files (:func:`names_of`). One recording given twice (under two names, or ``role`` and held
    out) is refused (:func:`refuse_same_samples`)."""
    entries = log_entries(args, *others)
    names = names_of([e.path for e in entries])  # among this group's files: a log's name is the same whatever else
    try:
        logs = [(_named(_read_named(e, names[e.path], allow_unknown, length), names[e.path]), e.hold_out)
                for e in entries]
    except LogFormatError as exc:  # a simulated run given to a command that reads none: not "--format sim"
        formats = getattr(args, "log_formats", ("sim",))
        if PARQUET_HINT not in str(exc) or "sim" in formats:
            raise
        raise LogFormatError(str(exc).replace(PARQUET_HINT, (
            f"; a Parquet file, a run of `ur5fault simulate`: this command reads {' and '.join(formats)} logs, not "
            "simulated runs (`ur5fault discrepancy` reads one with --format sim)"))) from None
    fitted, held = [g for g, h in logs if not h], [g for g, h in logs if h]
    refuse_same_samples([(role, fitted), ("held out", held)])
    return fitted, held
