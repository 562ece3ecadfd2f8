"""The variation set of ``detect_track.py --variations``: the bundled render under field
conditions (``dempath_twin.render.conditions.VARIATIONS``), scored per variation and held-out
apart.

Per variation (one JSON line each): ``recall`` (markers at least half visible that were found
within 3 px), ``numbered_right`` (found and given their own number, in the frames as
``StereoMarkerTracker.release`` gives them out), ``id_switches`` (numbered detections whose
nearest true marker within 8 px is another one and whose own marker is not within 3 px: two
markers whose images lie within 3 px of one spot are one spot, and the spot is either's;
``id_switches_nearest`` counts every numbered detection whose nearest marker is another, as
sessions 11-13 did; ``spurious_numbers``: no marker within 8 px),
``wrong_pair_points`` (3D points more than 5 mm from the truth whose pair holds
a wrongly numbered detection), ``traj_rms_mm`` (3D error of the trajectories, true cameras),
``fps`` (frames per second of wall time, decode included, one thread, on the machine as loaded
as it is), ``cpu_ms_per_frame`` and ``fps_two_free_cores`` (2 / CPU time per frame, of the
process's first pass over the recording), ``cpu_ms_per_frame_warm`` and
``fps_two_free_cores_warm`` (the same of the second pass, the determinism check's: a detector
node's steady rate) and ``first_pass_extra_ms`` (the first pass's CPU time beyond the second's:
once per process, mostly numba loading its cached kernels on their first call, 0.2-0.3 s; on
a recording of 34-50 frames it lowered the first look's ``fps_two_free_cores`` by up to a
fifth, session 21),
``deterministic`` (the offline path run twice gives the same frames, and the graph equals it),
``graph_equals_offline`` (what the detector nodes publish playing a bag, ``lossless``: each
tracks both cameras in stamp order; the same frames and numbers as the offline path whether the
images arrive in stamp order or every front image first; the nodes themselves are tested in
``tests/test_detector_stamp_order.py``), and ``live_order_independent`` (live, without
``lossless``: one tracker per camera exchanging numbered points; whether its result is the same
with the other camera's points heard at once or one frame late).
"""

from __future__ import annotations

import hashlib
import json
import pickle
import time
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_calib.camera import CameraModel
from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.merge import StampMerge
from dempath_recon.tracking.records import PixelFrame, StereoTrackConfig
from dempath_recon.tracking.stereo import StereoMarkerTracker, triangulate_tracks
from dempath_twin.render.conditions import (
    FRESH_PREFIX,
    VARIATIONS,
    Condition,
    moved_truth,
    vary_recording,
)

MATCH_PX = 3.0  # a detection this near a true centre found that marker
OWNER_PX = 8.0  # a numbered detection's marker is the true one nearest within this (about a
# marker's diameter in these views); none that near: a number given to no marker (spurious)
WRONG_PAIR_MM = 5.0
Frames = list[tuple[str, int, bytes]]
CLAY_SET = [False]  # the detectors are told a recording's clay colour when it is not blue
# (``--marker-colour look``); default: blue clay, the detector's default
TOOL_SPEED = [0.0]  # the tool's speed [m/s] for recordings whose truth does not give it
# (``--tool-speed``); 0: not known (the linkers' speed bound is off)
FLOOR = ['']  # ``--exposure-floor``: DetectorConfig.exposure_floor ('': the default)
RULES: dict[str, bool] = {}  # StereoTrackConfig's numbering rules as the command line sets them
# (``--coming-out``, ``--no-numbered-partner``, ``--no-regain``, ``--no-half-ghost``,
# ``--no-merge-release``: the field and its value); a rule not named keeps
# its default
EXPOSURE_KNOWN = [True]  # the trackers are told each recording's exposure (``--exposure-unknown``:
# not, as before session 16: no streak search)


def with_exposure(config: StereoTrackConfig, exposure_s: float) -> StereoTrackConfig:
    """``config`` whose trackers know the cameras' exposure [s] (a camera setting its driver
    reports; the faint search then looks for streaks along each track's motion), unless the
    bench runs with ``--exposure-unknown``."""
    if not EXPOSURE_KNOWN[0]:
        return config
    return replace(config, tracker=replace(config.tracker, exposure_s=exposure_s))


def with_clay(config: StereoTrackConfig, truth: dict[str, Any]) -> StereoTrackConfig:
    """``config`` whose detectors are told the clay's colour (``DetectorConfig.marker_bgr``) as
    a user would set it, when the recording's clay (``config.look.marker_bgr``) is not blue
    (blue not its largest channel) and the bench runs with ``--marker-colour look``; blue
    clay keeps the detector's default."""
    clay = truth.get('config', {}).get('look', {}).get('marker_bgr')
    if not CLAY_SET[0] or clay is None or int(np.argmax(clay)) == 0:
        return config
    bgr = (float(clay[0]), float(clay[1]), float(clay[2]))
    return replace(config, detector=replace(config.detector, marker_bgr=bgr))


def with_rules(config: StereoTrackConfig) -> StereoTrackConfig:
    """``config`` with the numbering rules the command line switched (``RULES``)."""
    return replace(config, **RULES)


def with_floor(config: StereoTrackConfig) -> StereoTrackConfig:
    """``config`` whose detectors floor the chroma as ``--exposure-floor`` asks
    (``DetectorConfig.exposure_floor``; unset: the detector's default)."""
    if not FLOOR[0]:
        return config
    return replace(config, detector=replace(config.detector, exposure_floor=FLOOR[0]))


def with_tool_speed(config: StereoTrackConfig, truth: dict[str, Any]) -> StereoTrackConfig:
    """``config`` told the tool's speed, as a user who drives the tractor knows it
    (``StereoTrackConfig.tool_speed_m_s``: it bounds each camera's links): the truth's
    ``tool_speed_m_s``, else its run's scene profile speed times the run's
    ``tool_speed.speed_scale``, else ``--tool-speed`` (0: not known)."""
    speed = truth.get('tool_speed_m_s')
    run = truth.get('run', {})
    scale = run.get('effects', {}).get('tool_speed', {}).get('speed_scale')
    if speed is None and run.get('scene') and scale is not None:
        from dempath_sim.scene import resolve_scene

        speed = resolve_scene(run['scene']).tool.profile.speed_m_s * float(scale)
    return replace(config, tool_speed_m_s=float(TOOL_SPEED[0] if speed is None else speed))


def look_exposure(truth: dict[str, Any]) -> float:
    """The exposure [s] a rendered recording's truth gives (``config.look.exposure_s``; 4 ms,
    the renderer's default, when absent)."""
    return float(truth.get('config', {}).get('look', {}).get('exposure_s', 0.004))


def vary(frames: Frames, truth: dict[str, Any], cond: Condition, cache: Path,
         ) -> tuple[Frames, dict[str, Any]]:
    """The recording's frames under ``cond`` and the truth moved with any image shift (cached
    in ``cache`` by the condition's hash and the source frames' digest: a re-rendered bundled
    recording must not meet the varied frames of the one before)."""
    digest = hashlib.sha1()
    for cam, stamp, data in frames:
        digest.update(f'{cam} {stamp} '.encode())
        digest.update(data)
    path = cache / f'{cond.name}-{cond.key()}-{digest.hexdigest()[:12]}.v3.pkl'
    if path.is_file():
        out, shifts = pickle.loads(path.read_bytes())
    else:
        out, shifts = vary_recording(frames, truth, cond)
        cache.mkdir(parents=True, exist_ok=True)
        path.write_bytes(pickle.dumps((out, shifts)))
    return out, moved_truth(truth, shifts)


def seen(fr: PixelFrame) -> PixelFrame:
    """The frame with its points where they were seen in the image (the tracker gives them
    out moved back by the image's estimated shake; the truth's pixels move with the image)."""
    return fr if fr.shake_px is None else fr._replace(uv=fr.uv + fr.shake_px)


def _truth_ids(fr: PixelFrame, t: dict[str, Any], ids: NDArray[np.int64], within_px: float,
               ) -> NDArray[np.int64]:
    """(k,) the true marker nearest each detection of a frame (-1: none within ``within_px``)."""
    uv = np.array(t['uv'])
    if not len(fr.uv):
        return np.zeros(0, np.int64)
    d = np.linalg.norm(fr.uv[:, None] - uv[None], axis=2)
    j = np.argmin(d, axis=1)
    return np.where(d[np.arange(len(fr.uv)), j] < within_px, ids[j], -1)


def _own_within(fr: PixelFrame, t: dict[str, Any], ids: NDArray[np.int64], within_px: float,
                ) -> NDArray[np.bool_]:
    """(k,) whether each detection's own number's true marker lies within ``within_px``."""
    uv = np.array(t['uv'])
    row = {int(m): i for i, m in enumerate(ids)}
    return np.array([m in row and float(np.linalg.norm(fr.uv[k] - uv[row[m]])) < within_px
                     for k, m in enumerate(fr.markers.tolist())], bool)


def score(out: list[PixelFrame], truth: dict[str, Any], cams: dict[str, CameraModel],
          ) -> dict[str, Any]:
    """recall, numbered_right, id_switches, wrong_pair_points, traj errors against the truth."""
    ids = np.array(truth['marker_ids'])
    by_key = {(f['camera'], round(f['stamp_ns'] * 1e-3)): f for f in truth['frames']}
    want = found = right = switches = switches_nearest = spurious = 0
    wrong: set[tuple[str, int, int]] = set()  # (camera, stamp us, number) wrongly given
    for fr in out:
        t = by_key.get((fr.camera, round(fr.stamp_s * 1e6)))
        if t is None:
            continue
        fr = seen(fr)
        true_of = _truth_ids(fr, t, ids, MATCH_PX)
        owner = _truth_ids(fr, t, ids, OWNER_PX)
        vis = np.array(t['visible'])
        for i, m in enumerate(ids):
            if vis[i] < 0.5:
                continue
            want += 1
            hits = np.flatnonzero(true_of == m)
            found += int(len(hits) > 0)
            right += int(any(fr.markers[h] == m for h in hits))
        own = _own_within(fr, t, ids, MATCH_PX)
        for k in np.flatnonzero(fr.markers >= 0):
            if owner[k] != fr.markers[k]:  # another marker's spot, or nobody's
                switches_nearest += int(owner[k] >= 0)
                switches += int(owner[k] >= 0 and not own[k])
                spurious += int(owner[k] < 0)
                wrong.add((fr.camera, round(fr.stamp_s * 1e6), int(fr.markers[k])))
    side = truth['cameras'][0]['name']
    front = truth['cameras'][1]['name']
    front_us = np.array(sorted({round(f.stamp_s * 1e6) for f in out if f.camera == front}))
    times, markers, xyz = triangulate_tracks(out, cams, side)
    true3d = {round(f['stamp_ns'] * 1e-3): np.array(f['xyz']) for f in truth['frames']
              if f['camera'] == side}
    d3, wrong_pairs = [], 0
    d3_right: list[float] = []  # the points not counted as wrong pairs
    for k, t_s in enumerate(times):
        us = round(t_s * 1e6)
        ref = true3d.get(us)
        if ref is None:
            continue
        near = front_us[np.abs(front_us - us) <= 1.5 * 20_000]
        for j, m in enumerate(markers):
            if not np.isfinite(xyz[k, j]).all():
                continue
            err = float(np.linalg.norm(xyz[k, j] - ref[list(ids).index(m)]))
            d3.append(err)
            bad = (side, us, int(m)) in wrong or any((front, int(f), int(m)) in wrong
                                                     for f in near)
            wrong_pairs += int(bad and err * 1e3 > WRONG_PAIR_MM)
            if not (bad and err * 1e3 > WRONG_PAIR_MM):
                d3_right.append(err)
    return {'want': want, 'found': found, 'right': right, 'id_switches': switches,
            'id_switches_nearest': switches_nearest,
            'spurious_numbers': spurious,
            'wrong_pair_points': wrong_pairs, 'sq3d': float(np.sum(np.square(d3))),
            'n3d': len(d3), 'max3d_mm': 1e3 * max(d3) if d3 else float('nan'),
            'sq3d_right': float(np.sum(np.square(d3_right))), 'n3d_right': len(d3_right)}


def calibrated(cams: dict[str, CameraModel], config: StereoTrackConfig,
               calib: Frames | None) -> StereoMarkerTracker:
    """A tracker given the frames the calibration was made on (the bag's board segment, as
    recorded: the shake's anchor, ``StereoMarkerTracker.add_reference``)."""
    tracker = StereoMarkerTracker(cams, config)
    for cam, _, data in calib or []:
        tracker.add_reference(cam, data)
    return tracker


def offline(frames: Frames, cams: dict[str, CameraModel], config: StereoTrackConfig,
            calib: Frames | None = None) -> list[PixelFrame]:
    """The offline path (one tracker for both cameras, the publication delay)."""
    tracker = calibrated(cams, config, calib)
    out: list[PixelFrame] = []
    for cam, stamp, data in frames:
        tracker.update(cam, stamp * 1e-9, data)
        out += tracker.release()
    return out + tracker.flush()


def lossless_graph(frames: Frames, cams: dict[str, CameraModel], config: StereoTrackConfig,
                   front_first: bool, calib: Frames | None = None) -> list[PixelFrame]:
    """What the detector nodes publish playing a bag (``lossless``): each tracks both cameras
    in stamp order (``StampMerge``) and gives out its own camera's frames; the images arrive
    in stamp order, or every front image before the first side image (``front_first``)."""
    names = list(cams)
    order = sorted(frames, key=lambda f: (f[0] == names[0], f[1])) if front_first \
        else sorted(frames, key=lambda f: f[1])
    out: list[PixelFrame] = []
    for own in names:
        tracker = calibrated(cams, config, calib)
        merge: StampMerge[bytes] = StampMerge(names)
        mine: list[PixelFrame] = []
        for cam, stamp, data in order:
            for c, s, d in merge.push(cam, stamp * 1e-9, data):
                tracker.update(c, s, d)
                mine += tracker.release()
        for c, s, d in merge.rest():
            tracker.update(c, s, d)
            mine += tracker.release()
        out += [f for f in mine + tracker.flush() if f.camera == own]
    return sorted(out, key=lambda f: f.stamp_s)


def live_nodes(frames: Frames, cams: dict[str, CameraModel], config: StereoTrackConfig,
               lag: int, calib: Frames | None = None) -> list[PixelFrame]:
    """The detector nodes live (not ``lossless``): one tracker per camera, each hearing the
    other's numbered points ``lag`` frames of the other camera late (0: at once)."""
    names = list(cams)
    cores = {c: calibrated(cams, config, calib) for c in names}
    waiting: dict[str, list[PixelFrame]] = {c: [] for c in names}
    out = []
    for cam, stamp, data in sorted(frames, key=lambda f: f[1]):
        fr = cores[cam].update(cam, stamp * 1e-9, data)
        out.append(fr)
        other = names[1 - names.index(cam)]
        waiting[other].append(fr)
        while len(waiting[other]) > lag:
            heard = waiting[other].pop(0)
            keep = heard.markers >= 0
            cores[other].note_other(heard.camera, heard.stamp_s, heard.markers[keep],
                                    heard.uv[keep])
    return out


def same(a: list[PixelFrame], b: list[PixelFrame]) -> bool:
    """Whether two runs gave the same frames and numbers."""
    return len(a) == len(b) and all(
        x.camera == y.camera and x.stamp_s == y.stamp_s and np.array_equal(x.markers, y.markers)
        and np.array_equal(x.uv, y.uv) for x, y in zip(a, b, strict=True))


def run_variation(frames: Frames, truth: dict[str, Any], cams: dict[str, CameraModel],
                  config: StereoTrackConfig, cond: Condition, cache: Path,
                  calib: Frames | None = None) -> dict[str, Any]:
    """One variation's figures (raw sums kept for the summaries). ``calib``: the frames the
    calibration was made on, as recorded (the condition varies the pass's frames: the camera
    shakes, the light changes after the calibration)."""
    varied, moved = vary(frames, truth, cond, cache)
    config = with_exposure(config, 1e-3 * cond.shutter_ms)
    return {'variation': cond.name, 'held_out': cond.held_out,
            **figures(varied, moved, cams, config, calib), 'condition': asdict(cond)}


def figures(frames: Frames, truth: dict[str, Any], cams: dict[str, CameraModel],
            config: StereoTrackConfig, calib: Frames | None = None) -> dict[str, Any]:
    """A recording's figures: scores, speed, and whether the offline path, the lossless graph
    and the live nodes agree (each given the calibration's frames ``calib`` first)."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = offline(frames, cams, config, calib)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    c1 = time.process_time()
    again = offline(frames, cams, config, calib)
    warm = time.process_time() - c1
    s = score(out, truth, cams)
    by_stamp = sorted(out, key=lambda f: f.stamp_s)
    graph = all(same(lossless_graph(frames, cams, config, first, calib), by_stamp)
                for first in (False, True))
    live = same(live_nodes(frames, cams, config, 0, calib),
                live_nodes(frames, cams, config, 1, calib))
    return {**summary([s]), 'fps': len(frames) / wall,
            'cpu_ms_per_frame': 1e3 * cpu / len(frames),
            'fps_two_free_cores': 2 * len(frames) / cpu,
            'cpu_ms_per_frame_warm': 1e3 * warm / len(frames),
            'fps_two_free_cores_warm': 2 * len(frames) / warm,
            'first_pass_extra_ms': 1e3 * (cpu - warm), 'deterministic': same(out, again),
            'graph_equals_offline': graph, 'live_order_independent': live, 'raw': s}


def run_rendered(bags: list[Path], read: Any, held_out: bool = True) -> dict[str, Any]:
    """Recordings re-rendered by the twin's renderer (``dempath twin render`` with other light,
    shutter, sand and marker colours, marker size, noise, JPEG quality, on another run), each
    with its own truth and cameras. One JSON line each, then their pooled figures.
    ``read(bag, start_ns, cameras)`` reads the frames; ``held_out`` labels the rows: True for a
    set never run while changing the code, False for the looks a change was tuned on (pooled
    apart by the caller)."""
    import json as _json

    rows = []
    for bag in bags:
        truth = _json.loads(bag.with_name(bag.name + '.truth.json').read_text())
        cams = {c['name']: CameraModel.from_dict(c) for c in truth['cameras']}
        start = truth['calibration_segment']['field_start_ns']
        frames = read(bag, start, list(cams))
        calib = [f for f in read(bag, 0, list(cams)) if f[1] < start]
        grid = MarkerGrid(layout_m=tuple(tuple(p) for p in truth['marker_grid_m']))
        row = {'variation': bag.name, 'held_out': held_out, 'rendered': True,
               'look': truth['config']['look'], 'jpeg_quality': truth['config']['jpeg_quality'],
               **figures(frames, truth, cams,
                         with_floor(with_rules(with_tool_speed(with_clay(with_exposure(
                             StereoTrackConfig(grid=grid), look_exposure(truth)),
                             truth), truth))), calib)}
        rows.append(row)
        print(json.dumps({k: v for k, v in row.items() if k != 'raw'}), flush=True)
    return {**summary([r['raw'] for r in rows]),
            'fps_two_free_cores': min(r['fps_two_free_cores'] for r in rows),
            'fps_two_free_cores_warm': min(r['fps_two_free_cores_warm'] for r in rows),
            'deterministic': all(r['deterministic'] and r['graph_equals_offline'] for r in rows),
            'live_order_independent': all(r['live_order_independent'] for r in rows),
            'variations': [r['variation'] for r in rows]}


def summary(scores: list[dict[str, Any]]) -> dict[str, Any]:
    """Pooled figures of several variations."""
    want = sum(s['want'] for s in scores)
    n3d = sum(s['n3d'] for s in scores)
    n_right = sum(s['n3d_right'] for s in scores)
    return {'recall': sum(s['found'] for s in scores) / max(want, 1),
            'numbered_right': sum(s['right'] for s in scores) / max(want, 1),
            'id_switches': sum(s['id_switches'] for s in scores),
            'id_switches_nearest': sum(s['id_switches_nearest'] for s in scores),
            'spurious_numbers': sum(s['spurious_numbers'] for s in scores),
            'wrong_pair_points': sum(s['wrong_pair_points'] for s in scores),
            'traj_rms_mm': 1e3 * float(np.sqrt(sum(s['sq3d'] for s in scores) / n3d))
            if n3d else float('nan'),
            'traj_max_mm': max((s['max3d_mm'] for s in scores), default=float('nan')),
            # the same without the wrong-pair points: the centres' accuracy apart from identity
            'traj_rms_right_mm': 1e3 * float(np.sqrt(sum(s['sq3d_right'] for s in scores)
                                                     / n_right)) if n_right else float('nan'),
            'visible_markers': want}


def run_all(frames: Frames, truth: dict[str, Any], cams: dict[str, CameraModel],
            config: StereoTrackConfig, cache: Path, tuned_only: bool = False,
            calib: Frames | None = None) -> dict[str, Any]:
    """Every variation (one JSON line each, the held-out ones first), then the held-out and
    tuned summaries; the held-out variations no decision has seen yet (``FRESH_PREFIX``) are
    also pooled apart. ``tuned_only``: the tuned variations alone (what a change is tuned on)."""
    rows = []
    pool = [c for c in VARIATIONS if not (tuned_only and c.held_out)]
    for cond in sorted(pool, key=lambda c: not c.held_out):  # the held-out set first
        row = run_variation(frames, truth, cams, config, cond, cache, calib)
        rows.append(row)
        print(json.dumps({k: v for k, v in row.items() if k not in ('raw', 'condition')}),
              flush=True)
    out: dict[str, Any] = {}
    for name, pick in (('held_out', 'held'), ('held_out_fresh', 'fresh'), ('tuned', 'tuned')):
        part = [r for r in rows if (not r['held_out'] if pick == 'tuned' else r['held_out'] and (
            pick == 'held' or r['variation'].startswith(FRESH_PREFIX)))]
        if not part:
            continue
        out[name] = {**summary([r['raw'] for r in part]),
                     'fps': min(r['fps'] for r in part),
                     'fps_two_free_cores': min(r['fps_two_free_cores'] for r in part),
                     'fps_two_free_cores_warm': min(r['fps_two_free_cores_warm']
                                                    for r in part),
                     'deterministic': all(r['deterministic'] and r['graph_equals_offline']
                                          for r in part),
                     'graph_equals_offline': all(r['graph_equals_offline'] for r in part),
                     'live_order_independent': all(r['live_order_independent']
                                                   for r in part),
                     'variations': [r['variation'] for r in part]}
    low = next(r for r in rows if r['variation'] == 'light_x0.3_shutter_12ms')
    out['light_x0.3_shutter_12ms_numbered_right'] = low['numbered_right']
    return out
