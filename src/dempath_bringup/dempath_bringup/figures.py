"""The PNG figures of the demo's report (matplotlib, Agg; OpenCV for the annotated frame).

Each function draws one figure into ``path`` and returns it: the calibration (corner coverage
and per-frame reprojection error per camera), a frame with the detected markers drawn, and the
measured against the model's best-matching trajectories in the XZ and YZ planes (the paper's
Figures 13-16 layout), before and after the recalibration.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

CAMERAS = ('side', 'front')
SHOWN = 4  # markers drawn in the trajectory figure (those that move the most)
ZOOM = 3  # magnification of the detections' region in the annotated frame


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt


def plot_calibration(result: Any, checks: list[dict[str, Any]], path: Path) -> Path:
    """Corner coverage of the image and per-frame reprojection RMSE, per camera."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8))
    w, h = result.calibration.side.width, result.calibration.side.height
    for c, name in enumerate(CAMERAS):
        ax = axes[c]
        pts = result.corners[:, c].reshape(-1, 2)
        ax.plot(pts[:, 0], pts[:, 1], '.', ms=2)
        ax.set_xlim(0, w)
        ax.set_ylim(h, 0)
        ax.set_aspect('equal')
        ax.set_title(f"{name}: board corners ({result.report['views'][name]} views, RMSE "
                     f"{result.report['rmse_px'][name]:.3f} px)", fontsize=9)
    fr = np.asarray(result.stereo.frame_rmse_px)
    for c, name in enumerate(CAMERAS):
        axes[2].plot(np.arange(len(fr)), fr[:, c], 'o-', label=name)
    axes[2].set_xlabel('paired board frame')
    axes[2].set_ylabel('reprojection RMSE [px]')
    axes[2].set_title('bundle adjustment, per frame', fontsize=9)
    axes[2].grid(True, alpha=0.3)
    axes[2].legend()
    if checks:
        text = '; '.join(f"{r['camera']}: f {r['fx_pct']:+.2f}/{r['fy_pct']:+.2f} %, centre "
                         f"{r['centre_mm']:.1f} mm, {r['angle_deg']:.2f} deg" for r in checks)
        fig.suptitle(f'against the truth: {text}', fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def frame_with_detections(field_bag: Path, run_bag: Path, path: Path,
                          camera: str = 'cam_side') -> Path | None:
    """The middle field frame of ``camera`` with the markers the detector numbered drawn on it.

    Returns None when the run recorded no detected points of that camera.
    """
    import cv2

    from dempath import topics
    from dempath.bagio import open_bag

    points = {}
    pp = topics.camera_topic(topics.PIXEL_POINTS, camera)
    with open_bag(run_bag, [pp]) as reader:
        for raw in reader.messages([pp]):
            msg = reader.deserialize(raw)
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            points[stamp] = (list(msg.marker_ids), np.column_stack([msg.u, msg.v]))
    if not points:
        return None
    stamp = sorted(points)[len(points) // 2]
    image_topic = topics.camera_topic(topics.IMAGE_COMPRESSED, camera)
    image: Any = None
    with open_bag(field_bag, [image_topic]) as reader:
        for raw in reader.messages([image_topic]):
            msg = reader.deserialize(raw)
            if msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == stamp:
                image = cv2.imdecode(np.asarray(msg.data, np.uint8), cv2.IMREAD_COLOR)
                break
        else:
            return None
    if image is None:
        return None
    ids, uv = points[stamp]
    cv2.imwrite(str(path), annotate(image, ids, uv, f'{camera}, t = {stamp * 1e-9:.3f} s'))
    return path


def annotate(image: Any, ids: list[int], uv: Any, title: str) -> Any:
    """The frame at half size with the detections' region boxed, over that region zoomed in
    ``ZOOM`` times with each detection circled at its sub-pixel centre and numbered."""
    import cv2

    h, w = image.shape[:2]
    pad = 60
    x0, y0 = int(max(np.min(uv[:, 0]) - pad, 0)), int(max(np.min(uv[:, 1]) - pad, 0))
    x1, y1 = int(min(np.max(uv[:, 0]) + pad, w)), int(min(np.max(uv[:, 1]) + pad, h))
    crop = cv2.resize(image[y0:y1, x0:x1], None, fx=ZOOM, fy=ZOOM,
                      interpolation=cv2.INTER_CUBIC)
    for m, (u, v) in zip(ids, uv, strict=True):
        cx, cy = (u - x0 + 0.5) * ZOOM - 0.5, (v - y0 + 0.5) * ZOOM - 0.5
        centre = (round(cx * 4), round(cy * 4))  # 2 fractional bits: sub-pixel drawing
        cv2.circle(crop, centre, 12 * ZOOM * 4, (0, 255, 255), 2, cv2.LINE_AA, shift=2)
        cv2.drawMarker(crop, (round(cx), round(cy)), (0, 255, 255), cv2.MARKER_CROSS, 8, 1)
        cv2.putText(crop, str(int(m)), (round(cx) + 10 * ZOOM, round(cy) - 8 * ZOOM),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.9, (0, 255, 255), 2, cv2.LINE_AA)
    full = cv2.resize(image, (w // 2, h // 2), interpolation=cv2.INTER_AREA)
    cv2.rectangle(full, (x0 // 2, y0 // 2), (x1 // 2, y1 // 2), (0, 255, 255), 2)
    cv2.putText(full, f'{title}: {len(ids)} markers numbered', (15, 35),
                cv2.FONT_HERSHEY_SIMPLEX, 0.9, (255, 255, 255), 2, cv2.LINE_AA)
    width = max(full.shape[1], crop.shape[1])
    out = np.zeros((full.shape[0] + crop.shape[0], width, 3), np.uint8)
    out[:full.shape[0], :full.shape[1]] = full
    out[full.shape[0]:, :crop.shape[1]] = crop
    return out


def moving_markers(res: Any, n: int = SHOWN) -> list[int]:
    """Indices of the ``n`` measured markers that move the most (largest path extent)."""
    meas = res.measured
    extent = [float(np.nanmax(np.ptp(meas.positions[e, : meas.lengths[e]], axis=0)))
              if meas.lengths[e] > 1 else 0.0 for e in range(len(meas.labels))]
    return [int(e) for e in np.argsort(extent)[::-1][:n]]


def plot_trajectories(results: dict[str, Any], path: Path) -> Path:
    """Measured (solid, dots) and best-matching model (dashed) trajectories, XZ and YZ.

    The markers that move the most (the same ones in every row), one colour each; every
    trajectory shifted to its start, as the comparison scores them.

    Args:
        results: ``{'before': CompareResult, 'after': CompareResult}`` (after optional).
    """
    plt = _pyplot()
    rows = [(k, r) for k, r in results.items() if r is not None]
    fig, axes = plt.subplots(len(rows), 2, figsize=(12, 4.0 * len(rows)), squeeze=False)
    chosen = moving_markers(rows[0][1])
    for row, (label, res) in enumerate(rows):
        meas, mod = res.measured, res.model
        for col, (axis, name) in enumerate(((0, 'X'), (1, 'Y'))):
            ax = axes[row, col]
            for k, e in enumerate(chosen):
                if e >= len(meas.labels):
                    continue
                p = 1e3 * meas.positions[e, : meas.lengths[e]]
                ax.plot(p[:, 2], p[:, axis], 'o-', color=f'C{k}', lw=1.4, ms=3,
                        label=f'marker {meas.idents[e]} measured')
                for j in res.best(e, 1):
                    q = 1e3 * mod.positions[j, : mod.lengths[j]]
                    ax.plot(q[:, 2], q[:, axis], '--', color=f'C{k}', lw=1.4,
                            label=f'marker {meas.idents[e]} model')
            ax.set_xlabel('Z [mm] (tool travel, from the start)')
            ax.set_ylabel(f'{name} [mm]')
            ax.set_title(f'{label} the recalibration: {name}Z plane', fontsize=10)
            ax.grid(True, alpha=0.3)
        axes[row, 1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def marker_coverage(measured_csv: Path, markers: int = 15,
                    fps: float = 50.0) -> dict[str, Any]:
    """Which markers the cameras reconstructed, and when: per marker the share of the pass's
    frames (from the first to the last 3D frame) with a 3D point, and the frame times.

    Returns:
        {'frames': n, 'times_s': (n,), 'present': {marker: (n,) bool}, 'share': {marker: f},
        'reconstructed': markers present in at least 80 % of the frames}.
    """
    data = np.loadtxt(measured_csv, delimiter=',', skiprows=1, ndmin=2)
    keys = np.round(data[:, 0] * fps).astype(int)
    first = int(keys.min()) if len(keys) else 0
    times = (first + np.arange(int(keys.max()) - first + 1 if len(keys) else 0)) / fps
    frame = keys - first
    present = {m: np.zeros(len(times), bool) for m in range(1, markers + 1)}
    for f, m in zip(frame, data[:, 1].astype(int), strict=True):
        if m in present and 0 <= f < len(times):
            present[m][f] = True
    share = {m: float(v.mean()) if len(v) else 0.0 for m, v in present.items()}
    return {'frames': len(times), 'times_s': times, 'present': present, 'share': share,
            'reconstructed': [m for m, s in share.items() if s >= 0.8]}


def plot_marker_coverage(coverage: dict[str, Any], path: Path) -> Path:
    """One row per marker: the frames in which it was reconstructed in 3D, and its share."""
    plt = _pyplot()
    marks = sorted(coverage['present'])
    fig, ax = plt.subplots(figsize=(8.0, 0.28 * len(marks) + 1.2))
    img = np.array([coverage['present'][m] for m in marks], float)
    t = coverage['times_s']
    extent = (float(t[0]), float(t[-1]), len(marks) - 0.5, -0.5) if len(t) > 1 else None
    ax.imshow(img, aspect='auto', cmap='Greens', vmin=0, vmax=1.3, extent=extent,
              interpolation='nearest')
    ax.set_yticks(range(len(marks)),
                  [f"{m} ({coverage['share'][m]:.0%})" for m in marks], fontsize=7)
    ax.set_xlabel('time of the pass [s]')
    ax.set_title(f"markers reconstructed in 3D (green): {len(coverage['reconstructed'])} of "
                 f'{len(marks)} in at least 80 % of the {coverage["frames"]} frames', fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
