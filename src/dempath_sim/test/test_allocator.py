"""The engine keeps glibc from mapping and unmapping its large arrays (Dask's worker setting)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

CHURN = """
import json, resource, sys
import numpy as np
if sys.argv[1] == 'engine':
    import dempath_sim.engine.engine  # noqa: F401  (sets the allocator's thresholds)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(200):  # an engine-like pattern: a fresh 4 MB array filled, then freed
    a = np.empty(512 * 1024)
    a.fill(1.0)
    del a
print(json.dumps(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before))
"""


def _faults(mode: str) -> int:
    env = {**os.environ, 'MALLOC_TRIM_THRESHOLD_': '65536'}  # as Dask's nanny sets it
    out = subprocess.run([sys.executable, '-c', CHURN, mode], env=env, check=True,
                         capture_output=True, text=True)
    return int(json.loads(out.stdout.strip().splitlines()[-1]))


@pytest.mark.skipif(not sys.platform.startswith('linux'), reason='glibc mallopt (Linux)')
def test_engine_import_stops_page_fault_churn_of_large_arrays() -> None:
    """Under Dask's MALLOC_TRIM_THRESHOLD_ every 4 MB array faults its pages in anew;
    with the engine imported the freed memory is reused."""
    plain = _faults('plain')
    engine = _faults('engine')
    assert plain > 200 * 200  # the churn is real here: hundreds of faults per array
    assert engine < plain / 20
