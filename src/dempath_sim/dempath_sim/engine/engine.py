"""The DEM engine: soft spheres, plane walls and a kinematic triangle-mesh tool.

Model assumptions: rigid spheres that overlap softly (Hertz-Mindlin with restitution damping,
optional EPSD2 rolling resistance and SJKR cohesion; see `laws/dispatch.py`); walls are
infinite planes and the tool a rigid triangle mesh moved kinematically (its motion is imposed,
not computed); gravity is uniform (default -Y); no fluid, no particle breakage. Units SI; frame
X lateral, Y up, Z tool travel.

One `Engine.step` is the named stages of a velocity-Verlet step (see `integrate.py`):
`integrate_first_half` (half kick + drift, domain and blow-up checks, see `stability.py`),
`find_contacts` (neighbour-list rebuild when a particle moved more than skin / 2, or with
``local_rebuild`` when grains moved a skin relative to their neighbours, see `rebuild.py`; history
carried over into rows for the touching pairs only, see `history.py`; states of REORDER_MIN or
more particles are first put in cell order, see `SimState.reorder`: index order changes, ids
follow the particles),
`contact_forces` (particle-particle, particle-plane, particle-tool), `integrate_second_half`.
The plane and tool pass runs over the particles that can reach a plane or the tool until the
next list build (`reach.BoundaryCandidates`, from the build positions); the candidates are
found again when the tool has moved more than TOOL_MARGIN_SKINS skins since they were found.
With ``sleep`` settings (`sleep.SleepSettings`, off by default) grains that stay at rest fall
asleep: they are not integrated, pairs of sleeping grains are skipped with their springs kept,
and a moving neighbour, a rim force imbalance or the tool's reach wakes them (`update_sleep`
after each step).
The arrays of `SimState` are updated in place; when particles leave the domain box they are
removed with a warning and a new, compacted state is returned, so always use the returned state.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numba
import numpy as np
from numpy.typing import NDArray

from dempath_sim.engine.allocator import keep_freed_memory
from dempath_sim.engine.boundary import MAX_CANDIDATES, N_SLOTS, boundary_forces
from dempath_sim.engine.history import PairHistory
from dempath_sim.engine.integrate import first_half, second_half
from dempath_sim.engine.kernel_cache import refresh_own_kernel_cache
from dempath_sim.engine.kernel_threads import prefer_openmp_layer, threads_at_most
from dempath_sim.engine.laws.dispatch import build_pair_table
from dempath_sim.engine.mesh import TriangleGrid, TriangleMesh, build_triangle_grid, mesh_margin
from dempath_sim.engine.neighbors import (
    build_neighbor_cells,
    cell_order,
    overlapping_pairs,
    permute_in_place,
)
from dempath_sim.engine.pair_forces import chunk_windows, pair_forces, reduce_buffers
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.reach import BoundaryCandidates, box_displacement
from dempath_sim.engine.rebuild import ListKeeper
from dempath_sim.engine.sleep import SleepSettings, near_tool_box, update_sleep
from dempath_sim.engine.stability import (
    check_contacts,
    check_drift,
    checked_time_step,
    inside_domain,
    unstable_overlap,
)
from dempath_sim.engine.state import SimState
from dempath_sim.engine.toolpose import ToolPose
from dempath_sim.engine.walls import Plane, pack_planes
from dempath_sim.errors import SimulationError

__all__ = ['Engine']

F64 = NDArray[np.float64]

refresh_own_kernel_cache()
prefer_openmp_layer()
keep_freed_memory()


class Engine:
    """Steps a `SimState` in time with walls and an optional kinematic tool.

    Attributes:
        dt: Time step [s] (set when the first state is bound; see `time_step`).
        tool_force: (3,) force of the particles on the tool after the last step [N].
        tool_torque: (3,) torque on the tool about its origin after the last step [N m].
        removed_count: Particles removed because they left the domain box.
        n_rebuilds: Neighbour-list builds so far.
        slot_overflows: Geometry contacts resolved without history (all slots busy).
        pair_evaluations: Particle pairs evaluated (distance computed) over all steps so far.
        n_asleep: Grains asleep after the last step (0 without sleep settings).
        woken: Grains woken so far.
    """

    BLOWUP_COURANT = 0.5  # |v| dt / r above this is an energy blow-up
    LOST_FRACTION = 0.01  # a run stops when more of its particles than this left the domain
    LOST_MIN = 10  # ... and more than this many (single grains thrown out are only counted)
    SERIAL_BELOW = 4000  # fewer particles run on one thread (thread wake-up costs more)
    REORDER_MIN = 4000  # states this large are put in cell order at every list build
    TOOL_MARGIN_SKINS = 2.0  # tool travel [skins] covered by one set of boundary candidates

    def __init__(self, params: SimParams, walls: Sequence[Plane] = (),
                 tool: TriangleMesh | None = None, reorder: bool = True,
                 candidates: bool = True, sleep: SleepSettings | None = None,
                 local_rebuild: bool = False) -> None:
        """Keep the set-up; no allocation until a state is stepped.

        Args:
            params: Physical and numerical parameters.
            walls: Plane walls (see `walls.box_walls`).
            tool: Tool mesh in its own frame, moved by the ToolPose of each step, or None.
            reorder: Sort states of >= REORDER_MIN particles in cell order at each list build
                (memory locality; same physics; outputs must then go by `SimState.ids`).
            candidates: Run the plane/tool pass over the particles within reach only (same
                physics; False tests every particle every step).
            sleep: Let grains at rest fall asleep (`sleep.py`); None (default): every grain is
                integrated at every step.
            local_rebuild: Keep the neighbour list past skin / 2 of travel while the grains
                that moved that far moved together with their neighbours (`rebuild.py`; same
                contacts, fewer builds near a tool).
        """
        self.reorder = reorder
        self.candidates = candidates
        self.sleep = sleep
        self.local_rebuild = local_rebuild
        self._n_bound = 0  # most particles bound so far (the base of the lost fraction)
        self._screen = 0.0  # overlap / radius below which no contact is unstable at dt
        self.params = params
        self.walls = tuple(walls)
        self.tool = tool
        self._tab = build_pair_table(params)
        self._planes, self._plane_mat = pack_planes(self.walls)
        self._gravity = np.asarray(params.gravity, np.float64)
        self._dom_lo = np.asarray(params.domain_min, np.float64)
        self._dom_hi = np.asarray(params.domain_max, np.float64)
        self._tris = np.zeros((0, 3, 3)) if tool is None else tool.triangles
        self._packed: tuple[ToolPose | None, F64] = (None, np.zeros(18))
        self._boundary_mats = [*(p.material for p in self.walls), *([] if tool is None
                                                                     else [tool.material])]
        bad = [m for m in self._boundary_mats if not 0 <= m < len(params.materials)]
        if bad:
            msg = f'Engine: wall/tool material index {bad[0]} is not in SimParams.materials'
            raise SimulationError(msg)
        self.dt: float | None = None
        self._dt = math.nan  # self.dt as a float once a state is bound
        self.tool_force = np.zeros(3)
        self.tool_torque = np.zeros(3)
        self.tool_pose = ToolPose(np.zeros(3), np.zeros(3))
        self.removed_count = 0
        self.n_rebuilds = 0
        self.slot_overflows = 0
        self.pair_evaluations = 0
        self.n_asleep = 0
        self.woken = 0
        self._bound: SimState | None = None

    # ----------------------------------------------------------------- set-up
    def time_step(self, state: SimState) -> float:
        """The time step for this state: params.dt, or rayleigh_safety * Rayleigh time step [s].

        Raises:
            SimulationError: params.dt exceeds the Rayleigh time step (message gives the limit).
        """
        return checked_time_step(state, self.params)

    def bind(self, state: SimState) -> None:
        """Allocate buffers and the neighbour list for `state` and compute its forces at t."""
        self.params.require_interactions(np.unique(state.material).tolist(), self._boundary_mats)
        self.dt = self._dt = self.time_step(state)
        n = state.n
        tool_mat = 0 if self.tool is None else self.tool.material
        self._screen = unstable_overlap(state, self.walls, tool_mat, self.params, self._dt)
        self._n_bound = max(self._n_bound, n)
        self._threads = 1 if n < self.SERIAL_BELOW else numba.get_num_threads()
        self._n_chunks = max(1, min(self._threads, n))
        self._force: F64 = np.zeros((n, 3))
        self._torque: F64 = np.zeros((n, 3))
        self._fbuf = np.zeros((self._n_chunks, n, 3))
        self._tbuf = np.zeros((self._n_chunks, n, 3))
        self._gkey: NDArray[np.int32] = np.full((n, N_SLOTS), -1, np.int32)
        self._ght: F64 = np.zeros((n, N_SLOTS, 3))
        self._ghr: F64 = np.zeros((n, N_SLOTS, 3))
        self._sleep_arrays(n)
        self._perm_tmp = np.empty(self._ght.nbytes, np.uint8)  # cell-order permutation scratch
        self._scratch()
        self._skin = self.params.skin * (float(state.radii.min()) if n else 0.0)
        self._keeper = ListKeeper(self._skin, self.local_rebuild)
        g_dt = float(np.linalg.norm(self._gravity)) * self._dt
        sleep = self.sleep
        self._v_sleep = 0.0 if sleep is None else sleep.speed_fraction * g_dt
        self._w_sleep = 0.0 if sleep is None else sleep.spin_fraction * g_dt
        self._v_wake = math.inf if sleep is None else sleep.wake_speed_fraction * g_dt
        self._tool_reach = 0.0 if sleep is None or not n else (
            sleep.tool_reach_radii * float(state.radii.max()))
        self.n_asleep = 0
        self._start: NDArray[np.int64] = np.zeros(n + 1, np.int64)
        self._nbr: NDArray[np.int32] = np.zeros(0, np.int32)
        self._hist = PairHistory()
        grid = self._grid = None if self.tool is None else build_triangle_grid(
            self.tool, mesh_margin(state.radii))
        self._reach = BoundaryCandidates(
            self._planes, self._skin, self.TOOL_MARGIN_SKINS * self._skin,
            None if grid is None else (grid.lo, grid.lo + grid.dims * grid.cell))
        self._bound = state
        with threads_at_most(self._threads):
            self.find_contacts(state, np.arange(n))
            self.contact_forces(state, self.tool_pose, dt=0.0)

    def _sleep_arrays(self, n: int) -> None:
        """Per-grain sleep state (all awake): asleep, rim, touch, wake, near-tool flags and the
        quiet-step counters."""
        self._asleep_u8 = np.zeros(n, np.uint8)
        self._rim_u8 = np.zeros(n, np.uint8)
        self._touch_u8 = np.zeros(n, np.uint8)
        self._wake_u8 = np.zeros(n, np.uint8)
        self._near_u8 = np.zeros(n, np.uint8)
        self._quiet = np.zeros(n, np.int32)
        self._sleep_counts = np.zeros(2, np.int64)

    def _sleep_take(self, order: NDArray[np.int64]) -> None:
        """Move the sleep state with the grains: row k becomes the old row order[k]."""
        for name in ('_asleep_u8', '_rim_u8', '_quiet'):
            setattr(self, name, np.ascontiguousarray(getattr(self, name)[order]))
        n = len(order)
        for name in ('_touch_u8', '_wake_u8', '_near_u8'):
            setattr(self, name, np.zeros(n, np.uint8))

    @property
    def asleep(self) -> NDArray[np.bool_]:
        """(n,) whether each grain of the bound state is asleep (a copy)."""
        return self._asleep_u8.astype(bool)

    def _scratch(self) -> None:
        nc = self._n_chunks
        self._worst = np.zeros((nc, 4))
        self._stats = np.zeros((nc, 4))
        self._tool_acc = np.zeros((nc, 6))
        self._cand = np.zeros((nc, MAX_CANDIDATES, 9))
        self._evals = np.zeros(nc, np.int64)
        self._tmp_t = np.zeros((nc, 1, 3))
        self._tmp_r = np.zeros((nc, 1, 3))

    # ----------------------------------------------------------------- stages
    def find_contacts(self, state: SimState, new_to_old: NDArray[np.int64]) -> None:
        """Rebuild the half neighbour list and carry the contact springs over.

        Args:
            state: The bound state.
            new_to_old: (n,) index of each current particle in the arrays of the previous list.
        """
        if self.reorder and state.n >= self.REORDER_MIN:
            order = cell_order(state.positions, state.radii, self._skin)
            state.reorder(order, self._perm_tmp)
            for a in (self._force, self._torque, self._gkey, self._ght, self._ghr):
                permute_in_place(a, order, self._perm_tmp)
            if self.sleep is not None:
                self._sleep_take(order)
            new_to_old = np.asarray(new_to_old)[order]
        rows = np.diff(self._start)
        cap = int(rows.max()) * 5 // 4 + 4 if rows.size == state.n and rows.size else 0
        start, nbr, grid = build_neighbor_cells(state.positions, state.radii, self._skin, cap)
        self._keeper.built(grid, float(state.radii.max()) if state.n else 0.0)
        self._hist.carry(np.asarray(new_to_old), self._start, self._nbr, start, nbr,
                         state.positions, state.radii, self._n_chunks)
        self._start, self._nbr = start, nbr
        self._chunk_windows()
        self._pos_build = state.positions.copy()
        self._tool_build = self.tool_pose.packed()
        self._reach.forget()
        self.n_rebuilds += 1

    def _chunk_windows(self) -> None:
        """The buffer rows each force chunk writes over the current list (see `pair_forces`)."""
        self._window = np.zeros((self._n_chunks, 2), np.int64)
        chunk_windows(self._start, self._nbr, self._window)

    def contact_forces(self, state: SimState, pose: ToolPose, dt: float) -> None:
        """Forces and torques of all contacts into the engine's force/torque arrays.

        Args:
            state: The bound state at the new positions.
            pose: Tool pose at the same time.
            dt: Time step used to advance the contact springs [s] (0 to evaluate only).

        Raises:
            SimulationError: A contact the time step no longer resolves, or an overlap beyond
                params.max_overlap_fraction of a radius (see `check_contacts`).
        """
        rolling = self.params.rolling_enabled
        cohesion = self.params.cohesion_enabled
        if self._packed[0] is not pose:
            self._packed = (pose, pose.packed())
        g_args = TriangleGrid.kernel_args(self._grid)
        tri_mat = 0 if self.tool is None else self.tool.material
        sleeping = self.sleep is not None
        hist = self._hist
        with threads_at_most(self._threads):
            hist.make_room(self._start)
            pair_forces(state.positions, state.velocities, state.angular_velocities,
                        state.radii, state.masses, state.material, self._start, self._nbr,
                        hist.slot, hist.ht, hist.hr, hist.tail, hist.live, self._tab, dt,
                        rolling, cohesion, self._fbuf, self._tbuf, self._window, self._worst,
                        sleeping, self._asleep_u8, self._rim_u8, self._touch_u8,
                        self._wake_u8, self._v_wake, self._evals)
            self.pair_evaluations += int(self._evals.sum())
            reduce_buffers(self._fbuf, self._tbuf, self._window, self._force, self._torque)
            self._worst[:, 3] = 0.0
            boundary_forces(state.positions, state.velocities, state.angular_velocities,
                            state.radii, state.masses, state.material, self._planes,
                            self._plane_mat, self._tris, tri_mat, *g_args, self._packed[1],
                            self._gkey, self._ght, self._ghr, self._tab, dt, rolling, cohesion,
                            self._force, self._torque, self._tool_acc, self._worst, self._cand,
                            self._tmp_t, self._tmp_r, self._boundary_particles(state))
        total = self._tool_acc.sum(axis=0)
        self.tool_force = total[:3]
        self.tool_torque = total[3:]
        worst = self._worst
        self.slot_overflows += int(worst[0, 3]) if worst.shape[0] == 1 else int(worst[:, 3].sum())
        check_contacts(state, worst, self.walls, tri_mat, self.params, self._dt, self._screen)

    def _boundary_particles(self, state: SimState) -> NDArray[np.int64]:
        """Particles the plane/tool pass must test at this step (see `BoundaryCandidates`)."""
        idx: NDArray[np.int64]
        if not self.candidates:
            idx = np.arange(state.n, dtype=np.int64)
        else:
            idx = self._reach.particles(self._pos_build, state.radii, self._packed[1],
                                        self._gkey, self._ght, self._ghr)
        if self.n_asleep:  # sleeping grains off the rim keep their wall springs untouched
            idx = idx[(self._asleep_u8[idx] == 0) | (self._rim_u8[idx] != 0)]
        return idx

    def integrate_first_half(self, state: SimState) -> tuple[float, int]:
        """Half kick and drift; returns (max displacement since the list build [m], n_out).

        Raises:
            SimulationError: Non-finite velocities or |v| dt / r > BLOWUP_COURANT.
        """
        first_half(state.positions, state.velocities, state.angular_velocities, self._force,
                   self._torque, state.masses, state.inertias, state.radii, self._gravity,
                   self._dt, self._pos_build, self._dom_lo, self._dom_hi, self._stats,
                   self._asleep_u8)
        return check_drift(state, self._stats, self.BLOWUP_COURANT, self.params, self._dt)

    def integrate_second_half(self, state: SimState) -> None:
        """Second half kick with the new forces; advances time and step."""
        second_half(state.velocities, state.angular_velocities, self._force, self._torque,
                    state.masses, state.inertias, self._gravity, self._dt, self._asleep_u8)
        if self.sleep is not None:
            self._update_sleep(state)
        state.time += self._dt
        state.step += 1

    # ----------------------------------------------------------------- stepping
    def step(self, state: SimState, tool_pose: ToolPose | None = None) -> SimState:
        """Advance one time step.

        Args:
            state: The state (bound on first use; a different object is bound afresh, which
                resets the contact history).
            tool_pose: Tool pose at state.time + dt; the previous pose if None.

        Returns:
            The state after the step: the same object, or a compacted copy if particles left
            the domain (they are removed with a warning and counted in removed_count).

        Raises:
            SimulationError: Unstable time step, excessive overlap or energy blow-up.
        """
        if state is not self._bound or self._force.shape[0] != state.n:
            self.bind(state)
        tool_moved = self._tool_moved()  # decided on the previous step's pose, as LIGGGHTS
        if tool_pose is not None:
            self.tool_pose = tool_pose
        with threads_at_most(self._threads):
            moved, n_out = self.integrate_first_half(state)
            if n_out:
                state = self._remove_outside(state)
            elif tool_moved or self._keeper.must_build(moved, state.positions, self._pos_build):
                self.find_contacts(state, np.arange(state.n))
            self.contact_forces(state, self.tool_pose, self._dt)
            self.integrate_second_half(state)
        return state

    def _update_sleep(self, state: SimState) -> None:
        """Grains quiet for long enough fall asleep; disturbed ones wake (`sleep.update_sleep`)."""
        sleep = self.sleep
        assert sleep is not None
        if self.tool is not None and self._grid is not None:
            grid = self._grid
            near_tool_box(state.positions, self._packed[1], grid.lo, grid.lo + grid.dims
                          * grid.cell, self._tool_reach, self._near_u8)
        update_sleep(state.velocities, state.angular_velocities, self._force, self._torque,
                     state.masses, state.radii, self._gravity, self._asleep_u8, self._quiet,
                     self._rim_u8, self._touch_u8, self._wake_u8, self._near_u8, self._v_sleep,
                     self._w_sleep, sleep.force_fraction, sleep.wake_force_fraction,
                     sleep.quiet_steps, self._sleep_counts)
        self.n_asleep = int(self._sleep_counts[0])
        self.woken += int(self._sleep_counts[1])

    def _tool_moved(self) -> bool:
        """LIGGGHTS' forms: the tool moved half the skin since the list build (LIGGGHTS 3.8
        then rebuilds every list, ending the springs separated pairs keep, see `pair_forces`;
        with dempath's forms a build changes nothing)."""
        if self.tool is None or self.params.contact_forms != 'liggghts':
            return False
        return box_displacement(self._reach.corners, self._tool_build,
                                self.tool_pose.packed()) > 0.5 * self._skin

    def _remove_outside(self, state: SimState) -> SimState:
        keep = inside_domain(state, self.params, self.removed_count, self._n_bound, self._dt,
                             self.LOST_MIN, self.LOST_FRACTION)
        self.removed_count += int(np.count_nonzero(~keep))
        new = state.subset(keep)
        new_to_old = np.flatnonzero(keep)
        for name in ('_force', '_torque', '_gkey', '_ght', '_ghr'):  # per-particle buffers
            setattr(self, name, np.ascontiguousarray(getattr(self, name)[keep]))
        if self.sleep is not None:
            self._sleep_take(new_to_old)
        else:
            self._sleep_arrays(new.n)
        self._n_chunks = max(1, min(self._n_chunks, new.n))
        self._fbuf = np.zeros((self._n_chunks, new.n, 3))
        self._tbuf = np.zeros((self._n_chunks, new.n, 3))
        self._scratch()
        self._bound = new
        self.find_contacts(new, new_to_old)
        return new

    def run(self, state: SimState, n_steps: int,
            tool_motion: Callable[[float], ToolPose] | None = None,
            callback: Callable[[SimState, Engine], None] | None = None,
            callback_every: int = 1) -> SimState:
        """Advance n_steps steps; the tool follows tool_motion(t) (pose at time t).

        Args:
            state: Initial state.
            n_steps: Number of steps.
            tool_motion: Tool pose as a function of time [s]; the tool stays put if None.
            callback: Called as callback(state, engine) after every callback_every steps.
            callback_every: Steps between callbacks.

        Returns:
            The final state (see `step`).
        """
        if callback_every < 1:
            msg = f'Engine.run: callback_every must be >= 1, got {callback_every!r}'
            raise SimulationError(msg)
        if state is not self._bound:
            self.bind(state)
        for k in range(n_steps):
            pose = None if tool_motion is None else tool_motion(state.time + self._dt)
            state = self.step(state, pose)
            if callback is not None and (k + 1) % callback_every == 0:
                callback(state, self)
        return state

    # ----------------------------------------------------------------- checkpoints
    _STATE_FIELDS = ('positions', 'velocities', 'angular_velocities', 'radii', 'masses',
                     'inertias', 'material', 'ids')
    _ENGINE_ARRAYS = ('_force', '_torque', '_gkey', '_ght', '_ghr', '_start', '_nbr',
                      '_pos_build', '_tool_build', '_asleep_u8', '_rim_u8', '_quiet')
    _COUNTERS = ('removed_count', 'n_rebuilds', 'slot_overflows', 'pair_evaluations',
                 'n_asleep', 'woken', '_n_bound')

    def checkpoint(self, state: SimState) -> dict[str, NDArray[np.generic]]:
        """Everything needed to go on stepping ``state`` (bound) later: the state, the neighbour
        list with its springs, the geometry slots, the forces of the last step, the sleep state,
        the counters and the tool pose (arrays; the caller writes them, e.g. ``np.savez``).
        `resume` continues the run: the particles' motion to rounding (the tool's force is a
        sum over its candidates in another grouping until the next candidate search)."""
        if state is not self._bound:
            msg = 'Engine.checkpoint: the state is not the one this engine steps'
            raise SimulationError(msg)
        out: dict[str, NDArray[np.generic]] = {
            f'state.{k}': getattr(state, k) for k in self._STATE_FIELDS}
        out.update({f'engine.{k}': getattr(self, k) for k in self._ENGINE_ARRAYS})
        out.update({f'engine.hist.{k}': v for k, v in self._hist.arrays().items()})
        out['state.clock'] = np.array([state.time, float(state.step)])
        out['engine.counters'] = np.array([getattr(self, k) for k in self._COUNTERS], np.int64)
        pose = self.tool_pose
        out['engine.tool_pose'] = np.concatenate([
            np.asarray(pose.position, np.float64).reshape(3),
            np.asarray(pose.velocity, np.float64).reshape(3),
            np.eye(3).reshape(9) if pose.rotation is None else np.asarray(pose.rotation).ravel(),
            np.zeros(3) if pose.angular_velocity is None else np.asarray(pose.angular_velocity)])
        return out

    def resume(self, data: Mapping[str, NDArray[np.generic]]) -> SimState:
        """The state of a `checkpoint`, bound to this engine (same parameters, walls, tool and
        sleep settings as the engine that wrote it) with its list, springs and forces."""
        saved = {k: np.array(data[f'state.{k}']) for k in self._STATE_FIELDS}
        state = SimState(**{k: v.copy() for k, v in saved.items()},  # type: ignore[arg-type]
                         time=float(data['state.clock'][0]), step=int(data['state.clock'][1]))
        pose = np.asarray(data['engine.tool_pose'], np.float64)
        self.tool_pose = ToolPose(pose[:3], pose[3:6], pose[6:15].reshape(3, 3), pose[15:18])
        self.bind(state)  # buffers and a list (reordered: overwritten next)
        for k, v in saved.items():
            getattr(state, k)[...] = v
        for k in self._ENGINE_ARRAYS:
            setattr(self, k, np.ascontiguousarray(data[f'engine.{k}']))
        self._hist.restore({k: data[f'engine.hist.{k}'] for k in ('slot', 'ht', 'hr')}
                           if 'engine.hist.slot' in data else  # by-entry springs (before)
                           {'ht': data['engine._ht'], 'hr': data['engine._hr']},
                           self._start, self._n_chunks)
        self._chunk_windows()
        for k, v in zip(self._COUNTERS, np.asarray(data['engine.counters']).tolist(),
                        strict=True):
            setattr(self, k, int(v))
        self._reach.forget()
        self._keeper.built(None, 0.0)  # the build's cells are not this order's: whole-bed rule
        return state

    # ----------------------------------------------------------------- introspection
    @property
    def forces(self) -> tuple[F64, F64]:
        """(force (n, 3) [N], torque (n, 3) [N m]) of the contacts at the last evaluation."""
        return self._force, self._torque

    @property
    def n_pairs(self) -> int:
        """Entries of the neighbour list (pairs within the skin)."""
        return int(self._nbr.size)

    @property
    def kept_lists(self) -> int:
        """Steps at which ``local_rebuild`` kept a list the whole-bed rule would have rebuilt
        (since the last bind)."""
        return self._keeper.kept_steps if self._bound is not None else 0

    @property
    def loaded_springs(self) -> int:
        """Particle pairs whose tangential spring is loaded now (their contact history)."""
        return self._hist.loaded()

    @property
    def pair_springs(self) -> tuple[F64, F64]:
        """(tangential [m], rolling [N m]) springs (m, 3) by neighbour-list entry (a copy)."""
        return self._hist.by_entry()

    @property
    def n_contacts(self) -> int:
        """Particle-particle pairs overlapping now (numpy over the neighbour list)."""
        st = self._bound
        return 0 if st is None else overlapping_pairs(st.positions, st.radii, self._start,
                                                      self._nbr)

    def memory_bytes(self) -> dict[str, int]:
        """Bytes held: per-particle arrays of engine + state, and neighbour-list entries."""
        st = self._bound
        per_particle = (self._force.nbytes + self._torque.nbytes + self._fbuf.nbytes
                        + self._tbuf.nbytes + self._gkey.nbytes + self._ght.nbytes
                        + self._ghr.nbytes + self._pos_build.nbytes + self._start.nbytes)
        if st is not None:
            per_particle += sum(a.nbytes for a in (
                st.positions, st.velocities, st.angular_velocities, st.radii, st.masses,
                st.inertias, st.material, st.ids))
        pairs = self._nbr.nbytes + self._hist.nbytes()
        return {'particle_arrays': int(per_particle), 'pair_arrays': int(pairs),
                'pairs': int(self._nbr.size)}
