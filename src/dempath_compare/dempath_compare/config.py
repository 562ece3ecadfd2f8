"""Settings of the paper's trajectory comparison.

Kuře & Kuřetová 2025, Technologies 13, 570, sec. 2.5.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import Enum
from typing import Any

from dempath_compare.errors import ConfigError


class RankBy(str, Enum):
    """Score used to rank model trajectories per experiment (paper eq. 4)."""

    SUM = 'sum'  # S_sum, total nearest-point distance
    MEAN = 'mean'  # S_mean = MAE


class Matching(str, Enum):
    """How the 'nearest corresponding point' of an experimental point is searched (paper eq. 3).

    DTW: among the model points that the DTW warping path pairs with the experimental point.
    NEAREST: among all points of the model trajectory (purely spatial).
    """

    DTW = 'dtw'
    NEAREST = 'nearest'


class Pairing(str, Enum):
    """Which model trajectories are compared with which measured marker."""

    AUTO = 'auto'  # MARKER when the model trajectories carry marker ids, else ALL
    ALL = 'all'  # every model trajectory against every experiment (the paper's folder mode)
    MARKER = 'marker'  # only model trajectories tagged with the experiment's marker id
    CUBE = 'cube'  # model trajectories starting inside the Cube region around the marker start


class DtwEngine(str, Enum):
    """Where the DTW distances of the batched path come from (identical numbers, tested)."""

    KERNEL = 'kernel'  # reuse the compiled kernel's DP (needed anyway for the warping path)
    DTAIDISTANCE = 'dtaidistance'  # dtaidistance dtw_ndim.distance_matrix_fast (C, OpenMP)


class RangeKind(str, Enum):
    """Normaliser of nRMSE ("trajectory range" in the paper's Table 7)."""

    EXTENT = 'extent'  # diagonal of the axis-aligned bounding box of the measured trajectory
    LENGTH = 'length'  # path length (sum of segment lengths) of the measured trajectory


@dataclass(frozen=True)
class CompareConfig:
    """Frozen settings of one comparison; every field is validated in ``__post_init__``.

    Attributes:
        top_n: number of best model trajectories kept per experiment (paper: 10).
        sp: sensitivity of the start-of-motion threshold v_thr = mean(v_z) + sp * std(v_z)
            over the rest phase (paper eq. 1; higher -> later detection).
        rest_samples: number of leading samples forming the rest phase of a model trajectory.
        z_weight: weight w of Z (travel) in d_i = sqrt(dx^2 + dy^2 + w dz^2) (paper eq. 3).
        rank_by: rank by S_sum or S_mean (paper eq. 4).
        matching: where the nearest corresponding model point is searched.
        pairing: which model trajectories are compared with which marker.
        cube_size: Cube region (X, Y, Z) [m] centred on a marker start (paper: 30x20x10 mm).
        trim_y_drop: trim the end of a measured trajectory once Y falls this far below its running
            maximum [m]; None disables trimming (the paper's optional, user-set trimming).
        detect_start_measured: also cut the rest phase of measured trajectories.
        mm_threshold: any |coordinate| above this [m] marks a trajectory as probably in mm.
        marker_ids: marker numbers that exist (the paper's 1-15 grid).
        range_kind: normaliser of nRMSE.
        min_points: fewest samples a trajectory needs to be scored.
        dtw_engine: source of the DTW distances in the batched path; with matching NEAREST the
            kernel builds no DTW matrix and dtaidistance is always used.
        match_speed: when both an experiment and a model run know their tool speed (run
            metadata, or names with ``identity_from_names``), compare only equal speeds.
        identity_from_names: fill what run metadata do not say from the name convention (a tool
            speed in ``experiment_1ms``, a seed in ``<scene>-s<seed>-<hash>``:
            :mod:`dempath_compare.runinfo`); off, names are never parsed.
    """

    top_n: int = 10
    sp: float = 3.0
    rest_samples: int = 5
    z_weight: float = 1.0
    rank_by: RankBy = RankBy.SUM
    matching: Matching = Matching.DTW
    pairing: Pairing = Pairing.AUTO
    cube_size: tuple[float, float, float] = (0.030, 0.020, 0.010)
    trim_y_drop: float | None = None
    detect_start_measured: bool = False
    mm_threshold: float = 5.0
    marker_ids: tuple[int, ...] = tuple(range(1, 16))
    range_kind: RangeKind = RangeKind.EXTENT
    min_points: int = 3
    match_speed: bool = True
    identity_from_names: bool = False
    dtw_engine: DtwEngine = DtwEngine.KERNEL

    def __post_init__(self) -> None:
        object.__setattr__(self, 'rank_by', _enum(RankBy, 'rank_by', self.rank_by))
        object.__setattr__(self, 'matching', _enum(Matching, 'matching', self.matching))
        object.__setattr__(self, 'pairing', _enum(Pairing, 'pairing', self.pairing))
        object.__setattr__(self, 'range_kind', _enum(RangeKind, 'range_kind', self.range_kind))
        object.__setattr__(self, 'dtw_engine', _enum(DtwEngine, 'dtw_engine', self.dtw_engine))
        object.__setattr__(self, 'cube_size', tuple(float(v) for v in self.cube_size))
        object.__setattr__(self, 'marker_ids', tuple(int(v) for v in self.marker_ids))
        checks = [
            ('top_n', self.top_n >= 1),
            ('sp', self.sp >= 0.0),
            ('rest_samples', self.rest_samples >= 2),
            ('z_weight', self.z_weight > 0.0),
            ('cube_size', len(self.cube_size) == 3 and min(self.cube_size) > 0.0),
            ('trim_y_drop', self.trim_y_drop is None or self.trim_y_drop > 0.0),
            ('mm_threshold', self.mm_threshold > 0.0),
            ('min_points', self.min_points >= 3),
        ]
        for name, ok in checks:
            if not ok:
                msg = f'CompareConfig.{name}: invalid value {getattr(self, name)!r}'
                raise ConfigError(msg)

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> CompareConfig:
        """Build from a flat mapping (ROS parameters, CLI options); unknown keys are rejected."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(params) - known)
        if unknown:
            msg = f'CompareConfig: unknown setting(s) {unknown}'
            raise ConfigError(msg)
        return cls(**params)


def _enum(kind: type[Enum], name: str, value: object) -> Any:
    try:
        return kind(value)
    except ValueError as err:
        options = [m.value for m in kind]  # type: ignore[var-annotated]
        msg = f'CompareConfig.{name}: {value!r} is not one of {options}'
        raise ConfigError(msg) from err
