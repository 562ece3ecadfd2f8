"""Streaming reconstruction of marker points: the core of the reconstruction node.

One frame of pixel points at a time (``MarkerStream.update``) for the node, and the batch form
``reconstruct_sequence`` for offline tools, built on it. Each output carries per-point 1-sigma
uncertainty propagated from the pixel noise, and every dropped point is counted with its reason.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath.sync import StampSync
from dempath_recon.methods.registry import METHODS, load_calibration, load_reconstructor
from dempath_recon.methods.triangulate import reprojection_errors, split_views
from dempath_recon.methods.uncertainty import CLICK_SIGMA_PX, propagate, sigma_from_covariance
from dempath_recon.pairing import PairedFrame, PixelFrame, match_ids

FloatArray = NDArray[np.float64]
logger = logging.getLogger(__name__)

REASON_NAN = 'NaN pixel'
REASON_OUTSIDE = ('outside the side image', 'outside the front image')
REASON_FAILED = 'reconstruction gave no finite point'


@dataclass(frozen=True)
class StreamConfig:
    """Settings of the reconstruction node (validated on construction).

    Attributes:
        method: one of ``dempath_recon.methods.registry.METHODS``.
        calibration_file: stereo YAML (needed by the triangulation methods; optional otherwise,
            where it gives image sizes and reprojection errors).
        model_file: trained model (needed by ``mlp`` and ``dlt_residual``).
        slop_s: largest stamp difference of the two cameras' frames in a pair [s].
        sigma_x_px: 1-sigma pixel noise along x [px] (the paper's clicking: 2.36).
        sigma_y_px: 1-sigma pixel noise along y [px] (the paper's clicking: 2.75).
        image_width: image width [px] when no calibration gives it.
        image_height: image height [px] when no calibration gives it.
        queue_size: frames kept per camera while waiting for a partner.
        device: torch device of the learned methods.
    """

    method: str = 'dlt'
    calibration_file: str = ''
    model_file: str = ''
    slop_s: float = 0.01
    sigma_x_px: float = CLICK_SIGMA_PX[0]
    sigma_y_px: float = CLICK_SIGMA_PX[1]
    image_width: int = 1920
    image_height: int = 1080
    queue_size: int = 16
    device: str = 'cpu'

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            msg = f'method: unknown {self.method!r}; known: {", ".join(METHODS)}'
            raise ValueError(msg)
        for name in ('slop_s', 'sigma_x_px', 'sigma_y_px'):
            if not getattr(self, name) >= 0.0:
                msg = f'{name}: must be >= 0, got {getattr(self, name)!r}'
                raise ValueError(msg)
        if self.image_width <= 0 or self.image_height <= 0 or self.queue_size < 1:
            msg = (f'image_width/image_height/queue_size: must be positive, got '
                   f'{self.image_width}/{self.image_height}/{self.queue_size}')
            raise ValueError(msg)

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> StreamConfig:
        """Build from a name -> value mapping (the node's declared parameters)."""
        known = cls.__dataclass_fields__
        return cls(**{k: v for k, v in params.items() if k in known})


@dataclass(frozen=True)
class MarkerFrame3D:
    """Reconstructed markers of one instant.

    Attributes:
        stamp_s: stamp [s].
        ids: (k,) marker ids.
        xyz: (k, 3) world points [m].
        sigma: (k, 3) 1-sigma uncertainty [m].
        reprojection_error: (k,) mean over both views [px]; NaN when no cameras are known.
        rejected: reason -> number of points dropped in this frame.
    """

    stamp_s: float
    ids: NDArray[np.int64]
    xyz: FloatArray
    sigma: FloatArray
    reprojection_error: FloatArray
    rejected: dict[str, int]


def reject_pixels(pixels: FloatArray, sizes: Sequence[tuple[int, int]]) -> NDArray[np.object_]:
    """Reason each pixel pair cannot be used ('' when usable).

    Args:
        pixels: (n, 4) px = (xs, ys, xf, yf).
        sizes: ((width, height) side, (width, height) front) [px].

    Returns:
        (n,) reasons: '', 'NaN pixel', 'outside the side image' or 'outside the front image'.
    """
    reasons = np.full(len(pixels), '', dtype=object)
    for cam in (1, 0):
        uv = pixels[:, 2 * cam:2 * cam + 2]
        w, h = sizes[cam]
        with np.errstate(invalid='ignore'):
            out = (uv[:, 0] < 0) | (uv[:, 0] > w) | (uv[:, 1] < 0) | (uv[:, 1] > h)
        reasons[out] = REASON_OUTSIDE[cam]
    reasons[~np.isfinite(pixels).all(axis=1)] = REASON_NAN
    return reasons


class MarkerStream:
    """Pairs the cameras' frames and reconstructs the markers with uncertainty.

    Args:
        reconstructor: fitted method with ``predict(pixels (n, 4) px) -> (n, 3) m``.
        slop_s: pairing tolerance [s].
        sigma_px: (x, y) 1-sigma pixel noise [px].
        sizes: image sizes ((w, h) side, (w, h) front) [px].
        cameras: cameras for reprojection errors (None: taken from the reconstructor if any).
        queue_size: frames kept per camera while waiting for a partner.
    """

    def __init__(self, reconstructor: Any, slop_s: float, sigma_px: tuple[float, float],
                 sizes: Sequence[tuple[int, int]], cameras: Sequence[Any] | None = None,
                 queue_size: int = 16) -> None:
        self.reconstructor = reconstructor
        self.sync: StampSync[PixelFrame] = StampSync(slop_s, queue_size)
        self.sigma_px = sigma_px
        self.sizes = tuple(sizes)
        self.cameras = cameras if cameras is not None else getattr(reconstructor, 'cameras_',
                                                                   None)
        self.rejected: Counter[str] = Counter()  # totals over the stream

    @classmethod
    def from_config(cls, cfg: StreamConfig) -> MarkerStream:
        """Load the method's files and build the stream (raises ModelFileError on bad files)."""
        rec = load_reconstructor(cfg.method, cfg.calibration_file, cfg.model_file, cfg.device)
        cams = getattr(rec, 'cameras_', None)
        if cams is None and cfg.calibration_file:
            cams = load_calibration(cfg.calibration_file).cameras
        sizes = [(c.width, c.height) for c in cams] if cams is not None else \
            [(cfg.image_width, cfg.image_height)] * 2
        return cls(rec, cfg.slop_s, (cfg.sigma_x_px, cfg.sigma_y_px), sizes, cams,
                   cfg.queue_size)

    def update(self, frame: PixelFrame) -> list[MarkerFrame3D]:
        """Add one camera frame; return the reconstructed instant it completes, if any."""
        out = self.sync.update(frame.camera, frame.stamp_s, frame)
        pairs = [p for s in out if (p := s.pair()) is not None]
        return [self.reconstruct_pair(match_ids(side, front)) for side, front in pairs]

    def reconstruct_pair(self, pair: PairedFrame) -> MarkerFrame3D:
        """Reject unusable points, reconstruct the rest, attach uncertainty."""
        rejected = Counter(pair.rejected)
        reasons = reject_pixels(pair.pixels, self.sizes)
        rejected.update(r for r in reasons if r)
        ok = reasons == ''
        pixels, ids = pair.pixels[ok], pair.ids[ok]
        xyz = self.reconstructor.predict(pixels) if len(pixels) else np.zeros((0, 3))
        good = np.isfinite(xyz).all(axis=1)
        rejected[REASON_FAILED] += int((~good).sum())
        pixels, ids, xyz = pixels[good], ids[good], xyz[good]
        if len(pixels):
            sigma = sigma_from_covariance(propagate(self.reconstructor, pixels, self.sigma_px))
        else:
            sigma = np.zeros((0, 3))
        if self.cameras is not None and len(pixels):
            reproj = reprojection_errors(self.cameras, split_views(pixels), xyz)
        else:
            reproj = np.full(len(pixels), np.nan)
        counts = {k: v for k, v in rejected.items() if v}
        self.rejected.update(counts)
        return MarkerFrame3D(pair.stamp_s, ids, xyz, sigma, reproj, counts)


def reconstruct_sequence(stream: MarkerStream,
                         frames: Iterable[PixelFrame]) -> list[MarkerFrame3D]:
    """Batch form: every frame in arrival order through ``stream.update``."""
    return [out for f in frames for out in stream.update(f)]

