"""Contact forces of LIGGGHTS 3.8's ``model hertz tangential history``, all contacts at once.

For a contact (i, partner) with unit normal n pointing from the partner to sphere i, overlap
delta, relative velocity v_r = v_i - v_partner (the partner being a sphere or the moving wall):

- v_n = v_r . n;   v_t = v_r - v_n n;   v_tr = v_t - c_r (omega_i + omega_partner) x n,
  c_r = R - delta/2 (LIGGGHTS' contact radius; a wall has omega = 0)
- F_n = k_n delta - gamma_n v_n  (no force limiting: a slightly attractive tail is possible)
- history: s += v_tr dt, then s -= (s . n) n; F_t = -k_t s, and if |F_t| > mu |F_n| then
  F_t is scaled to mu |F_n| and s = -F_t / k_t (sliding), else F_t -= gamma_t v_tr
- force on i: F_n n + F_t; torque on i: -c_r n x F_t; the history is reset when the contact
  opens. (LIGGGHTS sources read: surface_model_default.h, normal_model_hertz.h,
  tangential_model_history.h, fix_wall_gran.cpp.)

Energy terms per contact and step n (J). Velocity Verlet moves a sphere by dt v_{n-1/2} under
the mean force (F_{n-1} + F_n)/2, and the walls move by z_w(t_n) - z_w(t_{n-1}) = dt u_w
(u_w the wall's mean velocity over the step, :func:`pidpipe.dem.walls.wall_step_velocity`).
The work of a contact force over step n is therefore (F_{n-1} + F_n)/2 . u_r dt, with u_r the
relative displacement of the step over dt: v_r for a sphere pair, but v_r + (v_w - u_w) e_z
for a wall contact, whose force sees the wall velocity v_w(t_n) at the end of the step
(LIGGGHTS' mesh velocity), half a step later than the wall's actual move:

- normal damping: (gamma_n v_n |_{n-1} + gamma_n v_n |_n)/2 * u_n dt, u_n = u_r . n
- tangential: the work the tangential force absorbs, -(F_t,n-1 + F_t,n)/2 . u_tr dt, minus the
  change of the elastic energy 1/2 k_t |s|^2 stored in the history spring. On a sliding step
  it is the friction loss; on a sticking step it is the tangential damping
  gamma_t v_tr . u_tr dt plus a remainder (the ``tangential_spring`` term), because k_t
  changes with delta and the history is projected, so the Mindlin spring is not exactly
  conservative.
- wall work: (F_wall,n-1 + F_wall,n)/2 . u_w dt, summed over the sphere-wall contacts.

With these, the wall work minus the change of the energy (:mod:`pidpipe.dem.energy`) and the
sum of the terms differ only by the O(dt^2) error of the trapezoidal work of the elastic
forces. Taking v_w(t_n) for the wall's move instead (as before) put a bias of
(dt/2) * integral(F_wall,z a_w dt) per cycle into the wall work.

Layout: component-first dense arrays (3, n_batch, n, n + 8); see :mod:`pidpipe.dem.state`.
"""

from __future__ import annotations

import numpy as np

from pidpipe.dem.scene import Scene
from pidpipe.dem.state import N_WALLS, State
from pidpipe.dem.walls import wall_planes

#: Names of the per-step dissipation terms, in the order of :func:`reduce_terms`.
DISSIPATION_TERMS: tuple[str, ...] = (
    "normal_damping", "friction", "tangential_damping", "tangential_spring")

_DOT = "cbij,cbij->bij"


class Workspace:
    """Preallocated buffers of the force kernel for one scene and one state's shapes.

    Attributes of interest after :func:`compute_forces`
    ----------------------------------------------------
    delta : ndarray, shape (n_batch, n, n + 8)
        Overlaps (0 where not in contact), m.
    kn : ndarray, shape (n_batch, n, n + 8)
        Normal stiffness k_n, N/m.
    contact : ndarray of bool, shape (n_batch, n, n + 8)
    terms, terms_acc : ndarray, shape (4, n_batch, n, n + 8)
        This step's per-contact energy terms, and their sum since the last
        :func:`reset_accumulators` (see :func:`reduce_terms`, which turns them into J).
    step_wall_work, wall_work_acc : ndarray, shape (n_batch,)
        Work of the walls on the spheres this step, and since the last reset, J.
    gross_wall_work_acc : ndarray, shape (n_batch,)
        Sum of |step_wall_work| since the last reset: the work exchanged with the walls, J.
    wall_velocity_lag : ndarray, shape (n_batch,)
        v_w(t_n) - u_w of the last step: how much faster the wall contacts' force law sees the
        wall move than it actually moved, m/s.
    wall_force_z : ndarray, shape (n_batch,)
        Total z force of the walls on the spheres, N (minus the force on the mesh).
    """

    def __init__(self, scene: Scene, state: State):
        n_batch, n = state.n_batch, state.n_spheres
        m = n + N_WALLS
        shape3, shape1 = (3, n_batch, n, m), (n_batch, n, m)
        self.n = n
        self.normals, self.offsets = wall_planes(scene.cell)
        self.en = np.zeros(shape3)
        self.en[:, :, :, n:] = self.normals.T[:, None, None, :]   # walls never rotate
        self.pair_diff = np.zeros((3, n_batch, n, n))
        self.pair_dist = np.zeros((n_batch, n, n))
        self.wall_reach = np.zeros((n_batch, 1, N_WALLS))
        for name in ("vr", "t3", "t3b", "ft", "tangential_prev"):
            setattr(self, name, np.zeros(shape3))
        for name in ("delta", "vn", "cr", "sq", "q", "kn", "gn", "fn", "s1", "s2", "s3",
                     "ratio", "damping_prev", "stored2"):
            setattr(self, name, np.zeros(shape1))
        self.contact = np.zeros(shape1, dtype=bool)
        self.slide = np.zeros(shape1, dtype=bool)
        self.terms = np.zeros((4,) + shape1)          # see reduce_terms
        self.vcols = np.zeros((3, n_batch, m))
        self.ocols = np.zeros((3, n_batch, m))
        self.wall_dist = np.zeros((N_WALLS, n_batch * n))
        self.wall_term = np.zeros((N_WALLS, n_batch * n))
        self.terms_acc = np.zeros_like(self.terms)
        self.step_wall_work = np.zeros(n_batch)
        self.wall_work_acc = np.zeros(n_batch)
        self.gross_wall_work_acc = np.zeros(n_batch)
        self.wall_velocity_lag = np.zeros(n_batch)
        self.wall_force_z = np.zeros(n_batch)
        self.wall_force_z_prev = np.zeros(n_batch)
        self.kick = np.zeros((3, n_batch, n))         # integrator scratch
        self.eye = np.eye(n)
        # per-contact coefficients (columns: n spheres, then the 8 walls), broadcast to the
        # full shape once: same-shape contiguous operands are NumPy's fastest path
        def per_column(attr):
            row = np.concatenate([np.full(n, getattr(scene.pp, attr)),
                                  np.full(N_WALLS, getattr(scene.pw, attr))])
            return np.ascontiguousarray(np.broadcast_to(row, shape1))
        self.a_n, self.g_n, self.a_t, self.mu = (per_column(a) for a in
                                                 ("a_n", "g_n", "a_t", "friction"))
        g_t = per_column("g_t")
        self.gt_over_gn = np.divide(g_t, self.g_n, out=np.zeros(shape1), where=self.g_n != 0)
        self.r_minus_offset = scene.radius_m - self.offsets          # (8,)
        self.normal_z = self.normals[:, 2].copy()                     # (8,)
        # broadcast views of the state, bound once (the state arrays are updated in place)
        self.x_i, self.x_j = state.x[:, :, :, None], state.x[:, :, None, :]
        self.v_i, self.v_cols = state.v[:, :, :, None], self.vcols[:, :, None, :]
        self.w_i, self.w_cols = state.omega[:, :, :, None], self.ocols[:, :, None, :]


def compute_forces(scene: Scene, state: State, ws: Workspace, wall_z_m: np.ndarray,
                   wall_v_m_s: np.ndarray, wall_step_v_m_s: np.ndarray | None = None,
                   update_history: bool = True) -> None:
    """Evaluate all contact forces and torques (and gravity) at the current state.

    Fills ``state.force`` and ``state.torque``, updates ``state.shear`` and
    ``state.tangential_energy``, writes this step's energy terms into ``ws.terms`` and
    ``ws.step_wall_work`` and adds them to the accumulators.

    Parameters
    ----------
    scene : Scene
    state : State
        Positions at the new step and the (half-step) velocities the forces use; its arrays
        must be the ones ``ws`` was built with.
    ws : Workspace
    wall_z_m, wall_v_m_s : ndarray, shape (n_batch,)
        Wall displacement (m) and velocity (m/s) along z at the end of the step; the forces
        use this velocity.
    wall_step_v_m_s : ndarray, shape (n_batch,), optional
        The wall's displacement over the step divided by dt, m/s, for the energy terms and the
        wall work; ``wall_v_m_s`` if not given.
    update_history : bool
        Accumulate the tangential history (False for the set-up evaluation, as LIGGGHTS).
    """
    n = ws.n
    dt = scene.timestep_s
    radius = scene.radius_m
    en, vr, t3, t3b = ws.en, ws.vr, ws.t3, ws.t3b
    wall_step_v = wall_v_m_s if wall_step_v_m_s is None else wall_step_v_m_s
    np.subtract(wall_v_m_s, wall_step_v, out=ws.wall_velocity_lag)
    delta, s1 = ws.delta, ws.s1

    # --- geometry: normals and overlaps ---------------------------------------------------
    np.subtract(ws.x_i, ws.x_j, out=ws.pair_diff)
    r_pp = ws.pair_dist
    np.einsum(_DOT, ws.pair_diff, ws.pair_diff, out=r_pp)
    r_pp += ws.eye                                    # the diagonal: r = 1 m, never a contact
    np.sqrt(r_pp, out=r_pp)
    np.subtract(2.0 * radius, r_pp, out=delta[..., :n])
    np.divide(ws.pair_diff, r_pp, out=en[..., :n])
    # n . x as the kernel sums it, n_x x + n_y y + n_z z from the left (a matrix product
    # rounds differently, by an ulp of x, and a resting wall overlap of ~4e-8 m turns that
    # into 4e-11 of the contact force; BLAS's order also varies with the build)
    x_flat = state.x.reshape(3, -1)
    np.multiply(ws.normals[:, 0, None], x_flat[0], out=ws.wall_dist)
    for c in (1, 2):
        np.multiply(ws.normals[:, c, None], x_flat[c], out=ws.wall_term)
        ws.wall_dist += ws.wall_term
    dist = ws.wall_dist.reshape(N_WALLS, state.n_batch, n).transpose(1, 2, 0)
    np.multiply(wall_z_m[:, None, None], ws.normal_z, out=ws.wall_reach)
    ws.wall_reach += ws.r_minus_offset                            # R - c + n_z z_w
    np.subtract(ws.wall_reach, dist, out=delta[..., n:])          # ... - n.x
    np.maximum(delta, 0.0, out=delta)
    np.greater(delta, 0.0, out=ws.contact)

    # --- relative velocity at the contact point -------------------------------------------
    ws.vcols[:, :, :n] = state.v
    ws.vcols[2, :, n:] = wall_v_m_s[:, None]
    np.subtract(ws.v_i, ws.v_cols, out=vr)
    np.einsum(_DOT, vr, en, out=ws.vn)
    if scene.friction:
        np.multiply(en, ws.vn, out=t3)
        vr -= t3                                      # vr is now v_t
    if scene.friction and scene.rotation:
        np.multiply(delta, -0.5, out=ws.cr)
        ws.cr += radius
        ws.ocols[:, :, :n] = state.omega
        np.add(ws.w_i, ws.w_cols, out=t3)
        t3 *= ws.cr                                   # c_r (omega_i + omega_j)
        _cross(t3, en, t3b, s1)
        vr -= t3b                                     # vr is now v_tr

    # --- normal force ---------------------------------------------------------------------
    np.sqrt(delta, out=ws.sq)
    np.sqrt(ws.sq, out=ws.q)                          # delta^(1/4)
    np.multiply(ws.sq, ws.a_n, out=ws.kn)
    np.multiply(ws.q, ws.g_n, out=ws.gn)
    np.multiply(ws.kn, delta, out=ws.fn)
    np.multiply(ws.gn, ws.vn, out=s1)                 # gamma_n v_n, the damping force
    ws.fn -= s1
    terms = ws.terms
    np.add(ws.damping_prev, s1, out=terms[0])
    wall_lag_work = _wall_normal_lag_work(ws, terms[0])
    terms[0] *= ws.vn
    terms[0][..., n:] += wall_lag_work                # (f_d,prev + f_d) u_n
    ws.damping_prev, ws.s1 = s1, ws.damping_prev      # keep this step's damping force
    np.multiply(en, ws.fn, out=ws.ft)                 # ft: total contact force on i

    if scene.friction:
        _tangential(scene, state, ws, update_history)  # leaves -F_t in t3
        ws.ft -= t3
        if scene.rotation:
            _cross(en, t3, t3b, ws.s1)                # n x (-F_t)
            t3b *= ws.cr
            t3b.sum(axis=3, out=state.torque)
    ws.ft.sum(axis=3, out=state.force)
    state.force[2] -= scene.mass_kg * scene.gravity_m_s2

    # --- energy terms of this step --------------------------------------------------------
    # sphere-sphere forces cancel in the sum over spheres: what is left is the walls' force
    ws.wall_force_z_prev, ws.wall_force_z = ws.wall_force_z, ws.wall_force_z_prev
    state.force[2].sum(axis=1, out=ws.wall_force_z)
    ws.wall_force_z += n * scene.mass_kg * scene.gravity_m_s2
    np.add(ws.wall_force_z_prev, ws.wall_force_z, out=ws.step_wall_work)
    ws.step_wall_work *= wall_step_v * (0.5 * dt)
    ws.wall_work_acc += ws.step_wall_work
    ws.gross_wall_work_acc += np.abs(ws.step_wall_work)
    if scene.friction:
        ws.terms_acc += terms
    else:
        ws.terms_acc[0] += terms[0]


def _wall_normal_lag_work(ws: Workspace, normal_force: np.ndarray) -> np.ndarray:
    """f (u_n - v_n) = f lag n_z for the wall columns of a normal force f (n_batch, n, n + 8).

    u_n - v_n is zero for a sphere pair; a wall moved by u_w dt, not by v_w(t_n) dt, over the
    step. Returns shape (n_batch, n, 8).
    """
    return normal_force[..., ws.n:] * (ws.wall_velocity_lag[:, None, None] * ws.normal_z)


def _add_wall_lag_work(ws: Workspace, force_z: np.ndarray, out: np.ndarray) -> None:
    """Add F . (u_tr - v_tr) = F_z lag to the wall columns of ``out``, for a force F in a wall's
    tangent plane (u_tr - v_tr = lag (e_z - n_z n) there); ``force_z`` and ``out`` have shape
    (n_batch, n, n + 8)."""
    n = ws.n
    out[..., n:] += force_z[..., n:] * ws.wall_velocity_lag[:, None, None]


def _tangential(scene: Scene, state: State, ws: Workspace, update_history: bool) -> None:
    """History update, Coulomb cap and damping; leaves -F_t in ``ws.t3``, fills terms 1-3."""
    dt = scene.timestep_s
    en, vtr, t3, t3b = ws.en, ws.vr, ws.t3, ws.t3b
    shear = state.shear
    s1, s2, kt, ratio = ws.s1, ws.s2, ws.s3, ws.ratio
    terms = ws.terms
    if update_history:
        np.multiply(vtr, dt, out=t3)
        shear += t3
        np.einsum(_DOT, shear, en, out=s1)
        np.multiply(en, s1, out=t3)
        shear -= t3
    np.multiply(shear, ws.contact, out=shear)         # opened contacts forget their history
    np.multiply(ws.sq, ws.a_t, out=kt)
    np.einsum(_DOT, shear, shear, out=s2)             # |s|^2
    np.sqrt(s2, out=s1)
    s1 *= kt                                          # |F_t| of the spring
    np.abs(ws.fn, out=ratio)
    ratio *= ws.mu                                    # mu |F_n|
    np.greater(s1, ratio, out=ws.slide)
    s1 += 1e-300
    np.divide(ratio, s1, out=ratio)
    np.minimum(ratio, 1.0, out=ratio)                 # Coulomb cap (1 when sticking)
    shear *= ratio
    s2 *= ratio
    s2 *= ratio
    np.multiply(s2, kt, out=ws.s1)                    # 2 x stored energy k_t |s|^2
    stored2 = ws.s1
    # -F_t = k_t s + stick gamma_t v_tr
    np.multiply(shear, kt, out=t3)
    gamma_t = s2
    np.multiply(ws.gn, ws.gt_over_gn, out=gamma_t)
    gamma_t[ws.slide] = 0.0
    np.multiply(vtr, gamma_t, out=t3b)
    t3 += t3b
    # energy: 2 x dissipated = (-F_t,prev - F_t) . u_tr dt - (k_t|s|^2 - k_t|s|^2 prev)
    np.add(ws.tangential_prev, t3, out=t3b)
    np.einsum(_DOT, t3b, vtr, out=terms[1])
    _add_wall_lag_work(ws, t3b[2], terms[1])
    terms[1] *= dt
    terms[1] -= stored2
    terms[1] += ws.stored2
    np.multiply(terms[1], ws.slide, out=terms[2])
    np.einsum(_DOT, vtr, vtr, out=terms[3])
    terms[3] *= gamma_t                               # gamma_t |v_tr|^2, and on walls
    n = ws.n                                          # + gamma_t v_tr . (u_tr - v_tr)
    np.multiply(vtr[2][..., n:], gamma_t[..., n:], out=ratio[..., n:])
    _add_wall_lag_work(ws, ratio, terms[3])
    np.copyto(ws.tangential_prev, t3)
    ws.stored2, ws.s1 = stored2, ws.stored2
    np.multiply(ws.stored2, 0.5, out=state.tangential_energy)


def reduce_terms(terms: np.ndarray, n: int, dt: float) -> np.ndarray:
    """Sum per-contact energy terms by contact type; returns shape (4, 2, n_batch), J.

    Parameters
    ----------
    terms : ndarray, shape (4, n_batch, n, n + 8)
        Per contact (summed over any number of steps): 0: (f_d,prev + f_d) u_n; 1: twice the
        tangential dissipation; 2: its sliding part; 3: gamma_t v_tr . u_tr of sticking
        contacts (see the module docstring for u).
    n : int
        Spheres per cell.
    dt : float
        Timestep, s.

    Returns
    -------
    ndarray, shape (4, 2, n_batch)
        Energy by term (:data:`DISSIPATION_TERMS`) and contact type (0: sphere-sphere,
        1: sphere-wall), J.
    """
    per_col = terms.sum(axis=2)                       # (4, n_batch, n_cols)
    pp = per_col[..., :n].sum(axis=2) * 0.5           # each sphere pair appears twice
    pw = per_col[..., n:].sum(axis=2)
    out = np.zeros((len(DISSIPATION_TERMS), 2, terms.shape[1]))
    for col, sums in enumerate((pp, pw)):
        out[0, col] = 0.5 * dt * sums[0]
        out[1, col] = 0.5 * sums[2]
        out[2, col] = dt * sums[3]
        out[3, col] = 0.5 * (sums[1] - sums[2]) - out[2, col]
    return out


def reset_accumulators(ws: "Workspace") -> None:
    """Zero the energy accumulated since the last reset (wall work and contact terms)."""
    ws.terms_acc.fill(0.0)
    ws.wall_work_acc.fill(0.0)
    ws.gross_wall_work_acc.fill(0.0)


def accumulated_dissipation(ws: "Workspace", dt: float) -> np.ndarray:
    """Energy dissipated since the last reset, by term and contact type; (4, 2, n_batch), J."""
    return reduce_terms(ws.terms_acc, ws.n, dt)


def _cross(a: np.ndarray, b: np.ndarray, out: np.ndarray, tmp: np.ndarray) -> None:
    """Component-first cross product ``out = a x b`` over axis 0; ``tmp`` is scratch."""
    np.multiply(a[1], b[2], out=out[0])
    np.multiply(a[2], b[1], out=tmp)
    out[0] -= tmp
    np.multiply(a[2], b[0], out=out[1])
    np.multiply(a[0], b[2], out=tmp)
    out[1] -= tmp
    np.multiply(a[0], b[1], out=out[2])
    np.multiply(a[1], b[0], out=tmp)
    out[2] -= tmp


def clear_step_terms(ws: Workspace) -> None:
    """Zero this step's energy terms and the accumulators (after the set-up evaluation)."""
    ws.terms.fill(0.0)
    ws.step_wall_work.fill(0.0)
    reset_accumulators(ws)

