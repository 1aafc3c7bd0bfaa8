"""Every command's ``--help`` ends with examples, and every example is a command line the parser takes.

The examples are what a newcomer copies first; an option renamed or misspelled there would fail in their shell.
Each line is split as a shell splits it, after the shipped-log substitutions ``"$(ur5fault data NAME)"`` are
replaced by the paths ``ur5fault data NAME`` prints (each NAME must be a shipped log)."""

from __future__ import annotations

import argparse
import re
import shlex

import pytest

from ur5fault.cli import COMMAND_GROUPS, build_parser
from ur5fault.errors import UnknownNameError
from ur5fault.logs.shipped import shipped_log

SHIPPED = re.compile(r'"\$\(ur5fault data ([^)]+)\)"')


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """Every (nested) subcommand's parser by its words, e.g. ``campaign run``."""
    out = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                nested = _subparsers(sub)
                if nested:
                    out.update({f"{name} {k}": v for k, v in nested.items()})
                else:
                    out[name] = sub
    return out


PARSER = build_parser()
COMMANDS = _subparsers(PARSER)


def _examples(parser: argparse.ArgumentParser) -> list[str]:
    epilog = parser.epilog or ""
    assert "examples:" in epilog, f"{parser.prog}: no examples in its help"
    lines = epilog.split("examples:", 1)[1].strip().splitlines()
    commands = []
    for line in lines:
        line = line.split("    #", 1)[0].strip()  # the comment after four spaces
        commands += [part.strip() for part in line.split("&&")]
    return commands


def _argv(line: str) -> list[str]:
    line = SHIPPED.sub(lambda m: shlex.quote(str(shipped_log(m.group(1))[0].path)), line)
    words = shlex.split(line)
    assert words[0] == "ur5fault", line
    return words[1:]


def test_every_command_is_covered():
    names = {name for commands in COMMAND_GROUPS.values() for name in commands}
    assert {c.split()[0] for c in COMMANDS} == names
    assert {"campaign run", "campaign status"} <= set(COMMANDS)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_examples_parse(command):
    parser = COMMANDS[command]
    lines = _examples(parser)
    assert any(line.startswith(f"ur5fault {command}") for line in lines), f"{command}: no example of itself"
    for line in lines:
        args = PARSER.parse_args(_argv(line))  # a misspelled option or value exits with status 2 here
        assert args.func is not None


def test_a_wrong_example_would_fail():
    """The check above can fail: an option the command does not take is refused by the same parse."""
    with pytest.raises(SystemExit):
        PARSER.parse_args(_argv('ur5fault identify "$(ur5fault data nist)" --formt nist --out x.yaml'))
    with pytest.raises(UnknownNameError):
        _argv('ur5fault identify "$(ur5fault data no_such_log)" --format nist --out x.yaml')


def test_a_shipped_campaign_run_in_an_example_carries_yes_where_it_needs_it():
    """Parsing cannot tell that `ur5fault campaign run prognostics` is refused without --yes (over 1000 runs): each
    example that runs a shipped campaign carries --yes exactly where `campaign run` would ask for it."""
    from ur5fault.campaign import load_campaign
    from ur5fault.campaign.limits import confirmation_needed, estimate
    from ur5fault.campaign.spec import shipped_campaigns
    from ur5fault.health.prognostics.spec import is_life_file, life_confirmation_needed, load_life

    seen = 0
    for parser in COMMANDS.values():
        for line in _examples(parser):
            argv = _argv(line)
            if argv[:2] != ["campaign", "run"] or argv[2] not in shipped_campaigns():
                continue
            name, jobs = argv[2], 2
            if is_life_file(name):
                why = life_confirmation_needed(load_life(name))
            else:
                why = confirmation_needed(load_campaign(name), estimate(load_campaign(name), jobs))
            assert ("--yes" in argv) == (why is not None), (line, why)
            seen += 1
    assert seen >= 5
