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
  tangential damping, tangential spring) by contact type, the first-harmonic sums of the
  spheres' z force on the walls (:mod:`pidpipe.measurement.harmonics`), and at every cycle
  boundary the energies K, K_rot, P, U and the ledger total K^ + P + U.

Cells are independent, so within each cycle the loop runs cell by cell and step by step; the
wall's motion over the cycle is computed once for all cells. A sphere
pair is evaluated once, for i < j; its history lives in the (i, j) entries of the dense state
arrays (:mod:`pidpipe.dem.state`), and the (j, i) copies are filled at the end of each call so
that the arrays read as the reference's. A pair neither in contact now nor at the last
evaluation contributes exactly zero and is skipped; the pairs and planes that could be in
reach are kept in near lists (:func:`_build_near`, a skin of NEAR_SKIN radii, rebuilt when a
sphere or the walls have moved half of it), so that a step screens these few instead of every
pair and plane, and lists exactly the same contacts. Each force evaluation first lists the
contacts to evaluate, then takes them LANES at a time: their square roots and the contact law
in loops without dependences between contacts, which LLVM runs four contacts wide in the
vector registers, then the histories and the sums of forces and energy terms in the listed
order (:func:`_forces_into`; to the last bit the result of one pass contact by contact,
benchmarks/results.md).

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
# per-sphere columns of the packed body array (x, v, omega, force, torque)
BX, BV, BW, BF, BT, N_BODY = 0, 3, 6, 9, 12, 15
# per-contact columns of the packed history: shear, normal damping force, -F_t, k_t |s|^2,
# overlap, sliding (1.0 or 0.0)
HS, HD, HT, HS2, HDELTA, HSLIDE, N_HIST = 0, 3, 4, 7, 8, 9, 10
# rows of the boundary-energy output
E_TRANS, E_ROT, E_POT, E_ELASTIC, E_LEDGER, E_COM, E_LOWEST, E_HIGHEST = 0, 1, 2, 3, 4, 5, 6, 7
N_ENERGY_ROWS = 8
# rows of the contact scratch of _forces_into: distance^2 and then 1 / distance (sphere pairs),
# the overlap, its square and fourth root, the separation vector (sphere pairs)
W_R, W_DL, W_SQ, W_Q, W_DX, W_DY, W_DZ, N_WORK = 0, 1, 2, 3, 4, 5, 6, 7
LANES = 32
"""Contacts evaluated together by :func:`_forces_into`: their law inputs and results are rows of
LANES numbers in one flat array, whose row length is then a constant of the compiled code, so
that the compiler sees that the rows do not overlap and evaluates the law several contacts wide
(a 2-D scratch of rows leaves it unsure and one contact at a time)."""
# rows of the lane array: the law's inputs (overlap, its square and fourth roots, the unit
# normal, the relative velocity, the sum of the angular velocities, the history: shear,
# damping force, -F_t, k_t |s|^2), then its results in the order of _contact's tuple (force,
# torque, energy terms e0..e3, shear, damping force, -F_t, k_t |s|^2, sliding)
L_DL, L_SQ, L_Q, L_EX, L_VR, L_W, L_S, L_D, L_TP, L_S2 = 0, 1, 2, 3, 6, 9, 12, 15, 16, 19
R_F = 20
R_T, R_E, R_S, R_D, R_TP, R_S2, R_SLIDE, N_LANE_ROWS = 23, 26, 30, 33, 34, 37, 38, 39
# rows of the bed-motion output of run: sums over each window (the walls' work, J; the floor's
# upward force on the spheres and theirs on the lid, N, summed over the samples; the samples),
# then values at the window boundaries (K + K_rot + P, J; heights above the floor of the centre
# of mass and of the lowest and highest sphere centre, m)
M_WORK, M_FLOOR, M_LID, M_SAMPLES, M_ENERGY, M_CENTRE, M_BOTTOM, M_TOP = 0, 1, 2, 3, 4, 5, 6, 7
N_MOTION_ROWS = 8
NEAR_SKIN = 0.05
"""Skin of the near lists (:func:`_build_near`), as a fraction of the sphere radius."""
INDEX = np.uint32
"""Type of the sphere and plane indices in the contact lists: unsigned, so that Numba indexes
the state and history with them without its test for negative indices (1.03-1.09x)."""


@njit(cache=True, error_model="numpy", inline="always")
def _contact(dl, sq, q, ex, ey, ez, vrx, vry, vrz, wx, wy, wz, p, law, friction, rotation, update, sx, sy, sz, dprev, tpx, tpy, tpz, s2prev):
    """One contact, scalars in and out, inlined into the loop by Numba (``inline="always"``:
    that needs at most 30 arguments, beyond which Python passes them as one tuple; inlined
    before LLVM optimises, it runs 1.05-1.18x faster than LLVM's own later inlining).

    Inputs: the overlap ``dl`` (>= 0) with its square and fourth roots, the unit normal (ex, ey,
    ez) towards sphere i, the relative velocity vr = v_i - v_partner, the sum w of the angular
    velocities, the parameter vector ``p`` and the offset ``law`` of the contact's law in it (PP or
    PW), and the contact's history: shear s, the last step's normal damping force, -F_t (tp)
    and k_t |s|^2 (s2prev).

    Returns
    -------
    tuple
        Force on i (3, N), torque on i (3, N m), the raw energy terms e0..e3 (see
        :func:`pidpipe.dem.contacts.reduce_terms`), then the new history: shear (3), damping
        force, -F_t (3), k_t |s|^2, and whether the contact slid.
    """
    a_n, g_n, a_t, mu = p[law + A_N], p[law + G_N], p[law + A_T], p[law + MU]
    gt_over_gn, dt, radius = p[law + GT_OVER_GN], p[DT], p[RADIUS]
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
    gn = q * g_n
    damp = gn * vn
    fn = sq * a_n * dl - damp
    e0 = dprev + damp
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
    if sliding:                                       # the Coulomb cap; 1 when sticking
        ratio = cap / (spring + 1e-300)
        ratio = ratio if ratio < 1.0 else 1.0           # min(), which Numba does not vectorise
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
    e1 = e1 * dt - stored2 + s2prev
    e2 = e1 if sliding else 0.0
    tqx = tqy = tqz = 0.0
    if rotation:
        tqx = (ey * t3z - ez * t3y) * cr
        tqy = (ez * t3x - ex * t3z) * cr
        tqz = (ex * t3y - ey * t3x) * cr
    return (fx - t3x, fy - t3y, fz - t3z, tqx, tqy, tqz, e0, e1, e2, e3,
            sx, sy, sz, damp, t3x, t3y, t3z, stored2, sliding)


@njit(cache=True, error_model="numpy")
def _forces(body, hist, p, friction, rotation, normals, offsets, zw, vw, update):
    """All forces and torques of one cell (gravity included), written into ``body``.

    ``body`` (n, N_BODY) and ``hist`` (n, n + 8, N_HIST) are the cell's packed arrays. Returns
    the walls' total z force on the spheres (N) and the step's raw energy terms e0..e3 of the
    sphere pairs and then of the wall contacts. (:func:`_forces_into` with its scratch arrays
    allocated for this call; the time loop keeps its own.)
    """
    pairs, work, lane = _scratch(body.shape[0])
    near, near_n, anchor = _near_scratch(1, body.shape[0])
    return _forces_into(body, hist, p, friction, rotation, normals, offsets, zw, vw, update,
                        pairs, work, lane, near[0], near_n[0], anchor[0])


@njit(cache=True, error_model="numpy", inline="always")
def _scratch(n):
    """The scratch arrays of :func:`_forces_into` for cells of ``n`` spheres: the partners of
    every possible contact (2, n_max), its precomputed numbers (N_WORK, n_max) and the lane
    rows of the contact law (N_LANE_ROWS * LANES,)."""
    n_max = n * (n - 1) // 2 + n * N_WALLS
    return (np.empty((2, n_max), dtype=INDEX), np.empty((N_WORK, n_max)),
            np.empty(N_LANE_ROWS * LANES))


@njit(cache=True, error_model="numpy", inline="always")
def _near_scratch(nb, n):
    """Near lists of ``nb`` cells of ``n`` spheres, all stale (built at their first use).

    Returns ``near`` (nb, 2, n_max), the candidate partners (i, j) of the sphere pairs and then
    (i, plane) of the walls, in the screen's order; ``near_n`` (nb, 2), the number of pair
    candidates and of all candidates (-1: stale); ``anchor`` (nb, n + 1, 3), the sphere
    positions the lists were made at, m, and in row n the walls' height then, m.
    """
    n_max = n * (n - 1) // 2 + n * N_WALLS
    near_n = np.empty((nb, 2), dtype=np.int64)
    near_n[:] = -1
    return np.empty((nb, 2, n_max), dtype=INDEX), near_n, np.empty((nb, n + 1, 3))


@njit(cache=True, error_model="numpy", inline="always")
def _near_stale(body, zw, near_n, anchor, radius):
    """Whether one cell's near lists must be rebuilt: never built, or a sphere or the walls
    moved more than half the skin since (the lists then still hold every contact that the
    full screen would find; see :func:`_build_near`)."""
    if near_n[0] < 0:
        return True
    half = 0.5 * NEAR_SKIN * radius
    n = body.shape[0]
    if abs(zw - anchor[n, 0]) > half:
        return True
    half2 = half * half
    moved = 0.0
    for i in range(n):
        dx = body[i, BX] - anchor[i, 0]
        dy = body[i, BX + 1] - anchor[i, 1]
        dz = body[i, BX + 2] - anchor[i, 2]
        moved = max(moved, dx * dx + dy * dy + dz * dz)
    return moved > half2


@njit(cache=True, error_model="numpy", inline="always")
def _build_near(body, hist, radius, normals, offsets, zw, near, near_n, anchor):
    """Make one cell's near lists: the sphere pairs closer than 2 r (1 + 1e-9) + 1.01 skin or
    in contact at the last evaluation, and the sphere-plane pairs with an overlap above -1.01
    skin or in contact; the positions and the walls' height now go to ``anchor``.

    While no sphere and not the walls have moved more than half the skin, a pair left out
    is further apart than 2 r (1 + 1e-9) (each sphere moved at most half the skin) and a
    plane left out does not touch its sphere (the overlap changed by at most one skin), and
    neither was in contact: the screen of the candidates then lists exactly the contacts
    that the screen of all pairs and planes would, in the same order.
    """
    n = body.shape[0]
    skin = 1.01 * NEAR_SKIN * radius
    cut = 2.0 * radius * (1.0 + 1e-9) + skin
    cut2 = cut * cut
    count = 0
    for i in range(n):
        xi, yi, zi = body[i, BX], body[i, BX + 1], body[i, BX + 2]
        for j in range(i + 1, n):
            dx = xi - body[j, BX]
            dy = yi - body[j, BX + 1]
            dz = zi - body[j, BX + 2]
            if dx * dx + dy * dy + dz * dz > cut2 and not hist[i, j, HDELTA] > 0.0:
                continue
            near[0, count] = i
            near[1, count] = j
            count += 1
    near_n[0] = count
    for i in range(n):
        xi, yi, zi = body[i, BX], body[i, BX + 1], body[i, BX + 2]
        for k in range(N_WALLS):
            nz = normals[k, 2]
            dist = normals[k, 0] * xi + normals[k, 1] * yi + nz * zi
            dl = (zw * nz + (radius - offsets[k])) - dist
            if not dl > -skin and not hist[i, n + k, HDELTA] > 0.0:
                continue
            near[0, count] = i
            near[1, count] = k
            count += 1
    near_n[1] = count
    for i in range(n):
        for c in range(3):
            anchor[i, c] = body[i, BX + c]
    anchor[n, 0] = zw


@njit(cache=True, error_model="numpy", inline="always")
def _forces_into(body, hist, p, friction, rotation, normals, offsets, zw, vw, update, pairs,
                 work, lane, near, near_n, anchor):
    """:func:`_forces` with scratch arrays from :func:`_scratch` (reused step after step) and
    the cell's near lists from :func:`_near_scratch` (kept from step to step, rebuilt when
    :func:`_near_stale`).

    The screen lists the contacts to evaluate (the near lists' pairs within reach or in
    contact at the last evaluation, and walls likewise), in the order of the pairs (i < j) and
    then of the walls (sphere by sphere, plane by plane). Then, LANES contacts at a time (pairs
    and walls apart, as their laws differ): the square roots (distance, overlap^1/2,
    overlap^1/4) and the unit normals into the lane rows, several contacts wide; the
    velocities and histories gathered into them; the law of every contact in one loop,
    several wide (:func:`_law_into`); the new histories stored and the forces and energy
    terms summed in the listed order, which is the order of one pass contact by contact, so
    the result is the same to the last bit.
    """
    n = body.shape[0]
    radius = p[RADIUS]
    reach2 = 4.0 * radius * radius * (1.0 + 1e-9)
    torques = friction and rotation
    for i in range(n):
        for c in range(3):
            body[i, BF + c] = 0.0
        if torques:
            for c in range(3):
                body[i, BT + c] = 0.0
    # screen the near lists' candidates: the sphere pairs, then the walls
    if _near_stale(body, zw, near_n, anchor, radius):
        _build_near(body, hist, radius, normals, offsets, zw, near, near_n, anchor)
    count = 0
    for c in range(near_n[0]):
        i, j = near[0, c], near[1, c]
        dx = body[i, BX] - body[j, BX]
        dy = body[i, BX + 1] - body[j, BX + 1]
        dz = body[i, BX + 2] - body[j, BX + 2]
        r2 = dx * dx + dy * dy + dz * dz
        if r2 > reach2 and not hist[i, j, HDELTA] > 0.0:
            continue
        pairs[0, count] = i
        pairs[1, count] = j
        work[W_R, count] = r2
        work[W_DX, count] = dx
        work[W_DY, count] = dy
        work[W_DZ, count] = dz
        count += 1
    n_pairs = count
    for c in range(near_n[0], near_n[1]):
        i, k = near[0, c], near[1, c]
        nz = normals[k, 2]
        dist = normals[k, 0] * body[i, BX] + normals[k, 1] * body[i, BX + 1] + nz * body[i, BX + 2]
        dl = (zw * nz + (radius - offsets[k])) - dist
        if not dl > 0.0 and not hist[i, n + k, HDELTA] > 0.0:
            continue
        pairs[0, count] = i
        pairs[1, count] = k
        work[W_DL, count] = max(dl, 0.0)
        count += 1
    diameter = 2.0 * radius
    # evaluate and sum, LANES contacts at a time: gather their inputs into the lane rows,
    # evaluate the law for all of them in one loop without dependences between contacts
    # (which the compiler runs several contacts wide in the vector registers), then store
    # the histories and sum the forces and energy terms in the listed order
    p0 = p1 = p2 = p3 = 0.0
    for first in range(0, n_pairs, LANES):
        m = min(LANES, n_pairs - first)
        for l in range(m):                            # the square roots, several wide
            c = first + l
            r = math.sqrt(work[W_R, c])
            dl = diameter - r
            dl = dl if dl > 0.0 else 0.0              # max(), which Numba does not vectorise
            inv_r = 1.0 / r
            sq = math.sqrt(dl)
            lane[L_DL * LANES + l] = dl
            lane[L_SQ * LANES + l] = sq
            lane[L_Q * LANES + l] = math.sqrt(sq)
            lane[L_EX * LANES + l] = work[W_DX, c] * inv_r
            lane[(L_EX + 1) * LANES + l] = work[W_DY, c] * inv_r
            lane[(L_EX + 2) * LANES + l] = work[W_DZ, c] * inv_r
        for l in range(m):
            c = first + l
            i, j = pairs[0, c], pairs[1, c]
            hist[i, j, HDELTA] = lane[L_DL * LANES + l]
            for k in range(3):
                lane[(L_VR + k) * LANES + l] = body[i, BV + k] - body[j, BV + k]
                lane[(L_W + k) * LANES + l] = body[i, BW + k] + body[j, BW + k]
            _history_into(hist, i, j, lane, l)
        for l in range(m):
            _law_into(lane, l, p, PP, friction, rotation, update)
        for l in range(m):
            c = first + l
            i, j = pairs[0, c], pairs[1, c]
            _keep(hist, i, j, lane, l)
            fx, fy, fz = lane[R_F * LANES + l], lane[(R_F + 1) * LANES + l], lane[(R_F + 2) * LANES + l]
            body[i, BF] += fx
            body[i, BF + 1] += fy
            body[i, BF + 2] += fz
            body[j, BF] -= fx
            body[j, BF + 1] -= fy
            body[j, BF + 2] -= fz
            if torques:
                for k in range(3):
                    body[i, BT + k] += lane[(R_T + k) * LANES + l]
                    body[j, BT + k] += lane[(R_T + k) * LANES + l]
            p0 += lane[R_E * LANES + l]
            p1 += lane[(R_E + 1) * LANES + l]
            p2 += lane[(R_E + 2) * LANES + l]
            p3 += lane[(R_E + 3) * LANES + l]
    wall_fz = w0 = w1 = w2 = w3 = 0.0
    for first in range(n_pairs, count, LANES):
        m = min(LANES, count - first)
        for l in range(m):
            dl = work[W_DL, first + l]
            sq = math.sqrt(dl)
            lane[L_DL * LANES + l] = dl
            lane[L_SQ * LANES + l] = sq
            lane[L_Q * LANES + l] = math.sqrt(sq)
        for l in range(m):
            c = first + l
            i, k = pairs[0, c], pairs[1, c]
            col = n + k
            hist[i, col, HDELTA] = lane[L_DL * LANES + l]
            for d in range(3):
                lane[(L_EX + d) * LANES + l] = normals[k, d]
                lane[(L_VR + d) * LANES + l] = body[i, BV + d]
                lane[(L_W + d) * LANES + l] = body[i, BW + d]
            lane[(L_VR + 2) * LANES + l] = body[i, BV + 2] - vw
            _history_into(hist, i, col, lane, l)
        for l in range(m):
            _law_into(lane, l, p, PW, friction, rotation, update)
        for l in range(m):
            c = first + l
            i, k = pairs[0, c], pairs[1, c]
            _keep(hist, i, n + k, lane, l)
            body[i, BF] += lane[R_F * LANES + l]
            body[i, BF + 1] += lane[(R_F + 1) * LANES + l]
            body[i, BF + 2] += lane[(R_F + 2) * LANES + l]
            if torques:
                for d in range(3):
                    body[i, BT + d] += lane[(R_T + d) * LANES + l]
            wall_fz += lane[(R_F + 2) * LANES + l]
            w0 += lane[R_E * LANES + l]
            w1 += lane[(R_E + 1) * LANES + l]
            w2 += lane[(R_E + 2) * LANES + l]
            w3 += lane[(R_E + 3) * LANES + l]
    for i in range(n):
        body[i, BF + 2] -= p[WEIGHT]
    return wall_fz, p0, p1, p2, p3, w0, w1, w2, w3


@njit(cache=True, error_model="numpy", inline="always")
def _history_into(hist, i, col, lane, l):
    """Copy contact (i, col)'s history (shear, damping force, -F_t, k_t |s|^2) into lane l."""
    for k in range(3):
        lane[(L_S + k) * LANES + l] = hist[i, col, HS + k]
        lane[(L_TP + k) * LANES + l] = hist[i, col, HT + k]
    lane[L_D * LANES + l] = hist[i, col, HD]
    lane[L_S2 * LANES + l] = hist[i, col, HS2]


@njit(cache=True, error_model="numpy", inline="always")
def _law_into(lane, l, p, law, friction, rotation, update):
    """:func:`_contact` of the contact in lane l, its results into the lane's rows R_*."""
    h = _contact(lane[L_DL * LANES + l], lane[L_SQ * LANES + l], lane[L_Q * LANES + l],
                 lane[L_EX * LANES + l], lane[(L_EX + 1) * LANES + l],
                 lane[(L_EX + 2) * LANES + l], lane[L_VR * LANES + l],
                 lane[(L_VR + 1) * LANES + l], lane[(L_VR + 2) * LANES + l],
                 lane[L_W * LANES + l], lane[(L_W + 1) * LANES + l], lane[(L_W + 2) * LANES + l],
                 p, law, friction, rotation, update,
                 lane[L_S * LANES + l], lane[(L_S + 1) * LANES + l], lane[(L_S + 2) * LANES + l],
                 lane[L_D * LANES + l], lane[L_TP * LANES + l], lane[(L_TP + 1) * LANES + l],
                 lane[(L_TP + 2) * LANES + l], lane[L_S2 * LANES + l])
    lane[(R_F + 0) * LANES + l] = h[0]
    lane[(R_F + 1) * LANES + l] = h[1]
    lane[(R_F + 2) * LANES + l] = h[2]
    lane[(R_F + 3) * LANES + l] = h[3]
    lane[(R_F + 4) * LANES + l] = h[4]
    lane[(R_F + 5) * LANES + l] = h[5]
    lane[(R_F + 6) * LANES + l] = h[6]
    lane[(R_F + 7) * LANES + l] = h[7]
    lane[(R_F + 8) * LANES + l] = h[8]
    lane[(R_F + 9) * LANES + l] = h[9]
    lane[(R_F + 10) * LANES + l] = h[10]
    lane[(R_F + 11) * LANES + l] = h[11]
    lane[(R_F + 12) * LANES + l] = h[12]
    lane[(R_F + 13) * LANES + l] = h[13]
    lane[(R_F + 14) * LANES + l] = h[14]
    lane[(R_F + 15) * LANES + l] = h[15]
    lane[(R_F + 16) * LANES + l] = h[16]
    lane[(R_F + 17) * LANES + l] = h[17]
    lane[(R_F + 18) * LANES + l] = 1.0 if h[18] else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _keep(hist, i, col, lane, l):
    """Store contact (i, col)'s new history, the tail of :func:`_contact`'s tuple, from lane l."""
    for k in range(3):
        hist[i, col, HS + k] = lane[(R_S + k) * LANES + l]
        hist[i, col, HT + k] = lane[(R_TP + k) * LANES + l]
    hist[i, col, HD] = lane[R_D * LANES + l]
    hist[i, col, HS2] = lane[R_S2 * LANES + l]
    hist[i, col, HSLIDE] = lane[R_SLIDE * LANES + l]


@njit(cache=True, error_model="numpy", inline="always")
def _kick_drift(cell, half_over_m, half_over_i, dt, rotation):
    """Velocity Verlet's first half for one cell: half kick, drift, half kick of the spins."""
    for i in range(cell.shape[0]):
        for c in range(3):
            cell[i, BV + c] += cell[i, BF + c] * half_over_m
        for c in range(3):
            cell[i, BX + c] += cell[i, BV + c] * dt
        if rotation:
            for c in range(3):
                cell[i, BW + c] += cell[i, BT + c] * half_over_i


@njit(cache=True, error_model="numpy", inline="always")
def _kick(cell, half_over_m, half_over_i, rotation):
    """Velocity Verlet's second half kick for one cell, with the forces of the new positions."""
    for i in range(cell.shape[0]):
        for c in range(3):
            cell[i, BV + c] += cell[i, BF + c] * half_over_m
        if rotation:
            for c in range(3):
                cell[i, BW + c] += cell[i, BT + c] * half_over_i


@njit(cache=True, error_model="numpy", inline="always")
def _add_terms(acc, b, out):
    """Add one step's raw energy terms (``out[1:9]`` of :func:`_forces`) to cell b's ``acc``."""
    acc[0, 0, b] += out[1]
    acc[1, 0, b] += out[2]
    acc[2, 0, b] += out[3]
    acc[3, 0, b] += out[4]
    acc[0, 1, b] += out[5]
    acc[1, 1, b] += out[6]
    acc[2, 1, b] += out[7]
    acc[3, 1, b] += out[8]


@njit(cache=True, error_model="numpy", inline="always")
def _cycle_terms(acc, b, dt, out_terms, cycle):
    """Cell b's four dissipation terms of a cycle (J, by contact type) from its raw sums."""
    for kind in range(2):
        s0, s1, s2, s3 = acc[0, kind, b], acc[1, kind, b], acc[2, kind, b], acc[3, kind, b]
        damping = dt * s3
        out_terms[0, kind, b, cycle] = 0.5 * dt * s0
        out_terms[1, kind, b, cycle] = 0.5 * s2
        out_terms[2, kind, b, cycle] = damping
        out_terms[3, kind, b, cycle] = 0.5 * (s1 - s2) - damping


@njit(cache=True, error_model="numpy")
def _pack(x, v, w, f, t, body):
    """Copy the state's component-first arrays (3, nb, n) into ``body`` (nb, n, N_BODY)."""
    for b in range(x.shape[1]):
        for i in range(x.shape[2]):
            for c in range(3):
                body[b, i, BX + c] = x[c, b, i]
                body[b, i, BV + c] = v[c, b, i]
                body[b, i, BW + c] = w[c, b, i]
                body[b, i, BF + c] = f[c, b, i]
                body[b, i, BT + c] = t[c, b, i]


@njit(cache=True, error_model="numpy")
def _unpack(body, hist, x, v, w, f, t, shear, tenergy, delta, slide):
    """Copy ``body`` back into the state and export the history as the reference's dense
    arrays: both (i, j) and (j, i) entries of a pair (the shear of (j, i) is minus that of
    (i, j)), the wall columns as they are."""
    nb, n = body.shape[0], body.shape[1]
    for b in range(nb):
        for i in range(n):
            for c in range(3):
                x[c, b, i] = body[b, i, BX + c]
                v[c, b, i] = body[b, i, BV + c]
                w[c, b, i] = body[b, i, BW + c]
                f[c, b, i] = body[b, i, BF + c]
                t[c, b, i] = body[b, i, BT + c]
            for col in range(i + 1, n + N_WALLS):
                for c in range(3):
                    shear[c, b, i, col] = hist[b, i, col, HS + c]
                tenergy[b, i, col] = 0.5 * hist[b, i, col, HS2]
                delta[b, i, col] = hist[b, i, col, HDELTA]
                slide[b, i, col] = hist[b, i, col, HSLIDE] != 0.0
                if col < n:
                    for c in range(3):
                        shear[c, b, col, i] = -hist[b, i, col, HS + c]
                    tenergy[b, col, i] = tenergy[b, i, col]
                    delta[b, col, i] = delta[b, i, col]
                    slide[b, col, i] = slide[b, i, col]


@njit(cache=True, inline="always")
def _viblin_unit_z(step, omega, dt):
    """The wall's displacement after step ``step`` for W = 1, where LIGGGHTS' ``viblin`` puts its
    mesh: dt * sum_{k=1..n} v_w(t_k) in closed form (:func:`pidpipe.dem.walls.viblin_wall_motion`).

    Walls at the exact z_w(t_n) = W (cos(omega t_n) - 1) with contacts that see v_w(t_n) made the
    contacts integrate a move (dt/2) v_w off the walls' own, and the DEM dissipated 0.17-0.25 %
    less than LIGGGHTS at 1 g, 750-1000 Hz (docs/explanation/validation.md, "Why the DEM once dissipated less at 1 g").
    """
    theta = omega * dt
    half = 0.5 * theta
    return -theta * (math.cos(half) - math.cos((step + 0.5) * theta)) / (2.0 * math.sin(half))


@njit(cache=True, error_model="numpy")
def set_up(x, v, w, f, t, shear, tenergy, delta, slide, body, hist, wall_fz, p, flags, normals,
           offsets, amplitude, step0):
    """The forces of the initial state of every cell (no history update), as LIGGGHTS' set-up.

    Arrays as for :func:`run`; ``wall_fz`` (nb,) receives the walls' z force. The energy terms
    of this evaluation are not counted.
    """
    _pack(x, v, w, f, t, body)
    omega = p[OMEGA]
    phase = omega * (step0 * p[DT])
    for b in range(x.shape[1]):
        zw = amplitude[b] * _viblin_unit_z(step0, omega, p[DT])
        vw = amplitude[b] * (-omega * math.sin(phase))
        out = _forces(body[b], hist[b], p, flags[0] != 0, flags[1] != 0, normals, offsets, zw,
                      vw, False)
        wall_fz[b] = out[0]
    _unpack(body, hist, x, v, w, f, t, shear, tenergy, delta, slide)


@njit(cache=True, error_model="numpy")
def run(x, v, w, f, t, shear, tenergy, delta, slide, body, hist, wall_fz, p, flags, normals,
        offsets, amplitude, step0, n_cycles, steps_per_cycle, reset, acc, acc_work, acc_gross,
        reference, out_work, out_gross, out_terms, out_energy, motion_window, motion_every,
        out_motion, out_harmonics):
    """Advance every cell by ``n_cycles * steps_per_cycle`` steps from step ``step0``.

    Parameters (shapes; nb cells, n spheres, m = n + 8 partner columns)
    ----------
    x, v, w, f, t : (3, nb, n) positions m, velocities m/s, angular velocities rad/s, forces N,
        torques N m; read at the start, written at the end
    shear : (3, nb, n, m); tenergy, delta : (nb, n, m); slide : (nb, n, m) bool
        Written at the end from the history (tangential history m, its spring energy J, the
        overlaps m, sliding at the last step)
    body : (nb, n, N_BODY), hist : (nb, n, m, N_HIST)
        The kernel's packed state and contact history (hist is kept between calls and only
        its i < j entries and wall columns are used)
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
    motion_window, motion_every : steps per window of the bed-motion sampling (0: off) and
        steps between the samples of the floor and lid forces (a divisor of motion_window)
    out_motion : (N_MOTION_ROWS, nb, n_windows + 1), rows M_*: window w covers steps
        w * motion_window + 1 .. (w + 1) * motion_window from step 0 and boundary w is the end
        of step w * motion_window; only the windows and boundaries this call reaches are
        written (sums are added to), and steps past column n_windows are not sampled
    out_harmonics : (2, nb, n_cycles), N s: the spheres' z force on the walls (minus the walls'
        on them) summed over each cycle's steps n times dt cos(theta_n) (row 0) and
        dt sin(theta_n) (row 1), theta_n = omega (n + 1/2) dt the walls' phase
        (:mod:`pidpipe.measurement.harmonics`)
    """
    _pack(x, v, w, f, t, body)
    n = x.shape[2]
    dt = p[DT]
    omega = p[OMEGA]
    half_over_m = 0.5 * dt / p[MASS]
    half_over_i = 0.5 * dt / p[INERTIA]
    friction, rotation = flags[0] != 0, flags[1] != 0
    n_batch = x.shape[1]
    # the wall's motion over a cycle, W = 1 (the same for every cell: computed once)
    z_unit = np.empty(steps_per_cycle)
    v_unit = np.empty(steps_per_cycle)
    # the weights of the first-harmonic sums: the walls' phase when the force of a step is
    # evaluated (they stand at z_w(t + dt/2) - z_w(dt/2)), the same in every cycle (computed once
    # per call, from the step within the cycle, so that a run split into calls sums alike)
    cos_unit = np.empty(steps_per_cycle)
    sin_unit = np.empty(steps_per_cycle)
    within = step0 % steps_per_cycle
    for s in range(steps_per_cycle):
        cos_unit[s] = math.cos(omega * ((within + s + 1.5) * dt))
        sin_unit[s] = math.sin(omega * ((within + s + 1.5) * dt))
    pairs, work_rows, lane = _scratch(n)
    near, near_n, anchor = _near_scratch(n_batch, n)
    floor_k, lid_k = _floor_and_lid(normals)
    floor_z = -offsets[floor_k]
    n_windows = out_motion.shape[2] - 1
    for b in range(n_batch):
        _ledger(body[b], hist[b], p, rotation, reference[b], out_energy[:, b, 0])
        if motion_window > 0 and step0 % motion_window == 0 and step0 // motion_window <= n_windows:
            zw0 = amplitude[b] * _viblin_unit_z(step0, omega, dt)
            _bed_point(body[b], p, reference[b], floor_z + zw0, out_motion[:, b, step0 // motion_window])
    for cycle in range(n_cycles):
        first = step0 + cycle * steps_per_cycle
        for s in range(steps_per_cycle):
            step = first + s + 1
            # where LIGGGHTS' viblin puts the mesh: moved by v_w(t_n) dt in step n, so the
            # contacts' wall velocity is also the wall's own move over the step
            z_unit[s] = _viblin_unit_z(step, omega, dt)
            v_unit[s] = -omega * math.sin(omega * (step * dt))
        for b in range(n_batch):
            cell, history = body[b], hist[b]
            near_b, near_nb, anchor_b = near[b], near_n[b], anchor[b]
            amp = amplitude[b]
            if reset:
                for k in range(4):
                    acc[k, 0, b] = 0.0
                    acc[k, 1, b] = 0.0
                acc_work[b] = 0.0
                acc_gross[b] = 0.0
            fz_prev = wall_fz[b]
            work_sum = acc_work[b]
            gross_sum = acc_gross[b]
            cos_sum = sin_sum = 0.0
            for s in range(steps_per_cycle):
                _kick_drift(cell, half_over_m, half_over_i, dt, rotation)
                zw = amp * z_unit[s]
                vw = amp * v_unit[s]
                out = _forces_into(cell, history, p, friction, rotation, normals, offsets, zw,
                                   vw, True, pairs, work_rows, lane, near_b, near_nb,
                                   anchor_b)
                fz = out[0]
                work = (fz_prev + fz) * (vw * (0.5 * dt))
                fz_prev = fz
                work_sum += work
                gross_sum += abs(work)
                cos_sum += fz * cos_unit[s]
                sin_sum += fz * sin_unit[s]
                _add_terms(acc, b, out)
                _kick(cell, half_over_m, half_over_i, rotation)
                if motion_window > 0:
                    step = first + s + 1
                    window = (step - 1) // motion_window
                    if window < n_windows:
                        out_motion[M_WORK, b, window] += work
                        if step % motion_every == 0:
                            floor_up, lid_up = _floor_and_lid_forces(cell, history, p, normals,
                                                                     floor_k, lid_k)
                            out_motion[M_FLOOR, b, window] += floor_up
                            out_motion[M_LID, b, window] += lid_up
                            out_motion[M_SAMPLES, b, window] += 1.0
                        if step % motion_window == 0:
                            _bed_point(cell, p, reference[b], floor_z + zw, out_motion[:, b, window + 1])
            wall_fz[b] = fz_prev
            acc_work[b] = work_sum
            acc_gross[b] = gross_sum
            out_work[b, cycle] = work_sum
            out_gross[b, cycle] = gross_sum
            out_harmonics[0, b, cycle] = -cos_sum * dt
            out_harmonics[1, b, cycle] = -sin_sum * dt
            _cycle_terms(acc, b, dt, out_terms, cycle)
            _ledger(cell, history, p, rotation, reference[b], out_energy[:, b, cycle + 1])
    _unpack(body, hist, x, v, w, f, t, shear, tenergy, delta, slide)


@njit(cache=True, error_model="numpy")
def _floor_and_lid(normals):
    """Indices of the floor (inward normal up) and the lid (down) among the cell's planes."""
    floor_k = lid_k = 0
    for k in range(normals.shape[0]):
        if normals[k, 2] > normals[floor_k, 2]:
            floor_k = k
        if normals[k, 2] < normals[lid_k, 2]:
            lid_k = k
    return floor_k, lid_k


@njit(cache=True, error_model="numpy", inline="always")
def _floor_and_lid_forces(body, hist, p, normals, floor_k, lid_k):
    """The floor's upward force on one cell's spheres and theirs on the lid, N, from the wall
    contacts' state after the last force evaluation (normal force and -F_t as stored)."""
    n = body.shape[0]
    out0 = out1 = 0.0
    for i in range(n):
        for which in range(2):
            k = floor_k if which == 0 else lid_k
            dl = hist[i, n + k, HDELTA]
            if not dl > 0.0:
                continue
            fn = math.sqrt(dl) * p[PW + A_N] * dl - hist[i, n + k, HD]
            fz = normals[k, 2] * fn - hist[i, n + k, HT + 2]
            if which == 0:
                out0 += fz
            else:
                out1 -= fz
    return out0, out1


@njit(cache=True, error_model="numpy")
def _bed_point(body, p, reference, floor_z, out):
    """One cell's K + K_rot + P (J) and the heights above the floor at ``floor_z`` (m) of its
    centre of mass and lowest and highest sphere centre, into ``out[M_ENERGY:M_TOP + 1]``."""
    n = body.shape[0]
    trans = rot = heights = 0.0
    lowest, highest = body[0, BX + 2], body[0, BX + 2]
    for i in range(n):
        z = body[i, BX + 2]
        lowest = min(lowest, z)
        highest = max(highest, z)
        heights += z
        for c in range(3):
            trans += body[i, BV + c] * body[i, BV + c]
            rot += body[i, BW + c] * body[i, BW + c]
    out[M_ENERGY] = (0.5 * p[MASS] * trans + 0.5 * p[INERTIA] * rot
                     + p[WEIGHT] * (heights - n * reference))
    out[M_CENTRE] = heights / n - floor_z
    out[M_BOTTOM] = lowest - floor_z
    out[M_TOP] = highest - floor_z


@njit(cache=True, error_model="numpy")
def _ledger(body, hist, p, rotation, reference, out):
    """Energies of one cell at a cycle boundary into ``out`` (rows E_*), J, and its
    centre-of-mass height and lowest and highest sphere centre, m."""
    n = body.shape[0]
    dt = p[DT]
    trans = rot = heights = force2 = torque2 = 0.0
    lowest, highest = body[0, BX + 2], body[0, BX + 2]
    for i in range(n):
        z = body[i, BX + 2]
        lowest = min(lowest, z)
        highest = max(highest, z)
        for c in range(3):
            trans += body[i, BV + c] * body[i, BV + c]
            rot += body[i, BW + c] * body[i, BW + c]
            force2 += body[i, BF + c] * body[i, BF + c]
            torque2 += body[i, BT + c] * body[i, BT + c]
        heights += z
    trans *= 0.5 * p[MASS]
    rot *= 0.5 * p[INERTIA]
    potential = p[WEIGHT] * (heights - n * reference)
    elastic = 0.0
    for i in range(n):
        for col in range(i + 1, n + N_WALLS):
            dl = hist[i, col, HDELTA]
            if not dl > 0.0:
                continue
            law = PP if col < n else PW
            s2 = hist[i, col, HS] ** 2 + hist[i, col, HS + 1] ** 2 + hist[i, col, HS + 2] ** 2
            elastic += p[law + ENERGY_N] * dl ** 2.5 + 0.5 * p[law + A_T] * math.sqrt(dl) * s2
    shift = -dt * dt / (8.0 * p[MASS]) * force2
    if rotation:
        shift -= dt * dt / (8.0 * p[INERTIA]) * torque2
    out[E_TRANS] = trans
    out[E_ROT] = rot
    out[E_POT] = potential
    out[E_ELASTIC] = elastic
    out[E_LEDGER] = trans + rot + shift + potential + elastic
    out[E_COM] = heights / n
    out[E_LOWEST] = lowest
    out[E_HIGHEST] = highest
