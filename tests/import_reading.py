"""The modules a Python file imports, read with ``ast`` (lazy imports inside functions too).

Shared by the layout tests (floors, rooms) and the ROS packaging tests (declared dependencies),
which each ask a different question of the same list.
"""

from __future__ import annotations

import ast
from pathlib import Path


def imported_names(path: Path) -> set[str]:
    """Dotted names a file imports absolutely: ``import a.b`` gives ``a.b``; ``from a.b import
    c`` gives ``a.b`` and ``a.b.c`` (``c`` may be a module or a name inside ``a.b``)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found |= {node.module} | {f'{node.module}.{a.name}' for a in node.names}
    return found
