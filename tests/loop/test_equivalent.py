"""The dashpot model of the host (pidpipe.loop.sdof, pidpipe.loop.equivalent) and reading a curve's
peak (pidpipe.loop.compare)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pidpipe.loop.compare import find_peak, peak_with_uncertainty, redraw
from pidpipe.loop.equivalent import solve_point, surrogate_damping
from pidpipe.loop.sdof import complex_amplitude, loss_factor, steady_state
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2

MASS, NATURAL_HZ = 0.025, 275.0
STIFFNESS = MASS * (2 * np.pi * NATURAL_HZ) ** 2
HOST_DAMPING = 2 * 0.01 * np.sqrt(STIFFNESS * MASS)


def _integrated_amplitude(damping: float, freq_hz: float, force_n: float) -> complex:
    """X of the ODE m x'' + c x' + k x = F cos(Omega t) integrated numerically from its
    analytic steady state for 5 periods, read from the last period's first harmonic."""
    omega = 2 * np.pi * freq_hz
    x0, u0 = steady_state(complex_amplitude(force_n, MASS, STIFFNESS, damping, omega), omega)
    period = 1 / freq_hz
    t = np.linspace(4 * period, 5 * period, 2001)[:-1]
    sol = solve_ivp(lambda s, y: [y[1], (force_n * np.cos(omega * s) - damping * y[1]
                                         - STIFFNESS * y[0]) / MASS],
                    (0, 5 * period), [x0, u0], t_eval=t, rtol=1e-11, atol=1e-16, method="DOP853")
    x = sol.y[0]
    return 2 * np.mean(x * np.exp(-1j * omega * t))


@pytest.mark.parametrize("freq_hz", [240.0, 275.0, 310.0])
def test_the_analytic_response_is_the_integrated_one(freq_hz):
    damping = HOST_DAMPING + 0.8
    analytic = complex_amplitude(0.03, MASS, STIFFNESS, damping, 2 * np.pi * freq_hz)
    assert abs(_integrated_amplitude(damping, freq_hz, 0.03) / analytic - 1) < 1e-6


def test_a_constant_dashpot_gives_the_analytic_response_and_loss_factor():
    point = solve_point(260.0, 0.03, MASS, STIFFNESS, HOST_DAMPING,
                        lambda f, g: np.full_like(np.asarray(g, dtype=float), 0.8))
    omega = 2 * np.pi * 260.0
    expected = complex_amplitude(0.03, MASS, STIFFNESS, HOST_DAMPING + 0.8, omega)
    assert abs(point.amplitude / expected - 1) < 1e-9 and point.n_solutions == 1
    assert point.accel_g == pytest.approx(abs(expected) * omega**2 / STANDARD_GRAVITY_M_S2, rel=1e-9)
    assert loss_factor(HOST_DAMPING + 0.8, STIFFNESS, omega) == pytest.approx(
        np.pi * (HOST_DAMPING + 0.8) * omega * abs(expected)**2
        / (2 * np.pi * 0.5 * STIFFNESS * abs(expected)**2))


def test_a_level_dependent_dashpot_is_solved_to_consistency():
    """C_eq(Gamma) = 0.2 Gamma: the solution's C_eq is that of its own Gamma, and its amplitude
    the analytic response of that dashpot, integrated."""
    model = lambda f, g: 0.2 * np.asarray(g, dtype=float)           # noqa: E731
    point = solve_point(275.0, 0.05, MASS, STIFFNESS, HOST_DAMPING, model)
    assert point.ceq_ns_m == pytest.approx(0.2 * point.accel_g, rel=1e-9)
    integrated = _integrated_amplitude(HOST_DAMPING + point.ceq_ns_m, 275.0, 0.05)
    assert abs(point.amplitude / integrated - 1) < 1e-6


def test_the_surrogate_is_read_inside_its_domain_only_and_clipping_is_flagged():
    calls = []

    def predict(f, g, r):
        calls.append((np.asarray(f).copy(), np.asarray(g).copy(), np.asarray(r).copy()))
        return 441.0 * np.asarray(g)

    model, clipped = surrogate_damping(predict, {"freq_hz": (200, 350), "accel_g": (1, 10)},
                                       50.0, 21 / 441)
    assert model(400.0, np.array([0.5, 5.0, 20.0])) == pytest.approx([21.0, 105.0, 210.0])
    f, g, r = calls[-1]
    assert f.tolist() == [350.0] * 3 and g.tolist() == [1.0, 5.0, 10.0] and r.tolist() == [50.0] * 3
    assert clipped(275.0, 0.5) and clipped(400.0, 5.0) and not clipped(275.0, 5.0)


def test_the_peak_of_a_resonance_curve_and_its_uncertainty():
    freqs = np.linspace(240.0, 310.0, 15)
    damping = HOST_DAMPING + 0.5
    curve = np.abs(complex_amplitude(0.03, MASS, STIFFNESS, damping, 2 * np.pi * freqs))
    eta = loss_factor(damping, STIFFNESS, 2 * np.pi * freqs)
    peak = find_peak(freqs, curve, eta)
    true_peak = NATURAL_HZ * np.sqrt(1 - 2 * (damping / (2 * np.sqrt(STIFFNESS * MASS)))**2)
    assert not peak.at_edge
    assert abs(peak.freq_hz - true_peak) < 0.1 * (freqs[1] - freqs[0])
    assert peak.amplitude_m == pytest.approx(curve.max(), rel=0.05)
    assert peak.loss_factor == pytest.approx(damping * 2 * np.pi * peak.freq_hz / STIFFNESS, rel=1e-3)
    sems = 0.01 * curve
    out = peak_with_uncertainty(freqs, curve, eta, redraw(curve, sems, 300, 1),
                                redraw(eta, 0 * eta, 300, 2))
    assert 0.3 * 0.01 * peak.amplitude_m < out["peak_amplitude_m_sd"] < 3 * 0.01 * peak.amplitude_m
    edge = find_peak(freqs[:4], curve[:4], eta[:4])
    assert edge.at_edge and edge.freq_hz == freqs[3]
