"""Published centres of markers in dim frames: the chroma floored at the frame's own light.

The detector's chroma ``(B - R) / max(B + G + R, floor)`` is shading-invariant only where a
pixel is brighter than the floor. Blue clay is dark (albedo sum 0.94 against the yellow-brown
sand's 1.72), and the light comes from above (50 degrees in the twin), so a marker's lower,
shaded side sums to less than the lit side; where it falls under the fixed floor
``MIN_SUM_DN`` its chroma is divided down, its centroid weights fall, and the centroid moves up
the image towards the lit cap. In normal light that happens to few pixels; in a dim frame
(dusk, light x0.3; a short shutter) to most of the marker. On the 23 tuning re-renders
(session 19, isolated whole markers, 865 marker-frames) the published centres lay 0.23 px up
the image from the true centres on average, and 0.4-0.6 px up on the dusk looks (their RMS
1.0-1.2 px against 0.4-0.6 px in daylight): the largest single part of the 3D error there.

The fix: where the frame's own floor (:func:`~dempath_recon.tracking.colour_model.
chroma_floor`, ``FLOOR_SHARE`` of its median ``B + G + R``) lies below the detection's floor,
each spot's centroid is computed again, from the detection's centroid, on the chroma floored at
the frame's floor, so the shaded side keeps its chroma; its mass and peak then give the seen
share (:mod:`~dempath_recon.tracking.covered`). Only the published centres
(``Detections.centre``) take these: which spots there are, their linking and numbering keep the
detection's centroids (the covered correction's lesson: a change of the trackers' centroids
moved fine numbering margins). Frames in normal light (sand summing 100 or more) keep the
detection's floor and are not touched.

Measured on those markers (the detector alone, against the truth): up-the-image bias 0.23 ->
0.07 px, RMS 0.80 -> 0.65 px; on the dusk looks 1.0-1.2 -> 0.7-0.9 px; daylight looks
unchanged. Floors of 30 and 12 DN everywhere gave the same as the frame's floor (0.67 and
0.65 px), so the frame's floor, which leaves daylight frames alone, was kept.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
Refine = Callable[[NDArray[np.float32], NDArray[np.intp], NDArray[np.intp], float],
                  tuple[FloatArray, FloatArray, FloatArray, FloatArray]]


def shade_floor(frame_floor: float, floor: float) -> float | None:
    """The chroma floor the published centres take [DN]: the frame's own ``frame_floor`` where
    it lies below the detection's ``floor`` (a dim frame), None otherwise (nothing to redo)."""
    return frame_floor if frame_floor < floor else None


def lit_centroids(lit: NDArray[np.float32], uv: FloatArray, refine: Refine, thr: float,
                  ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each spot's centroid again on ``lit``, the chroma of the detection's window floored at
    the frame's own light, starting from the detection's centroid.

    Args:
        lit: (h, w) chroma of the detection's window [-] at the lowered floor.
        uv: (n, 2) the detection's centroids in the window [detector px].
        refine: the detector's iterated weighted centroid (``MarkerDetector._refine``).
        thr: the frame's threshold [-] (as the detection's centroids used).

    Returns:
        ``(uv (n, 2) [detector px], peak (n,), mass (n,))``: the centroids, each spot's chroma
        at its start pixel and its chroma mass above the core level (for the seen share); a
        spot whose centroid is lost on ``lit`` keeps the detection's (and NaN peak and mass).
    """
    n = len(uv)
    if n == 0 or lit.size == 0:
        return uv.copy(), np.full(n, np.nan), np.full(n, np.nan)
    h, w = lit.shape
    ok = np.isfinite(uv).all(axis=1)
    rows = np.clip(np.round(np.where(ok, uv[:, 1], 0)), 0, h - 1).astype(np.intp)
    cols = np.clip(np.round(np.where(ok, uv[:, 0], 0)), 0, w - 1).astype(np.intp)
    out, _, peak, mass = refine(lit, rows, cols, thr)
    good = ok & np.isfinite(out).all(axis=1) & (mass > 0)
    return (np.where(good[:, None], out, uv), np.where(good, peak, np.nan),
            np.where(good, mass, np.nan))
