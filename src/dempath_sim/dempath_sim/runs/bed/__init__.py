"""Bed preparation: the bin filled with a settled bed, and the tool placed in it.

One entry point for the bed, :func:`fill_bed` (``fill``): read the scene's packing file
(``packing_file``), or the cached or shipped packing (``cache``), or pour the layers at random
(``pour``), settle them (``settle``, around the standing tool when ``tool.placement: poured``,
``standing_tool``) and compact them to the target bulk density, measured by one yardstick
(``measure``, which also gives the :class:`FillReport`). Then the tool enters the settled bed
(``placement``: where its tip starts and which particles make room for it).

Order inside, bottom to top (tests/test_layout.py, ``ROOMS``): pour < measure < standing_tool <
packing_file < settle < cache < fill < placement (``placement`` reads the fill's report).
"""

from __future__ import annotations

from dempath_sim.runs.bed.cache import bundled_packing_dir, default_cache_dir, packing_key
from dempath_sim.runs.bed.fill import fill_bed
from dempath_sim.runs.bed.measure import FillReport, measure, surface_height
from dempath_sim.runs.bed.placement import PLACEMENTS, place_tool, tool_start

__all__ = ['PLACEMENTS', 'FillReport', 'bundled_packing_dir', 'default_cache_dir', 'fill_bed',
           'measure', 'packing_key', 'place_tool', 'surface_height', 'tool_start']
