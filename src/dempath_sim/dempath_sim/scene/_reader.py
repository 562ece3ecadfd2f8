"""Strict reading of one mapping of a scene file: typed getters, ranges, unknown-key hints.

Units are SI and named by the key's suffix (``depth_m``, ``speed_m_s``, ``youngs_modulus_pa``);
a key with another unit suffix (``depth_mm``) or a value with a unit in it (``'184 mm'``) is
reported as a wrong unit, any other unknown key with the closest known key as a suggestion.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

from dempath_sim.errors import SceneError

# Unit suffixes of scene keys and the SI unit each stands for.
UNIT_SUFFIXES = {
    '_kg_m3': 'kg/m^3', '_j_m3': 'J/m^3', '_m_s2': 'm/s^2', '_m_s': 'm/s', '_pa': 'Pa',
    '_m': 'm', '_s': 's',
}
_REQUIRED = object()
# PyYAML follows YAML 1.1, which reads 1.7e6 (no dot in the mantissa or no exponent sign) as a
# string; such plain numerals are accepted as numbers.
_NUMERAL = re.compile(r'^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$')
# Unit tokens a user may append instead of the SI one (``depth_mm``), recognised as a wrong unit.
OTHER_UNITS = frozenset({
    'mm', 'cm', 'km', 'm', 'in', 'ft', 's', 'ms', 'min', 'h', 'pa', 'kpa', 'mpa', 'gpa', 'mm_s',
    'km_h', 'm_s', 'cm_s', 'mm_s2', 'm_s2', 'g_cm3', 'kg_m3', 't_m3', 'j_m3', 'kj_m3', 'deg',
    'rad', 'n', 'kn', 'g', 'kg', 'percent', 'pct',
})


def unit_of(key: str) -> str | None:
    """The SI unit that ``key``'s suffix names, or None for a plain coefficient."""
    for suffix, unit in UNIT_SUFFIXES.items():
        if key.endswith(suffix):
            return unit
    return None


def _wrong_unit_hint(key: str, allowed: Sequence[str]) -> str | None:
    for known in allowed:
        unit = unit_of(known)
        if unit is None:
            continue
        stem = known[: known.rfind(next(s for s in UNIT_SUFFIXES if known.endswith(s)))]
        rest = key[len(stem) + 1:].lower()
        if key.startswith(stem + '_') and key != known and rest in OTHER_UNITS:
            return (f'wrong unit: scene keys take SI units named by their suffix; '
                    f'use {known!r} in {unit}')
    return None


class Reader:
    """Typed access to one mapping of the scene; ``finish()`` rejects what was not read.

    Args:
        data: The mapping (from YAML).
        path: Dotted location of the mapping in the scene, for messages (``tool``).
        source: Name of the scene file, for messages.
    """

    def __init__(self, data: Any, path: str, source: str) -> None:
        if data is None:
            data = {}
        if not isinstance(data, Mapping):
            self.fail_at(path, source, f'expected a mapping, got {type(data).__name__}')
        self.data: Mapping[str, Any] = data
        self.path = path
        self.source = source
        self.seen: set[str] = set()

    @staticmethod
    def fail_at(path: str, source: str, problem: str) -> None:
        """Raise SceneError for ``path`` in ``source``."""
        raise SceneError(f'{source}: {path}: {problem}')

    def where(self, key: str) -> str:
        """Dotted name of ``key`` in the scene."""
        return f'{self.path}.{key}' if self.path else key

    def fail(self, key: str, problem: str) -> None:
        """Raise SceneError naming ``key``."""
        self.fail_at(self.where(key), self.source, problem)

    def has(self, key: str) -> bool:
        """Whether the mapping sets ``key`` (marks it as read)."""
        self.seen.add(key)
        return key in self.data and self.data[key] is not None

    def raw(self, key: str, default: Any = _REQUIRED) -> Any:
        """The value of ``key`` as YAML gave it."""
        self.seen.add(key)
        if key not in self.data or self.data[key] is None:
            if default is _REQUIRED:
                self._fail_missing(key)
            return default
        return self.data[key]

    def _fail_missing(self, key: str) -> None:
        """Report a missing key, or the present key that was probably meant for it."""
        for other in self.data:
            other = str(other)
            hint = _wrong_unit_hint(other, [key])
            if hint is None and difflib.get_close_matches(other, [key], n=1, cutoff=0.75):
                hint = f'unknown key; did you mean {key!r}?'
            if hint is not None:
                self.fail(other, hint)
        self.fail(key, 'missing required key')

    def maybe_number(self, key: str, low: float, high: float,
                     low_open: bool = False) -> float | None:
        """Like :meth:`number` but None when the key is absent or null."""
        return self.number(key, low, high, None, low_open) if self.has(key) else None

    def number(self, key: str, low: float, high: float, default: Any = _REQUIRED,
               low_open: bool = False) -> float:
        """A finite number in [low, high] (or (low, high] with ``low_open``)."""
        value = self.raw(key, default)
        unit = unit_of(key) or ''
        if isinstance(value, str) and _NUMERAL.match(value.strip()):
            value = float(value)
        if isinstance(value, bool) or not isinstance(value, int | float):
            what = f'a number in {unit}' if unit else 'a number'
            self.fail(key, f'expected {what} (units are SI, named by the key suffix), '
                           f'got {value!r}')
        x = float(value)
        bad_low = x <= low if low_open else x < low
        if not math.isfinite(x) or bad_low or x > high:
            bracket = '(' if low_open else '['
            self.fail(key, f'{x!r} {unit} is out of range {bracket}{low:g}, {high:g}] {unit}'
                      .replace(' ]', ']').replace('  ', ' '))
        return x

    def integer(self, key: str, low: int, high: int, default: Any = _REQUIRED) -> int:
        """An integer in [low, high]."""
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, f'expected an integer, got {value!r}')
        if not low <= value <= high:
            self.fail(key, f'{value!r} is out of range [{low}, {high}]')
        return int(value)

    def text(self, key: str, default: Any = _REQUIRED,
             choices: Sequence[str] | None = None) -> str:
        """A string, optionally one of ``choices``."""
        value = self.raw(key, default)
        if not isinstance(value, str):
            self.fail(key, f'expected a string, got {value!r}')
        if choices is not None and value not in choices:
            hint = difflib.get_close_matches(value, choices, n=1)
            extra = f'; did you mean {hint[0]!r}?' if hint else ''
            self.fail(key, f'{value!r} is not one of {", ".join(choices)}{extra}')
        return str(value)

    def flag(self, key: str, default: Any = _REQUIRED) -> bool:
        """A boolean."""
        value = self.raw(key, default)
        if not isinstance(value, bool):
            self.fail(key, f'expected true or false, got {value!r}')
        return bool(value)

    def vector(self, key: str, length: int, low: float, high: float,
               default: Any = _REQUIRED) -> tuple[float, ...]:
        """A list of ``length`` numbers, each in [low, high]."""
        value = self.raw(key, default)
        if not isinstance(value, list | tuple) or len(value) != length:
            self.fail(key, f'expected a list of {length} numbers, got {value!r}')
        sub = Reader({str(i): v for i, v in enumerate(value)}, self.where(key), self.source)
        return tuple(sub.number(str(i), low, high) for i in range(length))

    def section(self, key: str, required: bool = True) -> Reader:
        """The nested mapping ``key`` as a Reader (empty when absent and not required)."""
        return Reader(self.raw(key, _REQUIRED if required else {}), self.where(key),
                      self.source)

    def finish(self) -> None:
        """Raise SceneError for the first key that was never read, with a suggestion."""
        allowed = sorted(self.seen)
        for key in self.data:
            if key in self.seen:
                continue
            hint = _wrong_unit_hint(str(key), allowed)
            if hint is None:
                close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
                hint = (f'unknown key; did you mean {close[0]!r}?' if close
                        else f'unknown key; known keys: {", ".join(allowed)}')
            self.fail(str(key), hint)
