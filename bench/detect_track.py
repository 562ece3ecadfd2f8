"""Benchmark: marker detection and tracking on a rendered field recording, against its truth.

Reads a bag written by ``dempath twin render`` (default: the bundled one) and its
``<bag>.truth.json``, runs the two-camera pipeline (``dempath_recon.tracking.stereo``: JPEG decode,
detection, tracking, numbering) over the run's frames, and compares with the truth:

- ``fps``: frames processed per second of wall time, decode included (JPEGs read from the bag
  into memory first, so bag I/O is not counted), with ``--threads`` threads (default 2: the two
  cameras' decode and detection on two threads, OpenCV releases the GIL, as two detector nodes
  would; tracking follows on the main thread); ``fps_one_thread`` the same on one thread;
  ``cpu_ms_per_frame`` is the process CPU time per frame of the threaded run and
  ``fps_two_free_cores`` the rate two otherwise idle cores would give (2 / CPU time per frame);
  ``stage_ms`` splits one thread's CPU time per frame into ``decode``, ``detect`` (chroma,
  filter, centroids) and ``track`` (linking, numbering, checks). On a shared machine the
  wall-clock figures measure the other jobs as much as this code: ``load_average`` (1, 5 and
  15 min, before the timed runs) and ``load_average_end`` say how busy the machine was;
- ``rms_px``: localisation error of detected markers whose disc is at least 90 % visible;
- ``recall``: share of markers at least half visible (truth) that were detected and numbered,
  in the frames as :meth:`StereoMarkerTracker.release` gives them out (held
  ``number_delay_frames`` frames, default config; the node path uses ``update``'s frames);
- ``id_switches``: numbered detections given a number other than the marker's own;
- ``traj_rms_mm``: 3D error of the triangulated trajectories (true cameras) against the truth;
- ``node_path``: the demo's code path (``make demo``; alone with ``--node-path-only``): both
  cameras calibrated from the bag's
  own board segment (``dempath_bringup.calibstep``), the detector nodes' tracking when playing a
  bag (``lossless``: both cameras in stamp order, the node's defaults, default grid, the
  publication delay), then the reconstructor's core (``MarkerStream``, ``dlt_refined``) fed the
  frames as they are released; its 3D error against the truth (``traj_rms_mm``), the numbers
  given to a detection of another marker (``wrong_numbers``), unnumbered and withheld points,
  and ``markers_reconstructed``: markers with a 3D point in at least 80 % of the frames in
  which they are on the surface (the truth's ``on_surface``; issue 26 asks for 13 of 15).

With ``--variations`` it scores the bundled render's field-condition variations instead
(``detect_track_variations.py``), with ``--rendered`` / ``--rendered-tuning`` other rendered
bags, and with ``--looks SPEC`` / ``--looks-tuning SPEC`` the looks a spec file lists
(``bench/looks/*.txt``: independent packings, tool speeds and cohesion, rendered on first use
and cached, ``rendered_looks.py``); held-out and tuned pools apart.

Prints one JSON object as the last line, with the machine's load average.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import cv2
import numpy as np

from dempath.bagio import open_bag
from dempath_calib.camera import CameraModel
from dempath_recon.tracking.associate import MarkerGrid
from dempath_recon.tracking.detect import decode_jpeg
from dempath_recon.tracking.merge import StampMerge
from dempath_recon.tracking.stereo import (
    StereoMarkerTracker,
    StereoTrackConfig,
    camera_detectors,
    triangulate_tracks,
)
from dempath_twin.render.coverage import coverage_of

HERE = Path(__file__).resolve().parent
DEFAULT_BAG = HERE.parent / 'bags' / 'field_render_reduced_1ms'
MATCH_PX = 3.0  # a detection within this of a true centre is that marker's


def read_frames(bag: Path, start_ns: int, cams: list[str]) -> list[tuple[str, int, bytes]]:
    """(camera, stamp ns, JPEG bytes) of the run's frames, in bag order."""
    topics = [f'/{c}/image_raw/compressed' for c in cams]
    out = []
    with open_bag(bag, topics) as reader:
        for raw in reader.messages(topics):
            msg = reader.deserialize(raw)
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            if stamp >= start_ns:
                out.append((raw.topic.split('/')[1], stamp, bytes(msg.data)))
    return out


def run(frames: list[tuple[str, int, bytes]], cams: dict[str, CameraModel],
        threads: int, config: StereoTrackConfig) -> tuple[list, float, dict]:
    """Detect in every frame (on ``threads`` threads), then track; frames and wall time."""
    detectors = camera_detectors(cams, config)
    tracker = StereoMarkerTracker(cams, config)
    t0, c0 = time.perf_counter(), time.process_time()
    with ThreadPoolExecutor(threads) as pool:
        dets = list(pool.map(lambda f: detectors[f[0]].detect_jpeg(f[2]), frames))
    out = []
    for (c, s, _), d in zip(frames, dets, strict=True):
        tracker.update_detections(c, s * 1e-9, d)
        out += tracker.release()  # held number_delay_frames frames, then given out
    out += tracker.flush()
    run.cpu_s = time.process_time() - c0  # type: ignore[attr-defined]
    return out, time.perf_counter() - t0, tracker.report()


def stage_times(frames: list[tuple[str, int, bytes]], cams: dict[str, CameraModel],
                config: StereoTrackConfig) -> dict[str, float]:
    """One thread's CPU time per frame [ms] of decode, detection and tracking."""
    detectors = camera_detectors(cams, config)
    tracker = StereoMarkerTracker(cams, config)
    spent = dict.fromkeys(('decode', 'detect', 'track'), 0.0)
    for cam, stamp, data in frames:
        t0 = time.thread_time()
        image = decode_jpeg(data, config.detector.downscale)
        t1 = time.thread_time()
        det = detectors[cam].detect(image, prescaled=True)
        t2 = time.thread_time()
        tracker.update_detections(cam, stamp * 1e-9, det)
        t3 = time.thread_time()
        spent['decode'] += t1 - t0
        spent['detect'] += t2 - t1
        spent['track'] += t3 - t2
    return {k: round(1e3 * v / len(frames), 3) for k, v in spent.items()}


def score(out: list, truth: dict, cams: dict[str, CameraModel]) -> dict[str, float]:
    """rms_px, recall, id_switches, traj_rms_mm against the truth frames."""
    ids = np.array(truth['marker_ids'])
    by_key = {(f['camera'], round(f['stamp_ns'] * 1e-3)): f for f in truth['frames']}  # us
    errs, want, found, switches = [], 0, 0, 0
    for fr in out:
        t = by_key.get((fr.camera, round(fr.stamp_s * 1e6)))
        if t is None:
            continue
        uv, vis = np.array(t['uv']), np.array(t['visible'])
        d = np.linalg.norm(uv[:, None] - fr.uv[None], axis=2) if len(fr.uv) else \
            np.full((len(uv), 0), np.inf)
        for i in range(len(uv)):
            j = int(np.argmin(d[i])) if d.shape[1] else -1
            hit = j >= 0 and d[i, j] < MATCH_PX
            if vis[i] >= 0.5:
                want += 1
                found += int(hit and fr.markers[j] == ids[i])
            if hit and fr.markers[j] >= 0 and fr.markers[j] != ids[i]:
                switches += 1
            if hit and vis[i] >= 0.9:
                errs.append(fr.uv[j] - uv[i])
    e = np.array(errs).reshape(-1, 2)
    side = truth['cameras'][0]['name']
    times, markers, xyz = triangulate_tracks(out, cams, side)
    true = {round(f['stamp_ns'] * 1e-3): np.array(f['xyz']) for f in truth['frames']
            if f['camera'] == side}
    d3 = []
    for k, t in enumerate(times):
        ref = true.get(round(t * 1e6))
        if ref is None:
            continue
        for j, m in enumerate(markers):
            if np.isfinite(xyz[k, j]).all():
                d3.append(np.linalg.norm(xyz[k, j] - ref[list(ids).index(m)]))
    return {'rms_px': float(np.sqrt((e ** 2).sum(1).mean())) if len(e) else float('nan'),
            'bias_px': np.round(e.mean(0), 4).tolist() if len(e) else [],
            'n_localised': len(e), 'recall': found / max(want, 1), 'visible_markers': want,
            'id_switches': switches,
            'traj_rms_mm': float(np.sqrt(np.mean(np.square(d3))) * 1e3) if d3 else float('nan'),
            'traj_max_mm': float(np.max(d3) * 1e3) if d3 else float('nan'),
            'traj_points': len(d3)}


def node_path(bag: Path, frames: list[tuple[str, int, bytes]], truth: dict) -> dict:
    """The demo's path: own calibration, one core per camera, reconstructor core; vs truth."""
    import tempfile

    from dempath_bringup.calibstep import calibrate_recording
    from dempath_calib.camera import StereoCalibration
    from dempath_recon.pairing import PixelFrame
    from dempath_recon.stream import MarkerStream, StreamConfig

    with tempfile.TemporaryDirectory() as tmp:
        yaml = Path(tmp) / 'stereo.yaml'
        calibrate_recording(bag, lambda *_: None).result.calibration.save(yaml)
        cams = {c.name: c for c in StereoCalibration.load(yaml).cameras}
        stream = MarkerStream.from_config(StreamConfig(method='dlt_refined',
                                                       calibration_file=str(yaml)))
    names = list(cams)
    # playing a bag (lossless) both detector nodes track both cameras in stamp order, with the
    # publication delay, and each publishes its camera's frames: one tracker does the same
    core = StereoMarkerTracker(cams)
    merge: StampMerge[bytes] = StampMerge(names)
    released = []
    for cam, stamp, data in frames:
        for c, s, d in merge.push(cam, stamp * 1e-9, data):
            core.update(c, s, d)
            released += core.release()
    for c, s, d in merge.rest():
        core.update(c, s, d)
        released += core.release()
    released += core.flush()
    ids, by_key = truth['marker_ids'], {(f['camera'], round(f['stamp_ns'] * 1e-3)): f
                                        for f in truth['frames']}
    out3d, wrong, unnumbered = [], 0, 0
    for fr in released:
        cam, key = fr.camera, (fr.camera, round(fr.stamp_s * 1e6))
        keep = fr.markers >= 0
        unnumbered += int((~keep).sum())
        true_uv = np.array(by_key[key]['uv']) if key in by_key else None
        for m, uv in zip(fr.markers[keep], fr.uv[keep], strict=True):
            if true_uv is not None:
                d = np.linalg.norm(true_uv - uv, axis=1)
                wrong += int(d.min() >= MATCH_PX or ids[int(np.argmin(d))] != m)
        out3d += stream.update(PixelFrame(names.index(cam), fr.stamp_s,
                                          fr.markers[keep].astype(np.int64), fr.uv[keep]))
    side = [f for f in truth['frames'] if f['camera'] == names[0]]
    stamps = np.array([int(f['stamp_ns']) for f in side])
    err = []
    for f3 in out3d:
        ref = np.array(side[int(np.argmin(np.abs(stamps - f3.stamp_s * 1e9)))]['xyz'])
        err += [np.linalg.norm(x - ref[ids.index(int(m))]) for m, x in zip(f3.ids, f3.xyz,
                                                                          strict=True)]
    e = 1e3 * np.array(err)
    present = np.zeros((len(side), len(ids)))
    for f3 in out3d:
        k = int(np.argmin(np.abs(stamps - f3.stamp_s * 1e9)))
        present[k, [ids.index(int(m)) for m in f3.ids]] = 1.0
    surface = truth.get('on_surface')
    cover = coverage_of({'3d': present}, ids,
                        None if surface is None else np.asarray(surface, bool))
    return {'markers_reconstructed': len(cover.reconstructed),
            'reconstructed': cover.reconstructed,
            'share_3d': {str(m): round(float(v), 3) for m, v in zip(ids, cover.both,
                                                                     strict=True)},
            'traj_rms_mm': float(np.sqrt(np.mean(e ** 2))) if len(e) else float('nan'),
            'traj_max_mm': float(e.max()) if len(e) else float('nan'), 'points': len(e),
            'markers': len({int(m) for f in out3d for m in f.ids}), 'wrong_numbers': wrong,
            'unnumbered': unnumbered,
            'withheld': sum(r['withheld'] for r in core.report().values())}


RULE_SWITCHES = (  # (flag, StereoTrackConfig field, help): the numbering rules a run may switch
    ('--coming-out', 'coming_out', 'number a marker coming out of the sand in one camera by where '
     'the bed carried it (StereoTrackConfig.coming_out; off by default)'),
    ('--no-numbered-partner', 'numbered_partner', "do not name a pair by the other camera's "
     'number when the carried point is far (StereoTrackConfig.numbered_partner; on by default)'),
    ('--no-regain', 'regain', 'do not give back a number elimination took back for a jump '
     '(StereoTrackConfig.regain; on by default)'),
    ('--no-ray-rivals', 'ray_rivals', "number a spot one camera's image grid numbers alone at "
     'the grid fit even where another free marker rests near its line of sight '
     '(StereoTrackConfig.ray_rivals; on by default)'),
    ('--no-half-ghost', 'half_ghost', "number both spots of a grid pair whose spot in one camera "
     "lies nearer an unclaimed marker's grid point (StereoTrackConfig.half_ghost; on)"),
    ('--no-merge-release', 'merge_release', "keep a track's number where a neighbour's blob "
     'merged into its spot in one camera (StereoTrackConfig.merge_release; on)'),
    ('--track-split', 'track_split', 'split a spot two numbered tracks (or the other '
     "camera's lines) say holds two markers (StereoTrackConfig.track_split; off by default)"),
    ('--no-line-rival', 'line_rival', 'let any unnumbered spot of the other camera on the '
     "track's epipolar line hold back elimination (StereoTrackConfig.line_rival; on)"),
    ('--no-whole-pass', 'whole_pass', 'give frames out as they come, without numbering the '
     'never-numbered tracks from the whole pass at its end (StereoTrackConfig.whole_pass; on)'),
    ('--no-joint-fill', 'joint_fill', "leave the spots the rules left unnumbered, not filled "
     "from each marker's 3D path over the whole pass (StereoTrackConfig.joint_fill; on)"),
    ('--piece-numbering', 'piece_numbering', 'number the unnumbered stretches of 2D tracks '
     "at the pass's end by how well they continue each marker's path "
     '(StereoTrackConfig.piece_numbering; off by default)'),
    ('--bed-numbering', 'bed_numbering', "number the unnumbered stretches of 2D tracks at the "
     "pass's end by where the bed's motion carried each marker "
     '(StereoTrackConfig.bed_numbering; off by default)'),
    ('--no-bed-sheared', 'bed_sheared', "weigh the bed field's neighbours by their rest "
     'distance, not by their gaps across and along the travel (StereoTrackConfig.bed_sheared; '
     'on by default)'),
    ('--no-bed-after-fill', 'bed_after_fill', 'run bed numbering before the joint fill, not '
     'after it (StereoTrackConfig.bed_after_fill; on by default)'),
    ('--dim-spots', 'dim_spots', "search a dim frame's markers again on the chroma floored at "
     "the frame's own light (StereoTrackConfig.dim_spots; off by default)"),
    ('--no-band-pass', 'band_pass', 'find spots on the matched filter alone, not less the local '
     'background (StereoTrackConfig.band_pass; on by default)'),
    ('--eager-split', 'eager_split', 'split touching markers where one more disc fits 1.7 '
     'times as well, not twice (StereoTrackConfig.eager_split; off by default)'),
    ('--smooth-centres', 'smooth_centres', 'publish centres measured on the lightly smoothed '
     'chroma (StereoTrackConfig.smooth_centres; off by default)'),
    ('--no-flux-share', 'flux_share', "place partly covered markers' published centres by "
     'their centroid mass, not their chroma flux over the local sand '
     '(StereoTrackConfig.flux_share; on)'),
    ('--band-adds-only', 'band_adds_only', 'keep every spot the fixed rule passes, the '
     'band-pass only adding spots (StereoTrackConfig.band_adds_only; off by default)'),
    ('--no-contrast-faint', 'contrast_faint', "do not look beside a numbered track's "
     "prediction for a faint marker by its contrast to the window's own sand "
     '(StereoTrackConfig.contrast_faint; on by default)'),
    ('--no-pass-audit', 'pass_audit', 'give the whole pass out without auditing its numbers '
     "against the markers' 3D paths (StereoTrackConfig.pass_audit; on)"),
    ('--audit-renumber', 'audit_renumber', 'let the pass audit renumber the stretches it '
     'finds on another marker instead of withholding them (StereoTrackConfig.audit_renumber; '
     'off)'),
    ('--shake-reference', 'shake_reference', "place the shake against the calibration's "
     "frames (the bag's board segment), not by its mean over the pass "
     '(StereoTrackConfig.shake_reference; off by default)'),
    ('--no-shake-shrink', 'shake_shrink', "take each frame's shake as estimated, not scaled "
     "by the share of the pass's scatter that is not the estimate's noise "
     '(StereoTrackConfig.shake_shrink; on)'),
    ('--shake-align', 'shake_align', "register each frame's shake again, its tiles cut where "
     "the reference's content went (StereoTrackConfig.shake_align; off by default)"),
    ('--no-smooth-paths', 'smooth_paths', "give the numbered centres out as detected, not "
     "smoothed along each marker's image path (StereoTrackConfig.smooth_paths; on)"),
    ('--carried-confirm', 'carried_confirm', 'withhold numbers a 2D track carried over a break '
     'that the other camera never confirms after it (StereoTrackConfig.carried_confirm; off)'),
    ('--no-touch-confirm', 'touch_confirm', 'give out the numbers of two markers that touched '
     'in one camera where the other does not tell them apart (StereoTrackConfig.touch_confirm; '
     'on)'),
    ('--no-touch-wait', 'touch_wait', 'judge a contact of two touching markers on the first '
     'frames after it alone, not on every run where the other camera gives a point '
     '(StereoTrackConfig.touch_wait; on)'),
    ('--no-touch-swap', 'touch_swap', 'withhold, not exchange, the numbers of two touching '
     'markers the other camera tells apart exchanged (StereoTrackConfig.touch_swap; on)'),
)


def main(argv: list[str]) -> int:
    """Run the benchmark and print the JSON line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument('bag', nargs='?', type=Path, default=DEFAULT_BAG)
    p.add_argument('--threads', type=int, default=2)
    p.add_argument('--repeat', type=int, default=3, help='timed passes (best is reported)')
    p.add_argument('--no-node-path', action='store_true', help="skip the demo's code path")
    p.add_argument('--node-path-only', action='store_true',
                   help="only the demo's code path (no timed passes)")
    p.add_argument('--variations', action='store_true',
                   help='score the field-condition variation set instead (held-out apart)')
    p.add_argument('--tuned-only', action='store_true',
                   help='with --variations: the tuned variations alone (what a change is tuned '
                        'on; the held-out ones are scored only to decide and report)')
    p.add_argument('--rendered', type=Path, nargs='*', default=[],
                   help='score these re-rendered bags (held out; with --variations: as well)')
    p.add_argument('--rendered-tuning', type=Path, nargs='*', default=[],
                   help='re-rendered bags a change was tuned on: labelled tuned, pooled apart')
    p.add_argument('--looks', type=Path, nargs='*', default=[], metavar='SPEC',
                   help='rendered looks listed in these spec files (bench/looks/*.txt), rendered '
                        'on first use and scored held out (as --rendered)')
    p.add_argument('--looks-tuning', type=Path, nargs='*', default=[], metavar='SPEC',
                   help='rendered looks a change was tuned on (bench/looks/burnt.txt): as '
                        '--rendered-tuning')
    p.add_argument('--looks-cache', type=Path, default=None,
                   help='where the looks are rendered (default ~/.cache/dempath/bench_looks)')
    p.add_argument('--cache', type=Path, default=HERE.parent / 'out' / 'bench_variations',
                   help='where the varied frames are kept between runs')
    p.add_argument('--exposure-unknown', action='store_true',
                   help='do not tell the trackers the exposure (no streak search)')
    p.add_argument('--marker-colour', choices=('blue', 'look'), default=None,
                   help="'look': tell the detectors each recording's clay colour when it is not "
                        "blue (DetectorConfig.marker_bgr, as a user sets it; the default with "
                        "--looks); 'blue': the detector's default clay (the default otherwise)")
    p.add_argument('--tool-speed', type=float, default=0.0, metavar='M_S',
                   help="the tool's speed [m/s] for recordings whose truth does not give it "
                        "(StereoTrackConfig.tool_speed_m_s, as the user knows it; 0: unknown)")
    p.add_argument('--exposure-floor', choices=('off', 'faint'), default='',
                   help="the detectors' chroma floor (DetectorConfig.exposure_floor; unset: the "
                        "default)")
    for flag, _, text in RULE_SWITCHES:
        p.add_argument(flag, action='store_true', help=text)
    args = p.parse_args(argv)
    if args.looks or args.looks_tuning:
        from rendered_looks import CACHE, rendered_bags

        cache = args.looks_cache or CACHE
        args.rendered += [b for spec in args.looks for b in rendered_bags(spec, cache)]
        args.rendered_tuning += [b for spec in args.looks_tuning
                                 for b in rendered_bags(spec, cache)]
        args.marker_colour = args.marker_colour or 'look'
    from detect_track_variations import (
        CLAY_SET,
        EXPOSURE_KNOWN,
        FLOOR,
        RULES,
        TOOL_SPEED,
        look_exposure,
        with_clay,
        with_exposure,
        with_floor,
        with_rules,
        with_tool_speed,
    )

    EXPOSURE_KNOWN[0] = not args.exposure_unknown
    TOOL_SPEED[0] = args.tool_speed
    FLOOR[0] = args.exposure_floor
    for flag, field, _ in RULE_SWITCHES:  # '--no-x' switches rule x off, '--x' on
        if getattr(args, flag[2:].replace('-', '_')):
            RULES[field] = not flag.startswith('--no-')
    CLAY_SET[0] = args.marker_colour == 'look'
    cv2.setNumThreads(1)
    truth = json.loads(args.bag.with_name(args.bag.name + '.truth.json').read_text())
    cams = {c['name']: CameraModel.from_dict(c) for c in truth['cameras']}
    frames = read_frames(args.bag, truth['calibration_segment']['field_start_ns'], list(cams))
    # the experiment's marker layout (the scene's grid points), as an experimenter knows it
    grid = MarkerGrid(layout_m=tuple(tuple(p) for p in truth['marker_grid_m']))
    config = with_floor(with_rules(with_tool_speed(with_clay(with_exposure(
        StereoTrackConfig(grid=grid), look_exposure(truth)), truth), truth)))
    load = [round(x, 2) for x in os.getloadavg()]
    if (args.rendered or args.rendered_tuning) and not args.variations:  # re-rendered bags alone
        from detect_track_variations import run_rendered

        tuned = (run_rendered(args.rendered_tuning, read_frames, held_out=False)
                 if args.rendered_tuning else None)
        rendered = (run_rendered(args.rendered, read_frames) if args.rendered
                    else tuned)
        print(json.dumps({**rendered, 'held_out': bool(args.rendered),
                          **({'tuned': tuned} if tuned and args.rendered else {}),
                          'load_average': load,
                          'load_average_end': [round(x, 2) for x in os.getloadavg()],
                          'cpus': os.cpu_count()}))
        return 0
    if args.variations:
        from detect_track_variations import run_all, run_rendered

        start = truth['calibration_segment']['field_start_ns']
        calib = [f for f in read_frames(args.bag, 0, list(cams)) if f[1] < start]
        found = run_all(frames, truth, cams, config, args.cache, args.tuned_only, calib)
        if args.rendered:
            found['rendered_held_out'] = run_rendered(args.rendered, read_frames)
        if args.rendered_tuning:
            found['rendered_tuned'] = run_rendered(args.rendered_tuning, read_frames,
                                                   held_out=False)
        held = found['tuned' if args.tuned_only else 'held_out']
        print(json.dumps({**{k: held[k] for k in (
            'recall', 'numbered_right', 'id_switches', 'wrong_pair_points', 'traj_rms_mm',
            'fps', 'deterministic')}, **found, 'load_average': load,
            'load_average_end': [round(x, 2) for x in os.getloadavg()],
            'cpus': os.cpu_count()}))
        return 0
    if args.node_path_only:
        print(json.dumps({'node_path': node_path(args.bag, frames, truth), 'load_average': load,
                          'load_average_end': [round(x, 2) for x in os.getloadavg()]}))
        return 0
    best, cpu, one = None, None, None
    for _ in range(args.repeat):
        out, wall, report = run(frames, cams, args.threads, config)
        best = wall if best is None else min(best, wall)
        cpu = run.cpu_s if cpu is None else min(cpu, run.cpu_s)  # type: ignore[attr-defined]
        _, wall1, _ = run(frames, cams, 1, config)
        one = wall1 if one is None else min(one, wall1)
    stages = min((stage_times(frames, cams, config) for _ in range(args.repeat)),
                 key=lambda st: sum(st.values()))
    h, w = next(iter(cams.values())).height, next(iter(cams.values())).width
    figures = {'fps': len(frames) / best, 'fps_one_thread': len(frames) / one,
               'frames': len(frames), 'image': f'{w}x{h}',
               'cpu_ms_per_frame': 1e3 * cpu / len(frames),
               'fps_two_free_cores': 2 * len(frames) / cpu, 'stage_ms': stages,
               'threads': args.threads, 'number_delay_frames': config.number_delay_frames,
               **score(out, truth, cams),
               'load_average': load, 'load_average_end': [round(x, 2) for x in os.getloadavg()],
               'cpus': os.cpu_count(),
               'lost': sum(r['lost'] for r in report.values()),
               'reattached': sum(r['reattached'] for r in report.values())}
    if not args.no_node_path:
        figures['node_path'] = node_path(args.bag, frames, truth)
    print(json.dumps(figures))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
