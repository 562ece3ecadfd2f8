"""Hidden-effect cases: a pass of the scene with one change, written as a measurement would be.

Used by the tests and ``bench/diagnose.py``: the markers (the scene's marker particles) get
Gaussian noise of ``noise_m`` per axis, as a camera pair gives, and are written as CSV
``t,marker,x,y,z``; the force as CSV ``t,Fx,Fy,Fz`` (force of the particles on the tool).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dempath_diagnose.library.simulator import CasePass, SceneSpec, pass_travel_s, run_case


@dataclass(frozen=True)
class HiddenCase:
    """One case: a name, the hidden change and the answer a diagnosis should give.

    Attributes:
        name: Case name.
        overrides: The hidden change (``{'effect.parameter': value}``; empty: the control).
        truth: The effect name of the change ('' for the control or a too weak change).
        verdicts: Verdicts counted as right.
        seed: Packing seed (never one of the library's).
    """

    name: str
    overrides: dict[str, float] = field(default_factory=dict)
    truth: str = ''
    verdicts: tuple[str, ...] = ('nothing_significant',)
    seed: int = 7


def write_case(case: CasePass, folder: Path, noise_m: float = 0.0015, seed: int = 0,
               ) -> tuple[Path, Path]:
    """Write ``markers.csv`` (with noise) and ``force.csv`` into ``folder``; their paths."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    noisy = case.positions + rng.normal(0.0, noise_m, case.positions.shape)
    markers, force = folder / 'markers.csv', folder / 'force.csv'
    with markers.open('w', newline='') as f:
        w = csv.writer(f)
        w.writerow(('t', 'marker', 'x', 'y', 'z'))
        for i, t in enumerate(case.times):
            for j, number in enumerate(case.markers):
                if np.all(np.isfinite(noisy[i, j])):
                    w.writerow((f'{t:.6g}', int(number), *(f'{v:.6g}' for v in noisy[i, j])))
    with force.open('w', newline='') as f:
        w = csv.writer(f)
        w.writerow(('t', 'Fx', 'Fy', 'Fz'))
        for i, t in enumerate(case.times):
            w.writerow((f'{t:.6g}', *(f'{v:.6g}' for v in case.force[i])))
    return markers, force


def make_case(scene: SceneSpec, hidden: HiddenCase, folder: Path, *, until_s: float,
              noise_m: float = 0.0015, cache_dir: Path | None = None,
              own_pour: bool = False, backend: str = 'dempath') -> tuple[Path, Path]:
    """Run ``hidden`` on ``scene`` and write it as a measurement of [0, ``until_s``] (a camera
    recording of fixed length; cached in ``folder``)."""
    markers, force = folder / 'markers.csv', folder / 'force.csv'
    if markers.is_file() and force.is_file():
        return markers, force
    follow = max(0.0, until_s - pass_travel_s(scene, hidden.overrides))
    case = run_case(scene, hidden.seed, hidden.overrides, follow_s=follow, cache_dir=cache_dir,
                    own_pour=own_pour, backend=backend)
    keep = case.times <= until_s + 1e-9
    case = CasePass(case.times[keep], case.markers, case.positions[keep], case.force[keep])
    return write_case(case, folder, noise_m, seed=hidden.seed)
