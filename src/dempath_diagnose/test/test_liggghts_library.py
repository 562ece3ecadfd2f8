"""`--backend liggghts`: a library run on LIGGGHTS 3.8 from dempath's settled bed of the seed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dempath_diagnose.library import LibrarySpec, library_dir
from dempath_diagnose.simulate import load_scene, pass_travel_s, run_pass

from .conftest import SCENE


@pytest.mark.timeout(1200)  # a guard, not a timing: one LIGGGHTS pass of the tiny scene
def test_liggghts_run_is_a_library_record(cache: Path, tmp_path: Path) -> None:
    """The pass covers the library's window, keeps the near-surface particles of the same bed
    (LIGGGHTS ids = dempath's + 1), the tool stands still after its travel, the draft is
    positive; the LIGGGHTS library has its own folder."""
    from dempath_sim.liggghts.errors import LiggghtsNotFoundError
    from dempath_sim.liggghts.install import ensure_liggghts

    try:
        ensure_liggghts(install=False)
    except LiggghtsNotFoundError as err:
        pytest.skip(f'LIGGGHTS unavailable: {err}')
    scene = load_scene(SCENE)
    until = round(pass_travel_s(scene, {}) + 0.1, 6)
    packings = cache / 'packings'
    ours = run_pass(scene, 1001, {}, until_s=until, cache_dir=packings)
    theirs = run_pass(scene, 1001, {}, until_s=until, cache_dir=packings, backend='liggghts')
    assert theirs.times[-1] >= until - 0.03
    assert len(set(theirs.ids.tolist()) & set((ours.ids + 1).tolist())) >= 0.9 * len(ours.ids)
    stop = theirs.meta['tool_stop_s']
    after = theirs.times > stop + 0.02
    assert after.any()
    assert float(np.ptp(theirs.tool_position[after], axis=0).max()) < 1e-6
    moving = theirs.force_times < stop
    assert float(np.mean(-theirs.tool_force[moving, 2])) > 0
    spec = LibrarySpec()
    assert library_dir(scene, spec, tmp_path, 'liggghts') != library_dir(scene, spec, tmp_path)
