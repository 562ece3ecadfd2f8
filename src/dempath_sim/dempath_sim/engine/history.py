# mypy: disable-error-code="no-untyped-def"
"""Contact-spring history of particle pairs, kept in rows for the touching pairs only.

The pair kernel visits every entry of the half neighbour list, but only the touching pairs (about
four in ten on a settled bed at a skin of 0.6 r) have springs: a tangential spring (3 floats) and a
rolling spring (3 floats), 48 bytes. Stored by list entry, they make the kernel stream 48 bytes for
every listed pair, touching or not (a 64-byte cache line holds fewer than three entries' springs,
so with four in ten entries touching nearly every line is read). Here each list entry k has a row
index ``slot[k]`` into the history store (-1: no spring), and the rows of one force chunk lie
together in list order, so the kernel reads 4 bytes for a pair apart and 52 for a touching one.

Layout: the store is cut into one region per force chunk (the particle ranges of
`pair_forces.pair_forces`: chunk c owns particles c n / n_chunks ... and their list entries).
Region c holds, from its base, the rows of chunk c's entries that have springs, in list order;
a pair that starts touching between two list builds takes the row at its chunk's tail (each chunk
has its own tail, so no two threads share a counter), and a pair that parts frees its row (the
row is left as a hole until the next compaction). A region has room for m_c + m_c / 4 + 64 rows
(m_c: the chunk's list entries); since a step can take at most one row for each entry without
one, the engine compacts the store (`PairHistory.make_room`) before any step at which a region
has fewer free rows than entries without a row. A list build and a compaction place the rows
afresh in list order and drop rows whose springs are all zero (a zero spring is what a new
contact starts from, so dropping it changes nothing).

What is stored and computed is what the by-entry store held: the same springs, updated by the
same arithmetic in the same order, so the run is the same to the bit (tested); only where the
springs lie in memory changes.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

I64 = NDArray[np.int64]
F64 = NDArray[np.float64]


@njit(cache=True)
def chunk_entries(start, n_chunks):  # pragma: no cover - compiled
    """(n_chunks + 1,) first list entry of each force chunk (and the entry count last)."""
    n = start.shape[0] - 1
    lo = np.empty(n_chunks + 1, np.int64)
    for c in range(n_chunks + 1):
        lo[c] = start[c * n // n_chunks]
    return lo


@njit(parallel=True, cache=True)
def carry_sources(new_to_old, old_start, old_nbr, old_slot, old_ht, old_hr, start, nbr, pos,
                  rad, src):  # pragma: no cover - compiled
    """For each new list entry, the old row whose springs it carries: src[k] = +-(row + 1)
    (minus: the pair is stored the other way round, so its springs flip), 0 for none.

    Only old pairs with a row and a non-zero spring that overlap at the new positions are
    carried (a pair apart starts at 0: with dempath's forms its spring would be reset at this
    step's force pass anyway; with LIGGGHTS' forms, whose springs outlive a separation until the
    next list build, this is LIGGGHTS 3.8's rule at a build, which keeps the history of touching
    pairs only). Each is looked up in the new row of its lower index.

    Args:
        new_to_old: (n,) index of each new particle in the old arrays (a subset, any order).
        old_start, old_nbr, old_slot: The previous list and the row of each of its entries.
        old_ht, old_hr: (rows, 3) the previous store's tangential [m] and rolling [N m] springs.
        start, nbr: The new list.
        pos, rad: (n, 3) positions [m] and (n,) radii [m] of the new particles.
        src: (m_new,) int64 out.
    """
    n_old = old_start.shape[0] - 1
    old_to_new = np.full(n_old, -1, np.int64)
    for i in range(new_to_old.shape[0]):
        old_to_new[new_to_old[i]] = i
    for k in prange(src.shape[0]):
        src[k] = 0
    for oi in prange(n_old):
        ni = old_to_new[oi]
        if ni < 0:
            continue
        for q in range(old_start[oi], old_start[oi + 1]):
            s = old_slot[q]
            if s < 0 or (old_ht[s, 0] == 0.0 and old_ht[s, 1] == 0.0 and old_ht[s, 2] == 0.0
                         and old_hr[s, 0] == 0.0 and old_hr[s, 1] == 0.0
                         and old_hr[s, 2] == 0.0):
                continue
            nj = old_to_new[old_nbr[q]]
            if nj < 0:
                continue
            rs = rad[ni] + rad[nj]
            if ((pos[ni, 0] - pos[nj, 0]) ** 2 + (pos[ni, 1] - pos[nj, 1]) ** 2
                    + (pos[ni, 2] - pos[nj, 2]) ** 2) >= rs * rs:
                continue  # separated: the spring is not carried over
            a, b, code = (ni, nj, s + 1) if ni < nj else (nj, ni, -(s + 1))
            for k in range(start[a], start[a + 1]):
                if nbr[k] == b:
                    src[k] = code
                    break


@njit(parallel=True, cache=True)
def place_rows(src, old_ht, old_hr, entry_lo, base, slot, ht, hr, tail,
               live):  # pragma: no cover - compiled
    """Give every entry with a non-zero source spring a row, in list order within its chunk.

    Args:
        src: (m,) +-(old row + 1) per entry (see `carry_sources`), 0 for none.
        old_ht, old_hr: (rows_old, 3) springs the sources point into.
        entry_lo: (n_chunks + 1,) first entry of each chunk; base: (n_chunks + 1,) first row
            of each chunk's region.
        slot: (m,) int32 out: row of each entry, -1 for none.
        ht, hr: (rows, 3) out: the new store (rows past each chunk's tail are left as they are).
        tail, live: (n_chunks,) int64 out: next free row and rows taken, per chunk.
    """
    for c in prange(entry_lo.shape[0] - 1):
        row = base[c]
        for k in range(entry_lo[c], entry_lo[c + 1]):
            code = src[k]
            s = abs(code) - 1
            if code == 0 or (old_ht[s, 0] == 0.0 and old_ht[s, 1] == 0.0
                             and old_ht[s, 2] == 0.0 and old_hr[s, 0] == 0.0
                             and old_hr[s, 1] == 0.0 and old_hr[s, 2] == 0.0):
                slot[k] = -1
                continue
            sign = 1.0 if code > 0 else -1.0
            for d in range(3):
                ht[row, d] = sign * old_ht[s, d]
                hr[row, d] = sign * old_hr[s, d]
            slot[k] = row
            row += 1
        tail[c] = row
        live[c] = row - base[c]


@njit(cache=True)
def slot_sources(slot, src):  # pragma: no cover - compiled
    """src[k] = slot[k] + 1 (the identity carry of a compaction; 0 where there is no row)."""
    for k in range(slot.shape[0]):
        src[k] = slot[k] + 1


class PairHistory:
    """The springs of the neighbour list's pairs, in rows for the touching pairs only.

    Attributes:
        slot: (m,) int32 row of each list entry (-1: none).
        ht, hr: (rows, 3) tangential [m] and rolling [N m] springs.
        tail: (n_chunks,) int64 next free row of each chunk's region (the kernel advances it).
        live: (n_chunks,) int64 rows in use per chunk (the kernel counts them).
        compactions: Compactions between list builds so far.
    """

    SPARE_FRACTION = 4  # a region holds m_c + m_c // SPARE_FRACTION + SPARE_ROWS rows
    SPARE_ROWS = 64

    def __init__(self) -> None:
        """An empty store (no list yet)."""
        self.slot: NDArray[np.int32] = np.zeros(0, np.int32)
        self.ht: F64 = np.zeros((0, 3))
        self.hr: F64 = np.zeros((0, 3))
        self.tail: I64 = np.zeros(1, np.int64)
        self.live: I64 = np.zeros(1, np.int64)
        self._entry_lo: I64 = np.zeros(2, np.int64)
        self._base: I64 = np.zeros(2, np.int64)
        self.compactions = 0

    def _layout(self, start: I64, n_chunks: int) -> None:
        """Chunk entries and region bases for the list ``start`` and fresh arrays."""
        self._entry_lo = chunk_entries(start, n_chunks)
        per = np.diff(self._entry_lo)
        self._base = np.concatenate([[0], np.cumsum(per + per // self.SPARE_FRACTION
                                                    + self.SPARE_ROWS)]).astype(np.int64)
        rows = int(self._base[-1])
        self.tail = np.zeros(n_chunks, np.int64)
        self.live = np.zeros(n_chunks, np.int64)
        self.slot = np.empty(int(start[-1]), np.int32)
        self.ht = np.empty((rows, 3))
        self.hr = np.empty((rows, 3))

    def carry(self, new_to_old: I64, old_start: I64, old_nbr: NDArray[np.int32], start: I64,
              nbr: NDArray[np.int32], pos: F64, rad: F64, n_chunks: int) -> None:
        """Move the springs from the previous list to a new one (see `carry_sources`)."""
        old_slot, old_ht, old_hr = self.slot, self.ht, self.hr
        src = np.empty(len(nbr), np.int64)
        carry_sources(new_to_old.astype(np.int64), old_start, old_nbr, old_slot, old_ht,
                      old_hr, start, nbr, pos, rad, src)
        self._layout(start, n_chunks)
        place_rows(src, old_ht, old_hr, self._entry_lo, self._base, self.slot, self.ht,
                   self.hr, self.tail, self.live)

    def compact(self, start: I64, n_chunks: int) -> None:
        """Place the rows afresh in list order for ``n_chunks`` chunks (same list)."""
        src = np.empty(len(self.slot), np.int64)
        slot_sources(self.slot, src)
        old_ht, old_hr = self.ht, self.hr
        self._layout(start, n_chunks)
        place_rows(src, old_ht, old_hr, self._entry_lo, self._base, self.slot, self.ht,
                   self.hr, self.tail, self.live)
        self.compactions += 1

    def make_room(self, start: I64) -> None:
        """Compact if a chunk could run out of rows at the next force pass (see module doc)."""
        per = np.diff(self._entry_lo)
        if np.any(self._base[1:] - self.tail < per - self.live):
            self.compact(start, len(self.tail))

    def by_entry(self) -> tuple[F64, F64]:
        """(ht, hr) as (m, 3) arrays by list entry, zeros for entries without a row (a copy)."""
        ht = np.zeros((len(self.slot), 3))
        hr = np.zeros((len(self.slot), 3))
        has = self.slot >= 0
        ht[has] = self.ht[self.slot[has]]
        hr[has] = self.hr[self.slot[has]]
        return ht, hr

    def loaded(self) -> int:
        """List entries whose tangential spring is loaded now."""
        rows = self.slot[self.slot >= 0]
        return int(np.count_nonzero(np.any(self.ht[rows] != 0.0, axis=1)))

    def nbytes(self) -> int:
        """Bytes held (rows, slots)."""
        return int(self.slot.nbytes + self.ht.nbytes + self.hr.nbytes)

    def arrays(self) -> dict[str, NDArray[np.generic]]:
        """What a checkpoint keeps: the slots and the store."""
        return {'slot': self.slot, 'ht': self.ht, 'hr': self.hr}

    def restore(self, data: Mapping[str, NDArray[np.generic]], start: I64,
                n_chunks: int) -> None:
        """The springs of a checkpoint's `arrays` for the list ``start``, laid out for
        ``n_chunks`` chunks. A checkpoint of the by-entry store (``ht``, ``hr`` with one row per
        entry and no ``slot``) is read too."""
        ht = np.ascontiguousarray(data['ht'], np.float64)
        hr = np.ascontiguousarray(data['hr'], np.float64)
        slot = (np.ascontiguousarray(data['slot'], np.int32) if 'slot' in data
                else np.arange(len(ht), dtype=np.int32))
        self.slot, self.ht, self.hr = slot, ht, hr
        self.compact(start, n_chunks)
        self.compactions -= 1  # not one between builds
