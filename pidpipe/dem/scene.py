"""The one-cell scene of the NumPy DEM: materials, contact laws, base motion and timestep.

Everything here is immutable and computed once, before the time loop. The contact laws are
LIGGGHTS 3.8's ``model hertz tangential history`` (see :mod:`pidpipe.physics.contact`), written as
four coefficients so that the force kernel needs only sqrt(delta) and delta^(1/4):

- k_n     = a_n sqrt(delta),  a_n = 4/3 E* sqrt(R*)                         [N/m]
- gamma_n = g_n delta^(1/4),  g_n = -2 sqrt(5/6) beta sqrt(2 E* sqrt(R*) m*)  [kg/s]
- k_t     = a_t sqrt(delta),  a_t = 8 G* sqrt(R*)                           [N/m]
- gamma_t = g_t delta^(1/4),  g_t = -2 sqrt(5/6) beta sqrt(8 G* sqrt(R*) m*)  [kg/s]

As in LIGGGHTS, a wall contact uses R* = particle radius and m* = particle mass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pidpipe.cell.geometry import HexCell
from pidpipe.physics import contact
from pidpipe.physics.materials import Material

_SQRT_FIVE_SIXTHS = math.sqrt(5.0 / 6.0)


@dataclass(frozen=True)
class ContactLaw:
    """Coefficients of one Hertz/history contact type (particle-particle or particle-wall).

    Attributes
    ----------
    a_n, g_n, a_t, g_t : float
        See the module docstring; units N/m^1.5, kg/(s m^0.25), N/m^1.5, kg/(s m^0.25).
    friction : float
        Coulomb coefficient mu (0 switches the tangential force off as LIGGGHTS does).
    restitution : float
        Normal coefficient of restitution e.
    youngs_eff_pa, shear_eff_pa, radius_eff_m, mass_eff_kg : float
        The effective E*, G* (LIGGGHTS' definition), R* and m* the coefficients come from.
    """

    a_n: float
    g_n: float
    a_t: float
    g_t: float
    friction: float
    restitution: float
    youngs_eff_pa: float
    shear_eff_pa: float
    radius_eff_m: float
    mass_eff_kg: float


def contact_law(mat_i: Material, mat_j: Material, radius_eff_m: float, mass_eff_kg: float,
                friction: float, restitution: float) -> ContactLaw:
    """Build the contact law of a pair of materials.

    Parameters
    ----------
    mat_i, mat_j : Material
        The two materials (Young's moduli already scaled if the fidelity asks for it).
    radius_eff_m, mass_eff_kg : float
        Effective radius R* (m) and mass m* (kg) of the contact.
    friction, restitution : float
        Coulomb coefficient mu >= 0 and restitution e in (0, 1].
    """
    e_eff = contact.effective_youngs_modulus(mat_i.youngs_modulus_pa, mat_i.poisson_ratio,
                                             mat_j.youngs_modulus_pa, mat_j.poisson_ratio)
    g_eff = contact.effective_shear_modulus(mat_i.youngs_modulus_pa, mat_i.poisson_ratio,
                                            mat_j.youngs_modulus_pa, mat_j.poisson_ratio)
    beta = contact.damping_beta(restitution)
    sqrt_r = math.sqrt(radius_eff_m)
    return ContactLaw(
        a_n=4.0 / 3.0 * e_eff * sqrt_r,
        g_n=-2.0 * _SQRT_FIVE_SIXTHS * beta * math.sqrt(2.0 * e_eff * sqrt_r * mass_eff_kg),
        a_t=8.0 * g_eff * sqrt_r,
        g_t=-2.0 * _SQRT_FIVE_SIXTHS * beta * math.sqrt(8.0 * g_eff * sqrt_r * mass_eff_kg),
        friction=float(friction), restitution=float(restitution),
        youngs_eff_pa=e_eff, shear_eff_pa=g_eff, radius_eff_m=radius_eff_m,
        mass_eff_kg=mass_eff_kg,
    )


@dataclass(frozen=True)
class Scene:
    """One shaken cell (or a batch of identical cells): everything the time loop needs.

    Attributes
    ----------
    cell : HexCell
        The cell; its eight planes move rigidly with the base.
    radius_m, mass_kg, inertia_kg_m2 : float
        Sphere radius, mass and moment of inertia (monodisperse spheres).
    pp, pw : ContactLaw
        Particle-particle and particle-wall contact laws.
    freq_hz : float
        Base-excitation frequency f, Hz (also sets the cycle length 1/f).
    accel_g : ndarray, shape (n_batch,)
        Base acceleration amplitude G of each cell of the batch, in units of 9.81 m/s^2.
        The wall moves as z_w(t) = W (cos(omega t) - 1), W = G 9.81 / omega^2.
    timestep_s : float
        Timestep dt, s; a cycle is exactly ``steps_per_cycle`` steps.
    steps_per_cycle : int
    rayleigh_time_s : float
        Rayleigh time of the (scaled) particle material, s.
    rotation, friction : bool
        Integrate rotation; tangential contact on.
    gravity_m_s2 : float
        Gravity (acting along -z), m/s^2.
    """

    cell: HexCell
    radius_m: float
    mass_kg: float
    inertia_kg_m2: float
    pp: ContactLaw
    pw: ContactLaw
    freq_hz: float
    accel_g: np.ndarray
    timestep_s: float
    steps_per_cycle: int
    rayleigh_time_s: float
    rotation: bool = True
    friction: bool = True
    gravity_m_s2: float = contact.STANDARD_GRAVITY_M_S2
    settings: dict = field(default_factory=dict, compare=False)

    @property
    def omega_rad_s(self) -> float:
        """Angular frequency of the base motion, rad/s."""
        return 2.0 * math.pi * self.freq_hz

    @property
    def amplitude_m(self) -> np.ndarray:
        """Wall displacement amplitude W = G 9.81 / omega^2 per cell; shape (n_batch,), m."""
        return self.accel_g * contact.STANDARD_GRAVITY_M_S2 / self.omega_rad_s**2

    @property
    def n_batch(self) -> int:
        """Number of independent cells integrated together."""
        return int(self.accel_g.shape[0])


def choose_timestep(freq_hz: float, rayleigh_time_s: float,
                    rayleigh_fraction: float) -> tuple[float, int]:
    """Timestep no larger than ``rayleigh_fraction`` x t_R with a whole number of steps per cycle.

    Returns
    -------
    timestep_s : float
        dt = (1/f) / steps_per_cycle, s.
    steps_per_cycle : int
        ceil((1/f) / (fraction t_R)).
    """
    if not (freq_hz > 0 and rayleigh_time_s > 0 and rayleigh_fraction > 0):
        raise ValueError("freq_hz, rayleigh_time_s and rayleigh_fraction must be positive")
    period = 1.0 / freq_hz
    steps = math.ceil(period / (rayleigh_fraction * rayleigh_time_s) * (1.0 - 1e-12))
    return period / steps, int(steps)


def make_scene(cell: HexCell, particle: Material, wall: Material, *,
               pp_friction: float, pp_restitution: float,
               pw_friction: float, pw_restitution: float,
               freq_hz: float, accel_g, timestep_rayleigh_fraction: float = 0.2,
               youngs_modulus_scale: float = 1.0, rotation: bool = True,
               friction: bool = True,
               gravity_m_s2: float = contact.STANDARD_GRAVITY_M_S2) -> Scene:
    """Build a :class:`Scene` from plain parameters (SI units).

    Parameters
    ----------
    cell : HexCell
    particle, wall : Material
        Particle material (with radius and density) and wall material, unscaled.
    pp_friction, pp_restitution, pw_friction, pw_restitution : float
        Coulomb mu and restitution e of particle-particle and particle-wall contacts.
    freq_hz : float
        Excitation frequency, Hz.
    accel_g : float or array_like, shape (n_batch,)
        Base acceleration amplitude(s), in g; one per cell of the batch (0 keeps the cell still).
    timestep_rayleigh_fraction : float
        dt / t_R before rounding down to whole steps per cycle.
    youngs_modulus_scale : float
        Multiplies every Young's modulus (also the one in the Rayleigh time).
    rotation, friction : bool
        Fidelity switches; ``friction=False`` removes the tangential force altogether.
    gravity_m_s2 : float
        Gravity along -z, m/s^2.
    """
    accel = np.atleast_1d(np.asarray(accel_g, dtype=float))
    if accel.ndim != 1 or np.any(~np.isfinite(accel)) or np.any(accel < 0):
        raise ValueError(f"accel_g must be finite and >= 0, got {accel_g!r}")
    part = particle.scaled(youngs_modulus_scale)
    wal = wall.scaled(youngs_modulus_scale)
    radius = part.radius_m
    mass = contact.sphere_mass(radius, part.density_kg_m3)
    inertia = contact.sphere_moment_of_inertia(radius, part.density_kg_m3)
    t_rayleigh = contact.rayleigh_time(radius, part.density_kg_m3, part.youngs_modulus_pa,
                                       part.poisson_ratio)
    dt, steps = choose_timestep(freq_hz, t_rayleigh, timestep_rayleigh_fraction)
    pp = contact_law(part, part, contact.effective_radius(radius, radius),
                     contact.effective_mass(mass, mass), pp_friction, pp_restitution)
    pw = contact_law(part, wal, contact.effective_radius(radius, None),
                     contact.effective_mass(mass, None), pw_friction, pw_restitution)
    settings = dict(timestep_rayleigh_fraction=timestep_rayleigh_fraction,
                    youngs_modulus_scale=youngs_modulus_scale)
    return Scene(cell=cell, radius_m=radius, mass_kg=mass, inertia_kg_m2=inertia, pp=pp, pw=pw,
                 freq_hz=float(freq_hz), accel_g=accel, timestep_s=dt, steps_per_cycle=steps,
                 rayleigh_time_s=t_rayleigh, rotation=bool(rotation), friction=bool(friction),
                 gravity_m_s2=float(gravity_m_s2), settings=settings)
