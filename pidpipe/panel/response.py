"""A layout on a mode driven at resonance by a modal force, solved to consistency.

The mode is a single-degree-of-freedom host: the loaded modal mass M, the bare plate's modal
stiffness k = omega_0^2 M_plate, structural damping c_s = 2 zeta sqrt(k M_plate), forced by the
modal force F_0 cos(Omega t) at the loaded mode's frequency Omega = sqrt(k / M). The filled
cells add the dashpot c_p(G) = sum_i C_eq,i(f, G |phi_i|, r_i) phi_i^2 that depends on the
antinode's acceleration G = |q| Omega^2 / g, which the added damping lowers. The steady
amplitude solves |q| = F_0 / |k - M Omega^2 + i Omega (c_s + c_p(|q| Omega^2 / g))|, found as the
host check finds it (:func:`pidpipe.loop.equivalent.solve_point`: sign changes on a log grid,
refined by Brent's method, the largest root where several exist).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from pidpipe.loop.equivalent import solve_mass_point, solve_point
from pidpipe.panel.loss import Layout, ModalLoss
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2


@dataclass(frozen=True)
class ForcedResponse:
    """The consistent steady state of a layout at one modal force.

    Attributes
    ----------
    force_n : float
    freq_hz : float
        The forcing (loaded mode's) frequency, Hz.
    accel_g : float
        Antinode acceleration G with the particles, g.
    bare_accel_g : float
        Antinode acceleration of the plate without particles at its own resonance, g.
    eta_particles : float
        c_p / (Omega M) at the solution.
    eta_total : float
        (c_s + c_p) / (Omega M).
    n_solutions : int
        Consistent amplitudes found (more than one: the response can jump).
    clipped_cells : int
        Filled cells whose G lay above the C_eq model's domain at the solution (clipped to it).
    """

    force_n: float
    freq_hz: float
    accel_g: float
    bare_accel_g: float
    eta_particles: float
    eta_total: float
    n_solutions: int
    clipped_cells: int


def forced_response(loss: ModalLoss, predict: Callable, layout: Layout, force_n: float,
                    damping_ratio: float) -> ForcedResponse:
    """Solve a layout at modal force ``force_n`` (N) to consistency (module docstring)."""
    mode = loss.mode
    stiffness = mode.omega**2 * mode.modal_mass_kg
    structural = 2.0 * damping_ratio * math.sqrt(stiffness * mode.modal_mass_kg)
    mass = loss.modal_mass_kg(layout)
    freq = loss.frequency_hz(layout)
    omega = 2.0 * math.pi * freq

    def model(freq_hz, accel_g):
        accel = np.asarray(accel_g, dtype=float)
        values = loss.damping_ns_m(predict, layout, accel, freq_hz=freq)
        return values.reshape(accel.shape)

    point = solve_point(freq, force_n, mass, stiffness, structural, model)
    bare = force_n / (structural * mode.omega) * mode.omega**2 / STANDARD_GRAVITY_M_S2
    c_p = point.ceq_ns_m
    return ForcedResponse(force_n=force_n, freq_hz=freq, accel_g=point.accel_g, bare_accel_g=bare,
                          eta_particles=c_p / (omega * mass),
                          eta_total=(structural + c_p) / (omega * mass),
                          n_solutions=point.n_solutions,
                          clipped_cells=loss.clipped_cells(layout, point.accel_g))


def response_curve(loss: ModalLoss, predict: Callable, layout: Layout, force_n: float,
                   damping_ratio: float, freqs_hz, mass_follows_accel: bool = False) -> list[dict]:
    """The layout's consistent steady state at modal force ``force_n`` (N) swept over ``freqs_hz``.

    The same single-degree-of-freedom mode as :func:`forced_response` (loaded modal mass M,
    stiffness omega_0^2 M_plate, structural damping c_s), forced at each frequency Omega instead of
    at the loaded mode's; the cells' C_eq is read at Omega. With ``mass_follows_accel`` the
    particles' share of M is read at each amplitude's G too (:meth:`ModalLoss.state_added_mass_kg`,
    solved to consistency in both, :func:`pidpipe.loop.equivalent.solve_mass_point`).

    Returns
    -------
    list of dict
        Per frequency: ``freq_hz``, ``amplitude`` (complex q, m), ``amplitude_m`` (|q|),
        ``accel_g`` (antinode G), ``ceq_ns_m`` (c_p), ``loss_factor`` ((c_s + c_p) Omega / k:
        the energy dissipated per cycle over 2 pi times the peak strain energy, as the host
        check's), ``particle_loss_factor`` (c_p Omega / k), ``modal_mass_kg`` (M),
        ``n_solutions``, ``clipped_cells``.
    """
    mode = loss.mode
    stiffness = mode.omega**2 * mode.modal_mass_kg
    structural = 2.0 * damping_ratio * math.sqrt(stiffness * mode.modal_mass_kg)
    mass = loss.modal_mass_kg(layout)
    rows = []
    for freq in np.asarray(freqs_hz, dtype=float):
        def model(freq_hz, accel_g, freq=float(freq)):
            accel = np.asarray(accel_g, dtype=float)
            return loss.damping_ns_m(predict, layout, accel, freq_hz=freq).reshape(accel.shape)

        if mass_follows_accel:
            def both(freq_hz, accel_g, model=model, freq=float(freq)):
                return loss.state_added_mass_kg(layout, accel_g, freq), model(freq_hz, accel_g)

            point = solve_mass_point(float(freq), force_n, mode.modal_mass_kg, stiffness, structural,
                                     both)
            state_mass = mode.modal_mass_kg + point.added_mass_kg
        else:
            point = solve_point(float(freq), force_n, mass, stiffness, structural, model)
            state_mass = mass
        omega = 2.0 * math.pi * freq
        rows.append({"freq_hz": float(freq), "amplitude": point.amplitude,
                     "amplitude_m": abs(point.amplitude), "accel_g": point.accel_g,
                     "ceq_ns_m": point.ceq_ns_m,
                     "loss_factor": (structural + point.ceq_ns_m) * omega / stiffness,
                     "particle_loss_factor": point.ceq_ns_m * omega / stiffness,
                     "modal_mass_kg": state_mass, "n_solutions": point.n_solutions,
                     "clipped_cells": loss.clipped_cells(layout, point.accel_g)})
    return rows


def design_force_n(loss: ModalLoss, predict: Callable, layout: Layout, damping_ratio: float,
                   accel_g: float) -> float:
    """The modal force (N) that drives the layout, at the loaded mode's frequency, to antinode
    acceleration ``accel_g`` (g): F_0 = (c_s + c_p(G)) Omega |q| at resonance."""
    mode = loss.mode
    stiffness = mode.omega**2 * mode.modal_mass_kg
    structural = 2.0 * damping_ratio * math.sqrt(stiffness * mode.modal_mass_kg)
    freq = loss.frequency_hz(layout)
    omega = 2.0 * math.pi * freq
    c_p = float(loss.damping_ns_m(predict, layout, np.array([accel_g]), freq_hz=freq)[0])
    return (structural + c_p) * omega * accel_g * STANDARD_GRAVITY_M_S2 / omega**2
