"""What the demo's stages share: the inputs, and each stage's typed result once it has run.

:class:`DemoContext` holds the demo's inputs and options and one field per stage result; each
stage (:mod:`dempath_bringup.stages`, :mod:`dempath_bringup.analysis`) reads the results of the
stages before it through :func:`need` and sets its own. The results are the records the stages'
typed calls return (the calibration's, the node graph's :class:`GraphResult`, the comparison's,
:class:`~dempath_diagnose.entry.diagnosis.DiagnosisOutcome`,
:class:`~dempath_diagnose.entry.recalibration.RecalibrationOutcome`), never files read back.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from dempath.errors import DempathError

if TYPE_CHECKING:
    from dempath_bringup.calibstep import CalibrationRun
    from dempath_bringup.nodes.graph import GraphResult
    from dempath_compare.comparison_folder import Outputs
    from dempath_compare.scoring import CompareResult
    from dempath_compare.summary import Table7
    from dempath_diagnose.entry.diagnosis import DiagnosisOutcome
    from dempath_diagnose.entry.recalibration import RecalibrationOutcome
    from dempath_diagnose.entry.requests import DiagnoseRequest

T = TypeVar('T')


@dataclass(frozen=True)
class DemoOptions:
    """The diagnosis and recalibration settings of the demo (None: the commands' defaults).

    Attributes:
        library_file: Packed signature library (the shipped one by default).
        library_root: Signature library cache folder.
        seeds: Library packing seeds.
        candidates: Candidate effects.
        strengths: Strengths per candidate (1 or 2).
        packing_cache: Packing cache folder.
        budget: Recalibration simulations.
        effect: Fit this effect whatever the diagnosis says.
        serial: Run simulations here, without Dask.
    """

    library_file: Path | None = None
    library_root: Path | None = None
    seeds: tuple[int, ...] | None = None
    candidates: tuple[str, ...] | None = None
    strengths: int | None = None
    packing_cache: Path | None = None
    budget: int = 2
    effect: str | None = None
    serial: bool = True


@dataclass(frozen=True)
class CalibrationStage:
    """The calibration stage's result.

    Attributes:
        run: The calibration of the recording (result, board views, field segment start).
        stereo_yaml: The stereo calibration written for the nodes.
        truth: The checks against the synthetic recording's true cameras (empty: no truth).
    """

    run: CalibrationRun
    stereo_yaml: Path
    truth: list[dict[str, Any]]

    @property
    def result(self) -> Any:
        """The calibrator's result (``dempath_calib.calibrator.CalibrationResult``)."""
        return self.run.result


@dataclass(frozen=True)
class ComparisonStage:
    """A comparison of the recorded markers with a model run, and its Table 7.

    Attributes:
        result: The comparison.
        table7: The paper's Table 7 of it.
        outputs: The files written (None: nothing written, the 'after' comparison).
    """

    result: CompareResult
    table7: Table7
    outputs: Outputs | None = None


@dataclass(frozen=True)
class DiagnosisStage:
    """The diagnosis stage's result: the outcome, or why there is none.

    Attributes:
        request: What the diagnosis was (or would have been) asked.
        outcome: The diagnosis (None: not run).
        missing: Why it did not run ('' when it did).
    """

    request: DiagnoseRequest
    outcome: DiagnosisOutcome | None = None
    missing: str = ''


@dataclass
class DemoContext:
    """What the stages share: inputs, options, the output folder and each stage's result.

    Attributes:
        calib_source: bag or frame folder with the board views (the field bag itself when it
            starts with a board segment).
        field_bag: the field recording (images, or clicked pixel points with ``clicked``).
        clicked: play the bag's pixel points instead of detecting markers in its images.
        options: the diagnosis and recalibration settings (``analysis`` reads them).
        progress: ``progress(description, total)`` context manager factory for long stages.
        calibration, graph, comparison, diagnosis, recalibration, after: the stages' results
            (None until the stage has run, or when it was skipped).
        traj_rms_mm: RMS of the reconstructed markers from the recording's truth [mm].
        surface_coverage: (reconstructed, markers) over the frames the truth has each marker
            on the surface (a rendered twin's truth only).
        measured_csv: The recorded 3D markers as the diagnosis reads them.
        stage_s: Seconds of each finished stage.
    """

    calib_source: Path
    field_bag: Path
    scene: str
    out: Path
    rate: float
    clicked: bool = False
    options: DemoOptions = field(default_factory=DemoOptions)
    progress: Callable[..., Any] | None = None
    calibration: CalibrationStage | None = None
    graph: GraphResult | None = None
    traj_rms_mm: float | None = None
    surface_coverage: tuple[int, int] | None = None
    comparison: ComparisonStage | None = None
    measured_csv: Path | None = None
    diagnosis: DiagnosisStage | None = None
    recalibration: RecalibrationOutcome | None = None
    after: ComparisonStage | None = None
    stage_s: dict[str, float] = field(default_factory=dict)


def need(value: T | None, stage: str) -> T:
    """The result of an earlier stage.

    Raises:
        DempathError: That stage has not run (the stages run in order; a step list that leaves
            it out cannot run this one).
    """
    if value is None:
        msg = f'the {stage} stage has not run before this one'
        raise DempathError(msg)
    return value
