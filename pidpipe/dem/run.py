"""Running the DEM: stepping, per-cycle energy ledgers and the case record.

Every function here runs the compiled kernel (:mod:`pidpipe.dem.compiled`); the NumPy
reference that tests compare it with is :mod:`pidpipe.dem.reference`.

The record of :func:`simulate_cell` has the shape of the LIGGGHTS path's
(:func:`pidpipe.liggghts.shake.run_case`) so that the two solvers compare case by case: the summary of
the measured cycles from :func:`pidpipe.measurement.statistics.summarise_cycles` at the top level, per-cycle
arrays (wall work, energy change, dissipation by the balance and term by term, by contact
type) under ``cycles``, and the fidelity settings. The measured cycles are chosen by the same
rule as the LIGGGHTS path's (:func:`pidpipe.measurement.steady_state.assess_steady_state`): the configured
transient is a floor, and a longer transient that MSER detects in the run's own series (a bed
that collapses a few cycles in, say) is discarded too.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable

import numpy as np

from pidpipe.config.inspection import MotionSampling
from pidpipe.dem import compiled, kernel
from pidpipe.dem.contacts import DISSIPATION_TERMS
from pidpipe.dem.energy import centre_of_mass_height
from pidpipe.dem.scene import Scene
from pidpipe.dem.state import State, initial_state
from pidpipe.errors import PackingError
from pidpipe.measurement.motion import BedMotion
from pidpipe.measurement.statistics import summarise_cycles
from pidpipe.measurement.steady_state import SteadyState, assess_steady_state

SOLVER_NAME = compiled.KERNEL_NAME
CONTACT_TYPES: tuple[str, ...] = ("pp", "pw")
"""Contact types of the term-by-term dissipation: sphere-sphere and sphere-wall."""

Observer = Callable[[State, "compiled.KernelWorkspace"], None]


def prepare(scene: Scene, positions_m, velocities_m_s=None, angular_velocities_rad_s=None,
            overlap_tolerance_m: float | None = None) -> tuple[Scene, State]:
    """The initial state of a batch, checked to lie in the cell, and the scene sized to it.

    Parameters and errors as :func:`start`; the forces are not evaluated.
    """
    n_batch = scene.n_batch
    state = initial_state(positions_m, velocities_m_s, angular_velocities_rad_s,
                          n_batch=n_batch)
    if state.n_batch != n_batch:
        if n_batch != 1:
            raise ValueError(f"{state.n_batch} packings for a scene of {n_batch} cells")
        scene = dataclasses.replace(scene, accel_g=np.repeat(scene.accel_g, state.n_batch))
    tol = 0.05 * scene.radius_m if overlap_tolerance_m is None else overlap_tolerance_m
    centres = np.moveaxis(state.x, 0, 2).reshape(-1, 3)
    inside = scene.cell.contains_spheres(centres, scene.radius_m, tol_m=tol)
    if not np.all(inside):
        bad = np.flatnonzero(~inside)
        raise PackingError(
            f"{bad.size} sphere(s) of radius {scene.radius_m:g} m lie outside the cell by more "
            f"than {tol:g} m (first: flat index {bad[0]} at {centres[bad[0]]} m); "
            "give positions of a packing settled in this cell")
    return scene, state


def start(scene: Scene, positions_m, velocities_m_s=None, angular_velocities_rad_s=None,
          overlap_tolerance_m: float | None = None
          ) -> tuple[Scene, State, compiled.KernelWorkspace]:
    """Initial state (at rest unless velocities are given) with its forces evaluated.

    Parameters
    ----------
    scene : Scene
        A scene with one acceleration per cell, or one for all.
    positions_m : array_like, shape (n, 3) or (n_batch, n, 3)
        Sphere centres in the cell frame, m.
    velocities_m_s, angular_velocities_rad_s : array_like, optional
        Initial velocities (m/s) and angular velocities (rad/s), same shape.
    overlap_tolerance_m : float, optional
        How far a sphere may initially reach into a wall, m; default 5 % of the radius.

    Returns
    -------
    scene : Scene
        The scene with ``accel_g`` broadcast to the batch size.
    state : State
    ws : pidpipe.dem.compiled.KernelWorkspace
        The compiled kernel's contact history and accumulators.

    Raises
    ------
    PackingError
        If a sphere lies outside the cell by more than the tolerance.
    """
    scene, state = prepare(scene, positions_m, velocities_m_s, angular_velocities_rad_s,
                           overlap_tolerance_m)
    ws = compiled.KernelWorkspace(scene, state)
    compiled.set_up(scene, state, ws)
    return scene, state, ws


def advance(scene: Scene, state: State, ws: compiled.KernelWorkspace, n_steps: int,
            observer: Observer | None = None) -> None:
    """Take ``n_steps`` steps in the compiled kernel, in one call, or one step per call with
    ``observer(state, ws)`` called after each step if given."""
    if observer is None:
        compiled.advance(state, ws, int(n_steps))
        return
    for _ in range(int(n_steps)):
        compiled.advance(state, ws, 1)
        observer(state, ws)


def run_cycles(scene: Scene, state: State, ws: compiled.KernelWorkspace, n_cycles: int) -> dict:
    """Run whole excitation cycles in one call of the compiled kernel and keep the ledger of each.

    Returns
    -------
    dict of ndarray
        Each of shape (n_batch, n_cycles), J, unless stated:

        - ``wall_work_j``: work of the walls on the spheres
        - ``gross_work_j``: work exchanged with the walls, the sum of |work| of every step
        - ``energy_change_j``: change of K^ + P + U over the cycle (see :mod:`.energy`)
        - ``dissipated_balance_j``: wall work minus energy change
        - ``dissipated_terms_j``: the term-by-term total, the E_d of the cycle
        - ``<term>_<type>_j`` for every term of :data:`DISSIPATION_TERMS` and contact type
          ``pp`` (sphere-sphere) or ``pw`` (sphere-wall)
        - ``kinetic_translational_j``, ``kinetic_rotational_j``, ``potential_j``,
          ``elastic_j``: plain energies at the cycle boundaries, shape (n_batch, n_cycles + 1);
          the potential energy is zero at the centre of mass the run started from
        - ``ledger_energy_j``: K^ + P + U at the boundaries, shape (n_batch, n_cycles + 1)
        - ``centre_of_mass_z_m``, ``lowest_z_m``, ``highest_z_m``: the centre of mass and the
          lowest and highest sphere centre at the boundaries (lab frame), shape
          (n_batch, n_cycles + 1), m
        - ``harmonic_cos_n_s``, ``harmonic_sin_n_s``: the first-harmonic sums S_c and S_s of
          the spheres' z force on the walls (:mod:`pidpipe.measurement.harmonics`), N s
    """
    return run_cycles_sampled(scene, state, ws, n_cycles, None)[0]


def run_cycles_sampled(scene: Scene, state: State, ws: compiled.KernelWorkspace, n_cycles: int,
                       sampling: MotionSampling | None) -> tuple[dict, BedMotion | None]:
    """:func:`run_cycles`, sampling the bed's motion within the cycle in the same kernel call.

    Parameters
    ----------
    sampling : MotionSampling or None
        Windows per cycle and the spacing of the force samples, as the LIGGGHTS deck takes
        them (:meth:`MotionSampling.window_steps`); None: no sampling. Windows count from
        step 0, so the run is sampled from its start when ``state.step`` is 0.

    Returns
    -------
    cycles : dict of ndarray
        As :func:`run_cycles`.
    motion : BedMotion or None
        Every cell's window means (:class:`pidpipe.measurement.motion.BedMotion`): the walls'
        power is the work of every step in the window over its length (exact, not sampled);
        the floor's and lid's forces are the means of samples every
        ``sampling.sample_every_steps`` steps (the floor's upward force on the spheres and
        theirs on the lid, from the contacts with those two planes); heights above the moving
        floor and K + K_rot + P (potential zero at the centre of mass the call started from)
        at the window ends, the heights averaged over each window's two ends as LIGGGHTS'
        are. None without sampling.
    """
    run = CycleRun(scene, state, ws, sampling)
    run.run(n_cycles)
    return run.cycles(), run.motion()


BOUNDARY_KEYS = ("kinetic_translational", "kinetic_rotational", "potential", "elastic", "ledger",
                 "centre_of_mass_z_m", "lowest_z_m", "highest_z_m")
"""The kernel outputs at the cycle boundaries (n_cycles + 1 columns); the others are per cycle."""


class CycleRun:
    """Whole cycles of one batch, run call after call as one run: its ledgers and sampled
    motion, so far, are those of a single call of all the cycles.

    The state, the workspace (contact history, the walls' last force) and the step count carry
    the kernel from one call to the next; what a call would start afresh is kept here: the
    zero of the potential energy (the centre of mass when the run started) and the bed-motion
    windows, one partial window beyond the last whole one, whose sums the next call goes on
    adding to. The kernel's near lists are rebuilt at every call, and list the same contacts in
    the same order whenever they are built (:func:`pidpipe.dem.kernel._build_near`), so a run
    of n + m cycles in two calls gives the same numbers, to the last bit, as one call
    (tests/dem/test_run.py).

    Parameters
    ----------
    scene : Scene
    state : State
        With its forces evaluated (:func:`start`); advanced in place.
    ws : pidpipe.dem.compiled.KernelWorkspace
    sampling : MotionSampling or None
        As for :func:`run_cycles_sampled`.

    Attributes
    ----------
    n_cycles : int
        Cycles run so far.
    """

    def __init__(self, scene: Scene, state: State, ws: compiled.KernelWorkspace,
                 sampling: MotionSampling | None = None):
        self.scene, self.state, self.ws, self.sampling = scene, state, ws, sampling
        self.reference_m = centre_of_mass_height(state)
        self.window = 0 if sampling is None else sampling.window_steps(scene.steps_per_cycle)
        self.every = 1 if sampling is None else int(sampling.sample_every_steps)
        self.n_cycles = 0
        self._out: dict[str, np.ndarray] = {}
        self._motion: np.ndarray | None = None

    def run(self, n_cycles: int) -> None:
        """Run ``n_cycles`` more cycles (at least one) in one kernel call."""
        if n_cycles < 1:
            raise ValueError(f"a run goes on by at least one cycle, not {n_cycles}")
        motion = None
        if self.window > 0:
            end = self.state.step + int(n_cycles) * self.scene.steps_per_cycle
            motion = np.zeros((kernel.N_MOTION_ROWS, self.state.n_batch, end // self.window + 2))
            if self._motion is not None:
                motion[:, :, :self._motion.shape[2]] = self._motion
        out = compiled.run_cycles(self.scene, self.state, self.ws, int(n_cycles),
                                  self.reference_m, self.window, self.every, motion)
        self._motion = out.pop("motion", None)
        if self._out:
            out = {key: np.concatenate([self._out[key], value[..., 1:] if key in BOUNDARY_KEYS
                                        else value], axis=-1) for key, value in out.items()}
        self._out = out
        self.n_cycles += int(n_cycles)

    def cycles(self) -> dict:
        """The ledgers of every cycle so far, as :func:`run_cycles` returns them."""
        out = self._out
        boundary = {key: out[key] for key in BOUNDARY_KEYS[:5]}
        return cycle_ledgers(out["wall_work_j"], out["gross_work_j"], out["terms_j"], boundary,
                             out["centre_of_mass_z_m"], out["lowest_z_m"], out["highest_z_m"],
                             out["harmonic_cos_n_s"], out["harmonic_sin_n_s"])

    def motion(self) -> BedMotion | None:
        """The bed's motion in every whole window so far (as :func:`run_cycles_sampled`), or
        None without sampling."""
        if self._motion is None:
            return None
        whole = self.state.step // self.window
        return bed_motion(self.scene, self.state, self._motion[:, :, :whole + 1], self.window)


def bed_motion(scene: Scene, state: State, sampled: np.ndarray, window_steps: int) -> BedMotion:
    """The kernel's motion output (N_MOTION_ROWS, n_batch, n_windows + 1) as a BedMotion.

    Every cell of the batch must share the wall amplitude (the cells of one case do).
    """
    amplitude = np.asarray(scene.amplitude_m, dtype=float).reshape(-1)
    if not np.allclose(amplitude, amplitude[0], rtol=1e-12, atol=0.0):
        raise ValueError("a BedMotion needs one wall amplitude for all cells of the batch")
    windows = sampled[:, :, :-1]
    samples = np.maximum(windows[kernel.M_SAMPLES], 1.0)
    ends = sampled[:, :, :]
    mean_of_ends = {name: (0.5 * (ends[row, :, 1:] + ends[row, :, :-1])).T
                    for name, row in (("centre_m", kernel.M_CENTRE), ("bottom_m", kernel.M_BOTTOM),
                                      ("top_m", kernel.M_TOP))}
    return BedMotion(window_steps=int(window_steps), timestep_s=scene.timestep_s,
                     period_s=1.0 / scene.freq_hz, amplitude_m=float(amplitude[0]),
                     power_w=(windows[kernel.M_WORK] / (window_steps * scene.timestep_s)).T,
                     floor_force_n=(windows[kernel.M_FLOOR] / samples).T,
                     lid_force_n=(windows[kernel.M_LID] / samples).T,
                     energy_j=ends[kernel.M_ENERGY].T,
                     weight_n=np.full(state.n_batch, state.n_spheres * scene.mass_kg
                                      * scene.gravity_m_s2),
                     radius_m=scene.radius_m, **mean_of_ends)


def cycle_ledgers(work: np.ndarray, gross: np.ndarray, terms: np.ndarray,
                  boundary: dict[str, np.ndarray], com: np.ndarray, lowest: np.ndarray,
                  highest: np.ndarray, harmonic_cos: np.ndarray,
                  harmonic_sin: np.ndarray) -> dict:
    """The per-cycle record of :func:`run_cycles` from its parts.

    Parameters
    ----------
    work, gross : ndarray, shape (n_batch, n_cycles)
        Wall work and work exchanged per cycle, J.
    terms : ndarray, shape (4, 2, n_batch, n_cycles)
        Dissipation by term (:data:`DISSIPATION_TERMS`) and contact type, J.
    boundary : dict of ndarray, each (n_batch, n_cycles + 1)
        ``kinetic_translational``, ``kinetic_rotational``, ``potential``, ``elastic`` and
        ``ledger`` at the cycle boundaries, J.
    com, lowest, highest : ndarray, shape (n_batch, n_cycles + 1)
        Centre-of-mass height, and the lowest and highest sphere centre, at the boundaries, m.
    harmonic_cos, harmonic_sin : ndarray, shape (n_batch, n_cycles)
        First-harmonic sums S_c and S_s of the spheres' z force on the walls per cycle, N s
        (:mod:`pidpipe.measurement.harmonics`).
    """
    change = np.diff(boundary["ledger"], axis=1)
    out = dict(wall_work_j=work, gross_work_j=gross, energy_change_j=change,
               dissipated_balance_j=work - change, dissipated_terms_j=terms.sum(axis=(0, 1)))
    for k, term in enumerate(DISSIPATION_TERMS):
        for c, ctype in enumerate(CONTACT_TYPES):
            out[f"{term}_{ctype}_j"] = terms[k, c]
    for key in ("kinetic_translational", "kinetic_rotational", "potential", "elastic"):
        out[f"{key}_j"] = boundary[key]
    out["ledger_energy_j"] = boundary["ledger"]
    out["centre_of_mass_z_m"] = com
    out["lowest_z_m"], out["highest_z_m"] = lowest, highest
    out["harmonic_cos_n_s"], out["harmonic_sin_n_s"] = harmonic_cos, harmonic_sin
    return out


def simulate_cell(scene: Scene, positions_m, *, transient_cycles: int, measured_cycles: int,
                  block_cycles: int = 2, n_cells: int = 1, seed: int | None = None
                  ) -> list[dict]:
    """Shake one cell per packing and return one record per cell, as the LIGGGHTS path does.

    Parameters
    ----------
    scene : Scene
    positions_m : array_like, shape (n, 3) or (n_batch, n, 3)
        Settled packing(s) in the cell frame, m; several packings run as one batch.
    transient_cycles, measured_cycles : int
        The configured transient (cycles discarded at least) and the measured cycles; the run
        is their sum, and a cell discards max(transient_cycles, MSER's detected transient), as
        :func:`pidpipe.liggghts.shake.run_case` does.
    block_cycles : int
        Cycles per block for the standard error of the mean.
    n_cells : int
        Cells of the coupon, for the coupon's C_eq.
    seed : int, optional
        The packing seed, recorded only (the DEM itself is deterministic).

    Returns
    -------
    list of dict, one per cell of the batch
        ``solver``, ``freq_hz``, ``accel_g``, ``n_spheres``; the keys of
        :func:`pidpipe.measurement.statistics.summarise_cycles` for the term-by-term E_d of the measured
        cycles; ``status`` and ``flags`` (the steady-state checks only), and the keys of
        :meth:`pidpipe.measurement.steady_state.SteadyState.as_record`; ``balance`` (the same summary
        from the energy balance);
        ``balance_mismatch_fraction`` (term-by-term minus balance, over the balance, summed over
        the measured cycles); ``wall_work_cycle_mean_j``; ``dissipated_by_term_j`` (measured
        mean per cycle of every term and contact type); ``cycles`` (every array of
        :func:`run_cycles`, transient included, as lists); ``fidelity``; ``wall_time_s``.
    """
    if transient_cycles < 0 or measured_cycles < 1:
        raise ValueError("need transient_cycles >= 0 and measured_cycles >= 1")
    wall_start = time.perf_counter()
    scene, state, ws = start(scene, positions_m)
    per_cycle = run_cycles(scene, state, ws, transient_cycles + measured_cycles)
    wall_time = time.perf_counter() - wall_start
    fidelity = fidelity_record(scene, state, transient_cycles, measured_cycles, block_cycles,
                               seed)
    records = []
    for b in range(state.n_batch):
        cycles = {key: value[b] for key, value in per_cycle.items()}
        accel = float(scene.accel_g[b])
        steady = steady_state(cycles, transient_cycles, block_cycles)
        measured = slice(steady.transient_cycles, None)
        terms = cycles["dissipated_terms_j"][measured]
        balance = cycles["dissipated_balance_j"][measured]
        by_term = {f"{term}_{ctype}_j": float(cycles[f"{term}_{ctype}_j"][measured].mean())
                   for term in DISSIPATION_TERMS for ctype in CONTACT_TYPES}
        records.append({
            "solver": SOLVER_NAME,
            "freq_hz": scene.freq_hz,
            "accel_g": accel,
            "n_spheres": state.n_spheres,
            "status": "flagged" if steady.flags else "ok",
            "flags": list(steady.flags),
            **_summarise(terms, scene.freq_hz, accel, n_cells, block_cycles),
            **steady.as_record(),
            "balance": _summarise(balance, scene.freq_hz, accel, n_cells, block_cycles),
            "balance_mismatch_fraction": float((terms.sum() - balance.sum()) / balance.sum()),
            "wall_work_cycle_mean_j": float(cycles["wall_work_j"][measured].mean()),
            "dissipated_by_term_j": by_term,
            "cycles": {key: value.tolist() for key, value in cycles.items()},
            "fidelity": dict(fidelity, transient_cycles=steady.transient_cycles),
            "wall_time_s": wall_time,
        })
    return records


def steady_state(cycles: dict, configured_transient: int, block_cycles: int) -> SteadyState:
    """The LIGGGHTS path's steady-state verdict on one cell's term-by-term E_d series.

    Parameters
    ----------
    cycles : dict of ndarray
        One cell's :func:`run_cycles` arrays (``dissipated_terms_j``, ``ledger_energy_j``).
    configured_transient : int
        The configured transient, a floor on the cycles discarded.
    block_cycles : int
        Cycles per block.
    """
    return assess_steady_state(cycles["dissipated_terms_j"], cycles["ledger_energy_j"],
                               configured_transient, block_cycles)


def fidelity_record(scene: Scene, state: State, transient_cycles: int, measured_cycles: int,
                    block_cycles: int, seed: int | None) -> dict:
    """The settings a result depends on (the keys of the LIGGGHTS record's, plus the batch)."""
    return dict(
        solver=SOLVER_NAME,
        timestep_s=scene.timestep_s,
        steps_per_cycle=scene.steps_per_cycle,
        rayleigh_time_s=scene.rayleigh_time_s,
        rayleigh_fraction=scene.timestep_s / scene.rayleigh_time_s,
        timestep_rayleigh_fraction_config=scene.settings.get("timestep_rayleigh_fraction"),
        youngs_modulus_scale=scene.settings.get("youngs_modulus_scale", 1.0),
        transient_cycles=int(transient_cycles),
        transient_cycles_configured=int(transient_cycles),
        measured_cycles=int(measured_cycles),
        sem_block_cycles=int(block_cycles),
        rotation=scene.rotation,
        friction=scene.friction,
        seed=seed,
        n_spheres=state.n_spheres,
        n_batch=state.n_batch,
    )


def _summarise(dissipated_j: np.ndarray, freq_hz: float, accel_g: float, n_cells: int,
               block_cycles: int) -> dict:
    """:func:`pidpipe.measurement.statistics.summarise_cycles` of one cell's measured cycles."""
    return summarise_cycles(np.asarray(dissipated_j, dtype=float), freq_hz, accel_g, n_cells,
                            block_cycles)
