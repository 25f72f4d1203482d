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

Cells are independent, so the loop runs cell by cell (outer) and step by step (inner). A sphere
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
E_TRANS, E_ROT, E_POT, E_ELASTIC, E_LEDGER, E_COM = 0, 1, 2, 3, 4, 5
N_ENERGY_ROWS = 6


@njit(cache=True)
def _contact(b, i, col, dl, ex, ey, ez, vrx, vry, vrz, wx, wy, wz, is_wall, nz, lag, law,
             p, friction, rotation, update, shear, tenergy, slide, dprev, tprev, s2prev, out):
    """One contact of sphere i with partner ``col``; writes force (0-2) and torque (3-5) on i
    and the four raw energy terms (6-9) into ``out``, updates the contact's history.

    ``dl`` is the overlap (>= 0), (ex, ey, ez) the unit normal towards i, vr the relative
    velocity v_i - v_partner, w the sum of the angular velocities, nz the normal's z component
    and lag = v_w - u_w (walls only).
    """
    vn = vrx * ex + vry * ey + vrz * ez
    vtx, vty, vtz = vrx, vry, vrz
    cr = 0.0
    if friction:
        vtx = vrx - ex * vn
        vty = vry - ey * vn
        vtz = vrz - ez * vn
        if rotation:
            cr = dl * -0.5 + p[RADIUS]
            ax, ay, az = wx * cr, wy * cr, wz * cr
            vtx -= ay * ez - az * ey
            vty -= az * ex - ax * ez
            vtz -= ax * ey - ay * ex
    # normal force and normal damping
    sq = math.sqrt(dl)
    q = math.sqrt(sq)
    gn = q * p[law + G_N]
    damp = gn * vn
    fn = sq * p[law + A_N] * dl - damp
    e0 = dprev[b, i, col] + damp
    if is_wall:
        e0 = e0 * vn + e0 * (lag * nz)
    else:
        e0 = e0 * vn
    dprev[b, i, col] = damp
    out[0] = ex * fn
    out[1] = ey * fn
    out[2] = ez * fn
    out[3] = 0.0
    out[4] = 0.0
    out[5] = 0.0
    out[6] = e0
    out[7] = 0.0
    out[8] = 0.0
    out[9] = 0.0
    if not friction:
        return
    # tangential history, Coulomb cap, tangential damping
    sx, sy, sz = shear[0, b, i, col], shear[1, b, i, col], shear[2, b, i, col]
    if update:
        dt = p[DT]
        sx += vtx * dt
        sy += vty * dt
        sz += vtz * dt
        s1 = sx * ex + sy * ey + sz * ez
        sx -= ex * s1
        sy -= ey * s1
        sz -= ez * s1
    if not dl > 0.0:                                  # an opened contact forgets its history
        sx, sy, sz = 0.0, 0.0, 0.0
    kt = sq * p[law + A_T]
    s2 = sx * sx + sy * sy + sz * sz
    spring = math.sqrt(s2) * kt
    cap = abs(fn) * p[law + MU]
    sliding = spring > cap
    ratio = min(cap / (spring + 1e-300), 1.0)
    sx *= ratio
    sy *= ratio
    sz *= ratio
    s2 = s2 * ratio * ratio
    stored2 = s2 * kt
    gamma_t = 0.0 if sliding else gn * p[law + GT_OVER_GN]
    t3x = sx * kt + vtx * gamma_t                     # -F_t
    t3y = sy * kt + vty * gamma_t
    t3z = sz * kt + vtz * gamma_t
    bx = tprev[0, b, i, col] + t3x
    by = tprev[1, b, i, col] + t3y
    bz = tprev[2, b, i, col] + t3z
    e1 = bx * vtx + by * vty + bz * vtz
    e3 = (vtx * vtx + vty * vty + vtz * vtz) * gamma_t
    if is_wall:
        e1 += bz * lag
        e3 += (vtz * gamma_t) * lag
    e1 = e1 * p[DT] - stored2 + s2prev[b, i, col]
    out[7] = e1
    out[8] = e1 if sliding else 0.0
    out[9] = e3
    shear[0, b, i, col] = sx
    shear[1, b, i, col] = sy
    shear[2, b, i, col] = sz
    tprev[0, b, i, col] = t3x
    tprev[1, b, i, col] = t3y
    tprev[2, b, i, col] = t3z
    s2prev[b, i, col] = stored2
    tenergy[b, i, col] = stored2 * 0.5
    slide[b, i, col] = sliding
    out[0] -= t3x
    out[1] -= t3y
    out[2] -= t3z
    if rotation:
        out[3] = (ey * t3z - ez * t3y) * cr
        out[4] = (ez * t3x - ex * t3z) * cr
        out[5] = (ex * t3y - ey * t3x) * cr


@njit(cache=True)
def _forces(b, x, v, w, f, t, shear, tenergy, delta, slide, dprev, tprev, s2prev, p, flags,
            normals, offsets, zw, vw, lag, update, acc, out):
    """All forces and torques of cell b (gravity included); adds the step's raw energy terms
    to ``acc[:, :, b]`` and returns the total z force of the walls on the spheres, N."""
    n = x.shape[2]
    friction, rotation = flags[0] != 0, flags[1] != 0
    radius = p[RADIUS]
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
            _contact(b, i, j, dl, dx / r, dy / r, dz / r,
                     v[0, b, i] - v[0, b, j], v[1, b, i] - v[1, b, j], v[2, b, i] - v[2, b, j],
                     w[0, b, i] + w[0, b, j], w[1, b, i] + w[1, b, j], w[2, b, i] + w[2, b, j],
                     False, 0.0, 0.0, PP, p, friction, rotation, update,
                     shear, tenergy, slide, dprev, tprev, s2prev, out)
            for c in range(3):
                f[c, b, i] += out[c]
                f[c, b, j] -= out[c]
            if friction and rotation:
                for c in range(3):
                    t[c, b, i] += out[3 + c]
                    t[c, b, j] += out[3 + c]
            for k in range(4):
                acc[k, 0, b] += out[6 + k]
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
            _contact(b, i, col, dl, nx, ny, nz, v[0, b, i], v[1, b, i], v[2, b, i] - vw,
                     w[0, b, i], w[1, b, i], w[2, b, i], True, nz, lag, PW, p, friction,
                     rotation, update, shear, tenergy, slide, dprev, tprev, s2prev, out)
            for c in range(3):
                f[c, b, i] += out[c]
            if friction and rotation:
                for c in range(3):
                    t[c, b, i] += out[3 + c]
            wall_fz += out[2]
            for kk in range(4):
                acc[kk, 1, b] += out[6 + kk]
    for i in range(n):
        f[2, b, i] -= p[WEIGHT]
    return wall_fz


@njit(cache=True)
def set_up(x, v, w, f, t, shear, tenergy, delta, slide, dprev, tprev, s2prev, wall_fz, p,
           flags, normals, offsets, amplitude, step0, acc):
    """The forces of the initial state of every cell (no history update), as LIGGGHTS' set-up.

    ``wall_fz`` (n_batch,) receives the walls' z force; the energy terms of this evaluation
    are not counted (``acc`` is zeroed).
    """
    buf = np.zeros(10)
    omega = p[OMEGA]
    phase = omega * (step0 * p[DT])
    for b in range(x.shape[1]):
        zw = amplitude[b] * (math.cos(phase) - 1.0)
        vw = amplitude[b] * (-omega * math.sin(phase))
        wall_fz[b] = _forces(b, x, v, w, f, t, shear, tenergy, delta, slide, dprev, tprev,
                             s2prev, p, flags, normals, offsets, zw, vw, 0.0, False, acc, buf)
    acc[:] = 0.0
    _mirror(shear, tenergy, delta, slide)


@njit(cache=True)
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
    out_energy : (6, nb, n_cycles + 1) energies at the cycle boundaries (rows E_*)
    """
    n = x.shape[2]
    dt = p[DT]
    omega = p[OMEGA]
    half_over_m = 0.5 * dt / p[MASS]
    half_over_i = 0.5 * dt / p[INERTIA]
    rotation = flags[1] != 0
    half_phase = 0.5 * omega * dt
    buf = np.zeros(10)
    for b in range(x.shape[1]):
        amp = amplitude[b]
        step = step0
        _ledger(b, x, v, w, f, t, shear, delta, p, flags, reference[b], out_energy, 0)
        for cycle in range(n_cycles):
            if reset:
                for k in range(4):
                    acc[k, 0, b] = 0.0
                    acc[k, 1, b] = 0.0
                acc_work[b] = 0.0
                acc_gross[b] = 0.0
            for _ in range(steps_per_cycle):
                for i in range(n):
                    for c in range(3):
                        v[c, b, i] += f[c, b, i] * half_over_m
                    for c in range(3):
                        x[c, b, i] += v[c, b, i] * dt
                    if rotation:
                        for c in range(3):
                            w[c, b, i] += t[c, b, i] * half_over_i
                step += 1
                phase = omega * (step * dt)
                zw = amp * (math.cos(phase) - 1.0)
                vw = amp * (-omega * math.sin(phase))
                uw = amp * (-2.0 * math.sin(omega * (step - 0.5) * dt) * math.sin(half_phase)
                            / dt)
                fz = _forces(b, x, v, w, f, t, shear, tenergy, delta, slide, dprev, tprev,
                             s2prev, p, flags, normals, offsets, zw, vw, vw - uw, True, acc,
                             buf)
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


@njit(cache=True)
def _ledger(b, x, v, w, f, t, shear, delta, p, flags, reference, out, at):
    """Energies of cell b at a cycle boundary into ``out[:, b, at]`` (rows E_*), J and m."""
    n = x.shape[2]
    dt = p[DT]
    trans = rot = heights = force2 = torque2 = 0.0
    for i in range(n):
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


@njit(cache=True)
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
