"""A layout on a mode driven by a modal force, solved to consistency.

The mode is a single-degree-of-freedom host: the loaded modal mass M, the bare plate's modal
stiffness k = omega_0^2 M_plate, structural damping c_s = 2 zeta sqrt(k M_plate), forced by the
modal force F_0 cos(Omega t). The filled cells add the dashpot
c_p(G) = sum_i C_eq,i(f, G |phi_i|, r_i) phi_i^2 that depends on the antinode's acceleration
G = |q| Omega^2 / g, which the added damping lowers. The steady amplitude solves
|q| = F_0 / |k - M Omega^2 + i Omega (c_s + c_p(|q| Omega^2 / g))|; where C_eq falls with G it
has up to three solutions near resonance (the response folds).

:func:`forced_response` solves it at the loaded mode's frequency Omega = sqrt(k / M) as the host
check does (:func:`pidpipe.loop.equivalent.solve_point`: the largest root, their count
reported). :func:`response_curve` sweeps it over frequencies by continuation
(:mod:`pidpipe.panel.branches`): each frequency starts from the amplitude reached at the one
before, up or down in frequency, so the curve is the one a sine sweep of the structure follows,
with its jumps at the folds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from pidpipe.loop.equivalent import (FLOOR_PROBE_DECADES, GRID_DECADES, GRID_POINTS, EquivalentPoint,
                                     solve_point)
from pidpipe.loop.sdof import complex_amplitude
from pidpipe.panel.branches import Amplitudes, consistent_amplitudes, reached_amplitude, sweep_order
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


def branch_point(freq_hz: float, force_n: float, mass_kg: float, stiffness_n_m: float,
                 structural_ns_m: float, model: Callable, start_m: float | None,
                 mass_model: Callable | None = None) -> tuple[EquivalentPoint, Amplitudes]:
    """The consistent steady state reached from amplitude ``start_m`` at one frequency.

    The same equation and log grid of |q| as :func:`pidpipe.loop.equivalent.solve_point`
    (dashpot only: below the bare host's amplitude) and
    :func:`pidpipe.loop.equivalent.solve_mass_point` (with ``mass_model``: below
    F_0 / (Omega (c_s + C_min))), but every consistent amplitude is kept and the one reached from
    ``start_m`` taken (:func:`pidpipe.panel.branches.reached_amplitude`; None: the largest, their
    rule).

    Parameters
    ----------
    freq_hz, force_n : float
        Omega / 2 pi (Hz) and F_0 (N).
    mass_kg : float
        M, kg: the loaded modal mass, or the bare one when ``mass_model`` adds the particles'.
    stiffness_n_m, structural_ns_m : float
        k (N/m) and c_s (N s/m).
    model : callable
        c_p(f_hz, accel_g array) -> N s/m array.
    start_m : float or None
        The amplitude the state starts from, m (0: rest).
    mass_model : callable, optional
        M_a(f_hz, accel_g array) -> kg array, the particles' added modal mass.

    Returns
    -------
    point : pidpipe.loop.equivalent.EquivalentPoint
        The state reached (``n_solutions``: the count of consistent amplitudes).
    amplitudes : pidpipe.panel.branches.Amplitudes
        All of them.
    """
    omega = 2.0 * math.pi * freq_hz
    to_g = omega**2 / STANDARD_GRAVITY_M_S2

    def parts(x_m):
        accel = np.asarray(x_m, dtype=float) * to_g
        added = np.zeros_like(accel) if mass_model is None else np.asarray(mass_model(freq_hz, accel))
        damping = structural_ns_m + np.asarray(model(freq_hz, accel))
        return complex_amplitude(force_n, mass_kg + added, stiffness_n_m, damping, omega), added, damping

    def residual(x_m):
        return np.asarray(x_m, dtype=float) - np.abs(parts(x_m)[0])

    if mass_model is None:
        top = float(np.abs(complex_amplitude(force_n, mass_kg, stiffness_n_m, structural_ns_m, omega)))
        grid = top * np.logspace(-GRID_DECADES, 0, GRID_POINTS)
    else:
        probe = np.logspace(-FLOOR_PROBE_DECADES, FLOOR_PROBE_DECADES, 121)
        floor = structural_ns_m + 0.5 * float(np.min(model(freq_hz, probe)))
        if not floor > 0:
            raise ValueError(f"at {freq_hz:g} Hz the host has no damping and the dashpot vanishes: "
                             "the amplitude has no bound")
        top = force_n / (omega * floor)
        grid = top * np.logspace(-GRID_DECADES - 2, 0, GRID_POINTS * 2)
    amplitudes = consistent_amplitudes(residual, grid)
    x = reached_amplitude(amplitudes, residual, start_m)
    amplitude, added, damping = parts(np.array([x]))
    point = EquivalentPoint(amplitude=complex(amplitude[0]), accel_g=x * to_g,
                            ceq_ns_m=float(damping[0]) - structural_ns_m,
                            n_solutions=amplitudes.count, added_mass_kg=float(added[0]))
    return point, amplitudes


def response_curve(loss: ModalLoss, predict: Callable, layout: Layout, force_n: float,
                   damping_ratio: float, freqs_hz, mass_follows_accel: bool = False,
                   sweep: str = "up") -> list[dict]:
    """The layout's consistent steady state at modal force ``force_n`` (N) swept over ``freqs_hz``.

    The same single-degree-of-freedom mode as :func:`forced_response` (loaded modal mass M,
    stiffness omega_0^2 M_plate, structural damping c_s), forced at each frequency Omega instead of
    at the loaded mode's; the cells' C_eq is read at Omega. With ``mass_follows_accel`` the
    particles' share of M is read at each amplitude's G too (:meth:`ModalLoss.state_added_mass_kg`,
    solved to consistency in both).

    ``sweep`` says which consistent amplitude each frequency takes (:mod:`pidpipe.panel.branches`):
    ``up`` (the default) and ``down`` follow the response by continuation, each frequency starting
    from the amplitude reached at the one before in ascending or descending order (the first from
    rest), as a sine sweep of the structure would; ``largest`` takes the largest at every
    frequency (the rule of :func:`pidpipe.loop.equivalent.solve_point`).

    Returns
    -------
    list of dict
        Per frequency, in ascending order: ``freq_hz``, ``amplitude`` (complex q, m),
        ``amplitude_m`` (|q|), ``accel_g`` (antinode G), ``ceq_ns_m`` (c_p), ``loss_factor``
        ((c_s + c_p) Omega / k: the energy dissipated per cycle over 2 pi times the peak strain
        energy, as the host check's), ``particle_loss_factor`` (c_p Omega / k), ``modal_mass_kg``
        (M), ``n_solutions`` (consistent amplitudes at that frequency), ``n_stable`` (of them
        stable), ``sweep``, ``clipped_cells``.
    """
    mode = loss.mode
    stiffness = mode.omega**2 * mode.modal_mass_kg
    structural = 2.0 * damping_ratio * math.sqrt(stiffness * mode.modal_mass_kg)
    mass = loss.modal_mass_kg(layout)
    freqs = np.asarray(freqs_hz, dtype=float)
    rows: list[dict | None] = [None] * freqs.size
    start = None if sweep == "largest" else 0.0
    for index in sweep_order(freqs, sweep):
        freq = float(freqs[index])

        def model(freq_hz, accel_g, freq=freq):
            accel = np.asarray(accel_g, dtype=float)
            return loss.damping_ns_m(predict, layout, accel, freq_hz=freq).reshape(accel.shape)

        if mass_follows_accel:
            def added(freq_hz, accel_g, freq=freq):
                return loss.state_added_mass_kg(layout, accel_g, freq)

            point, amplitudes = branch_point(freq, force_n, mode.modal_mass_kg, stiffness,
                                             structural, model, start, added)
            state_mass = mode.modal_mass_kg + point.added_mass_kg
        else:
            point, amplitudes = branch_point(freq, force_n, mass, stiffness, structural, model, start)
            state_mass = mass
        if sweep != "largest":
            start = abs(point.amplitude)
        omega = 2.0 * math.pi * freq
        rows[index] = {"freq_hz": freq, "amplitude": point.amplitude,
                       "amplitude_m": abs(point.amplitude), "accel_g": point.accel_g,
                       "ceq_ns_m": point.ceq_ns_m,
                       "loss_factor": (structural + point.ceq_ns_m) * omega / stiffness,
                       "particle_loss_factor": point.ceq_ns_m * omega / stiffness,
                       "modal_mass_kg": state_mass, "n_solutions": point.n_solutions,
                       "n_stable": int(amplitudes.stable.sum()), "sweep": sweep,
                       "clipped_cells": loss.clipped_cells(layout, point.accel_g)}
    return [rows[i] for i in np.argsort(freqs, kind="stable")]


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
