"""A scene run into a folder: ``run_to_folder(SimulateRequest) -> SimulationOutcome``.

What ``dempath simulate`` does after parsing its options, as one typed call (the demo's model
after the recalibration calls it too): the scene run on dempath's engine (its packing cached),
and ``model.csv`` (t,id,marker,x,y,z), ``markers.csv``, ``tool.csv``, ``result.npz`` and
``summary.json`` written whole into the folder, with the VTK series of the bed and the tool when
asked for (:mod:`dempath_sim.runs.vtk`).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dempath.outputs import staged_output
from dempath_sim.engine import TriangleMesh
from dempath_sim.runs.backend import Progress, RunOptions
from dempath_sim.runs.native import run_scene
from dempath_sim.runs.results import SimResult
from dempath_sim.runs.vtk import VtkOutput, write_vtk
from dempath_sim.scene import SceneSpec

SUMMARY = 'summary.json'  # the run's manifest, written last


@dataclass(frozen=True)
class SimulateRequest:
    """One scene to run into a folder.

    Attributes:
        scene: The scene, with its overrides and seed already set.
        out: Output folder (None: ``./sim_<scene>_s<seed>``).
        cache_dir: Packing cache folder (None: the default).
        vtk: Also write the bed snapshots (with radii) and the tool per snapshot as VTK.
    """

    scene: SceneSpec
    out: Path | None = None
    cache_dir: Path | None = None
    vtk: bool = False

    @property
    def folder(self) -> Path:
        """Where the outputs go."""
        return self.out or Path(f'sim_{self.scene.name}_s{self.scene.seed}')


@dataclass(frozen=True)
class SimulationOutcome:
    """A run written into its folder.

    Attributes:
        result: The run's tracked trajectories and metadata.
        summary: summary.json's content.
        folder: Where the outputs are.
        vtk: The VTK series (None unless asked for).
    """

    result: SimResult
    summary: dict[str, Any]
    folder: Path
    vtk: VtkOutput | None = None


def run_to_folder(request: SimulateRequest,
                  progress: Callable[[Progress], None] | None = None) -> SimulationOutcome:
    """Run the scene and write its outputs whole into the request's folder.

    Raises:
        DempathError: The run fails (unstable set-up, no particle near a marker, bad STL).
        OSError: The folder cannot be written.
    """
    scene = request.scene
    result = run_scene(scene, RunOptions(cache_dir=request.cache_dir, progress=progress))
    tool = (TriangleMesh.from_stl(scene.tool.mesh, scale=scene.tool.scale).triangles
            if request.vtk else None)
    summary, vtk = write_run_folder(result, request.folder, tool)
    return SimulationOutcome(result, summary, request.folder, vtk)


def write_run_folder(result: SimResult, out: Path, tool: Any = None,
                     ) -> tuple[dict[str, Any], VtkOutput | None]:
    """Write a run's outputs whole into ``out`` (staged beside it and installed at the end, with
    ``summary.json`` last as the manifest readers check); with ``tool`` ((n, 3, 3) triangles
    [m]) also the VTK series in ``out/vtk``. Returns the summary and the VTK outputs."""
    summary = {**result.meta, 'outputs': str(out),
               'max_draft_force_n': float(max(result.draft_force(), default=0.0))}
    vtk = None
    with staged_output(out, SUMMARY) as stage:
        result.write_model_csv(stage / 'model.csv')
        result.write_marker_csv(stage / 'markers.csv')
        result.write_tool_csv(stage / 'tool.csv')
        result.save_npz(stage / 'result.npz')
        if tool is not None:
            vtk = write_vtk(result, tool, stage / 'vtk')
        (stage / SUMMARY).write_text(json.dumps(summary, indent=2), encoding='utf-8')
    if vtk is not None:  # the paths where the files now are
        vtk = VtkOutput(_moved(vtk.bed_series, stage, out), _moved(vtk.tool_series, stage, out),
                        tuple(_moved(p, stage, out) for p in vtk.bed_files),
                        tuple(_moved(p, stage, out) for p in vtk.tool_files))
    return summary, vtk


def _moved(path: Path, stage: Path, out: Path) -> Path:
    """Where a file written under the staging folder lies once installed in ``out``."""
    return out / path.relative_to(stage)
