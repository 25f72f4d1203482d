"""The host with the cells replaced by a linear dashpot c = C_eq(f, Gamma), solved to consistency.

C_eq depends on the host's own acceleration amplitude Gamma = |X| Omega^2 / g, so the dashpot
model's steady amplitude at a forcing frequency is a solution of

    |X| = F_0 / |k_h - M Omega^2 + i Omega (c_h + C_eq(f, |X| Omega^2 / g))|.

The left side minus the right, as a function of |X|, is negative at |X| -> 0 and not negative at
the bare host's amplitude X_0 = F_0 / |k_h - M Omega^2 + i Omega c_h| (C_eq >= 0), so a solution
lies in (0, X_0]. Instead of a fixed-point iteration (which can oscillate where C_eq falls
steeply with Gamma) the function is evaluated on a log grid of |X| below X_0 and every sign change
is refined by Brent's method; where several solutions exist (a jump in the response) the largest
is taken and the count reported.

The surrogate does not extrapolate: Gamma and f are clipped to its domain, and every point where
that happened is flagged (below the domain's lowest G the spheres barely lift off, so clipping
there overstates C_eq).

The mass-and-dashpot model (:func:`solve_mass_point`) adds the cells' effective mass M(f, Gamma)
as well:

    |X| = F_0 / |k_h - (m_h + M(f, Gamma)) Omega^2 + i Omega (c_h + C(f, Gamma))|.

The mass moves the resonance with Gamma, so X_0 no longer bounds the solutions; but the right
side is at most F_0 / (Omega (c_h + C_min)) for any M (C_min the dashpot's smallest value), so
every solution lies in (0, F_0 / (Omega (c_h + C_min))], searched as above. C_min is read on a
log grid of Gamma from 1e-3 to 1e3 g (the surrogate is clipped to its domain, which lies inside
it) and halved for the spacing of that grid; only when c_h = 0 does it matter.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import brentq

from pidpipe.loop.sdof import complex_amplitude
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2

#: Points of the log grid of |X| (from X_0 / GRID_DECADES decades up to X_0) searched for sign changes.
GRID_POINTS = 400
GRID_DECADES = 6

DampingModel = Callable[[float, np.ndarray], np.ndarray]
"""C_eq(f_hz, accel_g array) -> N s/m array: the dashpot of all filled cells."""
MassDampingModel = Callable[[float, np.ndarray], tuple[np.ndarray, np.ndarray]]
"""(f_hz, accel_g array) -> (M kg array, C N s/m array): the added mass and dashpot of all cells."""
#: Decades of Gamma (g) around 1 g on which the dashpot's smallest value is read.
FLOOR_PROBE_DECADES = 3


@dataclass(frozen=True)
class EquivalentPoint:
    """The dashpot model's steady state at one forcing frequency.

    Attributes
    ----------
    amplitude : complex
        X, m (x = Re(X e^{i Omega t})).
    accel_g : float
        Gamma = |X| Omega^2 / g.
    ceq_ns_m : float
        The dashpot C_eq(f, Gamma) at the solution, N s/m.
    n_solutions : int
        Solutions found (more than one: the response jumps).
    added_mass_kg : float
        The added mass M(f, Gamma) at the solution, kg (0 for the dashpot alone).
    """

    amplitude: complex
    accel_g: float
    ceq_ns_m: float
    n_solutions: int
    added_mass_kg: float = 0.0


def solve_point(freq_hz: float, force_n: float, mass_kg: float, stiffness_n_m: float,
                host_damping_ns_m: float, model: DampingModel) -> EquivalentPoint:
    """The consistent steady state of the dashpot model at one frequency (module docstring).

    Parameters
    ----------
    freq_hz : float
        Forcing frequency, Hz.
    force_n : float
        F_0, N.
    mass_kg : float
        M, the moving mass (the host's, plus the spheres' if they are counted), kg.
    stiffness_n_m, host_damping_ns_m : float
        k_h (N/m) and c_h (N s/m).
    model : callable
        C_eq(f_hz, accel_g) of all filled cells, N s/m, vectorised over accel_g.
    """
    omega = 2.0 * np.pi * freq_hz
    to_g = omega**2 / STANDARD_GRAVITY_M_S2

    def amplitude(x_m):
        damping = host_damping_ns_m + model(freq_hz, np.asarray(x_m) * to_g)
        return np.abs(complex_amplitude(force_n, mass_kg, stiffness_n_m, damping, omega))

    bare = float(np.abs(complex_amplitude(force_n, mass_kg, stiffness_n_m, host_damping_ns_m, omega)))
    grid = bare * np.logspace(-GRID_DECADES, 0, GRID_POINTS)
    gap = grid - amplitude(grid)
    roots = [bare] if gap[-1] == 0 else []
    for i in np.flatnonzero(np.sign(gap[:-1]) * np.sign(gap[1:]) < 0):
        roots.append(brentq(lambda x: x - float(amplitude(x)), grid[i], grid[i + 1],
                            xtol=1e-14 * bare, rtol=1e-12))
    if not roots:
        roots = [grid[0]]        # C_eq so large that |X| < 1e-6 X_0: report the floor
    x = max(roots)
    damping = host_damping_ns_m + float(model(freq_hz, np.array([x * to_g]))[0])
    return EquivalentPoint(
        amplitude=complex(complex_amplitude(force_n, mass_kg, stiffness_n_m, damping, omega)),
        accel_g=x * to_g, ceq_ns_m=damping - host_damping_ns_m, n_solutions=len(roots))


def surrogate_damping(predict: Callable, domain: dict, fill_pct: float, cell_factor: float
                      ) -> tuple[DampingModel, Callable[[float, float], bool]]:
    """The dashpot of n_c cells from a coupon surrogate, and whether a point was clipped.

    Parameters
    ----------
    predict : callable
        The surrogate's C_eq of the coupon, ``predict(freq_hz, accel_g, fill_pct)``, N s/m.
    domain : dict
        The surrogate's ``freq_hz`` and ``accel_g`` bounds.
    fill_pct : float
        The cells' fill, %.
    cell_factor : float
        n_c / N: filled cells over the coupon's cells.

    Returns
    -------
    model : callable
        C(f_hz, accel_g) = cell_factor x C_eq_coupon(clip f, clip Gamma, r), N s/m.
    clipped : callable
        ``clipped(f_hz, accel_g)``: True where f or Gamma lies outside the domain.
    """
    (f_lo, f_hi), (g_lo, g_hi) = domain["freq_hz"], domain["accel_g"]

    def model(freq_hz, accel_g):
        accel = np.clip(np.asarray(accel_g, dtype=float), g_lo, g_hi)
        freq = np.full_like(accel, min(max(freq_hz, f_lo), f_hi))
        return cell_factor * np.asarray(predict(freq, accel, np.full_like(accel, fill_pct)))

    def clipped(freq_hz, accel_g):
        return bool(not (f_lo <= freq_hz <= f_hi) or not (g_lo <= accel_g <= g_hi))

    return model, clipped


def solve_mass_point(freq_hz: float, force_n: float, mass_kg: float, stiffness_n_m: float,
                     host_damping_ns_m: float, model: MassDampingModel) -> EquivalentPoint:
    """The consistent steady state of the host carrying an added mass and a dashpot, both
    functions of Gamma (module docstring).

    Parameters
    ----------
    freq_hz, force_n, stiffness_n_m, host_damping_ns_m : float
        As :func:`solve_point`.
    mass_kg : float
        m_h, the host's own mass (the cells' comes from ``model``), kg.
    model : callable
        ``model(f_hz, accel_g) -> (M, C)``: the cells' added mass (kg) and dashpot (N s/m),
        vectorised over accel_g; C >= 0.

    Raises
    ------
    ValueError
        c_h = 0 and the dashpot vanishes somewhere: the amplitude has no bound.
    """
    omega = 2.0 * np.pi * freq_hz
    to_g = omega**2 / STANDARD_GRAVITY_M_S2

    def response(x_m):
        added, damping = model(freq_hz, np.asarray(x_m, dtype=float) * to_g)
        return complex_amplitude(force_n, mass_kg + np.asarray(added), stiffness_n_m,
                                 host_damping_ns_m + np.asarray(damping), omega), added, damping

    probe = np.logspace(-FLOOR_PROBE_DECADES, FLOOR_PROBE_DECADES, 121)
    floor = host_damping_ns_m + 0.5 * float(np.min(model(freq_hz, probe)[1]))
    if not floor > 0:
        raise ValueError(f"at {freq_hz:g} Hz the host has no damping and the dashpot vanishes: "
                         "the amplitude has no bound")
    upper = force_n / (omega * floor)
    grid = upper * np.logspace(-GRID_DECADES - 2, 0, GRID_POINTS * 2)
    gap = grid - np.abs(response(grid)[0])
    roots = [upper] if gap[-1] == 0 else []
    for i in np.flatnonzero(np.sign(gap[:-1]) * np.sign(gap[1:]) < 0):
        roots.append(brentq(lambda x: x - float(np.abs(response(np.array([x]))[0][0])),
                            grid[i], grid[i + 1], xtol=1e-14 * upper, rtol=1e-12))
    if not roots:
        roots = [grid[0]]
    x = max(roots)
    amplitude, added, damping = response(np.array([x]))
    return EquivalentPoint(amplitude=complex(amplitude[0]), accel_g=x * to_g,
                           ceq_ns_m=float(damping[0]), n_solutions=len(roots),
                           added_mass_kg=float(added[0]))


def damper_model(damper, fill_pct: float, n_cells: int, mass_shift: float = 0.0,
                 damping_shift: float = 0.0
                 ) -> tuple[MassDampingModel, Callable[[float, float], bool]]:
    """The added mass and dashpot of n_c cells from a :class:`pidpipe.design.damper.Damper`,
    read at the domain's edge outside it, optionally shifted within the standard uncertainties.

    Parameters
    ----------
    damper : pidpipe.design.damper.Damper
    fill_pct : float
        The cells' fill, %.
    n_cells : int
        n_c.
    mass_shift, damping_shift : float
        z_m and z_c: the model is M = m_eff + z_m sd(m_eff) and C = max(C_eq + z_c sd(C_eq), 0)
        (an unknown, NaN, sd shifts nothing).

    Returns
    -------
    model : callable
        ``model(f_hz, accel_g) -> (M kg, C N s/m)``.
    clipped : callable
        ``clipped(f_hz, accel_g)``: True where f or Gamma lies outside the damper's domain.
    """
    (f_lo, f_hi), (g_lo, g_hi) = damper.domain["freq_hz"], damper.domain["accel_g"]

    def model(freq_hz, accel_g):
        accel = np.asarray(accel_g, dtype=float)
        v = damper.values(np.full_like(accel, freq_hz), accel, fill_pct, cells=n_cells, clip=True)
        mass = v.m_eff_kg + mass_shift * np.nan_to_num(v.m_eff_sd_kg)
        damping = np.maximum(v.ceq_ns_m + damping_shift * np.nan_to_num(v.ceq_sd_ns_m), 0.0)
        return mass.reshape(accel.shape), damping.reshape(accel.shape)

    def clipped(freq_hz, accel_g):
        return bool(not (f_lo <= freq_hz <= f_hi) or not (g_lo <= accel_g <= g_hi))

    return model, clipped
