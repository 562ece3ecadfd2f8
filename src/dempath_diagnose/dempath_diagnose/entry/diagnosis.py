"""``run_diagnosis(DiagnoseRequest) -> DiagnosisOutcome``: the whole diagnosis as one typed call.

What ``dempath diagnose`` does after parsing its options: read the measured pass (and the
force), check it against the scene, find (or build) the signature library that covers it,
diagnose, spend the simulation budget where it would settle an open answer, and write
diagnosis.json, report.md, the plots and the workbook. :func:`diagnosis_of` is the same without
the outputs (what the recalibration builds on). Faults of single markers are warned about on
stderr and the rest is still diagnosed; bad input raises a :class:`~dempath.errors.DempathError`
naming the input.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from dempath_diagnose.admission import check_force_time_base, markers_in_bin
from dempath_diagnose.decision.diagnosis import CaseGeometry, Diagnosis, diagnose
from dempath_diagnose.decision.measure import load_force, load_tracks
from dempath_diagnose.entry.library_build import ensure_library, library_executor
from dempath_diagnose.entry.requests import DiagnoseRequest
from dempath_diagnose.errors import MeasurementError
from dempath_diagnose.headline.stage import with_headline
from dempath_diagnose.library.simulator import (
    SceneSpec,
    load_scene,
    pass_travel_s,
    tool_geometry,
)
from dempath_diagnose.library.store import Library, LibrarySpec, covering_duration
from dempath_diagnose.records import Measurement

MAX_FOLLOW_S = 5.0  # the model follows the bed at most this long after the tool stops [s]


@dataclass(frozen=True)
class DiagnosisOutcome:
    """A diagnosis with what it rests on.

    Attributes:
        request: What was asked.
        scene: The scene.
        spec: The library design that covers the measured window.
        library: The library the diagnosis used (extended when the budget was spent).
        diagnosis: The decision, the statistics and where the model fails.
        data: diagnosis.json's content (empty when nothing was written).
    """

    request: DiagnoseRequest
    scene: SceneSpec
    spec: LibrarySpec
    library: Library
    diagnosis: Diagnosis
    data: dict[str, Any] = field(default_factory=dict)

    @property
    def folder(self) -> Path:
        """Where the outputs are."""
        return self.request.out


def run_diagnosis(request: DiagnoseRequest) -> DiagnosisOutcome:
    """The whole diagnosis; writes its outputs into ``request.out``.

    Raises:
        DempathError: Bad input (one line naming it), or outputs that cannot be written.
    """
    t0 = time.monotonic()
    outcome = diagnosis_of(request)
    result = outcome.diagnosis
    result.wall_s = time.monotonic() - t0
    from dempath_diagnose.report.diagnosis_outputs import write_outputs

    extra: dict[str, Any] = {'scene': outcome.scene.name, 'library': str(outcome.library.folder),
                             'allowance': vars(request.allowance), 'backend': request.backend,
                             'held_out': list(request.held_out)}
    if result.adaptive:
        extra['adaptive'] = result.adaptive
    if request.export_library is not None:
        extra['exported_library'] = export(request, outcome.library, result,
                                           tool_geometry(outcome.scene)[2])
    return replace(outcome, data=write_outputs(result, request.out, extra))


def library_spec(request: DiagnoseRequest, scene: SceneSpec, meas: Measurement) -> LibrarySpec:
    """The library design that covers the measured window (duration rounded up)."""
    travel = pass_travel_s(scene, {})
    end = float(meas.times[-1])
    if end > travel + MAX_FOLLOW_S:
        msg = (f'{request.measured}: the measured window lasts {end:.2f} s, longer than the '
               f'model can run (travel {travel:.2f} s + at most {MAX_FOLLOW_S:g} s after the '
               'stop)')
        raise MeasurementError(msg)
    duration = covering_duration(travel, end)
    return LibrarySpec(seeds=request.seeds, candidates=request.candidates,
                       duration_s=round(duration, 6), n_strengths=request.strengths)


def measurement_of(request: DiagnoseRequest, scene: SceneSpec) -> Measurement:
    """The measured pass in the scene frame, markers outside the bin and faulty ones left out
    (each said on stderr), with the measured force when one is given."""
    meas = markers_in_bin(request.measured, load_tracks(request.measured, request.origin), scene)
    if meas.time_origin:
        print(f'{request.measured}: {meas.time_origin}', file=sys.stderr)
    for marker, problem in sorted(meas.problems.items()):
        print(f'warning: {request.measured}: marker {marker}: {problem} (left out)',
              file=sys.stderr)
    if request.held_out:
        meas, held = meas.split(request.held_out)
        missing = sorted(set(request.held_out) - {int(m) for m in held.markers})
        if missing or len(meas.markers) < 2:
            msg = (f'--held-out {",".join(map(str, request.held_out))}: '
                   + (f'marker(s) {missing} not in {request.measured}' if missing else
                      f'leaves {len(meas.markers)} marker(s) to diagnose'))
            raise MeasurementError(msg)
        print(f'markers {", ".join(map(str, request.held_out))} held out of the diagnosis and '
              'the fit (scored apart)', file=sys.stderr)
    if request.force is not None:
        t, f = load_force(request.force)
        check_force_time_base(request.force, t, meas.times)
        meas = replace(meas, force_times=t, force=f)
    return meas


def diagnosis_of(request: DiagnoseRequest) -> DiagnosisOutcome:
    """The diagnosis of ``request`` without writing it: scene, library design, library (built
    when needed), diagnosis (what ``dempath recalibrate`` builds on)."""
    scene = load_scene(request.scene)
    meas = measurement_of(request, scene)
    spec = library_spec(request, scene, meas)
    library = ensure_library(request, scene, spec)  # a given library is only read
    library.check_scene(scene)  # before any diagnosis is computed or written
    tool_x, half_width, cube = tool_geometry(scene)
    geometry = CaseGeometry(tool_x, half_width, cube)

    def again(lib: Library) -> Diagnosis:
        return with_headline(diagnose(meas, lib, geometry, request.allowance, request.windows,
                                      str(request.force)), lib, cube, request.allowance.noise_m)

    result = again(library)
    result.simulations = len(library.runs)
    if request.budget > 0:
        result, library = spend_budget(request, scene, spec, library, result, again)
    if request.model is not None:
        result.table7 = own_model_table7(request.model, request.model_map, meas, cube)
    return DiagnosisOutcome(request, scene, spec, library, result)


def export(request: DiagnoseRequest, library: Library, result: Diagnosis,
           cube: tuple[float, float, float]) -> dict[str, Any]:
    """Pack the library for the measured markers (and the export box) into the export file."""
    from dempath_diagnose.library.packed import export_library

    assert request.export_library is not None
    box = None if request.export_box is None else np.array(
        [request.export_box[:3], request.export_box[3:]])
    summary = export_library(library, request.export_library, cube, result.layout.starts,
                             request.export_margin, box)
    print(f'packed library: {summary["path"]} ({summary["bytes"] / 1e6:.2f} MB, '
          f'{summary["runs"]} runs, {summary["particles_min"]}-{summary["particles_max"]} '
          'particles each)', file=sys.stderr)
    return summary


def own_model_table7(model: Path, model_map: Path | None, meas: Measurement,
                     cube: tuple[float, float, float]) -> dict[str, Any]:
    """The paper's Table 7 of the user's own model run (read as dempath compare reads a model)
    against the measured markers: each marker's Cube candidates in that run."""
    from dempath_compare.foreign import load_mapping
    from dempath_compare.loaders import MODEL, load_source
    from dempath_diagnose.decision.bandtracks import band_table7, model_record

    mapping = load_mapping(model_map) if model_map is not None else None
    record = model_record(load_source(model, MODEL, mapping))
    table = band_table7(meas, [record], cube, [model.stem])
    return {**table, 'model': str(model)}


def spend_budget(request: DiagnoseRequest, scene: SceneSpec, spec: LibrarySpec,
                 library: Library, first: Diagnosis,
                 again: Callable[[Library], Diagnosis]) -> tuple[Diagnosis, Library]:
    """Simulations beyond the library where they would settle an open answer
    (:mod:`dempath_diagnose.adaptive`), through the library's executor (Dask or serial)."""
    from contextlib import ExitStack

    from dempath_diagnose.adaptive import refine
    from dempath_diagnose.library.store import extend_library

    with ExitStack() as stack:
        executor, worker_cache = library_executor(request, stack)

        def extend(lib: Library, additions: list[tuple[str, float]], seeds: int) -> Library:
            for name, x in additions:
                print(f'{scene.name}: simulating {name} at {x:.4g} on {seeds} seeds',
                      file=sys.stderr)
            return extend_library(lib, scene, spec, additions, seeds, executor,
                                  request.packing_cache, worker_cache, request.backend)

        final, library, outcome = refine(first, library, again, extend, request.budget)
    final.adaptive = outcome.to_dict()
    print(f'{scene.name}: {outcome.used} simulations beyond the library; {outcome.stop}',
          file=sys.stderr)
    return final, library
