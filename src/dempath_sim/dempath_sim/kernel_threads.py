"""The number of threads numba's parallel kernels run on, limited around a block of calls.

The engine runs states of fewer than `Engine.SERIAL_BELOW` particles on one thread: waking a
second thread costs more than it saves there. With numba's TBB threading layer (picked when
libtbb is installed) the cost of a multi-threaded launch also grew with the number of launches
on the 2-core test machine under load (about 16 us to 440 us per launch of an empty kernel over
6,000 launches), while one-thread launches stay flat, so every kernel call of a small state,
also a direct `bind` or `contact_forces` call, goes through :func:`threads_at_most`.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numba


@contextmanager
def threads_at_most(n: int) -> Iterator[None]:
    """Run the enclosed numba kernels on at most n threads; numba's count is restored after.

    Args:
        n: Largest thread count (>= 1); nothing changes when numba's count is already <= n.
    """
    outer = numba.get_num_threads()
    if n >= outer:
        yield
        return
    numba.set_num_threads(n)
    try:
        yield
    finally:
        numba.set_num_threads(outer)
