"""The equivalent viscous damping of SPEC.md: W = a / omega^2 and C_eq = E_d / (pi omega W^2).

For base motion of acceleration amplitude a = G g at angular frequency omega, the displacement
amplitude is W = a / omega^2, and a viscous damper c dissipates pi c omega W^2 per cycle, so
C_eq = E_d / (pi omega W^2).
"""

from __future__ import annotations

import math

from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2


def displacement_amplitude_m(freq_hz: float, accel_g: float) -> float:
    """Base displacement amplitude W = G g / omega^2, m."""
    omega = 2.0 * math.pi * freq_hz
    return accel_g * STANDARD_GRAVITY_M_S2 / omega**2


def ceq_from_energy(energy_per_cycle_j: float, freq_hz: float, accel_g: float) -> float:
    """Equivalent viscous damping C_eq = E_d / (pi omega W^2), N s/m."""
    omega = 2.0 * math.pi * freq_hz
    amplitude = displacement_amplitude_m(freq_hz, accel_g)
    return energy_per_cycle_j / (math.pi * omega * amplitude**2)
