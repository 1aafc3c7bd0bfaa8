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


#: the options that read a shipped Kufieta run (``ur5fault data`` lists them), its payload stated as 0 kg
KUFIETA = "--format rtde --payload-kg 0 --tcp-offset-m 0 0 0"


def shipped(name: str) -> str:
    """A shipped log's path as a shell finds it: ``"$(ur5fault data NAME)"``."""
    return f'"$(ur5fault data {name})"'


#: two runs of the shipped Kufieta robot, a baseline or a joint fit in the examples
KUFIETA_RUNS = f"{shipped('kufieta/Movement_No3_Acc')} {shipped('kufieta/Movement_No4_Acc')}"


def examples(*lines: str, before: str = "") -> dict:
    """``add_parser`` keywords giving a command's help an ``examples:`` section of command lines, kept as written
    (``before``: an epilog they follow).  Every line runs as shown from an empty folder with the wheel installed
    (the shipped logs through ``"$(ur5fault data NAME)"``); ``tests/test_cli_examples.py`` parses each."""
    text = "examples:\n" + "\n".join(f"  {line}" for line in lines)
    return {"epilog": f"{before.rstrip()}\n\n{text}" if before else text,
            "formatter_class": argparse.RawDescriptionHelpFormatter}


__all__ = ["EXIT_USAGE", "KUFIETA", "KUFIETA_RUNS", "examples", "missing_command", "shipped"]
