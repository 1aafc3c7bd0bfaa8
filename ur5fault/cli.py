"""Command line: ``ur5fault simulate | effects | data | show | campaign | plot | discrepancy | identify | benchmark |
diagnose | prognose | monitor``: the parser, its one-line errors and ``main``; each command group registers its
own subcommands (``run_cli.py``: simulate, effects, data, show; ``campaign/cli.py``, ``discrepancy/cli.py``, ... ).

Bad input prints one line ``ur5fault: error: ...`` naming the problem and the valid
choices, and exits with status 2; never a traceback.  ``-v`` (before or after the
subcommand) shows the library's ``logging`` messages at INFO, ``-vv`` at DEBUG;
``--quiet`` switches the progress off (a bar on a terminal, plain lines in a log: util/progress.py).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import signal
import sys
from collections.abc import Sequence

from .errors import Ur5FaultError
from .util.usage import EXIT_USAGE


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        # on every (sub)parser, so `ur5fault -v simulate` and `ur5fault simulate -v` both work; SUPPRESS keeps a
        # subcommand's parser from resetting a count given before the subcommand
        self.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                          help="log what the library does (-v: INFO, -vv: DEBUG)")

    def parse_known_args(self, args=None, namespace=None):
        # every option, those of argument groups too (a group adds its actions past add_argument): a second --out,
        # --seed, --baseline-logs ... would silently win
        for action in self._actions:
            if action.option_strings and not isinstance(action, _REPEATABLE) and not getattr(action, "once", False):
                action.__class__ = _once(type(action))
        self._given: dict[str, str] = {}  # dest -> the option string that set it, in this parse
        namespace, extras = super().parse_known_args(args, namespace)
        for action in self._actions:  # an empty path or name ('--out ""') would be read as the current folder
            value = getattr(namespace, action.dest, None) if action.dest != argparse.SUPPRESS else None
            if value == "" or (isinstance(value, list) and "" in value):
                name = "/".join(action.option_strings) or action.metavar or action.dest
                self.error(f"{name}: an empty value; give a path or a value")
        return namespace, extras

    def error(self, message: str):  # one line, exit 2
        self.exit(EXIT_USAGE, f"ur5fault: error: {message}\n")


#: actions meant to be given several times (--backlash, --effect, -v), flags that take no value (--quiet twice
#: loses nothing) and those that end the parse (--help, --version)
_REPEATABLE = (argparse._AppendAction, argparse._CountAction, argparse._StoreConstAction, argparse._HelpAction,
               argparse._VersionAction)


@functools.cache
def _once(cls: type) -> type:
    """``cls`` refusing a second use of its option in one command line (argparse keeps the last value silently);
    one such class per action class, not one per option."""

    class Once(cls):  # type: ignore[valid-type, misc]
        once = True

        def __call__(self, parser, namespace, values, option_string=None):
            given = getattr(parser, "_given", None)
            if given is not None:
                if self.dest in given:  # an abbreviation (--dur) arrives as the full option string
                    parser.error(f"{option_string} given twice; give it once")
                given[self.dest] = option_string
            super().__call__(parser, namespace, values, option_string)

    Once.__name__ = Once.__qualname__ = f"Once{cls.__name__}"
    return Once


def _version() -> str:
    from importlib.metadata import version

    from . import __version__

    deps = ", ".join(f"{name} {version(name)}" for name in ("mujoco", "numpy"))
    return f"ur5fault {__version__} ({deps}, python {sys.version.split()[0]})"


def configure_logging(verbosity: int) -> None:
    """Send the ``ur5fault`` loggers' records to stderr: WARNING by default, INFO at ``-v``, DEBUG at ``-vv``."""
    import logging  # here, not at the top: imported before main(), a Ctrl-C in it would print a traceback

    logger = logging.getLogger("ur5fault")
    logger.setLevel(logging.WARNING if verbosity <= 0 else logging.INFO if verbosity == 1 else logging.DEBUG)
    if not any(getattr(h, "_ur5fault_cli", False) for h in logger.handlers):
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("ur5fault: %(levelname)s: %(name)s: %(message)s"))
        handler._ur5fault_cli = True  # type: ignore[attr-defined]
        logger.addHandler(handler)


#: each command group's module and the commands it registers with their one-line summaries (the ``help`` its
#: ``register`` gives them), in the order ``ur5fault --help`` lists them. A command line imports the module of its
#: command alone: all of them took 2-3 s (scipy, scikit-learn, the simulator), more than ``ur5fault --version``,
#: ``ur5fault --help`` or ``ur5fault effects`` should wait; the top-level help lists these summaries (a test holds
#: them equal to the modules')
COMMAND_GROUPS: dict[str, dict[str, str]] = {
    ".run_cli": {
        "simulate": "run one configuration and write its time series to Parquet or CSV",
        "effects": "list the effect registry",
        "data": "the real UR5 logs shipped with ur5fault (NIST CB3, Kufieta CB2): names, formats, paths",
        "show": "draw one run: setpoint vs resolver, encoder mismatch, currents, TCP deviation",
    },
    ".campaign.cli": {
        "campaign": "run a YAML fault campaign into Parquet feature tables",
        "plot": "draw the paper's backlash figures and a severity figure per swept effect (PNG)",
    },
    ".discrepancy.cli": {"discrepancy": "find, name and fix where the model and a measured log disagree"},
    ".identify.cli": {"identify": "re-derive the measured drive parameters from a log (parameter overlay)"},
    ".health.diagnostics.cli": {
        "benchmark": "train baseline classifiers on a campaign's train split, report on its test split (needs "
                     "scikit-learn and skops: pip install 'scikit-learn>=1.3' 'skops>=0.10', or the wheel's [ml] "
                     "extra)",
    },
    ".health.diagnosis.cli": {
        "diagnose": "score a measured log with the classifiers `ur5fault benchmark` saved: p(fault) per window and "
                    "joint, likeliest kinds and sizes",
    },
    ".health.prognostics.cli": {
        "prognose": "benchmark remaining-useful-life estimators on a life campaign's held-out units (report.md, "
                    "metrics.json, figures)",
    },
    ".health.monitoring.cli": {
        "monitor": "compare new logs of a robot with its fitted baseline: consistent, changed or anomaly",
    },
}

#: options of ``ur5fault`` itself that may stand before the command, spelled out (none takes a value)
_LEADING = ("--verbose", "--version")
#: options that end the parse with the top-level help, before any command is looked at
_HELP = ("-h", "--help")


def build_parser(groups: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser of ``ur5fault`` with the commands of ``groups`` (keys of :data:`COMMAND_GROUPS`; default: all).

    With no group (``ur5fault --help``, ``--version``, no command), every command is named by its summary in
    :data:`COMMAND_GROUPS` alone, on a parser that takes nothing: the top-level help is the one of all groups, and
    no command's module is imported."""
    p = _Parser(prog="ur5fault", description="UR5 fault-injection simulator")
    p.add_argument("--version", action="version", version=_version())
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    p.set_defaults(func=_usage(p))
    if groups is not None and not groups:
        for commands in COMMAND_GROUPS.values():
            for name, summary in commands.items():
                sub.add_parser(name, help=summary)
        return p
    for group in COMMAND_GROUPS if groups is None else groups:
        # imported directly: a broken module is an error, not a silently missing command
        importlib.import_module(group, __package__).register(sub)
    return p


def groups_needed(argv: Sequence[str]) -> tuple[str, ...]:
    """The command groups the command line ``argv`` needs: its command's alone; none for ``--version``, for
    ``--help``/``-h`` before any command and for no command at all (the top-level help, :func:`build_parser` makes
    from the summaries); every group when the command is not plain (a misspelled command, an abbreviated option
    before it), so that argparse answers as it does with all of them."""
    for arg in argv:
        if arg == "--version" or arg in _HELP:  # end the parse before any command is looked at
            return ()
        if arg in _LEADING or (arg.startswith("-v") and set(arg[1:]) == {"v"}):
            continue
        return tuple(group for group, commands in COMMAND_GROUPS.items() if arg in commands) or tuple(COMMAND_GROUPS)
    return ()


def _one_line(message: str) -> int:
    sys.stderr.write(f"ur5fault: error: {' '.join(message.split())}\n")
    return EXIT_USAGE


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that Python's own flush at exit raises no second BrokenPipeError."""
    import os

    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError):
        pass


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived: unwind like Ctrl-C (locks released, workers stopped, temporary files removed)."""


#: how long an executor thread's exception waits for the command's stop before it is printed [s]: a SIGTERM sent to
#: the process group reaches the workers too, and loky's thread may see them die before the main thread has run its
#: signal handler (a few ms; 1 s is far beyond it)
STOP_GRACE_S = 1.0


def quiet_when_stopping(previous, stopping, grace_s: float = STOP_GRACE_S):
    """A ``threading.excepthook`` that drops the exceptions of loky's executor manager thread once the command is
    stopped (``stopping``, a ``threading.Event`` the SIGTERM / Ctrl-C handlers set): while its workers are shut
    down it may raise (a ``KeyError`` of a task it no longer tracks) and print a thread traceback after the
    one-line message. Shutdown noise: the lock is released and the workers stopped. Any other exception, and one of
    that thread while the command runs, goes to ``previous`` (after ``grace_s``, the stop may be on its way)."""

    def quiet_hook(args) -> None:
        manager = args.thread is not None and args.thread.name.startswith("ExecutorManagerThread")
        if not (manager and stopping.wait(grace_s)):
            previous(args)

    return quiet_hook


def _usage(parser: argparse.ArgumentParser):
    """The action of a command group given without its subcommand (:func:`.util.usage.missing_command`)."""
    from .util.usage import missing_command

    def show(args: argparse.Namespace) -> int:
        return missing_command(parser)

    return show


def main(argv: Sequence[str] | None = None) -> int:
    try:  # from the first line: a stop while the handlers are set up, or the parser built, is the same one line
        return _run(argv)
    except Terminated:
        sys.stderr.write("ur5fault: terminated\n")
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        sys.stderr.write("ur5fault: interrupted\n")
        return 130


def _run(argv: Sequence[str] | None) -> int:
    """The command of ``argv``, its errors one line, under handlers that turn SIGTERM and Ctrl-C into exceptions
    (:func:`main` prints them)."""
    import threading

    stopping = threading.Event()  # set by the handlers below: the executor's thread is then quiet

    def on_sigterm(signum, frame) -> None:
        stopping.set()
        raise Terminated()

    def on_sigint(signum, frame) -> None:  # Python's own Ctrl-C, and the executor's thread quiet
        stopping.set()
        raise KeyboardInterrupt()

    hook = threading.excepthook  # restored when main() returns (main() called in a notebook) unless it was stopped
    previous = previous_int = None
    try:  # everything set up inside it: a stop arriving while the hook and handlers are installed undoes them too
        threading.excepthook = quiet_when_stopping(hook, stopping)
        try:
            previous = signal.signal(signal.SIGTERM, on_sigterm)
            # an ignored SIGINT (a job started in the background) stays ignored
            previous_int = (signal.signal(signal.SIGINT, on_sigint)
                            if signal.getsignal(signal.SIGINT) is signal.default_int_handler else None)
        except ValueError:  # not the main thread: leave signals alone
            pass
        given = sys.argv[1:] if argv is None else argv
        args = build_parser(groups_needed(given)).parse_args(given)
        configure_logging(getattr(args, "verbose", 0))
        return int(args.func(args) or 0)
    except Ur5FaultError as exc:
        return _one_line(str(exc))
    except BrokenPipeError:  # `ur5fault campaign status DIR | head`: the reader left, nothing is wrong
        _silence_stdout()
        return 128 + signal.SIGPIPE
    except Exception as exc:
        if type(exc).__name__ != "TerminatedWorkerError":  # joblib's: a worker process was killed
            raise
        return _one_line("a worker process died (killed, or out of memory); every result written before it is "
                         "kept: run the same command again to continue")
    finally:
        if not stopping.is_set():  # stopped: loky's thread may raise after main() returns, while the pool winds down
            threading.excepthook = hook
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if previous_int is not None:
            signal.signal(signal.SIGINT, previous_int)


if __name__ == "__main__":
    sys.exit(main())
