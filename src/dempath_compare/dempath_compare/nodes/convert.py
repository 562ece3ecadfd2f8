"""Message <-> numpy conversions of the compare node."""

from __future__ import annotations

from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from numpy.typing import NDArray
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from dempath_compare.scoring import CompareResult
from dempath_msgs.msg import ParticleStates, TrajectoryScore, TrajectoryScoreArray


def stamp_seconds(stamp: Time) -> float:
    """A ROS time as seconds."""
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def marker_arrays(msg: Any) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """(n,) marker ids and (n, 3) m positions of a MarkerPoints3D."""
    xyz = np.stack([np.asarray(msg.x), np.asarray(msg.y), np.asarray(msg.z)], axis=1)
    return np.asarray(msg.marker_ids, dtype=np.int64), xyz.reshape(-1, 3)


def particle_arrays(msg: Any) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """(n,) ids, (n,) marker ids and (n, 3) m positions of a ParticleStates, bed particles
    (role ROLE_BED) left out."""
    ids = np.asarray(msg.ids, dtype=np.int64)
    xyz = np.asarray(msg.positions, dtype=np.float64).reshape(len(ids), 3)
    keep = np.asarray(msg.roles, dtype=np.uint8) != ParticleStates.ROLE_BED
    return ids[keep], np.asarray(msg.marker_ids, dtype=np.int64)[keep], xyz[keep]


def scores_msg(result: CompareResult, run_id: str, header: Any) -> TrajectoryScoreArray:
    """The N best model trajectories per marker (rank 1 first); a marker with a problem gets one
    invalid entry naming it."""
    out = TrajectoryScoreArray(header=header)
    s, meas, mod = result.scores, result.measured, result.model
    nrmse = s.nrmse
    for e, label in enumerate(meas.labels):
        best = result.best(e)
        if len(best) == 0:
            problem = meas.problems[e] or 'no valid model trajectory to compare with'
            out.scores.append(TrajectoryScore(header=header, experiment_id=label,
                                              marker_id=int(meas.idents[e]), model_run_id=run_id,
                                              valid=False, problem=problem,
                                              dtw_distance=float('nan'), mae=float('nan'),
                                              rmse=float('nan'), nrmse=float('nan'),
                                              trajectory_range=float(s.ranges[e])))
        for j in best:
            out.scores.append(TrajectoryScore(
                header=header, experiment_id=label, marker_id=int(meas.idents[e]),
                model_run_id=mod.groups[j], model_particle_id=int(mod.idents[j]),
                dtw_distance=float(s.dtw[e, j]), mae=float(s.s_mean[e, j]),
                rmse=float(s.rmse[e, j]), trajectory_range=float(s.ranges[e]),
                nrmse=float(nrmse[e, j]), rank=int(s.rank[e, j]), valid=True, problem=''))
    return out


def best_markers_msg(result: CompareResult, header: Any) -> MarkerArray:
    """LINE_STRIPs of each measured trajectory (white) and its N best models, placed at the
    measured marker's start so that Foxglove shows them where the marker was."""
    out = MarkerArray()
    meas, mod = result.measured, result.model
    for e in range(len(meas)):
        origin = np.nan_to_num(meas.origins[e])
        strips = [(meas.positions[e, : meas.lengths[e]], ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0),
                   0.004)]
        for k, j in enumerate(result.best(e)):
            hue = k / max(1, result.config.top_n)
            color = ColorRGBA(r=float(1 - hue), g=float(0.3 + 0.6 * hue), b=0.2, a=0.8)
            strips.append((mod.positions[j, : mod.lengths[j]], color, 0.002))
        for k, (points, color, width) in enumerate(strips):
            marker = Marker(header=header, ns=meas.labels[e], id=k, type=Marker.LINE_STRIP,
                            action=Marker.ADD, color=color)
            marker.pose.orientation.w = 1.0
            marker.scale.x = width
            marker.points = [Point(x=float(p[0]), y=float(p[1]), z=float(p[2]))
                             for p in points + origin]
            out.markers.append(marker)
    return out
