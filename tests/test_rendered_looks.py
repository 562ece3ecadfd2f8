"""The bench's rendered-look specs (``bench/looks/*.txt``, ``bench/rendered_looks.py``): every
shipped look parses with the renderer's own command line, and a bad spec is refused by name."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from dempath_twin.render.bag import _parser

BENCH = Path(__file__).resolve().parents[1] / 'bench'
sys.path.insert(0, str(BENCH))
from rendered_looks import SCENE, read_spec  # noqa: E402


@pytest.mark.parametrize('spec', sorted((BENCH / 'looks').glob('*.txt')), ids=lambda p: p.stem)
def test_shipped_specs_parse_with_the_renderer(spec: Path) -> None:
    looks = read_spec(spec)
    assert len({look.name for look in looks}) == len(looks) >= 10
    for look in looks:
        args = _parser().parse_args([SCENE, '--out', f'/tmp/{look.name}', *look.args])
        assert args.hidden_seed is not None  # every look is an independent packing


def test_held_out_looks_share_no_seed_with_tuned_ones() -> None:
    seeds = {}
    for spec in (BENCH / 'looks').glob('*.txt'):
        looks = read_spec(spec)
        seeds[spec.stem] = {_parser().parse_args([SCENE, '--out', '/tmp/x', *look.args])
                            .hidden_seed for look in looks}
    held = set().union(*(s for k, s in seeds.items() if k.startswith('held')))
    assert held and not held & seeds['burnt']


@pytest.mark.parametrize(('text', 'says'), [
    ('A_asis\n', 'has no render arguments'),
    ('A_asis --hidden-seed 1 --out /tmp/a\n', 'sets --out'),
    ('A_asis --hidden-seed 1\nA_asis --hidden-seed 2\n', 'listed twice'),
    ('# nothing\n\n', 'no look listed'),
])
def test_bad_spec_is_refused_by_name(tmp_path: Path, text: str, says: str) -> None:
    spec = tmp_path / 'bad.txt'
    spec.write_text(text)
    with pytest.raises(ValueError, match=says) as err:
        read_spec(spec)
    assert str(spec) in str(err.value)
