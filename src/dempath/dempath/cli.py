"""The ``dempath`` command: one offline entry point whose subcommands come from the packages.

Each package registers its subcommands in its ``setup.py`` under the entry-point group
``dempath.commands`` as ``name = module:function`` where ``function(argv: list[str]) -> int`` is a
small CLI in the house style: it validates its input, prints one ``error: <input>: <problem>`` line
and returns 1, or runs the core and returns 0.

``dempath --help`` lists the commands with the first line of each function's docstring, read from
the source with ``ast`` so that no command module (numba, torch, OpenCV, Dask...) is imported
until a command runs. Logging is configured here, once, for every command (``dempath.logconfig``:
``-v``/``--verbose`` anywhere, ``-q`` before the command).
"""

from __future__ import annotations

import ast
import importlib.util
import sys
from collections.abc import Callable, Sequence
from importlib.metadata import entry_points
from pathlib import Path

from dempath.errors import DempathError
from dempath.logconfig import PROGRESS_COMMANDS, configure_logging, split_verbosity
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


def module_source(module: str) -> Path | None:
    """The source file of ``module`` (``a.b.c``), found without importing ``a.b``.

    Only the top-level package's spec is looked up (its ``__init__`` is not run either); the
    rest of the dotted name is a path below it. None when there is no such .py file.
    """
    top, *rest = module.split('.')
    spec = importlib.util.find_spec(top)
    if spec is None or not spec.submodule_search_locations:
        return None
    for folder in spec.submodule_search_locations:
        base = Path(folder).joinpath(*rest)
        for path in (base.with_name(base.name + '.py'), base / '__init__.py'):
            if path.is_file():
                return path
    return None


def docstring_summary(target: str) -> str:
    """First line of the docstring of ``module:function``, read from the source with ``ast``
    (nothing of the command's package is imported); '' when there is none."""
    module, _, func = target.partition(':')
    source = module_source(module)
    if source is None:
        return ''
    tree = ast.parse(source.read_text(encoding='utf-8'), str(source))
    node = next((n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == func), None)
    doc = (ast.get_docstring(node) or '').strip() if node is not None else ''
    line = doc.splitlines()[0] if doc else ''
    return line.split('``: ', 1)[1] if line.startswith('``dempath') and '``: ' in line else line


def _summary(target: str) -> str:
    try:
        return docstring_summary(target)
    except (ImportError, OSError, SyntaxError, ValueError):
        return ''


def _usage(commands: dict[str, str]) -> str:
    lines = ['usage: dempath [-v | -q] COMMAND [ARGS...]', '', 'commands:']
    for name in sorted(commands):
        lines.append(f'  {name:<12} {_summary(commands[name])}')
    lines.append('')
    lines.append("Run 'dempath COMMAND --help' for the options of a command. -v/--verbose (before")
    lines.append('or after the command): more log lines (-v info, -vv debug); -q: warnings only.')
    return '\n'.join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """Dispatch ``dempath COMMAND ...`` to the package that registered COMMAND."""
    apply_ros_defaults()
    verbosity, args = split_verbosity(list(sys.argv[1:] if argv is None else argv))
    commands = available_commands()
    if not args or args[0] in {'-h', '--help'}:
        print(_usage(commands))
        return 0 if args else 2
    name, rest = args[0], args[1:]
    if name not in commands:
        print(f'error: {name}: unknown command; known: {", ".join(sorted(commands))}',
              file=sys.stderr)
        return 2
    configure_logging(verbosity, progress=name in PROGRESS_COMMANDS)
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
