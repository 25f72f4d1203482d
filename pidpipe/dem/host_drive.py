"""Driving the compiled host-coupled loop (:mod:`pidpipe.dem.coupled`): one forcing frequency.

:func:`run_host` takes a DEM scene (its timestep, a whole number of steps per period of the
force), k settled packings (or none: the bare host), the host's parameters and the force, and
returns the per-cycle series: the host's first-harmonic displacement, the spheres' first-harmonic
force on it, and every term of the energy balance. See :mod:`pidpipe.dem.coupled` for the
equations and the gravity convention. :func:`run_host_groups` drives cells in groups at weights
phi_g along a mode shape (the host then is the mode's coordinate; :mod:`pidpipe.panel.check`).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from pidpipe.dem import compiled, coupled
from pidpipe.dem.energy import centre_of_mass_height
from pidpipe.dem.run import prepare
from pidpipe.dem.scene import Scene
from pidpipe.dem.state import initial_state


@dataclass(frozen=True)
class HostDrive:
    """The host and its forcing, SI.

    Attributes
    ----------
    mass_kg : float
        m_h, the host's mass without the spheres, kg.
    stiffness_n_m : float
        k_h, N/m.
    damping_ns_m : float
        c_h, the host's own (structural) viscous damping, N s/m.
    force_n : float
        F_0, amplitude of the force F_0 cos(Omega t), N.
    cell_scale : float
        S = n_c / k: filled cells each integrated cell stands for (0: the spheres feel the host
        but do not act on it).
    """

    mass_kg: float
    stiffness_n_m: float
    damping_ns_m: float
    force_n: float
    cell_scale: float

    def __post_init__(self) -> None:
        if not (self.mass_kg > 0 and self.stiffness_n_m > 0 and self.damping_ns_m >= 0
                and self.force_n >= 0 and self.cell_scale >= 0):
            raise ValueError(f"host needs mass > 0, stiffness > 0, damping >= 0, force >= 0 and "
                             f"cell_scale >= 0; got {self}")


def run_host(scene: Scene, positions_m, host: HostDrive, n_cycles: int,
             initial_displacement_m: float = 0.0, initial_velocity_m_s: float = 0.0) -> dict:
    """Force the host at the scene's frequency for ``n_cycles`` periods, from t = 0.

    Parameters
    ----------
    scene : Scene
        The DEM scene; its ``freq_hz`` is the forcing frequency and its timestep divides the
        period into ``steps_per_cycle`` steps (its base acceleration is not used).
    positions_m : array_like, shape (k, n, 3), or None
        Settled packings of the k integrated cells (cell frame, m); None or k = 0: no spheres.
    host : HostDrive
    n_cycles : int
    initial_displacement_m, initial_velocity_m_s : float
        The host's state at t = 0 (m, m/s); the packings start resting on its floor (shifted
        by the displacement, moving with its velocity).

    Returns
    -------
    dict
        Per cycle, shape (n_cycles,): ``force_work_j`` (W_F), ``host_damping_j`` (D_h),
        ``wall_work_j`` (S W_w), ``gross_wall_work_j`` (the sum of |S W_w| step by step),
        ``particle_dissipation_j`` (S D_p, term by term),
        ``energy_change_j`` (Delta(E_h + S E_p)), ``balance_residual_j`` (W_F - D_h - S D_p -
        Delta E), ``displacement`` (complex first harmonic X, m, x = Re(X e^{i Omega t})),
        ``reaction`` (complex first harmonic of the spheres' force on the host, N),
        ``peak_displacement_m``; and ``host_energy_j``, ``particle_energy_j`` (S E_p) at the
        n_cycles + 1 boundaries; per cell, shape (k, n_cycles): ``cell_wall_force`` (complex first
        harmonic of its walls' z force, N; the weight is a constant and drops out) and
        ``cell_dissipation_j`` (its spheres' dissipation, unscaled, J); ``steps_per_cycle``, ``timestep_s``, ``n_cells``,
        ``n_spheres``, ``cpu_s``.
    """
    started = time.process_time()
    k = 0 if positions_m is None else int(np.asarray(positions_m).shape[0])
    if k == 0:
        scene = dataclasses.replace(scene, accel_g=np.zeros(0))
        state = initial_state(np.zeros((0, 1, 3)))
    else:
        scene, state = prepare(dataclasses.replace(scene, accel_g=np.zeros(k)), positions_m)
        # the bed rests on the floor of the moving host: shifted with it and moving with it
        state.x[2] += initial_displacement_m
        state.v[2] = initial_velocity_m_s
    ws = compiled.KernelWorkspace(scene, state)
    compiled._call(coupled.set_up_coupled, *ws.state_arrays(state)[:-1],
                   float(initial_displacement_m), float(initial_velocity_m_s))
    n = state.n_spheres if k else 0
    omega = scene.omega_rad_s
    weight = k * n * scene.mass_kg * scene.gravity_m_s2
    params = _host_params(host, omega)
    params[coupled.H_SCALE] = host.cell_scale
    params[coupled.H_WEIGHT] = weight
    reaction0 = -host.cell_scale * (float(ws.wall_force_z.sum()) - weight)
    host_state = _host_state(host, initial_displacement_m, initial_velocity_m_s, reaction0)
    n_cycles = int(n_cycles)
    per_cycle, per_cell, terms, energy, host_energy = _series_buffers(k, n_cycles)
    reference = np.ascontiguousarray(centre_of_mass_height(state)) if k else np.zeros(0)
    compiled._call(coupled.run_coupled, *ws.state_arrays(state)[:-1], params, host_state,
                   0, n_cycles, int(scene.steps_per_cycle), reference, per_cycle, per_cell, terms,
                   energy, host_energy)
    state.step += n_cycles * scene.steps_per_cycle
    return cycle_series(per_cycle, terms, energy, host_energy, host.cell_scale) | dict(
        cell_wall_force=per_cell[0] - 1j * per_cell[1],
        cell_dissipation_j=terms.sum(axis=(0, 1)),
        steps_per_cycle=int(scene.steps_per_cycle), timestep_s=float(scene.timestep_s),
        n_cells=k, n_spheres=n, freq_hz=float(scene.freq_hz),
        cpu_s=time.process_time() - started)


@dataclass(frozen=True)
class CellGroups:
    """Integrated cells in groups along a mode shape (:func:`run_host_groups`).

    Attributes
    ----------
    group_of : tuple of int, length k
        Each integrated cell's group.
    weights : tuple of float, length G
        phi_g, the mode shape where the group's cells sit (the walls move as phi_g q).
    cells : tuple of float, length G
        n_g, the filled cells each group stands for (its integrated cells each stand for
        S_g = n_g / k_g of them; n_g = 0: the group feels the host but does not act on it).
    """

    group_of: tuple
    weights: tuple
    cells: tuple

    def __post_init__(self) -> None:
        n_groups = len(self.weights)
        members = np.bincount(np.asarray(self.group_of, dtype=int), minlength=n_groups)
        if (len(self.cells) != n_groups or members.size != n_groups or np.any(members == 0)
                or not all(np.isfinite(w) for w in self.weights) or min(self.cells, default=0) < 0):
            raise ValueError(f"every group needs a finite weight, cells >= 0 and at least one "
                             f"integrated cell; got {self}")

    @property
    def scales(self) -> np.ndarray:
        """S_g = n_g / k_g, shape (G,)."""
        members = np.bincount(np.asarray(self.group_of, dtype=int), minlength=len(self.weights))
        return np.asarray(self.cells, dtype=float) / members

    @property
    def cell_weights(self) -> np.ndarray:
        """phi of each integrated cell, shape (k,)."""
        return np.asarray(self.weights, dtype=float)[np.asarray(self.group_of, dtype=int)]

    @property
    def cell_scales(self) -> np.ndarray:
        """S of each integrated cell, shape (k,)."""
        return self.scales[np.asarray(self.group_of, dtype=int)]


def run_host_groups(scene: Scene, positions_m, groups: CellGroups, host: HostDrive, n_cycles: int,
                    initial_displacement_m: float = 0.0, initial_velocity_m_s: float = 0.0) -> dict:
    """:func:`run_host` with the cells in groups at weights phi_g along a mode shape.

    The host is a mode's coordinate q (the antinode's displacement, m): modal mass
    ``host.mass_kg``, stiffness and structural damping as ``host``'s; the cells of group g ride
    at phi_g q and their generalised force on the mode is -sum_g S_g phi_g (F_w,g - W_0,g)
    (:func:`pidpipe.dem.coupled.run_coupled_groups`). ``host.cell_scale`` is not used (the groups
    carry theirs). One group at weight 1 standing for S k cells is :func:`run_host` with scale S.

    Parameters
    ----------
    scene : Scene
    positions_m : array_like, shape (k, n, 3)
        Settled packings of the k integrated cells (every group's at one fill: the kernel's cells
        hold equal numbers of spheres), m.
    groups : CellGroups
    host : HostDrive
    n_cycles : int
    initial_displacement_m, initial_velocity_m_s : float
        q and q' at t = 0; each cell's packing starts on its floor at phi_g q moving at phi_g q'.

    Returns
    -------
    dict
        As :func:`run_host`, with ``wall_work_j``, ``particle_dissipation_j`` and
        ``particle_energy_j`` summed over the cells with their S_g, ``reaction`` the generalised
        force, and ``group_wall_force`` (complex first harmonic of each group's mean wall z force
        per integrated cell, N, shape (G, n_cycles)).
    """
    started = time.process_time()
    positions = np.asarray(positions_m, dtype=float)
    k = int(positions.shape[0])
    group_of = np.ascontiguousarray(groups.group_of, dtype=np.int64)
    if group_of.shape != (k,):
        raise ValueError(f"{group_of.size} group indices for {k} packings")
    phi = groups.cell_weights
    scene, state = prepare(dataclasses.replace(scene, accel_g=np.zeros(k)), positions)
    state.x[2] += phi[:, None] * initial_displacement_m
    state.v[2] = phi[:, None] * initial_velocity_m_s
    ws = compiled.KernelWorkspace(scene, state)
    n = state.n_spheres
    one_weight = n * scene.mass_kg * scene.gravity_m_s2
    members = np.bincount(group_of, minlength=len(groups.weights))
    group_p = np.zeros((len(groups.weights), coupled.N_GROUP_PARAMS))
    group_p[:, coupled.G_WEIGHT] = groups.weights
    group_p[:, coupled.G_SCALE] = groups.scales
    group_p[:, coupled.G_GRAVITY] = members * one_weight
    compiled._call(coupled.set_up_coupled_groups, *ws.state_arrays(state)[:-1], group_of, group_p,
                   float(initial_displacement_m), float(initial_velocity_m_s))
    params = _host_params(host, scene.omega_rad_s)
    fz_group = np.bincount(group_of, weights=ws.wall_force_z, minlength=len(groups.weights))
    reaction0 = float(-np.sum(group_p[:, coupled.G_SCALE] * group_p[:, coupled.G_WEIGHT]
                              * (fz_group - group_p[:, coupled.G_GRAVITY])))
    host_state = _host_state(host, initial_displacement_m, initial_velocity_m_s, reaction0)
    n_cycles = int(n_cycles)
    per_cycle, per_cell, terms, energy, host_energy = _series_buffers(k, n_cycles)
    reference = np.ascontiguousarray(centre_of_mass_height(state))
    compiled._call(coupled.run_coupled_groups, *ws.state_arrays(state)[:-1], params, group_of,
                   group_p, host_state, 0, n_cycles, int(scene.steps_per_cycle), reference,
                   per_cycle, per_cell, terms, energy, host_energy)
    state.step += n_cycles * scene.steps_per_cycle
    cell_force = per_cell[0] - 1j * per_cell[1]
    group_force = np.stack([cell_force[group_of == g].mean(axis=0)
                            for g in range(len(groups.weights))])
    return cycle_series(per_cycle, terms, energy, host_energy, groups.cell_scales) | dict(
        cell_wall_force=cell_force, group_wall_force=group_force,
        cell_dissipation_j=terms.sum(axis=(0, 1)),
        steps_per_cycle=int(scene.steps_per_cycle), timestep_s=float(scene.timestep_s),
        n_cells=k, n_spheres=n, freq_hz=float(scene.freq_hz),
        cpu_s=time.process_time() - started)


def cycle_series(per_cycle: np.ndarray, terms: np.ndarray, energy: np.ndarray,
                 host_energy: np.ndarray, cell_scale) -> dict:
    """The named per-cycle series of :func:`run_host` from the kernel's output arrays
    (``cell_scale``: S of every cell, or one per cell, shape (k,), for :func:`run_host_groups`)."""
    from pidpipe.dem.kernel import E_LEDGER

    if np.ndim(cell_scale):
        scales = np.asarray(cell_scale, dtype=float)
        particle_energy = (scales[:, None] * energy[E_LEDGER]).sum(axis=0)
        dissipation = (scales[:, None] * terms.sum(axis=(0, 1))).sum(axis=0)
    else:
        particle_energy = cell_scale * energy[E_LEDGER].sum(axis=0)
        dissipation = cell_scale * terms.sum(axis=(0, 1, 2))
    change = np.diff(host_energy + particle_energy)
    work, damping = per_cycle[coupled.C_FORCE_WORK], per_cycle[coupled.C_HOST_DAMPING]
    # x = Re(X e^{i Omega t}) = X_r cos - X_i sin: the cosine sum is X_r, the sine sum -X_i
    displacement = per_cycle[coupled.C_X_COS] - 1j * per_cycle[coupled.C_X_SIN]
    reaction = per_cycle[coupled.C_R_COS] - 1j * per_cycle[coupled.C_R_SIN]
    return dict(force_work_j=work, host_damping_j=damping,
                wall_work_j=per_cycle[coupled.C_WALL_WORK],
                gross_wall_work_j=per_cycle[coupled.C_WALL_GROSS], particle_dissipation_j=dissipation,
                energy_change_j=change, balance_residual_j=work - damping - dissipation - change,
                displacement=displacement, reaction=reaction,
                peak_displacement_m=per_cycle[coupled.C_X_PEAK], host_energy_j=host_energy,
                particle_energy_j=particle_energy)


def effective_mass_and_damping(displacement: np.ndarray, reaction: np.ndarray,
                               omega_rad_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The spheres' force as a mass and a dashpot: R = -m_eff x'' - c_eff x' at the first
    harmonic, so R / X = m_eff Omega^2 - i Omega c_eff.

    Parameters
    ----------
    displacement, reaction : complex ndarray, same shape
        First harmonics of the host's displacement (m) and of the spheres' force on it (N).
    omega_rad_s : float

    Returns
    -------
    m_eff_kg, c_eff_ns_m : ndarray
    """
    ratio = reaction / displacement
    return ratio.real / omega_rad_s**2, -ratio.imag / omega_rad_s


__all__ = ["HostDrive", "CellGroups", "run_host", "run_host_groups", "cycle_series",
           "effective_mass_and_damping"]


def _host_params(host: HostDrive, omega_rad_s: float) -> np.ndarray:
    """The kernel's host parameters: mass, damping, stiffness, force and frequency (the cells'
    scale and weight left at 0 for the caller)."""
    params = np.zeros(coupled.N_HOST_PARAMS)
    params[coupled.H_MASS] = host.mass_kg
    params[coupled.H_DAMPING] = host.damping_ns_m
    params[coupled.H_STIFFNESS] = host.stiffness_n_m
    params[coupled.H_FORCE] = host.force_n
    params[coupled.H_OMEGA] = omega_rad_s
    return params


def _host_state(host: HostDrive, displacement_m: float, velocity_m_s: float,
                reaction_n: float) -> np.ndarray:
    """The host's (x, x', x'') at t = 0 with the spheres' initial reaction on it (N)."""
    accel = (host.force_n - host.damping_ns_m * velocity_m_s - host.stiffness_n_m * displacement_m
             + reaction_n) / host.mass_kg
    return np.array([displacement_m, velocity_m_s, accel])


def _series_buffers(k: int, n_cycles: int) -> tuple[np.ndarray, ...]:
    """The kernel's output arrays for k cells over n_cycles: per cycle, per cell, the energy
    terms, the cells' energies and the host's at the cycle boundaries."""
    return (np.zeros((coupled.N_CYCLE_ROWS, n_cycles)), np.zeros((2, k, n_cycles)),
            np.zeros((4, 2, k, n_cycles)), np.zeros((coupled.N_ENERGY_ROWS, k, n_cycles + 1)),
            np.zeros(n_cycles + 1))
