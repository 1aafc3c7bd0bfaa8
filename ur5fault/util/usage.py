"""A command group given without its subcommand (``ur5fault``, ``ur5fault campaign``): its help, then one error line
naming the commands it takes, exit status 2 - as every other usage error."""

from __future__ import annotations

import argparse
import sys

#: the exit status of a usage error (argparse's)
EXIT_USAGE = 2


def missing_command(parser: argparse.ArgumentParser) -> int:
    """Print ``parser``'s help and ``ur5fault: error: PROG: name a command (...)`` on stderr; return 2."""
    parser.print_help(sys.stderr)
    names = next((list(a.choices) for a in parser._actions if isinstance(a, argparse._SubParsersAction)), [])
    group = parser.prog.removeprefix("ur5fault").strip()
    print("ur5fault: error: " + (f"{group}: " if group else "") + "name a command"
          + (f" ({', '.join(names)})" if names else ""), file=sys.stderr)
    return EXIT_USAGE


__all__ = ["EXIT_USAGE", "missing_command"]
