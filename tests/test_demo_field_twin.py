"""The demo's field recordings hide an effect that the shipped library names.

The demo's story (the error falling after the recalibration) rests on its data: the hidden
setting of ``bags/field_twin_reduced_1ms`` and ``bags/field_render_reduced_1ms`` (one run, read
from their truth files) must stand out of the reduced scene's chaos. ``dempath diagnose`` with
the shipped ``reduced_1ms`` library (packed: no simulation runs) on the twin's true marker paths
must name that effect, and fit its strength within two of its standard deviations of the hidden
one. The two recordings must come from the same run, so the clicked and the rendered demo agree.
"""

from __future__ import annotations

import json
from pathlib import Path

from dempath_bringup.analysis import shipped_library
from dempath_diagnose.cli import diagnose_main

ROOT = Path(__file__).resolve().parents[1]
BAGS = ROOT / 'bags'
TWIN = json.loads((BAGS / 'field_twin_reduced_1ms.truth.json').read_text())
RENDER = json.loads((BAGS / 'field_render_reduced_1ms.truth.json').read_text())


def test_both_recordings_are_one_run() -> None:
    """The rendered and the clicked recording come from the same hidden run."""
    assert RENDER['run']['run_id'] == TWIN['run_id']
    assert RENDER['run']['seed'] == TWIN['hidden']['packing_seed']
    assert RENDER['run']['effects'] == TWIN['hidden']['effects']


def test_shipped_library_names_the_hidden_effect(tmp_path: Path) -> None:
    """The diagnosis of the field twin names the hidden effect and fits its strength."""
    library = shipped_library(TWIN['scene'])
    assert library is not None, f"no shipped library for {TWIN['scene']}"
    origin = ','.join(str(v) for v in TWIN['field_origin_in_scene_m'])
    code = diagnose_main(['--measured', str(BAGS / 'field_twin_reduced_1ms.truth.csv'),
                          '--scene', TWIN['scene'], '--origin', origin, '--library',
                          str(library), '--out', str(tmp_path), '--serial'])
    assert code == 0
    data = json.loads((tmp_path / 'diagnosis.json').read_text())
    (hidden,) = TWIN['hidden']['effects_switched_on']
    top = data['ranking'][0]
    assert data['verdict'] == 'effect_missing', (data['verdict'], data['ranking'][:3])
    assert top['effect'] == hidden, data['ranking'][:3]
    strength = top['strength']
    truth = TWIN['hidden']['effects'][hidden][strength['parameter']]
    assert abs(strength['value'] - truth) <= 2 * strength['uncertainty'], (strength, truth)
