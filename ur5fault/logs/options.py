"""The command line's options for a measured log, shared by ``ur5fault identify`` and ``ur5fault discrepancy``."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from ..errors import ParameterError
from .measured import UNKNOWN_PAYLOAD, MeasuredLog
from .readers import read_log


def add_log_options(parser: argparse.ArgumentParser, formats: Sequence[str]) -> None:
    """The log file, its ``--format`` (one of ``formats``) and what an RTDE file does not record."""
    parser.add_argument("log", help="measured log file")
    parser.add_argument("--format", required=True, choices=tuple(formats), dest="fmt")
    parser.add_argument("--payload-kg", type=float,
                        help="payload held during the log [kg] (rtde: required, 0 for none; other formats carry "
                             "their own)")
    parser.add_argument("--tcp-offset-m", type=float, nargs=3,
                        help="tool offset (payload position) in the flange frame [m] (rtde: required, 0 0 0 for the "
                             "flange; other formats carry their own)")


def read_log_option(args: argparse.Namespace) -> MeasuredLog:
    """Read the log named by :func:`add_log_options`' options. ``--payload-kg`` / ``--tcp-offset-m`` apply to
    RTDE only (the other formats carry their own; given with them, refused); an RTDE log without them has an
    unknown payload / tool offset, refused with one line (after the file's own checks)."""
    if args.fmt != "rtde":
        for flag, value in (("--payload-kg", args.payload_kg), ("--tcp-offset-m", args.tcp_offset_m)):
            if value is not None:
                raise ParameterError(f"{flag} applies to --format rtde only: a {args.fmt} log carries its own "
                                     "payload and tool offset")
    log = read_log(args.log, args.fmt, payload_kg=args.payload_kg,
                   tcp_offset_m=None if args.tcp_offset_m is None else tuple(args.tcp_offset_m))
    if not log.payload_known:  # the file's own problems are named first
        flag = "--payload-kg" if args.payload_kg is None else "--tcp-offset-m"
        raise ParameterError(f"{log.source}: {flag} missing: {UNKNOWN_PAYLOAD}")
    return log
