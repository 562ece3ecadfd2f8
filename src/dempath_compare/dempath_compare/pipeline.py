"""The whole comparison in one call: load, check, preprocess, score, rank."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

from dempath_compare.config import CompareConfig
from dempath_compare.foreign import ExportMapping
from dempath_compare.loaders import load_source
from dempath_compare.preprocess import prepare_set
from dempath_compare.records import MEASURED, MODEL, Track
from dempath_compare.scoring import CompareResult, score_sets


class Problem(NamedTuple):
    """A trajectory that was not scored (problem) or scored with a warning (note)."""

    kind: str
    label: str
    problem: str
    note: str


def compare_tracks(measured: Sequence[Track], model: Sequence[Track],
                   config: CompareConfig | None = None) -> CompareResult:
    """Prepare (checks, start of motion, trimming, shift to origin) and score tracks.

    Args:
        measured: measured marker tracks as loaded.
        model: model particle tracks as loaded.
        config: settings; the paper's defaults when None.
    """
    config = config or CompareConfig()
    return score_sets(prepare_set(measured, MEASURED, config), prepare_set(model, MODEL, config),
                      config)


def compare_paths(measured: str | Path, model: str | Path,
                  config: CompareConfig | None = None,
                  model_map: ExportMapping | None = None) -> CompareResult:
    """Load both sides (CSV file, CSV folder or bag each) and compare them.

    Args:
        measured: The measured source.
        model: The model source; also a LIGGGHTS dump or a foreign CSV export read through
            ``model_map`` (:mod:`dempath_compare.foreign`).
        config: The comparison settings (defaults when None).
        model_map: How to read a foreign model export.

    Raises:
        InputError: a source is missing, empty or unreadable.
    """
    names = (config or CompareConfig()).identity_from_names
    return compare_tracks(load_source(measured, MEASURED, from_names=names),
                          load_source(model, MODEL, model_map, names), config)


def problems(result: CompareResult) -> list[Problem]:
    """Every trajectory with a problem or a note, measured first."""
    out = []
    for kind, tset in ((MEASURED, result.measured), (MODEL, result.model)):
        for label, problem, note in zip(tset.labels, tset.problems, tset.notes, strict=True):
            if problem or note:
                out.append(Problem(kind, label, problem, note))
    return out
