"""The requests of the typed entry points: what a diagnosis and a recalibration are asked to do.

Frozen records of plain typed values, as the commands take them (SI units); the commands parse
their options into them, the demo builds them directly. Their checks run when they are made, so
a bad option fails before any work.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from dempath_diagnose.decision.emulator import Allowance
from dempath_diagnose.errors import DiagnosisError
from dempath_diagnose.library.packed import DEFAULT_MARGIN_M
from dempath_diagnose.library.simulator import LIBRARY_CANDIDATES

DEFAULT_SEEDS = (1001, 1002, 1003)  # the library's packing seeds
DEFAULT_BUDGET = 6  # simulations beyond the library (two strengths on the default 3 seeds)
Box = tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class DiagnoseRequest:
    """Everything a diagnosis needs, as ``dempath diagnose`` takes it (SI units).

    Attributes:
        measured: CSV t,marker,x,y,z [s, m] or a bag with MarkerPoints3D.
        scene: Scene file or shipped scene (``builtin:tiny``).
        out: Output folder.
        force: CSV t,Fx,Fy,Fz [s, N] of the force on the tool, or None.
        origin: The measured frame's origin in the scene frame [m].
        library: A packed library file or library folder to use as it is (never built).
        library_root: Signature library cache folder (None: the default).
        packing_cache: Packing cache folder (None: the default).
        backend: Engine of the library's runs (``dempath`` or ``liggghts``).
        seeds: Library packing seeds.
        candidates: Candidate effects of the library.
        strengths: Strengths per candidate (1 or 2).
        windows: Time windows of the statistics.
        allowance: Measurement noise and model-discrepancy allowance.
        serial: Run the library here, without Dask.
        scheduler: Dask scheduler address (None: a local cluster).
        workers: Local Dask workers (0: by cores).
        budget: Simulations allowed beyond the library where they would settle an open answer.
        model: The paper's Table 7 against this model run of the user's instead of the
            library's baseline band (dempath CSV, LIGGGHTS dump or mapped EDEM/Rocky CSV).
        model_map: How to read ``model`` (columns, units, axes).
        export_library: Also pack the library into this file for the measured markers' region.
        export_margin: Packed: particles within this of a marker's cube are kept [m].
        export_box: Packed: also keep the particles starting in this box, X0,Y0,Z0,X1,Y1,Z1 [m].
        held_out: Markers left out of the diagnosis and of any fit built on it, scored apart
            before and after the fit (the held-out check).
    """

    measured: Path
    scene: str
    out: Path
    force: Path | None = None
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    library: Path | None = None
    library_root: Path | None = None
    packing_cache: Path | None = None
    backend: str = 'dempath'
    seeds: tuple[int, ...] = DEFAULT_SEEDS
    candidates: tuple[str, ...] = LIBRARY_CANDIDATES
    strengths: int = 2
    windows: int = 4
    allowance: Allowance = field(default_factory=Allowance)
    serial: bool = False
    scheduler: str | None = None
    workers: int = 0
    budget: int = 0
    model: Path | None = None
    model_map: Path | None = None
    export_library: Path | None = None
    export_margin: float = DEFAULT_MARGIN_M
    export_box: Box | None = None
    held_out: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.budget < 0:
            raise DiagnosisError(f'--budget {self.budget}: must be >= 0')
        if len(set(self.held_out)) != len(self.held_out) or any(m < 1 for m in self.held_out):
            raise DiagnosisError(f'--held-out {self.held_out}: distinct marker numbers >= 1')


@dataclass(frozen=True)
class RecalibrationRequest:
    """What ``dempath recalibrate`` is asked to do, beside the diagnosis it builds on.

    Attributes:
        diagnose: The diagnosis' request; its ``out`` is the recalibration's output folder.
        diagnosis_file: diagnosis.json of an earlier diagnosis that names the candidates.
        effects: (candidate, start value or None) to fit, tried in turn; empty: the diagnosis'.
        also: Existing parameters of the scene refitted beside the effect (CMA-ES).
        budget: At most this many simulations.
        seeds_per_eval: Library packing seeds per real evaluation (paired with the baseline).
    """

    diagnose: DiagnoseRequest
    diagnosis_file: Path | None = None
    effects: tuple[tuple[str, float | None], ...] = ()
    also: tuple[str, ...] = ()
    budget: int = 12
    seeds_per_eval: int = 2

    def __post_init__(self) -> None:
        if self.budget <= 0:
            raise DiagnosisError(f'--budget {self.budget}: must be a positive number of '
                                 'simulations')
        if self.seeds_per_eval <= 0:
            raise DiagnosisError(f'--seeds-per-eval {self.seeds_per_eval}: must be positive')

    @property
    def out(self) -> Path:
        """The output folder."""
        return self.diagnose.out
