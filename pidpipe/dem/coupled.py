"""The compiled time loop of cells riding on a vibrating single-degree-of-freedom host.

The cells' eight planes move with the host instead of a prescribed sinusoid, and the spheres'
force on the walls is fed back to the host (two-way coupling). The spheres' physics is the
compiled kernel's (:func:`pidpipe.dem.kernel._forces`, packed state, ledgers); only the wall
motion differs from :func:`pidpipe.dem.kernel.run`.

The host
--------
The host's displacement x (m) is measured from its static equilibrium with the spheres at rest
on the floor: the spring's preload holds the weight of the host and of the spheres, so gravity
leaves the host's equation and enters only through the spheres' deviation from their weight.
With S = n_c / k (k integrated cells stand for n_c filled cells, which are independent),
F_w the walls' total z force on the spheres of the k cells, and W_0 the weight of those spheres,

    m_h x'' + c_h x' + k_h x = F_0 cos(Omega t) - S (F_w - W_0),

and the cells' walls sit at z_w = x in the cell frame (the frame of the settled packing; the
spheres' positions are lab-frame as in :func:`pidpipe.dem.kernel.run`, whose walls move as
W (cos(omega t) - 1) and are likewise at rest at z = 0 at t = 0).

Velocity Verlet for both, in LIGGGHTS' order: half kick and drift of spheres and host, the
forces at the new positions with the walls at x_{n+1} and moving with the host's half-step
velocity u_{n+1/2} (the spheres' velocities at that point are half-step values too, and it is
exactly the displacement the walls made over the step, as in the prescribed loop),
then the second half kick. The host's damping makes its second half kick implicit in u_{n+1};
it is linear and solved in closed form.

Energy bookkeeping (exact for the host, to the kernel's O(dt^2) elastic-energy error for the
spheres): with a the host's acceleration,

    Delta E_h = W_F - D_h - S W_w,     E_h = 1/2 m_h u^2 - m_h dt^2 a^2 / 8 + 1/2 k_h x^2 - S W_0 x,

W_F = sum (F_n + F_{n+1})/2 dx (the force's work), D_h = sum c_h (u_n + u_{n+1})/2 dx (the
host's damping) and W_w = sum (F_w,n + F_w,n+1)/2 dx (the walls' work on the spheres, the
kernel's definition), and for the spheres W_w = Delta(K^ + P + U) + D_p (:mod:`.energy`), so
per cycle W_F = D_h + S D_p + Delta(E_h + S E_p). -S W_0 x is the spring preload's share of
the potential energy of the spheres' weight (their own P is lab-frame).
"""

from __future__ import annotations

import math

import numpy as np

from pidpipe.dem.kernel import (
    DT,
    INERTIA,
    MASS,
    N_ENERGY_ROWS,
    _add_terms,
    _cycle_terms,
    _forces,
    _forces_into,
    _kick,
    _kick_drift,
    _ledger,
    _near_scratch,
    _pack,
    _scratch,
    _unpack,
    njit,
)

# the host's parameter vector
H_MASS, H_DAMPING, H_STIFFNESS, H_SCALE, H_FORCE, H_OMEGA, H_WEIGHT, N_HOST_PARAMS = range(8)
# a group's parameters (run_coupled_groups): weight phi_g, cells per integrated cell S_g, and
# the weight of its integrated cells' spheres W_0,g (N)
G_WEIGHT, G_SCALE, G_GRAVITY, N_GROUP_PARAMS = range(4)
# the host's state vector: displacement m, velocity m/s, acceleration m/s^2
S_X, S_U, S_A, N_HOST_STATE = 0, 1, 2, 3
# rows of the per-cycle host output (J for the works; m and N for the harmonic sums)
(C_FORCE_WORK, C_HOST_DAMPING, C_WALL_WORK, C_X_COS, C_X_SIN, C_R_COS, C_R_SIN, C_X_PEAK,
 C_WALL_GROSS, N_CYCLE_ROWS) = range(10)


@njit(cache=True, error_model="numpy")
def _host_energy(host_p, state, dt):
    """E_h = 1/2 m u^2 - m dt^2 a^2 / 8 + 1/2 k x^2 - S W_0 x, J (see the module docstring)."""
    m = host_p[H_MASS]
    x, u, a = state[S_X], state[S_U], state[S_A]
    return (0.5 * m * u * u - m * dt * dt * a * a / 8.0 + 0.5 * host_p[H_STIFFNESS] * x * x
            - host_p[H_SCALE] * host_p[H_WEIGHT] * x)


@njit(cache=True, error_model="numpy")
def set_up_coupled(x, v, w, f, t, shear, tenergy, delta, slide, body, hist, wall_fz, p, flags,
                   normals, offsets, zw, vw):
    """The forces of the initial state with the walls at ``zw`` (m) moving at ``vw`` (m/s), as
    :func:`pidpipe.dem.kernel.set_up` (no history update; its energy terms are not counted)."""
    _pack(x, v, w, f, t, body)
    for b in range(x.shape[1]):
        out = _forces(body[b], hist[b], p, flags[0] != 0, flags[1] != 0, normals, offsets, zw,
                      vw, False)
        wall_fz[b] = out[0]
    _unpack(body, hist, x, v, w, f, t, shear, tenergy, delta, slide)


@njit(cache=True, error_model="numpy")
def run_coupled(x, v, w, f, t, shear, tenergy, delta, slide, body, hist, wall_fz, p, flags,
                normals, offsets, host_p, host_state, step0, n_cycles, steps_per_cycle,
                reference, out_cycle, out_cell, out_terms, out_energy, out_host_energy):
    """Advance the host and every cell by ``n_cycles * steps_per_cycle`` steps from ``step0``.

    Parameters (shapes; nb cells, n spheres, m = n + 8 partner columns)
    ----------
    x ... wall_fz, p, flags, normals, offsets : as for :func:`pidpipe.dem.kernel.run`; the
        forces in ``f``/``t`` and ``wall_fz`` (nb,) must be those of the state (set-up).
    host_p : (N_HOST_PARAMS,) m_h kg, c_h N s/m, k_h N/m, S (cells per integrated cell),
        F_0 N, Omega rad/s, W_0 N (the weight of the nb cells' spheres, unscaled)
    host_state : (N_HOST_STATE,) x m, u m/s, a m/s^2 at step ``step0``; written at the end
    reference : (nb,) zero of the spheres' potential energy, m
    out_cycle : (N_CYCLE_ROWS, n_cycles) per cycle: the force's work W_F, the host's damping
        D_h, the scaled walls' work S W_w (J); sums over the cycle's steps of x cos, x sin,
        R cos, R sin of Omega t (R = -S (F_w - W_0), the spheres' force on the host), divided
        by steps_per_cycle / 2 (the first Fourier coefficients, m and N); the largest |x|, m;
        the scaled work exchanged with the walls, the sum of |S W_w| step by step, J
    out_cell : (2, nb, n_cycles) per cell, the sums of F_w,b cos and F_w,b sin of Omega t divided
        by steps_per_cycle / 2 (the first Fourier coefficients of its walls' z force, N)
    out_terms : (4, 2, nb, n_cycles) the spheres' dissipation by term and contact type, J
    out_energy : (8, nb, n_cycles + 1) the spheres' energies at the cycle boundaries (kernel
        rows E_*)
    out_host_energy : (n_cycles + 1,) E_h at the boundaries, J

    It is :func:`run_coupled_groups` with every cell in one group at weight 1 (the same
    arithmetic, operation for operation).
    """
    n_batch = x.shape[1]
    group_of = np.zeros(n_batch, dtype=np.int64)
    group_p = np.empty((1, N_GROUP_PARAMS))
    group_p[0, G_WEIGHT] = 1.0
    group_p[0, G_SCALE] = host_p[H_SCALE]
    group_p[0, G_GRAVITY] = host_p[H_WEIGHT]
    run_coupled_groups(x, v, w, f, t, shear, tenergy, delta, slide, body, hist, wall_fz, p, flags,
                       normals, offsets, host_p, group_of, group_p, host_state, step0, n_cycles,
                       steps_per_cycle, reference, out_cycle, out_cell, out_terms, out_energy,
                       out_host_energy)


@njit(cache=True, error_model="numpy")
def _preload(group_p):
    """sum_g S_g phi_g W_0,g, N: the modal weight of the spheres that the spring's preload holds."""
    total = 0.0
    for g in range(group_p.shape[0]):
        total += group_p[g, G_SCALE] * group_p[g, G_WEIGHT] * group_p[g, G_GRAVITY]
    return total


@njit(cache=True, error_model="numpy")
def set_up_coupled_groups(x, v, w, f, t, shear, tenergy, delta, slide, body, hist, wall_fz, p,
                          flags, normals, offsets, group_of, group_p, zh, uh):
    """:func:`set_up_coupled` with the walls of cell b at phi_g(b) zh (m) moving at phi_g(b) uh
    (m/s), the host at (zh, uh)."""
    _pack(x, v, w, f, t, body)
    for b in range(x.shape[1]):
        phi = group_p[group_of[b], G_WEIGHT]
        out = _forces(body[b], hist[b], p, flags[0] != 0, flags[1] != 0, normals, offsets,
                      phi * zh, phi * uh, False)
        wall_fz[b] = out[0]
    _unpack(body, hist, x, v, w, f, t, shear, tenergy, delta, slide)


@njit(cache=True, error_model="numpy")
def run_coupled_groups(x, v, w, f, t, shear, tenergy, delta, slide, body, hist, wall_fz, p, flags,
                       normals, offsets, host_p, group_of, group_p, host_state, step0, n_cycles,
                       steps_per_cycle, reference, out_cycle, out_cell, out_terms, out_energy,
                       out_host_energy):
    """:func:`run_coupled` for cells in groups that move with the host at weights phi_g.

    The host is a mode's coordinate q (the antinode's displacement, m); the cells of group g sit
    where the mode shape is phi_g, their walls at z_w = phi_g q moving at phi_g q', and each
    integrated cell of the group stands for S_g cells. The spheres' generalised force on the
    mode is R = -sum_g S_g phi_g (F_w,g - W_0,g) (F_w,g the group's walls' total z force on its
    spheres, W_0,g the weight of those spheres), the walls' work S_g W_w,g is phi_g times the
    host's displacement step, and E_h's preload term is -sum_g S_g phi_g W_0,g q.

    Parameters
    ----------
    host_p : (N_HOST_PARAMS,)
        As for :func:`run_coupled`; its S and W_0 are not used (the groups carry them).
    group_of : (nb,) int64
        Each cell's group.
    group_p : (n_groups, N_GROUP_PARAMS)
        Per group: phi_g, S_g, W_0,g (N, the weight of its integrated cells' spheres, unscaled).
    others
        As for :func:`run_coupled`; ``out_cycle``'s wall works and R are the groups' sums.
    """
    _pack(x, v, w, f, t, body)
    n_batch = x.shape[1]
    n_groups = group_p.shape[0]
    pairs, work_rows, lane = _scratch(x.shape[2])       # reused at every step, as in kernel.run
    near, near_n, anchor = _near_scratch(n_batch, x.shape[2])
    dt = p[DT]
    half_over_m = 0.5 * dt / p[MASS]
    half_over_i = 0.5 * dt / p[INERTIA]
    friction, rotation = flags[0] != 0, flags[1] != 0
    m_h, c_h, k_h = host_p[H_MASS], host_p[H_DAMPING], host_p[H_STIFFNESS]
    force0, omega = host_p[H_FORCE], host_p[H_OMEGA]
    # E_h's preload term, -sum_g S_g phi_g W_0,g x, as S W_0 x of a single host
    energy_p = host_p.copy()
    energy_p[H_SCALE] = 1.0
    energy_p[H_WEIGHT] = _preload(group_p)
    half_dt_over_mh = 0.5 * dt / m_h
    implicit = 1.0 / (1.0 + c_h * half_dt_over_mh)
    xh, uh, ah = host_state[S_X], host_state[S_U], host_state[S_A]
    fz_prev = np.empty(n_batch)
    for b in range(n_batch):
        fz_prev[b] = wall_fz[b]
    acc = np.zeros((4, 2, n_batch))
    cell_fz = np.zeros(n_batch)
    fz_group = np.zeros(n_groups)
    work_group = np.zeros(n_groups)
    force_prev = force0 * math.cos(omega * (step0 * dt))
    harmonic = 2.0 / steps_per_cycle
    for b in range(n_batch):
        _ledger(body[b], hist[b], p, rotation, reference[b], out_energy[:, b, 0])
    out_host_energy[0] = _host_energy(energy_p, host_state, dt)
    for cycle in range(n_cycles):
        acc[:] = 0.0
        work_f = damp_h = work_w = gross_w = xc = xs = rc = rs = peak = 0.0
        first = step0 + cycle * steps_per_cycle
        for s in range(steps_per_cycle):
            # first half kick and drift: spheres, then the host (the walls)
            for b in range(n_batch):
                _kick_drift(body[b], half_over_m, half_over_i, dt, rotation)
            u_half = uh + ah * (0.5 * dt)
            dx = u_half * dt
            x_new = xh + dx
            # forces at the new positions, the walls of group g at phi_g x_new moving with
            # phi_g u_half
            fz_group[:] = 0.0
            work_group[:] = 0.0
            for b in range(n_batch):
                g = group_of[b]
                phi = group_p[g, G_WEIGHT]
                out = _forces_into(body[b], hist[b], p, friction, rotation, normals, offsets,
                                   phi * x_new, phi * u_half, True, pairs, work_rows, lane,
                                   near[b], near_n[b], anchor[b])
                fz = out[0]
                work_group[g] += (fz_prev[b] + fz) * (0.5 * (phi * dx))
                fz_prev[b] = fz
                cell_fz[b] = fz
                fz_group[g] += fz
                _add_terms(acc, b, out)
            reaction = 0.0
            step_work = 0.0
            for g in range(n_groups):
                reaction += -(group_p[g, G_SCALE] * group_p[g, G_WEIGHT]) * (fz_group[g] - group_p[g, G_GRAVITY])
                step_work += group_p[g, G_SCALE] * work_group[g]
            # the host's second half kick, implicit in its damping
            phase = omega * ((first + s + 1) * dt)
            force_new = force0 * math.cos(phase)
            rhs = force_new - k_h * x_new + reaction
            u_new = (u_half + rhs * half_dt_over_mh) * implicit
            a_new = (rhs - c_h * u_new) / m_h
            work_f += (force_prev + force_new) * (0.5 * dx)
            damp_h += c_h * (uh + u_new) * (0.5 * dx)
            work_w += step_work
            gross_w += abs(step_work)
            cos_p, sin_p = math.cos(phase), math.sin(phase)
            xc += x_new * cos_p
            xs += x_new * sin_p
            rc += reaction * cos_p
            rs += reaction * sin_p
            peak = max(peak, abs(x_new))
            for b in range(n_batch):
                out_cell[0, b, cycle] += cell_fz[b] * cos_p
                out_cell[1, b, cycle] += cell_fz[b] * sin_p
            xh, uh, ah = x_new, u_new, a_new
            force_prev = force_new
            # the spheres' second half kick
            for b in range(n_batch):
                _kick(body[b], half_over_m, half_over_i, rotation)
        out_cycle[C_FORCE_WORK, cycle] = work_f
        out_cycle[C_HOST_DAMPING, cycle] = damp_h
        out_cycle[C_WALL_WORK, cycle] = work_w
        out_cycle[C_X_COS, cycle] = xc * harmonic
        out_cycle[C_X_SIN, cycle] = xs * harmonic
        out_cycle[C_R_COS, cycle] = rc * harmonic
        out_cycle[C_R_SIN, cycle] = rs * harmonic
        out_cycle[C_X_PEAK, cycle] = peak
        out_cycle[C_WALL_GROSS, cycle] = gross_w
        for b in range(n_batch):
            out_cell[0, b, cycle] *= harmonic
            out_cell[1, b, cycle] *= harmonic
            _cycle_terms(acc, b, dt, out_terms, cycle)
            _ledger(body[b], hist[b], p, rotation, reference[b], out_energy[:, b, cycle + 1])
        host_state[S_X], host_state[S_U], host_state[S_A] = xh, uh, ah
        out_host_energy[cycle + 1] = _host_energy(energy_p, host_state, dt)
    for b in range(n_batch):
        wall_fz[b] = fz_prev[b]
    host_state[S_X], host_state[S_U], host_state[S_A] = xh, uh, ah
    _unpack(body, hist, x, v, w, f, t, shear, tenergy, delta, slide)


__all__ = ["run_coupled", "run_coupled_groups", "set_up_coupled", "set_up_coupled_groups",
           "N_ENERGY_ROWS"]
