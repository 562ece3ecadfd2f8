"""Run identity as track fields (tool speed, run id, seed, scene and physics keys), filled by the
loaders from run metadata (names only on request); pairing by the fields."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from dempath_compare.config import CompareConfig
from dempath_compare.loaders import load_source
from dempath_compare.pipeline import compare_tracks
from dempath_compare.records import MEASURED, MODEL, Track
from dempath_compare.runinfo import run_info, speed_from_name


def test_name_convention_only_on_request() -> None:
    """Names are not parsed by default; with from_names: speed from the name, seed from a
    dempath run id, unknown otherwise."""
    assert speed_from_name('experiment_1p5ms') == 1.5
    assert speed_from_name('model_1ms') == 1.0
    assert math.isnan(speed_from_name('trial_a'))
    plain = run_info('reduced_1ms-s7-0123abcd')
    assert math.isnan(plain.speed_m_s) and plain.seed == -1
    assert plain.run_id == 'reduced_1ms-s7-0123abcd'
    assert run_info('reduced_1ms-s7-0123abcd', from_names=True)[:3] == \
        (1.0, 'reduced_1ms-s7-0123abcd', 7)
    info = run_info('trial_a', from_names=True)
    assert math.isnan(info.speed_m_s) and info.run_id == 'trial_a' and info.seed == -1


def test_run_metadata_comes_first() -> None:
    """Run metadata give the run id, seed and (when stated) the speed; the name is not read."""
    meta = {'run_id': 'bin-s3-89abcdef', 'seed': 3, 'scene': 'bin', 'tool_speed_m_s': 1.5,
            'scene_key': 'a1', 'physics_key': 'b2'}
    assert run_info('model_1ms', meta) == (1.5, 'bin-s3-89abcdef', 3, 'a1', 'b2')
    assert run_info('model_1ms', meta, from_names=True) == (1.5, 'bin-s3-89abcdef', 3, 'a1', 'b2')
    assert math.isnan(run_info('model_1ms', {'scene': 'bin', 'seed': 3}).speed_m_s)


def write_track_csv(path: Path, key: str, ident: int, z: np.ndarray) -> Path:
    """A one-trajectory CSV ``t,<key>,x,y,z`` rising along Z after a rest."""
    rows = [f'{0.02 * k:.2f},{ident},0,0,{v:.6f}' for k, v in enumerate(z)]
    path.write_text(f't,{key},x,y,z\n' + '\n'.join(rows) + '\n')
    return path


def test_loaders_fill_the_fields(tmp_path: Path) -> None:
    """A dempath simulate folder: from its summary.json; a CSV: from its name on request only."""
    z = np.concatenate([np.zeros(5), np.linspace(0, 0.1, 20)])
    csv = write_track_csv(tmp_path / 'experiment_1ms.csv', 'marker', 1, z)
    measured = load_source(csv, MEASURED)
    assert math.isnan(measured[0].speed_m_s)
    assert (measured[0].run_id, measured[0].seed) == ('experiment_1ms', -1)
    named = load_source(csv, MEASURED, from_names=True)
    assert (named[0].speed_m_s, named[0].run_id, named[0].seed) == (1.0, 'experiment_1ms', -1)
    run = tmp_path / 'run'
    run.mkdir()
    write_track_csv(run / 'model.csv', 'id', 5, z)
    meta = {'run_id': 'reduced_1ms-s7-0123abcd', 'seed': 7, 'scene': 'reduced_1ms',
            'tool_speed_m_s': 1.0, 'scene_key': 'a1', 'physics_key': 'b2'}
    (run / 'summary.json').write_text(json.dumps(meta))
    model = load_source(run, MODEL)
    assert model[0][-5:] == (1.0, 'reduced_1ms-s7-0123abcd', 7, 'a1', 'b2')


def rising(label: str, group: str, speed: float) -> Track:
    """A trajectory resting 5 samples, then rising 0.1 m along Z, of tool speed ``speed``."""
    z = np.concatenate([np.zeros(5), np.linspace(0, 0.1, 20)])
    pos = np.stack([np.zeros_like(z), np.zeros_like(z), z], axis=1)
    return Track(label, group, 1, 1, np.arange(len(z)) * 0.02, pos, speed_m_s=speed)


def test_pairing_uses_the_speed_field() -> None:
    """Group names say nothing; the fields decide: 1 m/s pairs with 1 m/s and unknown only."""
    measured = [rising('a/marker1', 'a', 1.0)]
    model = [rising('b/1', 'b', 1.0), rising('c/1', 'c', 1.5), rising('d/1', 'd', math.nan)]
    result = compare_tracks(measured, model, CompareConfig(pairing='all'))
    assert result.scores.compared[0].tolist() == [True, False, True]


def test_pairing_uses_the_scene_key() -> None:
    """Runs of another scene set-up are not compared; an unknown key pairs with every key."""
    measured = [rising('a/marker1', 'a', 1.0)._replace(scene_key='k1')]
    model = [rising('b/1', 'b', 1.0)._replace(scene_key='k1'),
             rising('c/1', 'c', 1.0)._replace(scene_key='k2'), rising('d/1', 'd', 1.0)]
    result = compare_tracks(measured, model, CompareConfig(pairing='all'))
    assert result.scores.compared[0].tolist() == [True, False, True]
    assert result.model.scene_keys == ('k1', 'k2', '')


def test_identity_from_names_is_a_config_option(tmp_path: Path) -> None:
    """compare_paths reads names only with identity_from_names: 1 m/s is not paired with 1.5."""
    from dempath_compare.pipeline import compare_paths

    z = np.concatenate([np.zeros(5), np.linspace(0, 0.1, 20)])
    measured = write_track_csv(tmp_path / 'experiment_1ms.csv', 'marker', 1, z)
    model = write_track_csv(tmp_path / 'model_1p5ms.csv', 'marker', 1, z)
    plain = compare_paths(measured, model, CompareConfig(pairing='all'))
    assert plain.scores.compared.tolist() == [[True]]
    named = compare_paths(measured, model, CompareConfig(pairing='all', identity_from_names=True))
    assert named.scores.compared.tolist() == [[False]]
