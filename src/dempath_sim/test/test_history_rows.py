"""Springs in rows for touching pairs only (engine/history.py) on the real engine: where the rows
lie changes nothing in a run, only touching pairs hold rows, and a checkpoint of the by-entry
store written before resumes the same run."""

from __future__ import annotations

import numpy as np
import pytest

from dempath_sim.engine import Engine, SimState
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.walls import box_walls

from .sand_beds import lattice_bed, lattice_centres, sand_params

LO, HI = (-0.016, 0.0, -0.016), (0.016, 0.1, 0.032)  # m


def _params(forms: str) -> SimParams:
    return sand_params(forms)


def _falling_lattice(params: SimParams) -> SimState:
    """About 450 grains on a jittered lattice, dropped into the bin: contacts form and part."""
    centres = lattice_centres(LO, HI, 8, 2.1, 0.05, 3)
    vel = np.random.default_rng(3).normal(scale=0.05, size=centres.shape)
    return lattice_bed(params, centres, vel)


def _engine(params: SimParams) -> Engine:
    """One force chunk (a small bed runs serially; several chunks: test_kernels.py)."""
    return Engine(params, box_walls(LO, HI, material=1))


@pytest.mark.parametrize('forms', ['dempath', 'liggghts'])
def test_rows_placed_anywhere_give_the_same_run(forms: str) -> None:
    """A bed falling into a bin, run once as the engine runs it and once with the rows placed
    afresh before every step: the same positions, spins and forces to the bit; with dempath's
    forms the rows in use are exactly the touching pairs."""
    params = _params(forms)
    plain = _engine(params)
    a = plain.run(_falling_lattice(params), 450)
    moved = _engine(params)
    state = _falling_lattice(params)
    moved.bind(state)
    hist = moved._hist
    hist.make_room = lambda start: hist.compact(start, len(hist.tail))  # type: ignore[method-assign]
    b = moved.run(state, 450)
    assert hist.compactions >= 450 and plain.n_rebuilds > 3
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.angular_velocities, b.angular_velocities)
    np.testing.assert_array_equal(plain.forces[0], moved.forces[0])
    assert plain.n_contacts > 0.8 * a.n  # a bed settling, not a few collisions
    if forms == 'dempath':
        assert int(plain._hist.live.sum()) == plain.n_contacts
        assert int((plain._hist.slot >= 0).sum()) == plain.n_contacts
    assert len(plain._hist.ht) < 1.3 * plain.n_pairs + 64 * len(plain._hist.tail)


def test_checkpoint_of_springs_by_entry_resumes(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A checkpoint holding one spring row per list entry (the store before rows) resumes the
    run exactly as the checkpoint of the rows does."""
    params = _params('dempath')
    first = _engine(params)
    half = first.run(_falling_lattice(params), 400)
    data = {k: np.array(v) for k, v in first.checkpoint(half).items()}  # as read from a file
    old = {k: v.copy() for k, v in data.items() if not k.startswith('engine.hist.')}
    old['engine._ht'], old['engine._hr'] = first.pair_springs
    assert np.count_nonzero(old['engine._ht']) > 0
    out = []
    for cp in (data, old):
        engine = _engine(params)
        state = engine.resume(cp)
        out.append(engine.run(state, 300).positions)
    np.testing.assert_array_equal(out[0], out[1])
