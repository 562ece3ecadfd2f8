"""dempath's message types for reading and writing bags without ROS: a rosbags typestore.

The store is rosbags' ROS 2 Jazzy store plus every ``dempath_msgs`` type parsed from its ``.msg``
text (installed under ``sys.prefix/share/dempath_msgs/msg`` or an ``AMENT_PREFIX_PATH`` prefix,
else the source tree). A type the store lacks is registered from an installed ``.msg`` file with
its dependencies, and its full ros2msg text (what Foxglove reads) is generated for MCAP schemas.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

from rosbags.typesys import Stores, TypesysError, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from dempath.errors import BagError

MSG_PACKAGE = 'dempath_msgs'
SOURCE_MSG_DIR = Path(__file__).resolve().parents[2] / MSG_PACKAGE / 'msg'
PRIMITIVES = frozenset(
    ['bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16', 'int32',
     'uint32', 'int64', 'uint64', 'string', 'wstring'])


def share_dirs() -> list[Path]:
    """Install prefixes' ``share`` folders: this interpreter's, then ``AMENT_PREFIX_PATH``."""
    prefixes = [sys.prefix, *os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)]
    return [Path(p) / 'share' for p in dict.fromkeys(prefixes) if p]


def find_msg_file(msgtype: str) -> Path | None:
    """The ``.msg`` file defining ``pkg/msg/Name`` in an install prefix (or dempath's sources)."""
    parts = msgtype.split('/')
    if len(parts) != 3 or not all(parts):
        return None
    pkg, _, name = parts
    dirs = [d / pkg / 'msg' for d in share_dirs()]
    if pkg == MSG_PACKAGE:
        dirs.append(SOURCE_MSG_DIR)
    return next((d / f'{name}.msg' for d in dirs if (d / f'{name}.msg').is_file()), None)


def dempath_msg_dir() -> Path:
    """The folder holding the ``dempath_msgs`` .msg files (installed copy first)."""
    for folder in [d / MSG_PACKAGE / 'msg' for d in share_dirs()] + [SOURCE_MSG_DIR]:
        if any(folder.glob('*.msg')):
            return folder
    msg = f'{SOURCE_MSG_DIR}: no dempath_msgs .msg files found (nor under {sys.prefix}/share)'
    raise BagError(msg)


def make_typestore() -> Typestore:
    """A fresh ROS 2 Jazzy typestore with every dempath_msgs type registered from its .msg text."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    for path in sorted(dempath_msg_dir().glob('*.msg')):
        types.update(get_types_from_msg(path.read_text(), f'{MSG_PACKAGE}/msg/{path.stem}'))
    store.register(types)
    return store


def _dependencies(text: str, pkg: str) -> set[str]:
    """Message types a .msg text refers to, as ``pkg/msg/Name``."""
    deps = set()
    for line in text.splitlines():
        words = line.split('#', 1)[0].split()
        if len(words) < 2 or '=' in words[1] or '=' in words[0]:
            continue
        base = words[0].split('[', 1)[0].split('<=', 1)[0]
        if base in PRIMITIVES or base.startswith(('string<', 'wstring<')):
            continue
        if base == 'Header':
            deps.add('std_msgs/msg/Header')
        elif '/' in base:
            dep_pkg, dep_name = base.split('/')[0], base.split('/')[-1]
            deps.add(f'{dep_pkg}/msg/{dep_name}')
        else:
            deps.add(f'{pkg}/msg/{base}')
    return deps


def ensure_type(store: Typestore, msgtype: str) -> bool:
    """Register ``msgtype`` and its dependencies from installed .msg files if the store lacks it.

    Returns:
        Whether the store knows the type afterwards.
    """
    if msgtype in store.fielddefs:
        return True
    path = find_msg_file(msgtype)
    if path is None:
        return False
    text = path.read_text()
    known = all(ensure_type(store, dep) for dep in _dependencies(text, msgtype.split('/')[0]))
    store.register(get_types_from_msg(text, msgtype))
    return known


def message_definition(store: Typestore, msgtype: str) -> str:
    """The full ros2msg text of ``msgtype`` with its dependencies (what Foxglove reads), or ''."""
    if not ensure_type(store, msgtype):
        return ''
    try:
        text, _ = store.generate_msgdef(msgtype, ros_version=2)
    except (KeyError, TypesysError):
        return ''
    return text
