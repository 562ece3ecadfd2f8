"""ParaView output of a run: the bed snapshots with radii and the tool mesh, one file per frame.

``write_vtk`` writes VTK XML unstructured grids with meshio: ``bed_NNNN.vtu`` per bed snapshot
(one vertex per particle, point data ``radius`` [m], ``id``, ``displacement`` [m] from the first
snapshot) and ``tool_NNNN.vtu`` (the tool's triangles moved to its position at that time), and a
``bed.pvd`` / ``tool.pvd`` collection each that ParaView opens as a time series (File > Open,
then the Point Gaussian representation scaled by ``radius`` draws the spheres at their size).
Units SI, the paper's frame (X lateral, Y up, Z tool travel); particles removed from the bin are
left out of a frame.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath.errors import OutputError
from dempath_sim.runs.results import SimResult

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class VtkOutput:
    """What :func:`write_vtk` wrote.

    Attributes:
        bed_series: The bed's ``.pvd`` collection (one dataset per snapshot).
        tool_series: The tool's ``.pvd`` collection (same times).
        bed_files: (ns,) the bed's ``.vtu`` files.
        tool_files: (ns,) the tool's ``.vtu`` files.
    """

    bed_series: Path
    tool_series: Path
    bed_files: tuple[Path, ...]
    tool_files: tuple[Path, ...]


def _write_series(path: Path, times: F64, files: list[Path]) -> None:
    """A ParaView ``.pvd`` collection: one dataset per time, file names relative to it."""
    root = ET.Element('VTKFile', type='Collection', version='0.1')
    collection = ET.SubElement(root, 'Collection')
    for t, file in zip(times, files, strict=True):
        ET.SubElement(collection, 'DataSet', timestep=f'{t:.9g}', part='0', file=file.name)
    ET.ElementTree(root).write(path, xml_declaration=True, encoding='utf-8')


def tool_position_at(result: SimResult, times: F64) -> F64:
    """(k, 3) the tool's reference point [m] at ``times``, interpolated in the output frames."""
    return np.column_stack([np.interp(times, result.times, result.tool_position[:, a])
                            for a in range(3)])


def write_vtk(result: SimResult, tool_triangles: F64, out_dir: str | Path,
              prefix: str = '') -> VtkOutput:
    """Write the bed snapshots and the tool per snapshot time as VTK for ParaView.

    Args:
        result: A run with bed snapshots and their radii (``dempath simulate`` records them).
        tool_triangles: (n_tri, 3, 3) the tool's mesh in its own frame [m] (origin = the
            reference point whose position the result records).
        out_dir: Folder for the files (created).
        prefix: Prefix of the file names (e.g. a run id).

    Raises:
        OutputError: The result has no snapshots or no radii, or a file cannot be written.
    """
    import meshio

    snaps = np.asarray(result.snapshot_positions, np.float64)
    radii = np.asarray(result.snapshot_radii, np.float64)
    if len(snaps) == 0 or radii.shape != (snaps.shape[1],):
        msg = (f'VTK output: the run has {len(snaps)} bed snapshots and {radii.size} radii for '
               f'{snaps.shape[1] if snaps.ndim == 3 else 0} particles; run it with dempath '
               'simulate (the native engine records both)')
        raise OutputError(msg)
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OutputError(f'{out}: cannot create the VTK folder ({err.strerror})') from err
    tris = np.asarray(tool_triangles, np.float64)
    tool_cells = [('triangle', np.arange(3 * len(tris)).reshape(-1, 3))]
    tool_at = tool_position_at(result, result.snapshot_times)
    ids = np.asarray(result.snapshot_ids, np.int64)
    bed_files, tool_files = [], []
    for s, positions in enumerate(snaps):
        keep = np.isfinite(positions).all(axis=1)
        start = np.where(np.isfinite(snaps[0]), snaps[0], positions)
        bed = meshio.Mesh(positions[keep], [('vertex', np.arange(int(keep.sum()))[:, None])],
                          point_data={'radius': radii[keep], 'id': ids[keep],
                                      'displacement': (positions - start)[keep]})
        tool = meshio.Mesh(tris.reshape(-1, 3) + tool_at[s], tool_cells)
        bed_files.append(out / f'{prefix}bed_{s:04d}.vtu')
        tool_files.append(out / f'{prefix}tool_{s:04d}.vtu')
        try:
            meshio.write(bed_files[-1], bed)
            meshio.write(tool_files[-1], tool)
        except OSError as err:
            raise OutputError(f'{bed_files[-1]}: cannot write VTK ({err.strerror})') from err
    series = out / f'{prefix}bed.pvd', out / f'{prefix}tool.pvd'
    _write_series(series[0], result.snapshot_times, bed_files)
    _write_series(series[1], result.snapshot_times, tool_files)
    return VtkOutput(series[0], series[1], tuple(bed_files), tuple(tool_files))


__all__ = ['VtkOutput', 'tool_position_at', 'write_vtk']
