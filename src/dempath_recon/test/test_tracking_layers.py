"""The tracking room's modules import only the ones below them (its __init__ gives the order),
so no import circle can form inside it (``stereo_track`` <-> ``trajectories`` was one)."""

from __future__ import annotations

import ast
from pathlib import Path

import dempath_recon.tracking

ROOM = Path(dempath_recon.tracking.__file__).parent
# Bottom to top: a module may import the modules before it, never one after it.
ORDER = ('merge', 'centroid_kernel', 'cut_discs_kernel', 'cut_discs', 'split', 'covered',
         'seen_flux', 'streak', 'band_pass', 'contrast_faint', 'colour_model', 'shaded',
         'detect', 'shake',
         'linker', 'two_view_kernel', 'associate', 'speed_bound', 'grid_pairs', 'pair_anchor',
         'half_ghost',
         'records', 'release',
         'publish_gate', 'trajectories', 'whole_pass', 'joint_fill', 'piece_numbering',
         'bed_field', 'bed_numbering',
         'pass_audit', 'carried_numbers', 'touching_exchange',
         'path_smoother',
         'number_record', 'state',
         'held_line',
         'link_guide', 'crowded_pair', 'merge_release', 'track_split', 'parted', 'one_camera',
         'ray_rivals',
         'numbering',
         'pair_checks', 'pair_numbering', 'track_pairs', 'line_rival',
         'grid_elimination', 'regain', 'coming_out', 'stereo')


def imported_modules(path: Path) -> set[str]:
    """Dotted names of the modules a file imports (any depth, lazy imports included;
    ``from dempath_recon.tracking import x`` counts as ``dempath_recon.tracking.x``)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.module == 'dempath_recon.tracking':
            out |= {f'dempath_recon.tracking.{a.name}' for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
    return out


def imported_tracking_modules(path: Path) -> set[str]:
    """The tracking modules (names inside the room) a file imports."""
    prefix = 'dempath_recon.tracking.'
    return {m.removeprefix(prefix).split('.')[0] for m in imported_modules(path)
            if m.startswith(prefix)}


def test_every_module_of_the_room_has_a_place() -> None:
    """A new module is placed in the order before it lands."""
    assert {p.stem for p in ROOM.glob('*.py')} - {'__init__'} == set(ORDER)


def test_no_module_imports_a_higher_one() -> None:
    """detect < linker < ... < stereo: none reaches up (imports read with ast)."""
    wrong = []
    for level, name in enumerate(ORDER):
        higher = imported_tracking_modules(ROOM / f'{name}.py') & set(ORDER[level + 1:])
        wrong += [f'{name} imports {sorted(higher)}'] if higher else []
    assert not wrong, wrong


def test_the_room_imports_nothing_that_uses_it() -> None:
    """Tracking stands below recon's stream, nodes and CLI: it imports none of them."""
    above = ('dempath_recon.stream', 'dempath_recon.nodes', 'dempath_recon.cli')
    wrong = {p.name: sorted(m for m in imported_modules(p) if m.startswith(above))
             for p in ROOM.glob('*.py')}
    assert not {k: v for k, v in wrong.items() if v}, wrong

