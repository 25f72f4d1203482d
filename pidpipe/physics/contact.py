"""Contact-model constants shared by the LIGGGHTS path and the NumPy DEM.

The normal contact is Hertz with the restitution-based (Tsuji-type) damping that LIGGGHTS'
``model hertz`` uses; the tangential contact is a Mindlin-type history spring capped by
Coulomb's law (LIGGGHTS' ``tangential history``). All quantities are SI.

For a pair (i, j), with overlap delta and effective radius R* and mass m*:

- normal stiffness      k_n = 4/3 E* sqrt(R* delta)             [N/m]
- tangential stiffness  k_t = 8 G* sqrt(R* delta)               [N/m]
- normal damping        gamma_n = -2 sqrt(5/6) beta sqrt(2 E* sqrt(R* delta) m*)   [kg/s]
- tangential damping    gamma_t = -2 sqrt(5/6) beta sqrt(8 G* sqrt(R* delta) m*)  [kg/s]
- beta = ln(e) / sqrt(ln(e)^2 + pi^2)
- normal elastic energy  U_n = 8/15 E* sqrt(R*) delta^{5/2}     (the integral of k_n delta)  [J]
- tangential spring energy U_t = 1/2 k_t |xi|^2, xi the stored tangential displacement      [J]

This is SPEC.md's f_n = -(k delta^{3/2} + alpha sqrt(m* k) delta^{1/4} d(delta)/dt) with
k = 4/3 E* sqrt(R*) and alpha = -ln(e) sqrt(5/(ln^2 e + pi^2)); for Hertz contact it
reproduces the restitution coefficient e exactly (the damping is self-similar in delta).
"""

from __future__ import annotations

import math

import numpy as np

STANDARD_GRAVITY_M_S2 = 9.81
"""Gravitational acceleration used throughout, as in SPEC.md (a = G * 9.81 m/s^2)."""

_SQRT_FIVE_SIXTHS = math.sqrt(5.0 / 6.0)


def effective_youngs_modulus(e1_pa: float, nu1: float, e2_pa: float, nu2: float) -> float:
    """Effective Young's modulus E* of a Hertz contact, in Pa.

    ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2``.
    """
    return 1.0 / ((1.0 - nu1**2) / e1_pa + (1.0 - nu2**2) / e2_pa)


def effective_shear_modulus(e1_pa: float, nu1: float, e2_pa: float, nu2: float) -> float:
    """Effective shear modulus G* of a Mindlin contact as LIGGGHTS defines it, in Pa.

    ``1/G* = 2(2 - nu1)(1 + nu1)/E1 + 2(2 - nu2)(1 + nu2)/E2``.
    """
    return 1.0 / (2.0 * (2.0 - nu1) * (1.0 + nu1) / e1_pa + 2.0 * (2.0 - nu2) * (1.0 + nu2) / e2_pa)


def effective_radius(r1_m: float, r2_m: float | None) -> float:
    """Effective radius R* in m; ``r2_m=None`` means a flat wall (R* = r1)."""
    if r2_m is None:
        return r1_m
    return r1_m * r2_m / (r1_m + r2_m)


def effective_mass(m1_kg: float, m2_kg: float | None) -> float:
    """Effective mass m* in kg; ``m2_kg=None`` means an immovable wall (m* = m1)."""
    if m2_kg is None:
        return m1_kg
    return m1_kg * m2_kg / (m1_kg + m2_kg)


def damping_beta(restitution: float) -> float:
    """LIGGGHTS' beta = ln(e)/sqrt(ln(e)^2 + pi^2) (dimensionless, <= 0).

    Parameters
    ----------
    restitution : float
        Normal coefficient of restitution e, 0 < e <= 1.
    """
    if not 0.0 < restitution <= 1.0:
        raise ValueError(f"restitution must lie in (0, 1], got {restitution!r}")
    log_e = math.log(restitution)
    return log_e / math.sqrt(log_e**2 + math.pi**2)


def normal_damping_gamma(restitution: float, youngs_eff_pa: float, radius_eff_m: float,
                         mass_eff_kg: float, overlap_m: float) -> float:
    """Normal damping coefficient gamma_n in kg/s at the given overlap (>= 0)."""
    sn = 2.0 * youngs_eff_pa * math.sqrt(radius_eff_m * overlap_m)
    return -2.0 * _SQRT_FIVE_SIXTHS * damping_beta(restitution) * math.sqrt(sn * mass_eff_kg)


def sphere_mass(radius_m: float, density_kg_m3: float) -> float:
    """Mass of a sphere in kg."""
    return density_kg_m3 * 4.0 / 3.0 * math.pi * radius_m**3


def sphere_moment_of_inertia(radius_m: float, density_kg_m3: float) -> float:
    """Moment of inertia of a solid sphere about its centre, in kg m^2."""
    return 0.4 * sphere_mass(radius_m, density_kg_m3) * radius_m**2


def rayleigh_time(radius_m: float, density_kg_m3: float, youngs_pa: float, poisson: float) -> float:
    """Rayleigh-wave time of a sphere, in s: the usual upper bound for a DEM timestep.

    ``t_R = pi R sqrt(rho/G) / (0.1631 nu + 0.8766)`` with ``G = E/(2(1 + nu))``.
    """
    shear_pa = youngs_pa / (2.0 * (1.0 + poisson))
    return math.pi * radius_m * math.sqrt(density_kg_m3 / shear_pa) / (0.1631 * poisson + 0.8766)


def hertz_contact_duration(mass_eff_kg: float, radius_eff_m: float, youngs_eff_pa: float,
                           impact_speed_m_s: float) -> float:
    """Duration of an elastic Hertz impact, in s.

    ``t_c = 2.9432 delta_max / v`` with ``delta_max = (15 m* v^2 / (16 E* sqrt(R*)))^{2/5}``
    (Johnson, Contact Mechanics, section 11.4), i.e.
    ``t_c = 2.8682 (m*^2 / (R* E*^2 v))^{1/5}``.
    """
    return 2.868265 * (mass_eff_kg**2 / (radius_eff_m * youngs_eff_pa**2 * impact_speed_m_s)) ** 0.2


def hertz_normal_force(youngs_eff_pa: float, radius_eff_m: float, overlap_m):
    """Elastic part of the Hertz normal force, ``4/3 E* sqrt(R*) delta^{3/2}`` in N (0 for delta <= 0).

    Parameters
    ----------
    youngs_eff_pa : float
        Effective Young's modulus E*, Pa.
    radius_eff_m : float
        Effective radius R*, m.
    overlap_m : float or ndarray
        Overlap delta, m; any shape.

    Returns
    -------
    float or ndarray
        The force, N, shaped as ``overlap_m``. This is LIGGGHTS' ``k_n delta`` (normal_model_hertz.h).
    """
    overlap = np.maximum(np.asarray(overlap_m, dtype=float), 0.0)
    return 4.0 / 3.0 * youngs_eff_pa * np.sqrt(radius_eff_m) * overlap**1.5


def hertz_normal_energy(youngs_eff_pa: float, radius_eff_m: float, overlap_m):
    """Elastic energy of a Hertz contact, ``8/15 E* sqrt(R*) delta^{5/2}`` in J (0 for delta <= 0).

    The integral of :func:`hertz_normal_force` from 0 to delta (the damping part of LIGGGHTS'
    normal force does no conservative work and stores nothing).

    Parameters
    ----------
    youngs_eff_pa : float
        Effective Young's modulus E*, Pa.
    radius_eff_m : float
        Effective radius R*, m.
    overlap_m : float or ndarray
        Overlap delta, m; any shape.

    Returns
    -------
    float or ndarray
        Energy per contact, J, shaped as ``overlap_m``.
    """
    overlap = np.maximum(np.asarray(overlap_m, dtype=float), 0.0)
    return 8.0 / 15.0 * youngs_eff_pa * np.sqrt(radius_eff_m) * overlap**2.5


def tangential_stiffness(shear_eff_pa: float, radius_eff_m: float, overlap_m):
    """Tangential spring stiffness of LIGGGHTS' hertz/history contact, ``8 G* sqrt(R* delta)`` in N/m.

    Parameters
    ----------
    shear_eff_pa : float
        Effective shear modulus G* (:func:`effective_shear_modulus`), Pa.
    radius_eff_m : float
        Effective radius R*, m.
    overlap_m : float or ndarray
        Overlap delta, m; any shape (0 stiffness for delta <= 0).
    """
    overlap = np.maximum(np.asarray(overlap_m, dtype=float), 0.0)
    return 8.0 * shear_eff_pa * np.sqrt(radius_eff_m * overlap)


def tangential_spring_energy(shear_eff_pa: float, radius_eff_m: float, overlap_m, displacement_m):
    """Energy held in the tangential spring, ``1/2 k_t |xi|^2`` in J.

    LIGGGHTS' ``tangential history`` stores the tangential displacement xi (m; the relative
    tangential velocity integrated over the contact's life, kept in the tangent plane and
    shortened so that k_t |xi| never exceeds mu |F_n|) and applies F_t = -k_t xi (plus damping
    while it sticks), with k_t from :func:`tangential_stiffness` at the current overlap. As
    k_t changes with the overlap this spring is not strictly conservative; 1/2 k_t |xi|^2 is the
    energy it would give back if the contact unloaded tangentially at the present overlap.

    Parameters
    ----------
    shear_eff_pa : float
        Effective shear modulus G*, Pa.
    radius_eff_m : float
        Effective radius R*, m.
    overlap_m : float or ndarray, shape (...)
        Overlap delta, m.
    displacement_m : ndarray, shape (..., 3)
        Stored tangential displacement xi, m.

    Returns
    -------
    float or ndarray, shape (...)
        Energy per contact, J.
    """
    displacement = np.asarray(displacement_m, dtype=float)
    stiffness = tangential_stiffness(shear_eff_pa, radius_eff_m, overlap_m)
    return 0.5 * stiffness * np.sum(displacement**2, axis=-1)
