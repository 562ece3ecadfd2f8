"""Keep glibc's allocator from handing the engine's large arrays back to the kernel every step.

The engine allocates arrays of about a megabyte or more several times per step (the neighbour
list and its spring history at every rebuild, copies of the positions). glibc serves such
arrays from the heap and keeps freed memory for the next request while its *dynamic* mmap and
trim thresholds are in force. Setting ``MALLOC_TRIM_THRESHOLD_`` turns that dynamic behaviour
off, and Dask's nanny sets it to 64 KiB in every worker it spawns (its
``distributed.nanny.pre-spawn-environ`` default): there every array above 128 KiB was mapped and
unmapped each time, and each of its pages faulted in anew. A reduced-scene pass in a Dask worker
took 2.1 M minor page faults and 10.7 s of system time against 0.14 M and 1.0 s in a plain
process; the 45-run signature library spent 682 of its 7,638 CPU seconds in the kernel.

:func:`keep_freed_memory` fixes both thresholds with ``mallopt`` from inside the process, so the
engine runs alike whatever the environment (a local Dask cluster, a remote worker, a plain
process). Memory a process retains after freeing is bounded by ``TRIM_THRESHOLD_B``.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import sys

logger = logging.getLogger(__name__)

M_TRIM_THRESHOLD = -1  # glibc's mallopt parameter numbers (malloc.h)
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD_B = 32 * 1024 * 1024  # glibc's largest: arrays below this come from the heap
TRIM_THRESHOLD_B = 256 * 1024 * 1024  # free heap kept for reuse before it is given back

_done: list[bool] = []


def keep_freed_memory() -> bool:
    """Set glibc's mmap and trim thresholds for the engine's allocation pattern (once).

    Returns:
        True when both thresholds were set; False off glibc (another libc, macOS, Windows),
        where nothing changes.
    """
    if _done:
        return _done[0]
    ok = False
    if sys.platform.startswith('linux'):
        try:
            libc = ctypes.CDLL(ctypes.util.find_library('c') or 'libc.so.6')
            mallopt = libc.mallopt
        except (OSError, AttributeError) as err:  # not glibc (musl has no mallopt)
            logger.debug('mallopt unavailable (%s); allocator left as it is', err)
        else:
            mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
            mallopt.restype = ctypes.c_int
            ok = bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_B)) and bool(
                mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_B))
    _done.append(ok)
    return ok
