"""The DEM check of a mode (pidpipe.panel.check): groups along the mode shape, and the coupled
mode on the real compiled DEM against the panel model where the answer is known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.panel.check import check_fill, check_mode, layout_groups
from pidpipe.panel.cells import cell_centres
from pidpipe.panel.layout import antinode_layout
from pidpipe.panel.loss import ModalLoss
from pidpipe.panel.plate import navier_mode
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2, sphere_mass
from tests.dem.conftest import DATA
from tests.panel.test_layout import DOMAIN, mode_loss
from tests.panel.test_plate import TABLE_2

ZETA = 0.02


def test_groups_keep_the_layouts_sum_of_phi_squared():
    phi = np.random.default_rng(3).uniform(-1.0, 1.0, 101)
    groups = layout_groups(phi, 4)
    assert groups.cells.tolist() == [26, 25, 25, 25]
    assert np.sum(groups.cells * groups.weights**2) == pytest.approx(np.sum(phi**2), rel=1e-12)
    assert np.all(np.diff(groups.weights) < 0)
    assert np.all((groups.phi_min <= groups.weights) & (groups.weights <= groups.phi_max))


def test_the_dem_fill_is_the_commonest_count_clipped_to_the_model():
    loss, _ = mode_loss()
    layout = antinode_layout(loss.phi, 10, 90.0)
    spheres = lambda r: round(21 * r / 100)                 # noqa: E731  (poured capacity 21)
    assert check_fill(layout, spheres, 21, DOMAIN) == (19, 90.0)    # 19/21 = 90.5 % -> 90 %


def zero_below_1g(f, g, r):
    """A coupon C_eq that is 0 below 1 g (the spheres rest) and small above."""
    return np.where(np.asarray(g) < 1.0, 0.0, 1e-3) * np.ones_like(np.asarray(f, dtype=float))


def default_plate_mode() -> ModalLoss:
    """Mode (1, 1) of the default 1.05 m x 0.65 m panel (271 Hz), acrylic spheres."""
    mode = navier_mode(TABLE_2, 1.05, 0.65, 1, 1)
    centres = cell_centres(1.05, 0.65, 4.76e-3)
    return ModalLoss(mode, mode.shape(centres[:, 0], centres[:, 1]), 441, 21,
                     sphere_mass(1.25e-3, 1180.0), DOMAIN)


@pytest.fixture(scope="module")
def resting():
    """2000 antinode cells of 11 spheres in two groups of one DEM cell each, at a modal force
    that keeps every bed below 1 g: the beds add their whole mass (half the plate's modal mass
    at phi^2 ~ 0.9), so the loaded peak lies 19 % below the bare mode."""
    loss = default_plate_mode()
    layout = antinode_layout(loss.phi, 2000, 100 * 11 / 21)         # 11 spheres a cell
    groups = layout_groups(loss.phi[layout.cells], 2)
    packing = np.loadtxt(DATA / "settled_11.csv", delimiter=",")
    full = loss.frequency_hz(layout)
    freqs = full * np.linspace(0.985, 1.015, 7)
    omega = 2 * math.pi * full
    structural = 2 * ZETA * math.sqrt(loss.mode.stiffness_n_m * loss.mode.modal_mass_kg)
    force = 0.5 * STANDARD_GRAVITY_M_S2 / omega**2 * structural * omega      # 0.5 g at the peak
    check = check_mode(CellScene.from_config(load_config()), loss, loss, zero_below_1g, layout,
                       groups, 1, np.stack([packing, packing[::-1]]), 100 * 11 / 21, force, ZETA,
                       freqs, transient_cycles=8, measured_cycles=8, sweeps=("up",))
    return loss, layout, check


def test_resting_beds_on_the_coupled_mode_add_their_whole_mass_and_no_damping(resting):
    """The beds at 0.5 g ride on their floors: the coupled peak is the fully loaded mode's, its
    loss factor the structural one (2 zeta f / f_0 in the host check's definition, per the bare
    stiffness), but for the beds' small contact damping (measured: 4 % of it); their measured
    mass is the projected sum n_g phi_g^2 m_bed (measured 1 % above it: the bed's compliance)."""
    loss, layout, check = resting
    summary = check.summary.set_index("model")
    coupled, panel = summary.loc["coupled"], summary.loc["panel_full_mass"]
    assert coupled.peak_accel_g < 0.7
    assert panel.peak_freq_hz < 0.85 * loss.mode.freq_hz          # the bare mode: 19 % higher
    assert abs(coupled.peak_freq_hz / panel.peak_freq_hz - 1) < 3e-3
    assert abs(coupled.peak_amplitude_m / panel.peak_amplitude_m - 1) < 0.05
    structural = 2 * ZETA * coupled.peak_freq_hz / loss.mode.freq_hz
    assert coupled.peak_loss_factor == pytest.approx(structural, rel=0.06)
    assert coupled.peak_particle_loss_factor < 0.06 * coupled.peak_loss_factor
    curves = check.curves[check.curves.model == "coupled"]
    assert curves.steady.all() and (curves.balance_residual_fraction < 0.01).all()
    projected = np.sum(loss.cell_effective_mass_kg(layout.fill_pct) * loss.phi[layout.cells] ** 2)
    assert np.allclose(curves.m_eff_kg, projected, rtol=0.02)
    # the whole beds' mass unprojected would be 10 % more
    assert np.all(curves.m_eff_kg < 0.95 * np.sum(loss.cell_effective_mass_kg(layout.fill_pct)))


def test_the_coupled_sweep_starts_from_rest_and_continues_from_the_previous_frequency(resting):
    """Up sweep: the first frequency from q = 0, every other one from the last cycle's amplitude
    of the one below. With 8 + 8 cycles at zeta 0.02 the host still rings up from rest (the
    transient decays by 0.88 a cycle), so the last cycle lies within 11 % of the measured mean."""
    _, _, check = resting
    coupled = check.curves[check.curves.model == "coupled"].sort_values("freq_hz")
    assert (coupled.sweep == "up").all() and check.meta["reported_sweep"] == "up"
    starts, amplitudes = coupled.start_amplitude_m.to_numpy(), coupled.amplitude_m.to_numpy()
    assert starts[0] == 0.0
    assert np.allclose(starts[1:], amplitudes[:-1], rtol=0.15)
