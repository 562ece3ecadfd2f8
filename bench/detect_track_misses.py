"""Where the "numbered right" misses go: every marker-frame at least half visible (truth) that
the two-camera tracker does not give out with its own number, sorted by cause.

Runs the offline path (``StereoMarkerTracker``: detect, link, number, check, the publication
delay) on rendered bags (``dempath twin render`` with ``<bag>.truth.json``) and, with
``--variations``, on the bundled render's field-condition variations (tuned and held-out
apart, as ``detect_track.py --variations``). Each miss falls in the first cause that fits:

- ``not_detected``: no detection within ``OWNER_PX`` of the marker's true centre;
- ``merged``: no detection within ``MATCH_PX``, but one within ``OWNER_PX`` that also lies
  within ``OWNER_PX`` of another visible marker (two markers in one spot, its centre between);
- ``off_centre``: a detection within ``OWNER_PX`` but not ``MATCH_PX``, alone;
- ``crowded``: its spot was flagged by the detector as two touching markers and withheld;
- ``wrong_number``: found, given another marker's number;
- ``withheld_<rule>``: found, numbered, then withheld in this frame by a rule that says so in
  the frame's events: ``ambiguous`` (``link_guide.ambiguous_spots``), ``unconfirmed`` (a jump,
  a re-attachment or a faint spot waiting for the other camera), ``epipolar``, ``position``,
  ``rival`` (the bed carried another marker nearer), ``frame_moved``, ``audit`` (the whole
  pass's audit: ``tracking.pass_audit``);
- ``number_elsewhere``: found and unnumbered while its number went to another spot;
- ``never_numbered_paired`` / ``never_numbered_alone``: found, unnumbered, no rule named
  (numbering not reached), while the other camera gives that marker out within a frame period
  (numbering by the epipolar line did not happen) / does not (a marker only this camera has).

Each wrong number and each late number is traced to the rule that gave it, by the tracker's
record of which rule numbered what (``StereoTrackConfig.record_numbers``,
:mod:`~dempath_recon.tracking.number_record`): ``switch_rules`` counts the numbered points given
out on another marker's spot (the bench's ``id_switches``) by the rule behind the number and
``/given_wrong`` (the track was on another marker's spot when numbered) or ``/moved`` (it was on
its own marker then and its links later took it to another; ``/untraced``: no truth then);
``late_rules`` counts the points numbered right that were unnumbered on arrival, by the rule
that numbered their track later. ``--trace`` prints each switch (one JSON line: the frame, the
number, the true owner, the rule and its evidence, and the track's record).

Prints one JSON line per recording and a last line with the pooled counts (and, with
``--variations``, ``tuned`` and ``held_out`` pools). Shares are of the visible marker-frames.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections import Counter
from dataclasses import replace
from itertools import pairwise
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from detect_track_variations import (
    EXPOSURE_KNOWN,
    TOOL_SPEED,
    look_exposure,
    seen,
    with_exposure,
    with_tool_speed,
)

from dempath_calib.camera import CameraModel
from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import decode_jpeg
from dempath_recon.tracking.number_record import NumberChange, NumberRecord
from dempath_recon.tracking.records import PixelFrame, StereoTrackConfig
from dempath_recon.tracking.stereo import StereoMarkerTracker

HERE = Path(__file__).resolve().parent
MATCH_PX = 3.0  # as detect_track_variations: a detection this near a true centre found it
OWNER_PX = 8.0  # about a marker's diameter in these views
RULES = (('its spot may hold a neighbour', 'withheld_ambiguous'),
         ('not yet confirmed by the other camera', 'withheld_unconfirmed'),
         ('moved together', 'withheld_frame_moved'),
         ('off the epipolar line', 'withheld_epipolar'),
         ('nearer where the bed carried', 'withheld_rival'),
         ('from its last position', 'withheld_position'),
         ('by the pass audit', 'withheld_audit'))
Frames = list[tuple[str, int, bytes]]
Key = tuple[str, int]  # (camera, stamp us)
TRACE = [False]  # --trace: print each switch


def track(frames: Frames, cams: dict[str, CameraModel], config: StereoTrackConfig,
          ) -> tuple[list[PixelFrame], dict[Key, tuple[Any, Any]], NumberRecord]:
    """The offline path's released frames, each frame's raw detections (uv, crowded), and
    the record of which rule numbered what."""
    tracker = StereoMarkerTracker(cams, replace(config, record_numbers=True))
    raw: dict[Key, tuple[Any, Any]] = {}
    out: list[PixelFrame] = []
    for cam, stamp, data in frames:
        detector = tracker.detectors[cam]
        image = decode_jpeg(data, detector.config.downscale)
        det = detector.detect(image, prescaled=True)
        raw[(cam, round(stamp * 1e-3))] = (det.uv, det.crowded)
        # the image's shake measured as ``StereoMarkerTracker.update`` does (the bench's path;
        # the frames come in stamp order)
        shaker = tracker.shakers.get(cam)
        shake = shaker.update(image, detector.config.downscale) if shaker else None
        tracker.update_detections(cam, stamp * 1e-9, det, shake)
        out += tracker.release()
    out += tracker.flush()
    assert tracker.state.record is not None
    return out, raw, tracker.state.record


def withheld_rule(events: tuple[str, ...], camera: str, marker: int) -> str | None:
    """The rule that withheld ``marker`` in a frame, from its events (None: none named)."""
    head = f'{camera}: marker {marker} withheld'
    for ev in events:
        if ev.startswith(head):
            return next((name for text, name in RULES if text in ev), 'withheld_other')
    return None


def owner_then(change: NumberChange, by_key: dict[Key, Any], ids: Any) -> int | None:
    """The true marker whose spot the track was on when its number changed (-1: none within
    ``OWNER_PX``; None: no truth for that frame)."""
    t = by_key.get((change.camera, round(change.seen_s * 1e6)))
    if t is None:
        return None
    d = np.linalg.norm(np.array(t['uv']) - np.array(change.uv), axis=1)
    return int(ids[np.argmin(d)]) if d.min() < OWNER_PX else -1


def rule_behind(record: NumberRecord, fr: PixelFrame, k: int, by_key: dict[Key, Any],
                ids: Any) -> tuple[str, NumberChange | None]:
    """``rule/how`` behind point ``k``'s number (see the module docstring) and the change."""
    change = record.behind(fr.camera, fr.stamp_s, k, int(fr.markers[k]))
    if change is None:
        return 'unrecorded', None
    then = owner_then(change, by_key, ids)
    how = 'untraced' if then is None else 'moved' if then == change.after else 'given_wrong'
    return f'{change.rule}/{how}', change


def trace_rules(fr: PixelFrame, t: dict[str, Any], record: NumberRecord,
                by_key: dict[Key, Any], ids: Any, tally: Counter[str]) -> None:
    """Count the rule behind each switch and each late number of one frame (and print each
    switch with ``--trace``)."""
    true_uv = np.array(t['uv'])
    uv = fr.uv if fr.shake_px is None else fr.uv + fr.shake_px  # where seen, as the bench
    for k in np.flatnonzero(fr.markers >= 0).tolist():
        m = int(fr.markers[k])
        d = np.linalg.norm(true_uv - uv[k], axis=1)
        owner = int(ids[np.argmin(d)]) if d.min() < OWNER_PX else -1
        own = float(d[list(ids).index(m)]) < MATCH_PX if m in ids else False
        if owner == m or owner < 0 or own:
            if owner == m and record.arrival_number(fr.camera, fr.stamp_s, k) == -1:
                tally['late:' + rule_behind(record, fr, k, by_key, ids)[0]] += 1
            continue
        rule, change = rule_behind(record, fr, k, by_key, ids)
        tally['switch:' + rule] += 1
        if TRACE[0]:
            track = record.track_of(fr.camera, fr.stamp_s, k)
            print(json.dumps({'switch': fr.camera, 'stamp_s': round(fr.stamp_s, 4),
                              'number': m, 'owner': owner, 'rule': rule,
                              'change': None if change is None else change._asdict(),
                              'track': [c._asdict() for c in
                                        record.history(fr.camera, -1 if track is None
                                                       else track)]}))


def classify(out: list[PixelFrame], raw: dict[Key, tuple[Any, Any]], truth: dict[str, Any],
             record: NumberRecord | None = None) -> Counter[str]:
    """Counts of each cause over the visible marker-frames (``right`` and ``want`` too), and
    with ``record``, the rules behind the switches (``switch:<rule>/<how>``) and the late
    numbers (``late:<rule>/<how>``)."""
    ids = np.array(truth['marker_ids'])
    by_key = {(f['camera'], round(f['stamp_ns'] * 1e-3)): f for f in truth['frames']}
    tally: Counter[str] = Counter()
    given: dict[str, list[tuple[float, set[int]]]] = {}
    for fr in out:
        given.setdefault(fr.camera, []).append(
            (fr.stamp_s, {int(m) for m in fr.markers if m >= 0}))
    period = min((b[0] - a[0] for g in given.values() for a, b in pairwise(g)
                  if b[0] > a[0]), default=0.02)
    for fr in out:
        key = (fr.camera, round(fr.stamp_s * 1e6))
        t = by_key.get(key)
        if t is None:
            continue
        true_uv, vis = np.array(t['uv']), np.array(t['visible'])
        det_uv, crowded = raw.get(key, (np.zeros((0, 2)), None))
        if record is not None:
            trace_rules(fr, t, record, by_key, ids, tally)
        at = seen(fr)  # its points where the image showed them, as the raw detections and truth
        for i, m in enumerate(ids.tolist()):
            if vis[i] < 0.5:
                continue
            tally['want'] += 1
            why = cause(at, det_uv, crowded, true_uv, vis, i, m)
            if why == 'never_numbered':
                paired = any(abs(s - fr.stamp_s) <= period and m in g
                             for c, frs in given.items() if c != fr.camera for s, g in frs)
                why += '_paired' if paired else '_alone'
            tally[why] += 1
    return tally


def cause(fr: PixelFrame, det_uv: Any, crowded: Any, true_uv: Any, vis: Any, i: int,
          m: int) -> str:
    """One visible marker-frame's outcome: ``right`` or the cause of the miss."""
    hits = np.zeros(0, np.int64)
    if len(fr.uv):  # as the bench: a detection within MATCH_PX whose nearest marker is this
        d = np.linalg.norm(fr.uv[:, None] - true_uv[None], axis=2)
        hits = np.flatnonzero((d[:, i] < MATCH_PX) & (np.argmin(d, axis=1) == i))
    if any(fr.markers[h] == m for h in hits):
        return 'right'
    if not len(hits):
        dd = np.linalg.norm(det_uv - true_uv[i], axis=1) if len(det_uv) else np.zeros(0)
        near = np.flatnonzero(dd < OWNER_PX)
        if not len(near):
            return 'not_detected'
        others = np.delete(np.arange(len(true_uv)), i)
        others = others[vis[others] > 0.1]
        for k in near:
            if len(others) and np.min(np.linalg.norm(true_uv[others] - det_uv[k], axis=1)) \
                    < OWNER_PX:
                return 'merged'
        return 'off_centre'
    if any(fr.markers[h] >= 0 for h in hits):
        return 'wrong_number'
    if crowded is not None and crowded.any():
        big = {tuple(p) for p in det_uv[crowded].tolist()}
        if any(tuple(fr.uv[h]) in big for h in hits.tolist()):
            return 'crowded'
    rule = withheld_rule(fr.events, fr.camera, m)
    if rule is not None:
        return rule
    return 'number_elsewhere' if (fr.markers == m).any() else 'never_numbered'


def shares(tally: Counter[str]) -> dict[str, Any]:
    """The counts and their shares of the visible marker-frames, largest miss first."""
    want = max(tally['want'], 1)
    misses = {k: v for k, v in tally.most_common() if k not in ('want', 'right')
              and ':' not in k}
    rules = {f'{kind}_rules': {k.split(':', 1)[1]: v for k, v in tally.most_common()
                               if k.startswith(kind + ':')} for kind in ('switch', 'late')}
    return {'want': tally['want'], 'numbered_right': tally['right'] / want,
            'misses': misses, 'miss_share': {k: round(v / want, 4) for k, v in misses.items()},
            **rules}


def run_bags(bags: list[Path]) -> dict[str, Any]:
    """Each rendered bag's breakdown (one JSON line each) and their pool."""
    from detect_track import read_frames

    pool: Counter[str] = Counter()
    for bag in bags:
        truth = json.loads(bag.with_name(bag.name + '.truth.json').read_text())
        cams = {c['name']: CameraModel.from_dict(c) for c in truth['cameras']}
        frames = read_frames(bag, truth['calibration_segment']['field_start_ns'], list(cams))
        grid = MarkerGrid(layout_m=tuple(tuple(p) for p in truth['marker_grid_m']))
        config = with_tool_speed(with_exposure(StereoTrackConfig(grid=grid),
                                               look_exposure(truth)), truth)
        out, raw, record = track(frames, cams, config)
        tally = classify(out, raw, truth, record)
        pool += tally
        print(json.dumps({'recording': bag.name, **shares(tally)}), flush=True)
    return shares(pool)


def run_variations(bag: Path, cache: Path) -> dict[str, Any]:
    """The variation set's breakdown, tuned and held-out pooled apart."""
    from detect_track import read_frames
    from detect_track_variations import vary

    from dempath_twin.render.conditions import VARIATIONS

    truth = json.loads(bag.with_name(bag.name + '.truth.json').read_text())
    cams = {c['name']: CameraModel.from_dict(c) for c in truth['cameras']}
    frames = read_frames(bag, truth['calibration_segment']['field_start_ns'], list(cams))
    grid = MarkerGrid(layout_m=tuple(tuple(p) for p in truth['marker_grid_m']))
    pools: dict[bool, Counter[str]] = {True: Counter(), False: Counter()}
    for cond in sorted(VARIATIONS, key=lambda c: not c.held_out):
        varied, moved = vary(frames, truth, cond, cache)
        config = with_tool_speed(with_exposure(StereoTrackConfig(grid=grid),
                                               1e-3 * cond.shutter_ms), truth)
        out, raw, record = track(varied, cams, config)
        tally = classify(out, raw, moved, record)
        pools[cond.held_out] += tally
        print(json.dumps({'variation': cond.name, 'held_out': cond.held_out,
                          **shares(tally)}), flush=True)
    return {'held_out': shares(pools[True]), 'tuned': shares(pools[False])}


def main(argv: list[str]) -> int:
    """Print the breakdowns; the last line is the pooled JSON."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument('bags', nargs='*', type=Path, help='rendered bags with <bag>.truth.json')
    p.add_argument('--variations', action='store_true',
                   help="also the bundled render's variation set (held-out apart; the default "
                   'without bags)')
    p.add_argument('--bag', type=Path, default=HERE.parent / 'bags' / 'field_render_reduced_1ms',
                   help='the recording the variations are made of')
    p.add_argument('--cache', type=Path, default=HERE.parent / 'out' / 'bench_variations')
    p.add_argument('--exposure-unknown', action='store_true',
                   help='do not tell the trackers the exposure (no streak search)')
    p.add_argument('--tool-speed', type=float, default=0.0, metavar='M_S',
                   help="the tool's speed [m/s] for recordings whose truth does not give it "
                        '(0: unknown)')
    p.add_argument('--trace', action='store_true',
                   help='print each switch with the rule behind its number and its evidence')
    args = p.parse_args(argv)
    TRACE[0] = args.trace
    EXPOSURE_KNOWN[0] = not args.exposure_unknown
    TOOL_SPEED[0] = args.tool_speed
    for bag in args.bags:
        if not bag.with_name(bag.name + '.truth.json').is_file():
            print(f'error: {bag}: no {bag.name}.truth.json beside it', file=sys.stderr)
            return 1
    cv2.setNumThreads(1)
    load = [round(x, 2) for x in os.getloadavg()]
    found: dict[str, Any] = {}
    if args.bags:
        found['rendered'] = run_bags(args.bags)
    if args.variations or not args.bags:
        found.update(run_variations(args.bag, args.cache))
    print(json.dumps({**found, 'load_average': load,
                      'load_average_end': [round(x, 2) for x in os.getloadavg()]}))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
