"""A layout at a modal force, solved to consistency; intervals from a model's own std."""

import math

import numpy as np
import pytest

from pidpipe.panel.layout import antinode_layout
from pidpipe.panel.response import forced_response
from pidpipe.panel.uncertainty import UncertainCeq, interval
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2
from tests.panel.test_layout import DOMAIN, mode_loss


def test_a_constant_ceq_gives_the_closed_form_resonant_amplitude():
    loss, _ = mode_loss()
    layout = antinode_layout(loss.phi, 200, 50.0)
    c = 30.0                                    # coupon C_eq, N s/m, at every G

    def model(f, g, r):
        return np.full(np.broadcast(f, g, r).shape, c)

    force, zeta = 0.2, 0.01
    response = forced_response(loss, model, layout, force, zeta)
    mode = loss.mode
    k = mode.omega**2 * mode.modal_mass_kg
    c_s = 2 * zeta * math.sqrt(k * mode.modal_mass_kg)
    a2 = np.sum(loss.phi[layout.cells] ** 2)
    c_p = c / 441 * a2                          # every cell is above the 1 g floor here
    omega = 2 * math.pi * loss.frequency_hz(layout)
    expected_g = force / (omega * (c_s + c_p)) * omega**2 / STANDARD_GRAVITY_M_S2
    assert response.accel_g > 1.0 / np.abs(loss.phi[layout.cells]).min()
    assert response.accel_g == pytest.approx(expected_g, rel=1e-6)
    assert response.eta_particles == pytest.approx(c_p / (omega * loss.modal_mass_kg(layout)), rel=1e-9)
    assert response.bare_accel_g > response.accel_g


def test_added_damping_that_grows_with_g_lowers_the_response_below_the_bare_plate():
    loss, _ = mode_loss()
    layout = antinode_layout(loss.phi, 400, 50.0)

    def model(f, g, r):
        return 5.0 * np.asarray(g) * np.ones_like(np.asarray(f))

    low, high = (forced_response(loss, model, layout, f, 0.01) for f in (0.05, 0.5))
    assert low.accel_g < low.bare_accel_g and high.accel_g < high.bare_accel_g
    assert high.eta_particles > low.eta_particles            # more G, more C_eq per cell
    assert high.n_solutions == 1


def test_a_models_own_std_gives_an_interval_around_the_mean():
    loss, _ = mode_loss()
    layout = antinode_layout(loss.phi, 300, 50.0)

    def mean(f, g, r):
        return 2.0 * np.asarray(g) * np.ones_like(np.asarray(f))

    def with_std(f, g, r):
        m = mean(f, g, r)
        return m, 0.1 * m

    model = UncertainCeq(predict=mean, domain=DOMAIN, predict_with_uncertainty=with_std)
    assert model.kind == "predictive_std"
    value = lambda predict: float(loss.loss_factor(predict, layout, [5.0])[0])
    lo, hi = interval(model, value, 0.95)
    centre = value(mean)
    assert lo < centre < hi
    # eta is linear in C_eq: the ends are (1 -/+ 1.96 x 0.1) times the mean's
    assert lo == pytest.approx(centre * (1 - 0.196), rel=1e-3)
    assert hi == pytest.approx(centre * (1 + 0.196), rel=1e-3)
