"""The ``dempath`` command: one offline entry point whose subcommands come from the packages.

Each package registers its subcommands in its ``setup.py`` under the entry-point group
``dempath.commands`` as ``name = module:function`` where ``function(argv: list[str]) -> int`` is a
small CLI in the house style: it validates its input, prints one ``error: <input>: <problem>`` line
and returns 1, or runs the core and returns 0.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from importlib.metadata import entry_points

from dempath.errors import DempathError
from dempath.rosenv import apply_ros_defaults

ENTRY_POINT_GROUP = 'dempath.commands'
Command = Callable[[list[str]], int]


def available_commands() -> dict[str, str]:
    """Map each registered subcommand to the ``module:function`` that implements it."""
    return {ep.name: ep.value for ep in entry_points(group=ENTRY_POINT_GROUP)}


def _load(name: str) -> Command:
    (ep,) = [ep for ep in entry_points(group=ENTRY_POINT_GROUP) if ep.name == name]
    command: Command = ep.load()
    return command


def _summary(name: str) -> str:
    """First line of the command function's docstring (what the command does)."""
    doc = (_load(name).__doc__ or '').strip()
    line = doc.splitlines()[0] if doc else ''
    return line.split('``: ', 1)[1] if line.startswith('``dempath') and '``: ' in line else line


def _usage(commands: dict[str, str]) -> str:
    lines = ['usage: dempath COMMAND [ARGS...]', '', 'commands:']
    for name in sorted(commands):
        lines.append(f'  {name:<12} {_summary(name)}')
    lines.append('')
    lines.append("Run 'dempath COMMAND --help' for the options of a command.")
    return '\n'.join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Dispatch ``dempath COMMAND ...`` to the package that registered COMMAND."""
    apply_ros_defaults()
    args = list(sys.argv[1:] if argv is None else argv)
    commands = available_commands()
    if not args or args[0] in {'-h', '--help'}:
        print(_usage(commands))
        return 0 if args else 2
    name, rest = args[0], args[1:]
    if name not in commands:
        print(f'error: {name}: unknown command; known: {", ".join(sorted(commands))}',
              file=sys.stderr)
        return 2
    try:
        return _load(name)(rest)
    except DempathError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print('interrupted', file=sys.stderr)
        return 130


if __name__ == '__main__':
    sys.exit(main())
