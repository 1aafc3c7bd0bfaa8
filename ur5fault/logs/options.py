"""The command line's options for a measured log, shared by ``ur5fault identify`` and ``ur5fault discrepancy``."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from .measured import MeasuredLog
from .readers import read_log


def add_log_options(parser: argparse.ArgumentParser, formats: Sequence[str]) -> None:
    """The log file, its ``--format`` (one of ``formats``) and what an RTDE file does not record."""
    parser.add_argument("log", help="measured log file")
    parser.add_argument("--format", required=True, choices=tuple(formats), dest="fmt",
                        help="layout of the log (required): rtde = UR RTDE CSV (actual_q_0.., actual_current_0.., "
                             "target_q_0..), nist = the NIST UR5 CSV, sim = a ur5fault time series (Parquet)")
    parser.add_argument("--payload-kg", type=float,
                        help="payload held during the log [kg] (rtde only; default 0; the other formats carry "
                             "their own)")
    parser.add_argument("--tcp-offset-m", type=float, nargs=3,
                        help="tool offset in the flange frame [m] (rtde only; default 0 0 0.15)")


def read_log_option(args: argparse.Namespace) -> MeasuredLog:
    """Read the log named by :func:`add_log_options`' options (payload and tool offset apply to RTDE only:
    the other formats carry their own)."""
    kwargs = {}
    if args.fmt == "rtde":
        if args.payload_kg is not None:
            kwargs["payload_kg"] = args.payload_kg
        if args.tcp_offset_m is not None:
            kwargs["tcp_offset_m"] = tuple(args.tcp_offset_m)
    return read_log(args.log, args.fmt, **kwargs)
