"""A synthetic worked example: measured markers and DEM-like candidates (clearly not real data).

Run ``python -m dempath_compare.example OUT_DIR`` to (re)write the committed fixture in
``dempath_compare/data/example``. The shapes follow the paper's setting (Kuře & Kuřetová 2025):
markers of the 1-15 grid at 50 mm spacing, tracked 0.44-0.56 s at 1 m/s and 0.24-0.38 s at
1.5 m/s, pushed forward (Z) and lifted (Y) by the chisel; camera-rate measured samples (50 Hz)
with 2.7 mm noise (the paper's ANN deviation) and model candidates from a Cube region
(30 x 20 x 10 mm) around each marker, sampled at 100 Hz with a rest phase before the tool
arrives. Everything here is synthetic and only shows the tool working.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

# (speed label, speed [m/s], {marker: tracked duration [s]}) as in the paper's Figures 11-12
EXPERIMENTS = (('1ms', 1.0, {7: 0.46, 9: 0.44, 10: 0.44, 15: 0.56}),
               ('1p5ms', 1.5, {6: 0.24, 7: 0.26, 8: 0.38, 9: 0.28}))
CANDIDATES_PER_MARKER = 12
CAMERA_RATE_HZ = 50.0
MODEL_RATE_HZ = 100.0
NOISE_M = 0.0027
REST_S = 0.06
SETTLE_M = 2e-5  # jitter of resting DEM particles [m]


def marker_start(marker: int) -> NDArray[np.float64]:
    """Grid position of a marker [m]: 5 columns 50 mm apart in X, rows 50 mm apart in Z."""
    row, col = divmod(marker - 1, 5)
    return np.array([0.05 * (col - 2), 0.0, 0.05 * row])


def path_shape(s: NDArray[np.float64], marker: int, speed: float,
               scale: NDArray[np.float64]) -> NDArray[np.float64]:
    """(k, 3) m displacement over normalised time s in [0, 1] (forward push, lift, side drift)."""
    side = marker_start(marker)[0]
    reach = 0.12 * speed * scale[0] + 0.04
    lift = 0.05 * speed * scale[1]
    drift = (0.6 * side + 0.01) * scale[2]
    return np.stack([drift * s * s, lift * np.sin(np.pi * 0.9 * s), reach * (1 - (1 - s) ** 2)], 1)


def measured_rows(rng: np.random.Generator, tag: str, speed: float,
                  markers: dict[int, float]) -> list[list[float]]:
    """Rows t,marker,x,y,z of one experiment (camera rate, noisy)."""
    rows = []
    for marker, duration in markers.items():
        t = np.arange(0.0, duration + 1e-9, 1.0 / CAMERA_RATE_HZ)
        s = np.asarray(t / duration, dtype=np.float64)
        xyz = marker_start(marker) + path_shape(s, marker, speed, np.ones(3))
        xyz += rng.normal(0.0, NOISE_M, xyz.shape) * (t[:, None] > 0)
        rows += [[round(ti, 4), marker, *np.round(p, 5)] for ti, p in zip(t, xyz, strict=True)]
    return rows


def model_rows(rng: np.random.Generator, speed: float, markers: dict[int, float],
               first_id: int) -> list[list[float]]:
    """Rows t,id,marker,x,y,z of the Cube candidates of one simulated run (100 Hz, rest first)."""
    rows, pid = [], first_id
    cube = np.array([0.030, 0.020, 0.010])
    for marker, duration in markers.items():
        for _ in range(CANDIDATES_PER_MARKER):
            start = marker_start(marker) + rng.uniform(-cube / 2, cube / 2)
            length = duration * rng.uniform(0.9, 1.15)
            t = np.arange(0.0, REST_S + length + 1e-9, 1.0 / MODEL_RATE_HZ)
            s = np.asarray(np.clip((t - REST_S) / length, 0.0, 1.0), dtype=np.float64)
            scale = rng.normal(1.0, 0.08, 3)
            xyz = start + path_shape(s, marker, speed, scale)
            xyz += rng.normal(0.0, SETTLE_M, xyz.shape)
            rows += [[round(ti, 4), pid, marker, *np.round(p, 6)] for ti, p in zip(t, xyz,
                                                                                   strict=True)]
            pid += 1
    return rows


def write_example(out_dir: str | Path, seed: int = 7) -> list[Path]:
    """Write experiment_<speed>.csv and model_<speed>.csv files; returns their paths."""
    rng = np.random.default_rng(seed)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for k, (tag, speed, markers) in enumerate(EXPERIMENTS):
        files = ((f'experiment_{tag}.csv', 't,marker,x,y,z', measured_rows(rng, tag, speed,
                                                                           markers)),
                 (f'model_{tag}.csv', 't,id,marker,x,y,z',
                  model_rows(rng, speed, markers, 500000 + 10000 * k)))
        for name, header, rows in files:
            path = out / name
            with path.open('w', newline='') as handle:
                writer = csv.writer(handle)
                writer.writerow(header.split(','))
                writer.writerows(rows)
            written.append(path)
    return written


def main(argv: list[str] | None = None) -> int:
    """Command line: write the synthetic example into a folder."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('out_dir', type=Path)
    parser.add_argument('--seed', type=int, default=7)
    args = parser.parse_args(argv)
    for path in write_example(args.out_dir, args.seed):
        print(path)
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
