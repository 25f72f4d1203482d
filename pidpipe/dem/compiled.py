"""The engine of the DEM: the compiled kernel (:mod:`pidpipe.dem.kernel`) behind plain functions.

:class:`KernelWorkspace` holds the contact history and the ledgers' accumulators of a batch of
cells next to their :class:`~pidpipe.dem.state.State`; :func:`set_up`, :func:`advance` and
:func:`run_cycles` call the kernel. The arrays read as the NumPy reference's
(``ws.delta``, ``ws.contact``, ``ws.slide``, ``state.shear``, ``state.tangential_energy``), so
:mod:`pidpipe.dem.energy` works on either.

A missing Numba stops the import with the fix (``pip install numba`` or ``bash install.sh``);
a kernel that fails to compile raises :class:`KernelError` naming it. There is no fallback to
the NumPy reference, which is some 100-400 times slower (437 us per cell-step alone and 73 us
in a batch of 8, benchmarks/results.md, against about 1 us).
"""

from __future__ import annotations

import numpy as np

from pidpipe.dem import kernel
from pidpipe.dem.scene import ContactLaw, Scene
from pidpipe.dem.state import N_WALLS, State
from pidpipe.dem.walls import wall_planes
from pidpipe.errors import PidpipeError

KERNEL_NAME = "numba-dem"
"""The solver named in the records of the compiled DEM."""


class KernelError(PidpipeError):
    """The compiled DEM kernel could not be built: it stops the run (no case could run), not
    one case."""


def _law_parameters(law: ContactLaw) -> list[float]:
    """The kernel's six numbers of a contact law (order: kernel.A_N ... kernel.ENERGY_N)."""
    gt_over_gn = law.g_t / law.g_n if law.g_n != 0 else 0.0
    energy_n = 8.0 / 15.0 * law.youngs_eff_pa * np.sqrt(law.radius_eff_m)
    return [law.a_n, law.g_n, law.a_t, law.friction, gt_over_gn, float(energy_n)]


def scene_parameters(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """The scene as the kernel's float vector (kernel.N_PARAMS,) and switches (2,) int64."""
    values = [scene.timestep_s, scene.radius_m, scene.mass_kg, scene.inertia_kg_m2,
              scene.mass_kg * scene.gravity_m_s2, scene.omega_rad_s,
              *_law_parameters(scene.pp), *_law_parameters(scene.pw)]
    params = np.array(values, dtype=float)
    assert params.shape == (kernel.N_PARAMS,)
    return params, np.array([int(scene.friction), int(scene.rotation)], dtype=np.int64)


class KernelWorkspace:
    """Contact history and ledger accumulators of a batch of cells, for the compiled kernel.

    The kernel keeps the contact history in ``history`` (the state's ``shear`` and
    ``tangential_energy``, and ``delta`` and ``slide`` here, are written from it after every
    call, for reading).

    Attributes
    ----------
    n : int
        Spheres per cell.
    delta : ndarray, shape (n_batch, n, n + 8)
        Overlaps at the last force evaluation (0 where not in contact), m.
    slide : ndarray of bool, shape (n_batch, n, n + 8)
        Contacts that slid at the last evaluation.
    terms_raw : ndarray, shape (4, 2, n_batch)
        Raw energy terms by contact type since the last reset (see :func:`accumulated_dissipation`).
    wall_work_acc, gross_wall_work_acc : ndarray, shape (n_batch,)
        Work of the walls on the spheres since the last reset, and the sum of its absolute
        value step by step, J.
    wall_force_z : ndarray, shape (n_batch,)
        Total z force of the walls on the spheres at the last evaluation, N.
    """

    def __init__(self, scene: Scene, state: State):
        n_batch, n = state.n_batch, state.n_spheres
        m = n + N_WALLS
        self.n = n
        self.params, self.flags = scene_parameters(scene)
        normals, offsets = wall_planes(scene.cell)
        self.normals, self.offsets = np.ascontiguousarray(normals), np.ascontiguousarray(offsets)
        self.amplitude = np.ascontiguousarray(scene.amplitude_m, dtype=float)
        self.delta = np.zeros((n_batch, n, m))
        self.slide = np.zeros((n_batch, n, m), dtype=np.bool_)
        self.body = np.zeros((n_batch, n, kernel.N_BODY))
        self.history = np.zeros((n_batch, n, m, kernel.N_HIST))
        self.terms_raw = np.zeros((4, 2, n_batch))
        self.wall_work_acc = np.zeros(n_batch)
        self.gross_wall_work_acc = np.zeros(n_batch)
        self.wall_force_z = np.zeros(n_batch)

    @property
    def contact(self) -> np.ndarray:
        """Contacts closed at the last evaluation; bool, shape (n_batch, n, n + 8)."""
        return self.delta > 0.0

    def state_arrays(self, state: State) -> tuple:
        """The kernel's leading arguments, state and history, in its order."""
        return (state.x, state.v, state.omega, state.force, state.torque, state.shear,
                state.tangential_energy, self.delta, self.slide, self.body, self.history,
                self.wall_force_z, self.params, self.flags, self.normals, self.offsets,
                self.amplitude)


def _call(function, *args):
    """Call a kernel function; a Numba failure becomes a :class:`KernelError` with the fix."""
    try:
        return function(*args)
    except Exception as exc:
        from numba.core.errors import NumbaError
        if isinstance(exc, NumbaError):
            raise KernelError(
                f"the compiled DEM kernel failed to compile ({type(exc).__name__}: "
                f"{str(exc).splitlines()[0] if str(exc) else ''}); reinstall numba with "
                "`bash install.sh` (or `pip install --force-reinstall numba`)") from exc
        raise


def set_up(scene: Scene, state: State, ws: KernelWorkspace) -> None:
    """Evaluate the forces of the initial state (LIGGGHTS' set-up: no history update)."""
    _call(kernel.set_up, *ws.state_arrays(state), int(state.step))
    ws.terms_raw.fill(0.0)
    ws.wall_work_acc.fill(0.0)
    ws.gross_wall_work_acc.fill(0.0)


def _run(state: State, ws: KernelWorkspace, n_cycles: int, steps_per_cycle: int, reset: bool,
         reference: np.ndarray, motion_window: int = 0, motion_every: int = 1,
         motion: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    n_batch = state.n_batch
    work, gross = np.zeros((n_batch, n_cycles)), np.zeros((n_batch, n_cycles))
    terms = np.zeros((4, 2, n_batch, n_cycles))
    energy = np.zeros((kernel.N_ENERGY_ROWS, n_batch, n_cycles + 1))
    harmonics = np.zeros((2, n_batch, n_cycles))
    end = state.step + n_cycles * steps_per_cycle
    if motion is None:
        n_windows = end // motion_window if motion_window > 0 else 0
        motion = np.zeros((kernel.N_MOTION_ROWS, n_batch, n_windows + 1))
    _call(kernel.run, *ws.state_arrays(state), int(state.step), int(n_cycles),
          int(steps_per_cycle), bool(reset), ws.terms_raw, ws.wall_work_acc,
          ws.gross_wall_work_acc, np.ascontiguousarray(reference, dtype=float), work, gross,
          terms, energy, int(motion_window), int(motion_every), motion, harmonics)
    state.step = end
    return work, gross, terms, energy, motion, harmonics


def advance(state: State, ws: KernelWorkspace, n_steps: int) -> None:
    """Take ``n_steps`` steps, adding their energy terms to the accumulators."""
    if n_steps > 0:
        _run(state, ws, 1, int(n_steps), False, np.zeros(state.n_batch))


def run_cycles(scene: Scene, state: State, ws: KernelWorkspace, n_cycles: int,
               reference_height_m: np.ndarray, motion_window: int = 0,
               motion_every: int = 1, motion: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Whole cycles with the ledger of each, in one kernel call.

    With ``motion_window`` > 0 the call also samples the bed's motion in windows of that many
    steps, counted from step 0 (``motion_every``, a divisor of it, spaces the samples of the
    floor and lid forces): the result then has ``motion``, the kernel's (N_MOTION_ROWS,
    n_batch, n_windows + 1) array (rows ``kernel.M_*``), n_windows the windows that end by the
    end of the call. A ``motion`` array passed in is added into instead (the kernel samples the
    windows below its last column, whatever their number: a run continued call after call
    passes the same windows, grown).

    Returns
    -------
    dict of ndarray
        ``wall_work_j``, ``gross_work_j`` (n_batch, n_cycles); ``terms_j`` (4, 2, n_batch,
        n_cycles) by term and contact type; and at the n_cycles + 1 boundaries
        ``kinetic_translational``, ``kinetic_rotational``, ``potential``, ``elastic``,
        ``ledger`` (J), ``centre_of_mass_z_m``, ``lowest_z_m`` and ``highest_z_m`` (the
        lowest and highest sphere centre, lab frame, m), each (n_batch, n_cycles + 1);
        ``harmonic_cos_n_s``, ``harmonic_sin_n_s`` (n_batch, n_cycles), each cycle's
        first-harmonic sums S_c and S_s of the spheres' z force on the walls, N s
        (:mod:`pidpipe.measurement.harmonics`).
    """
    if motion_window > 0 and motion_window % motion_every:
        raise ValueError(f"motion samples every {motion_every} steps do not divide windows of "
                         f"{motion_window} steps")
    work, gross, terms, energy, motion, harmonics = _run(
        state, ws, int(n_cycles), scene.steps_per_cycle, True, reference_height_m,
        motion_window, motion_every, motion)
    extra = {"motion": motion} if motion_window > 0 else {}
    return dict(**extra, wall_work_j=work, gross_work_j=gross, terms_j=terms,
                kinetic_translational=energy[kernel.E_TRANS],
                kinetic_rotational=energy[kernel.E_ROT], potential=energy[kernel.E_POT],
                elastic=energy[kernel.E_ELASTIC], ledger=energy[kernel.E_LEDGER],
                centre_of_mass_z_m=energy[kernel.E_COM], lowest_z_m=energy[kernel.E_LOWEST],
                highest_z_m=energy[kernel.E_HIGHEST], harmonic_cos_n_s=harmonics[0],
                harmonic_sin_n_s=harmonics[1])


def set_base_motion(ws: KernelWorkspace, scene: Scene) -> None:
    """Move the cells with ``scene``'s base motion from the next call on, keeping the history.

    The scene must be the workspace's own but for the acceleration amplitudes (the same
    timestep, frequency, spheres and laws): a pour settles (0 g), is tapped and settles again in
    one workspace, its contacts' history carried through.

    Raises
    ------
    ValueError
        ``scene`` differs from the workspace's in more than ``accel_g``.
    """
    params, flags = scene_parameters(scene)
    amplitude = np.ascontiguousarray(scene.amplitude_m, dtype=float)
    normals, offsets = wall_planes(scene.cell)
    if (not np.array_equal(params, ws.params) or not np.array_equal(flags, ws.flags)
            or not np.array_equal(offsets, ws.offsets) or not np.array_equal(normals, ws.normals)
            or amplitude.shape != ws.amplitude.shape):
        raise ValueError("set_base_motion: the scene differs from the workspace's in more than "
                         "its acceleration amplitudes")
    ws.amplitude = amplitude


def accumulated_dissipation(ws: KernelWorkspace, dt: float) -> np.ndarray:
    """Energy dissipated since the last reset by term and contact type; (4, 2, n_batch), J."""
    s0, s1, s2, s3 = ws.terms_raw
    damping = dt * s3
    return np.stack([0.5 * dt * s0, 0.5 * s2, damping, 0.5 * (s1 - s2) - damping])
