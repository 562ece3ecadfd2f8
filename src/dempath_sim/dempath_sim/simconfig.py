"""Configuration of the simulation node, validated in the core (the node only declares it)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dempath_sim.scene import SceneError, SceneSpec, parse_overrides, resolve_scene


@dataclass(frozen=True)
class SimulatorConfig:
    """What the simulation node runs.

    Attributes:
        scene: Scene file or shipped scene name.
        seed: Packing seed; -1 keeps the scene's.
        effects: Parameter overrides ``EFFECT.PARAM=VALUE``.
        off: Effects switched off.
        cache_dir: Packing cache directory; '' for the default.
        candidates: Whether candidates are published with the markers.
        viz_every: Publish the MarkerArray every this many frames.
        wait_for_subscribers: Subscribers each data topic needs before the first frame (a
            recorder that discovers topics periodically would otherwise miss the first ones).
        wait_timeout_s: Longest wait for them [s]; the run starts anyway after it.
    """

    scene: str = 'tiny'
    seed: int = -1
    effects: tuple[str, ...] = ()
    off: tuple[str, ...] = ()
    cache_dir: str = ''
    candidates: bool = True
    viz_every: int = 5
    wait_for_subscribers: int = 0
    wait_timeout_s: float = 10.0

    def __post_init__(self) -> None:
        if not self.scene:
            raise ValueError('SimulatorConfig.scene: empty; give a scene file or name')
        if self.seed < -1:
            raise ValueError(f'SimulatorConfig.seed: {self.seed!r} must be >= -1')
        if self.viz_every < 1:
            raise ValueError(f'SimulatorConfig.viz_every: {self.viz_every!r} must be >= 1')
        if self.wait_for_subscribers < 0 or not self.wait_timeout_s >= 0:
            raise ValueError('SimulatorConfig.wait_for_subscribers / wait_timeout_s: '
                             f'{self.wait_for_subscribers!r} / {self.wait_timeout_s!r} must be '
                             '>= 0')

    @classmethod
    def from_params(cls, values: Mapping[str, Any]) -> SimulatorConfig:
        """Build from parameter values (string lists; empty strings are dropped)."""
        def strings(key: str) -> tuple[str, ...]:
            return tuple(s for s in values.get(key, ()) if s)

        return cls(scene=str(values['scene']), seed=int(values.get('seed', -1)),
                   effects=strings('effects'), off=strings('off'),
                   cache_dir=str(values.get('cache_dir', '')),
                   candidates=bool(values.get('candidates', True)),
                   viz_every=int(values.get('viz_every', 5)),
                   wait_for_subscribers=int(values.get('wait_for_subscribers', 0)),
                   wait_timeout_s=float(values.get('wait_timeout_s', 10.0)))

    def load_scene(self) -> SceneSpec:
        """The scene with this config's overrides applied.

        Raises:
            SceneError: Bad scene file, name or override.
        """
        scene = resolve_scene(self.scene).with_overrides(
            parse_overrides(list(self.effects)), off=self.off,
            seed=None if self.seed < 0 else self.seed)
        if not self.candidates:
            from dataclasses import replace

            scene = replace(scene, output=replace(scene.output, candidates=False))
        return scene

    @property
    def cache_path(self) -> Path | None:
        """The cache directory, or None for the default."""
        return Path(self.cache_dir) if self.cache_dir else None


__all__ = ['SceneError', 'SimulatorConfig']
