"""The linear single-degree-of-freedom oscillator m x'' + c x' + k x = F_0 cos(Omega t).

Its steady response is x = Re(X e^{i Omega t}) with X = F_0 / (k - m Omega^2 + i c Omega); the
energy a dashpot takes per cycle is pi c Omega |X|^2, and the loss factor, that energy over
2 pi times the peak strain energy 1/2 k |X|^2, is eta = c Omega / k.
"""

from __future__ import annotations

import numpy as np


def complex_amplitude(force_n, mass_kg, stiffness_n_m, damping_ns_m, omega_rad_s) -> np.ndarray:
    """X = F_0 / (k - m Omega^2 + i c Omega), m (complex; broadcast over the inputs).

    Parameters
    ----------
    force_n : float or array_like
        F_0, N.
    mass_kg, stiffness_n_m, damping_ns_m : float or array_like
        m (kg), k (N/m), c (N s/m).
    omega_rad_s : float or array_like
        Forcing frequency Omega, rad/s.
    """
    omega = np.asarray(omega_rad_s, dtype=float)
    return np.asarray(force_n) / (np.asarray(stiffness_n_m) - np.asarray(mass_kg) * omega**2
                                  + 1j * np.asarray(damping_ns_m) * omega)


def loss_factor(damping_ns_m, stiffness_n_m, omega_rad_s) -> np.ndarray:
    """eta = c Omega / k: energy dissipated per cycle over 2 pi x peak strain energy."""
    return np.asarray(damping_ns_m) * np.asarray(omega_rad_s) / np.asarray(stiffness_n_m)


def steady_state(amplitude: complex, omega_rad_s: float) -> tuple[float, float]:
    """Displacement (m) and velocity (m/s) at t = 0 of x = Re(X e^{i Omega t})."""
    return float(np.real(amplitude)), float(np.real(1j * omega_rad_s * amplitude))
