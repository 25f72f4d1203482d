"""A simply supported sandwich plate with the core's transverse shear: Navier modes of first-order shear deformation.

The sandwich (thin faces, antiplane core; Allen 1969, Zenkert 1995) as an equivalent first-order
shear deformation (Mindlin) plate, x along the core's ribbon (L) and y along W:

- bending stiffness  D = E_f t_f d^2 / (2 (1 - nu_f^2)),  d = c + t_f  (face centroid distance,
  c the core's height; the faces' own bending E_f t_f^3 / (6 (1 - nu_f^2)) is added, 3e-5 of D
  for the source's panel);
- transverse shear stiffnesses  S_x = G_xz d^2 / c,  S_y = G_yz d^2 / c  (no shear correction
  factor: the antiplane core carries a uniform shear stress);
- mass per area  rho_A = 2 rho_f t_f + rho_c c;  rotary inertia  I = rho_f t_f d^2 / 2 + rho_c c^3 / 12.

For simply supported edges (w = 0, M_n = 0, tangential rotation 0) the modes separate:
w = W sin(alpha x) sin(beta y), phi_x = X cos(alpha x) sin(beta y), phi_y = Y sin(alpha x) cos(beta y)
with alpha = m pi / a, beta = n pi / b, and (W, X, Y) solve the 3 x 3 generalised eigenproblem
K v = omega^2 M v (:func:`navier_matrices`). The lowest of its three roots is the flexural mode
the panel vibrates in; the other two are thickness-shear modes (tens of kHz for the source's panel).

Limits: S -> infinity (and I = 0) gives Kirchhoff's omega^2 = D (alpha^2 + beta^2)^2 / rho_A;
D -> infinity gives the pure shear plate omega^2 = (S_x alpha^2 + S_y beta^2) / rho_A; for an
isotropic core without rotary inertia 1/omega^2 = 1/omega_b^2 + 1/omega_s^2 exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh


@dataclass(frozen=True)
class Sandwich:
    """The sandwich's section (SI): two equal faces and a honeycomb core.

    Attributes
    ----------
    face_thickness_m, face_density_kg_m3, face_youngs_modulus_pa, face_poisson_ratio : float
    core_height_m, core_density_kg_m3 : float
    core_shear_modulus_xz_pa, core_shear_modulus_yz_pa : float
        G_xz (along the ribbon L) and G_yz (along W), N/m^2.
    rotary_inertia : bool
        Keep the rotary inertia I (False: I = 0, the classical sandwich formula).
    """

    face_thickness_m: float
    face_density_kg_m3: float
    face_youngs_modulus_pa: float
    face_poisson_ratio: float
    core_height_m: float
    core_density_kg_m3: float
    core_shear_modulus_xz_pa: float
    core_shear_modulus_yz_pa: float
    rotary_inertia: bool = True

    @property
    def poisson_ratio(self) -> float:
        """nu of the bending stiffness: the faces'."""
        return self.face_poisson_ratio

    @property
    def face_distance_m(self) -> float:
        """d = c + t_f, m."""
        return self.core_height_m + self.face_thickness_m

    @property
    def bending_stiffness_nm(self) -> float:
        """D, N*m (faces about the mid-plane, plus their own bending)."""
        t, d, nu = self.face_thickness_m, self.face_distance_m, self.face_poisson_ratio
        return self.face_youngs_modulus_pa * (t * d**2 / 2.0 + t**3 / 6.0) / (1.0 - nu**2)

    @property
    def shear_stiffness_n_m(self) -> tuple[float, float]:
        """(S_x, S_y) = G d^2 / c, N/m."""
        factor = self.face_distance_m**2 / self.core_height_m
        return self.core_shear_modulus_xz_pa * factor, self.core_shear_modulus_yz_pa * factor

    @property
    def mass_per_area_kg_m2(self) -> float:
        """rho_A, kg/m^2."""
        return 2.0 * self.face_density_kg_m3 * self.face_thickness_m + self.core_density_kg_m3 * self.core_height_m

    @property
    def rotary_inertia_kg(self) -> float:
        """I per unit area, kg (kg*m^2/m^2); 0 when ``rotary_inertia`` is False."""
        if not self.rotary_inertia:
            return 0.0
        t, d, c = self.face_thickness_m, self.face_distance_m, self.core_height_m
        return self.face_density_kg_m3 * t * d**2 / 2.0 + self.core_density_kg_m3 * c**3 / 12.0


@dataclass(frozen=True)
class HomogeneousPlate:
    """A homogeneous isotropic Mindlin plate of thickness h (SI), the same interface as
    :class:`Sandwich`: D = E h^3 / (12 (1 - nu^2)), S = kappa G h, rho_A = rho h, I = rho h^3 / 12.

    It lets the Navier solver be checked on published thick-plate benchmarks.
    """

    thickness_m: float
    density_kg_m3: float
    youngs_modulus_pa: float
    poisson_ratio: float
    shear_correction: float = 5.0 / 6.0
    rotary_inertia: bool = True

    @property
    def bending_stiffness_nm(self) -> float:
        return self.youngs_modulus_pa * self.thickness_m**3 / (12.0 * (1.0 - self.poisson_ratio**2))

    @property
    def shear_stiffness_n_m(self) -> tuple[float, float]:
        shear = self.shear_correction * self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio)) * self.thickness_m
        return shear, shear

    @property
    def mass_per_area_kg_m2(self) -> float:
        return self.density_kg_m3 * self.thickness_m

    @property
    def rotary_inertia_kg(self) -> float:
        return self.density_kg_m3 * self.thickness_m**3 / 12.0 if self.rotary_inertia else 0.0


@dataclass(frozen=True)
class Mode:
    """One flexural mode (m, n) of the plate, with the shape normalised to w = 1 at the antinode.

    Attributes
    ----------
    m, n : int
        Half-waves along x (length a) and y (width b).
    freq_hz : float
        Natural frequency of the bare plate, Hz.
    amplitudes : tuple of float
        (W, X, Y) = (1, X, Y): w, phi_x (rad/m of W) and phi_y amplitudes.
    modal_mass_kg : float
        Generalised mass of the bare plate, int (rho_A w^2 + I phi_x^2 + I phi_y^2) dA, kg.
    length_m, width_m : float
        a and b, m.
    """

    m: int
    n: int
    freq_hz: float
    amplitudes: tuple[float, float, float]
    modal_mass_kg: float
    length_m: float
    width_m: float

    @property
    def omega(self) -> float:
        """2 pi f, rad/s."""
        return 2.0 * math.pi * self.freq_hz

    @property
    def stiffness_n_m(self) -> float:
        """Generalised stiffness omega^2 M, N/m."""
        return self.omega**2 * self.modal_mass_kg

    def shape(self, x_m, y_m) -> np.ndarray:
        """w at (x, y), m per m of antinode deflection: sin(m pi x / a) sin(n pi y / b), shape of x."""
        x, y = np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float)
        return np.sin(self.m * np.pi * x / self.length_m) * np.sin(self.n * np.pi * y / self.width_m)

    def rotations(self, x_m, y_m) -> tuple[np.ndarray, np.ndarray]:
        """(phi_x, phi_y) at (x, y), rad per m of antinode deflection."""
        x, y = np.asarray(x_m, dtype=float), np.asarray(y_m, dtype=float)
        ax, by = self.m * np.pi * x / self.length_m, self.n * np.pi * y / self.width_m
        return (self.amplitudes[1] * np.cos(ax) * np.sin(by),
                self.amplitudes[2] * np.sin(ax) * np.cos(by))


def navier_matrices(sandwich: Sandwich, alpha: float, beta: float) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness K and mass M (3 x 3) of the Navier term (alpha, beta) in (W, X, Y).

    Per unit of (a b / 4), K in N/m^3 (rows: transverse, x- and y-moment equilibrium), M in kg/m^2.
    """
    d = sandwich.bending_stiffness_nm
    sx, sy = sandwich.shear_stiffness_n_m
    nu = sandwich.poisson_ratio
    k = np.array([
        [sx * alpha**2 + sy * beta**2, sx * alpha, sy * beta],
        [sx * alpha, d * alpha**2 + 0.5 * d * (1 - nu) * beta**2 + sx, 0.5 * d * (1 + nu) * alpha * beta],
        [sy * beta, 0.5 * d * (1 + nu) * alpha * beta, 0.5 * d * (1 - nu) * alpha**2 + d * beta**2 + sy],
    ])
    inertia = sandwich.rotary_inertia_kg
    mass = np.diag([sandwich.mass_per_area_kg_m2, inertia, inertia])
    return k, mass


def navier_mode(sandwich: Sandwich, length_m: float, width_m: float, m: int, n: int) -> Mode:
    """The flexural mode (m, n) of the simply supported plate (the lowest root of the 3 x 3 problem)."""
    alpha, beta = m * math.pi / length_m, n * math.pi / width_m
    k, mass = navier_matrices(sandwich, alpha, beta)
    if sandwich.rotary_inertia_kg > 0.0:
        values, vectors = eigh(k, mass)
        omega2, vector = float(values[0]), vectors[:, 0]
        amplitudes = vector / vector[0]
    else:
        # no rotary inertia: the rotations follow w statically (condense them out)
        rot = np.linalg.solve(k[1:, 1:], -k[1:, 0])
        omega2 = float((k[0, 0] + k[0, 1:] @ rot) / mass[0, 0])
        amplitudes = np.concatenate([[1.0], rot])
    area = length_m * width_m / 4.0
    modal_mass = area * float(amplitudes @ mass @ amplitudes)
    return Mode(m=m, n=n, freq_hz=math.sqrt(omega2) / (2.0 * math.pi),
                amplitudes=tuple(float(v) for v in amplitudes), modal_mass_kg=modal_mass,
                length_m=length_m, width_m=width_m)


def plate_modes(sandwich: Sandwich, length_m: float, width_m: float, max_freq_hz: float,
                max_order: int = 40) -> list[Mode]:
    """Every flexural mode below ``max_freq_hz`` (Hz), in rising frequency.

    ``max_order`` bounds m and n; a mode of order max_order below the limit raises ValueError
    (the list would be incomplete).
    """
    modes = []
    for m in range(1, max_order + 1):
        for n in range(1, max_order + 1):
            mode = navier_mode(sandwich, length_m, width_m, m, n)
            if mode.freq_hz > max_freq_hz:
                break          # frequency rises with n
            if m == max_order or n == max_order:
                raise ValueError(f"modes of order {max_order} lie below {max_freq_hz:g} Hz; "
                                 "raise max_order")
            modes.append(mode)
    return sorted(modes, key=lambda mode: mode.freq_hz)
