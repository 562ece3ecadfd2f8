"""The tool's speed bounds how far a marker can move in one camera's image between two frames.

Markers move with the sand, and the sand in front of a tine is pushed by it: it does not outrun
the tool by much. On the tuning looks (session 18, 16 looks, tools at 0.5, 1.0 and 1.75 m/s,
3,378 right links of numbered tracks) a marker's image speed from one sighting to the next,
taken at the grid's depth, stayed within 0.89 of the tool's speed (99 % within 0.6), while
links that moved a number onto another marker reached 1.0-2.3 times it: a track whose marker
is covered takes a neighbour a pitch away within one frame, which no marker can have reached.
So with the tool's speed known (the user sets it on the tractor), a link farther from the
track's last position than ``OUTRUN`` times that speed over the time since, plus
``linker.SLACK_PX`` for the centroid's noise and a covered marker's shifting visible part, is not
made (:class:`~dempath_recon.tracking.linker.MarkerTracker` takes the bound as
``TrackerConfig.max_image_speed_px_s``).

:func:`camera_tracker` gives each camera's linker its settings in that camera's image scale:
this bound, and the distance within which another track's prediction keeps a spot from being
held before the assignment (``TrackerConfig.hold_rival_px``, a marker's image diameter).

The image scale is the camera's at the grid's median depth (``f / Z``, the scale the detector's
expected marker size uses); a marker lifted towards the camera looks faster by the ratio of
depths, a few per cent at the tiny scene's 0.3-0.5 m, inside ``OUTRUN``'s margin.
"""

from __future__ import annotations

from dataclasses import replace

from dempath_recon.methods.triangulate import Camera
from dempath_recon.tracking.associate import MarkerGrid, marker_diameter_px
from dempath_recon.tracking.linker import TrackerConfig

OUTRUN = 1.2  # fastest marker as a share of the tool's speed (0.89 seen on the tuning looks)


def image_speed_bound(cam: Camera, grid: MarkerGrid, tool_speed_m_s: float) -> float:
    """The fastest a marker can move in ``cam``'s image [px/s]: ``OUTRUN`` times the tool's
    speed [m/s] at the grid's median depth; 0 (no bound) when the speed is not known (0)."""
    if tool_speed_m_s <= 0:
        return 0.0
    return OUTRUN * tool_speed_m_s * marker_diameter_px(cam, grid, 1.0)


def bounded_tracker(config: TrackerConfig, cam: Camera, grid: MarkerGrid,
                    tool_speed_m_s: float) -> TrackerConfig:
    """``config`` with ``cam``'s image speed bound from the tool's speed, unless it sets one."""
    if config.max_image_speed_px_s > 0:
        return config
    return replace(config, max_image_speed_px_s=image_speed_bound(cam, grid, tool_speed_m_s))


def camera_tracker(config: TrackerConfig, cam: Camera, grid: MarkerGrid, tool_speed_m_s: float,
                   marker_diameter_m: float) -> TrackerConfig:
    """One camera's linker settings: the speed bound (:func:`bounded_tracker`) and, unless
    set, the rival distance of a held link (``TrackerConfig.hold_rival_px``): the markers'
    diameter in ``cam``'s image at the grid's depth (fast markers crossing: a prediction
    within 2 px of a spot another track predicts within a marker's width proves nothing)."""
    config = bounded_tracker(config, cam, grid, tool_speed_m_s)
    if config.hold_rival_px is not None:
        return config
    return replace(config, hold_rival_px=marker_diameter_px(cam, grid, marker_diameter_m))
