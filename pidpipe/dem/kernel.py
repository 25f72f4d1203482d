"""The DEM time loop compiled with Numba: many steps of a batch of cells in one call.

The physics is exactly that of the NumPy reference (:mod:`pidpipe.dem.contacts`,
:mod:`pidpipe.dem.integrator`, :mod:`pidpipe.dem.energy`; their docstrings give the
equations), written contact by contact instead of as dense arrays:

- Hertz normal force with restitution damping, the tangential history spring capped by
  Coulomb friction, tangential damping while sticking, contact torques (LIGGGHTS' ``model hertz
  tangential history``); the eight planes of the cell moving as z_w = W (cos(omega t) - 1);
  velocity Verlet in LIGGGHTS' order;
- the ledgers inside the loop: the walls' work over the displacement they actually made in
  each step (the half-step wall move), the four dissipation terms (normal damping, friction,
  tangential damping, tangential spring) by contact type, and at every cycle boundary the
  energies K, K_rot, P, U and the ledger total K^ + P + U.

Cells are independent, so within each cycle the loop runs cell by cell and step by step; the
wall's motion over the cycle is computed once for all cells. A sphere
pair is evaluated once, for i < j; its history lives in the (i, j) entries of the dense state
arrays (:mod:`pidpipe.dem.state`), and the (j, i) copies are filled at the end of each call so
that the arrays read as the reference's. A pair neither in contact now nor at the last
evaluation contributes exactly zero and is skipped.

Nothing here is called directly: :mod:`pidpipe.dem.compiled` builds the arrays and reports a
missing or failing Numba with the fix.
"""

from __future__ import annotations

import math

import numpy as np

try:
    from numba import njit
except ImportError as exc:  # pragma: no cover - exercised by hand, see compiled.py
    raise ImportError(
        "the compiled DEM needs numba, which is not installed in this environment: run "
        "`pip install numba` in it, or re-run `bash install.sh`") from exc

# indices into the float parameter vector (see compiled.scene_parameters)
DT, RADIUS, MASS, INERTIA, WEIGHT, OMEGA = 0, 1, 2, 3, 4, 5
PP, PW = 6, 12                 # start of the particle-particle and particle-wall laws
A_N, G_N, A_T, MU, GT_OVER_GN, ENERGY_N = 0, 1, 2, 3, 4, 5   # offsets within a law
N_PARAMS = 18
N_WALLS = 8
# rows of the boundary-energy output
E_TRANS, E_ROT, E_POT, E_ELASTIC, E_LEDGER, E_COM, E_LOWEST, E_HIGHEST = 0, 1, 2, 3, 4, 5, 6, 7
N_ENERGY_ROWS = 8


@njit(cache=True, error_model="numpy")
def _contact(dl, ex, ey, ez, vrx, vry, vrz, wx, wy, wz, is_wall, nz, lag, a_n, g_n, a_t, mu,
             gt_over_gn, dt, radius, friction, rotation, update, sx, sy, sz, dprev, tpx, tpy,
             tpz, s2prev):
    """One contact, scalars in and out (so that it inlines into the loop without overhead).

    Inputs: the overlap ``dl`` (>= 0), the unit normal (ex, ey, ez) towards sphere i, the
    relative velocity vr = v_i - v_partner, the sum w of the angular velocities, whether the
    partner is a wall (its normal's z component ``nz``, and lag = v_w - u_w), the law's
    coefficients, and the contact's history: shear s, the last step's normal damping force,
    -F_t (tp) and k_t |s|^2 (s2prev).

    Returns
    -------
    tuple
        Force on i (3, N), torque on i (3, N m), the raw energy terms e0..e3 (see
        :func:`pidpipe.dem.contacts.reduce_terms`), then the new history: shear (3), damping
        force, -F_t (3), k_t |s|^2, and whether the contact slid.
    """
    vn = vrx * ex + vry * ey + vrz * ez
    vtx, vty, vtz = vrx, vry, vrz
    cr = 0.0
    if friction:
        vtx = vrx - ex * vn
        vty = vry - ey * vn
        vtz = vrz - ez * vn
        if rotation:
            cr = dl * -0.5 + radius
            ax, ay, az = wx * cr, wy * cr, wz * cr
            vtx -= ay * ez - az * ey
            vty -= az * ex - ax * ez
            vtz -= ax * ey - ay * ex
    # normal force and normal damping
    sq = math.sqrt(dl)
    q = math.sqrt(sq)
    gn = q * g_n
    damp = gn * vn
    fn = sq * a_n * dl - damp
    e0 = dprev + damp
    if is_wall:
        e0 = e0 * vn + e0 * (lag * nz)
    else:
        e0 = e0 * vn
    fx, fy, fz = ex * fn, ey * fn, ez * fn
    if not friction:
        return (fx, fy, fz, 0.0, 0.0, 0.0, e0, 0.0, 0.0, 0.0,
                sx, sy, sz, damp, 0.0, 0.0, 0.0, 0.0, False)
    # tangential history, Coulomb cap, tangential damping
    if update:
        sx += vtx * dt
        sy += vty * dt
        sz += vtz * dt
        s1 = sx * ex + sy * ey + sz * ez
        sx -= ex * s1
        sy -= ey * s1
        sz -= ez * s1
    if not dl > 0.0:                                  # an opened contact forgets its history
        sx, sy, sz = 0.0, 0.0, 0.0
    kt = sq * a_t
    s2 = sx * sx + sy * sy + sz * sz
    spring = math.sqrt(s2) * kt
    cap = abs(fn) * mu
    sliding = spring > cap
    ratio = min(cap / (spring + 1e-300), 1.0)
    sx *= ratio
    sy *= ratio
    sz *= ratio
    s2 = s2 * ratio * ratio
    stored2 = s2 * kt
    gamma_t = 0.0 if sliding else gn * gt_over_gn
    t3x = sx * kt + vtx * gamma_t                     # -F_t
    t3y = sy * kt + vty * gamma_t
    t3z = sz * kt + vtz * gamma_t
    bx, by, bz = tpx + t3x, tpy + t3y, tpz + t3z
    e1 = bx * vtx + by * vty + bz * vtz
    e3 = (vtx * vtx + vty * vty + vtz * vtz) * gamma_t
    if is_wall:
        e1 += bz * lag
        e3 += (vtz * gamma_t) * lag
    e1 = e1 * dt - stored2 + s2prev
    e2 = e1 if sliding else 0.0
    tqx = tqy = tqz = 0.0
    if rotation:
        tqx = (ey * t3z - ez * t3y) * cr
        tqy = (ez * t3x - ex * t3z) * cr
        tqz = (ex * t3y - ey * t3x) * cr
    return (fx - t3x, fy - t3y, fz - t3z, tqx, tqy, tqz, e0, e1, e2, e3,
            sx, sy, sz, damp, t3x, t3y, t3z, stored2, sliding)


@njit(cache=True, error_model="numpy", inline="always")
def _forces(b, x, v, w, f, t, shear, tenergy, delta, slide, dprev, tprev, s2prev, p, flags,
            normals, offsets, zw, vw, lag, update, acc):
    """All forces and torques of cell b (gravity included); adds the step's raw energy terms
    to ``acc[:, :, b]`` and returns the total z force of the walls on the spheres, N."""
    n = x.shape[2]
    friction, rotation = flags[0] != 0, flags[1] != 0
    radius = p[RADIUS]
    dt = p[DT]
    reach2 = 4.0 * radius * radius * (1.0 + 1e-9)
    for i in range(n):
        f[0, b, i] = 0.0
        f[1, b, i] = 0.0
        f[2, b, i] = 0.0
        if friction and rotation:
            t[0, b, i] = 0.0
            t[1, b, i] = 0.0
            t[2, b, i] = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            dx = x[0, b, i] - x[0, b, j]
            dy = x[1, b, i] - x[1, b, j]
            dz = x[2, b, i] - x[2, b, j]
            r2 = dx * dx + dy * dy + dz * dz
            if r2 > reach2 and not delta[b, i, j] > 0.0:
                continue
            r = math.sqrt(r2)
            dl = max(2.0 * radius - r, 0.0)
            delta[b, i, j] = dl
            h = _contact(dl, dx / r, dy / r, dz / r,
                         v[0, b, i] - v[0, b, j], v[1, b, i] - v[1, b, j],
                         v[2, b, i] - v[2, b, j], w[0, b, i] + w[0, b, j],
                         w[1, b, i] + w[1, b, j], w[2, b, i] + w[2, b, j], False, 0.0, 0.0,
                         p[PP + A_N], p[PP + G_N], p[PP + A_T], p[PP + MU],
                         p[PP + GT_OVER_GN], dt, radius, friction, rotation, update,
                         shear[0, b, i, j], shear[1, b, i, j], shear[2, b, i, j],
                         dprev[b, i, j], tprev[0, b, i, j], tprev[1, b, i, j],
                         tprev[2, b, i, j], s2prev[b, i, j])
            shear[0, b, i, j] = h[10]
            shear[1, b, i, j] = h[11]
            shear[2, b, i, j] = h[12]
            dprev[b, i, j] = h[13]
            tprev[0, b, i, j] = h[14]
            tprev[1, b, i, j] = h[15]
            tprev[2, b, i, j] = h[16]
            s2prev[b, i, j] = h[17]
            tenergy[b, i, j] = h[17] * 0.5
            slide[b, i, j] = h[18]
            f[0, b, i] += h[0]
            f[1, b, i] += h[1]
            f[2, b, i] += h[2]
            f[0, b, j] -= h[0]
            f[1, b, j] -= h[1]
            f[2, b, j] -= h[2]
            if friction and rotation:
                t[0, b, i] += h[3]
                t[1, b, i] += h[4]
                t[2, b, i] += h[5]
                t[0, b, j] += h[3]
                t[1, b, j] += h[4]
                t[2, b, j] += h[5]
            acc[0, 0, b] += h[6]
            acc[1, 0, b] += h[7]
            acc[2, 0, b] += h[8]
            acc[3, 0, b] += h[9]
    wall_fz = 0.0
    for i in range(n):
        for k in range(N_WALLS):
            col = n + k
            nx, ny, nz = normals[k, 0], normals[k, 1], normals[k, 2]
            dist = nx * x[0, b, i] + ny * x[1, b, i] + nz * x[2, b, i]
            dl = (zw * nz + (radius - offsets[k])) - dist
            if not dl > 0.0 and not delta[b, i, col] > 0.0:
                continue
            dl = max(dl, 0.0)
            delta[b, i, col] = dl
            h = _contact(dl, nx, ny, nz, v[0, b, i], v[1, b, i], v[2, b, i] - vw,
                         w[0, b, i], w[1, b, i], w[2, b, i], True, nz, lag,
                         p[PW + A_N], p[PW + G_N], p[PW + A_T], p[PW + MU],
                         p[PW + GT_OVER_GN], dt, radius, friction, rotation, update,
                         shear[0, b, i, col], shear[1, b, i, col], shear[2, b, i, col],
                         dprev[b, i, col], tprev[0, b, i, col], tprev[1, b, i, col],
                         tprev[2, b, i, col], s2prev[b, i, col])
            shear[0, b, i, col] = h[10]
            shear[1, b, i, col] = h[11]
            shear[2, b, i, col] = h[12]
            dprev[b, i, col] = h[13]
            tprev[0, b, i, col] = h[14]
            tprev[1, b, i, col] = h[15]
            tprev[2, b, i, col] = h[16]
            s2prev[b, i, col] = h[17]
            tenergy[b, i, col] = h[17] * 0.5
            slide[b, i, col] = h[18]
            f[0, b, i] += h[0]
            f[1, b, i] += h[1]
            f[2, b, i] += h[2]
            if friction and rotation:
                t[0, b, i] += h[3]
                t[1, b, i] += h[4]
                t[2, b, i] += h[5]
            wall_fz += h[2]
            acc[0, 1, b] += h[6]
            acc[1, 1, b] += h[7]
            acc[2, 1, b] += h[8]
            acc[3, 1, b] += h[9]
    for i in range(n):
        f[2, b, i] -= p[WEIGHT]
    return wall_fz


@njit(cache=True, error_model="numpy")
def set_up(x, v, w, f, t, shear, tenergy, delta, slide, dprev, tprev, s2prev, wall_fz, p,
           flags, normals, offsets, amplitude, step0, acc):
    """The forces of the initial state of every cell (no history update), as LIGGGHTS' set-up.

    ``wall_fz`` (n_batch,) receives the walls' z force; the energy terms of this evaluation
    are not counted (``acc`` is zeroed).
    """
    omega = p[OMEGA]
    phase = omega * (step0 * p[DT])
    for b in range(x.shape[1]):
        zw = amplitude[b] * (math.cos(phase) - 1.0)
        vw = amplitude[b] * (-omega * math.sin(phase))
        wall_fz[b] = _forces(b, x, v, w, f, t, shear, tenergy, delta, slide, dprev, tprev,
                             s2prev, p, flags, normals, offsets, zw, vw, 0.0, False, acc)
    acc[:] = 0.0
    _mirror(shear, tenergy, delta, slide)


@njit(cache=True, error_model="numpy")
def run(x, v, w, f, t, shear, tenergy, delta, slide, dprev, tprev, s2prev, wall_fz, p, flags,
        normals, offsets, amplitude, step0, n_cycles, steps_per_cycle, reset, acc, acc_work,
        acc_gross, reference, out_work, out_gross, out_terms, out_energy):
    """Advance every cell by ``n_cycles * steps_per_cycle`` steps from step ``step0``.

    Parameters (shapes; nb cells, n spheres, m = n + 8 partner columns)
    ----------
    x, v, w, f, t : (3, nb, n) positions m, velocities m/s, angular velocities rad/s, forces N,
        torques N m; updated in place
    shear, tprev : (3, nb, n, m) tangential history m, and -F_t of the last step N
    tenergy, delta, dprev, s2prev : (nb, n, m) spring energy J, overlap m, the last step's
        normal damping force N and k_t |s|^2 J
    slide : (nb, n, m) bool, sliding at the last step
    wall_fz : (nb,) walls' z force at the last step, N
    p, flags : the scene's parameters and (friction, rotation) switches
    normals, offsets : (8, 3), (8,) the cell's planes at rest
    amplitude : (nb,) wall amplitude W, m
    reset : bool, zero the accumulators at the start of every cycle
    acc : (4, 2, nb) raw energy terms by contact type; acc_work, acc_gross : (nb,) wall work
        and its absolute sum, J (accumulated)
    reference : (nb,) zero of the potential energy (a height, m)
    out_work, out_gross : (nb, n_cycles); out_terms : (4, 2, nb, n_cycles), J, per cycle
    out_energy : (8, nb, n_cycles + 1) energies and heights at the cycle boundaries (rows E_*)
    """
    n = x.shape[2]
    dt = p[DT]
    omega = p[OMEGA]
    half_over_m = 0.5 * dt / p[MASS]
    half_over_i = 0.5 * dt / p[INERTIA]
    rotation = flags[1] != 0
    n_batch = x.shape[1]
    # the wall's motion over a cycle, W = 1 (the same for every cell: computed once)
    z_unit = np.empty(steps_per_cycle)
    v_unit = np.empty(steps_per_cycle)
    u_unit = np.empty(steps_per_cycle)
    half_phase = 0.5 * omega * dt
    for b in range(n_batch):
        _ledger(b, x, v, w, f, t, shear, delta, p, flags, reference[b], out_energy, 0)
    for cycle in range(n_cycles):
        first = step0 + cycle * steps_per_cycle
        for s in range(steps_per_cycle):
            step = first + s + 1
            phase = omega * (step * dt)
            z_unit[s] = math.cos(phase) - 1.0
            v_unit[s] = -omega * math.sin(phase)
            u_unit[s] = -2.0 * math.sin(omega * (step - 0.5) * dt) * math.sin(half_phase) / dt
        for b in range(n_batch):
            amp = amplitude[b]
            if reset:
                for k in range(4):
                    acc[k, 0, b] = 0.0
                    acc[k, 1, b] = 0.0
                acc_work[b] = 0.0
                acc_gross[b] = 0.0
            for s in range(steps_per_cycle):
                for i in range(n):
                    for c in range(3):
                        v[c, b, i] += f[c, b, i] * half_over_m
                    for c in range(3):
                        x[c, b, i] += v[c, b, i] * dt
                    if rotation:
                        for c in range(3):
                            w[c, b, i] += t[c, b, i] * half_over_i
                zw = amp * z_unit[s]
                vw = amp * v_unit[s]
                uw = amp * u_unit[s]
                fz = _forces(b, x, v, w, f, t, shear, tenergy, delta, slide, dprev, tprev,
                             s2prev, p, flags, normals, offsets, zw, vw, vw - uw, True, acc)
                work = (wall_fz[b] + fz) * (uw * (0.5 * dt))
                wall_fz[b] = fz
                acc_work[b] += work
                acc_gross[b] += abs(work)
                for i in range(n):
                    for c in range(3):
                        v[c, b, i] += f[c, b, i] * half_over_m
                    if rotation:
                        for c in range(3):
                            w[c, b, i] += t[c, b, i] * half_over_i
            out_work[b, cycle] = acc_work[b]
            out_gross[b, cycle] = acc_gross[b]
            for kind in range(2):
                s0, s1, s2, s3 = acc[0, kind, b], acc[1, kind, b], acc[2, kind, b], acc[3, kind, b]
                damping = dt * s3
                out_terms[0, kind, b, cycle] = 0.5 * dt * s0
                out_terms[1, kind, b, cycle] = 0.5 * s2
                out_terms[2, kind, b, cycle] = damping
                out_terms[3, kind, b, cycle] = 0.5 * (s1 - s2) - damping
            _ledger(b, x, v, w, f, t, shear, delta, p, flags, reference[b], out_energy,
                    cycle + 1)
    _mirror(shear, tenergy, delta, slide)


@njit(cache=True, error_model="numpy")
def _ledger(b, x, v, w, f, t, shear, delta, p, flags, reference, out, at):
    """Energies of cell b at a cycle boundary into ``out[:, b, at]`` (rows E_*), J, and its
    centre-of-mass height and lowest and highest sphere centre, m."""
    n = x.shape[2]
    dt = p[DT]
    trans = rot = heights = force2 = torque2 = 0.0
    lowest, highest = x[2, b, 0], x[2, b, 0]
    for i in range(n):
        lowest = min(lowest, x[2, b, i])
        highest = max(highest, x[2, b, i])
        for c in range(3):
            trans += v[c, b, i] * v[c, b, i]
            rot += w[c, b, i] * w[c, b, i]
            force2 += f[c, b, i] * f[c, b, i]
            torque2 += t[c, b, i] * t[c, b, i]
        heights += x[2, b, i]
    trans *= 0.5 * p[MASS]
    rot *= 0.5 * p[INERTIA]
    potential = p[WEIGHT] * (heights - n * reference)
    elastic = 0.0
    for i in range(n):
        for col in range(i + 1, n + N_WALLS):
            dl = delta[b, i, col]
            if not dl > 0.0:
                continue
            law = PP if col < n else PW
            s2 = shear[0, b, i, col] ** 2 + shear[1, b, i, col] ** 2 + shear[2, b, i, col] ** 2
            elastic += p[law + ENERGY_N] * dl ** 2.5 + 0.5 * p[law + A_T] * math.sqrt(dl) * s2
    shift = -dt * dt / (8.0 * p[MASS]) * force2
    if flags[1] != 0:
        shift -= dt * dt / (8.0 * p[INERTIA]) * torque2
    out[E_TRANS, b, at] = trans
    out[E_ROT, b, at] = rot
    out[E_POT, b, at] = potential
    out[E_ELASTIC, b, at] = elastic
    out[E_LEDGER, b, at] = trans + rot + shift + potential + elastic
    out[E_COM, b, at] = heights / n
    out[E_LOWEST, b, at] = lowest
    out[E_HIGHEST, b, at] = highest


@njit(cache=True, error_model="numpy")
def _mirror(shear, tenergy, delta, slide):
    """Fill the (j, i) entries of the pair columns from the (i, j) ones, i < j."""
    n = delta.shape[1]
    for b in range(delta.shape[0]):
        for i in range(n):
            for j in range(i + 1, n):
                for c in range(3):
                    shear[c, b, j, i] = -shear[c, b, i, j]
                tenergy[b, j, i] = tenergy[b, i, j]
                delta[b, j, i] = delta[b, i, j]
                slide[b, j, i] = slide[b, i, j]
