"""The particles' effective mass in the modal mass: from the m_eff surrogate, refused when stale,
and the bed's mass (said in one line) when there is none."""

import logging
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pidpipe.cli import main
from pidpipe.design.ceq_table import read_ceq_table
from pidpipe.design.surrogate import fit_surrogate, save_surrogate
from pidpipe.errors import TableError
from pidpipe.panel.layout import antinode_layout
from pidpipe.panel.loss import ModalLoss
from pidpipe.panel.mass import SurrogateEffectiveMass, check_m_eff_surrogate
from pidpipe.panel.response import response_curve
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2, sphere_mass
from pidpipe.steps.panel import panel_m_eff_surrogate
from tests.design.test_optimise_command import write_config, write_table
from tests.panel.test_layout import DOMAIN, N_COUPON, SPHERE_KG, mode_loss

DEM_TABLE = Path(__file__).parents[1] / "fixtures" / "ceq_table_dem_default_100.csv"


def fit_m_eff(table, source="table"):
    return fit_surrogate(table, method="gp", target="linear", source=source,
                         value_column="m_eff_cell_kg", sem_column="m_eff_cell_sem_kg")


class Airborne:
    """m_eff of a bed that lifts off above 1 g: the whole bed (21 r / 100 spheres) at 1 g, none
    from 3 g on, linear between."""

    domain = DOMAIN

    def predict(self, f, g, r):
        share = np.clip((3.0 - np.asarray(g)) / 2.0, 0.0, 1.0)
        return share * 21 * np.asarray(r) / 100.0 * SPHERE_KG * np.ones_like(np.asarray(f))


def loss_with(mass):
    loss, _ = mode_loss()
    return ModalLoss(loss.mode, loss.phi, N_COUPON, 21, SPHERE_KG, DOMAIN, effective_mass_kg=mass)


def test_an_airborne_bed_adds_less_modal_mass_than_its_whole_mass_and_a_resting_one_all_of_it():
    full, _ = mode_loss()
    layout = antinode_layout(full.phi, 500, 50.0)
    bed = full.modal_mass_kg(layout) - full.mode.modal_mass_kg
    # at 5 g the antinode cells fly (m_eff 0); the 500 cells reach down to |phi| ~ 0.75, 3.7 g
    flying = loss_with(SurrogateEffectiveMass(Airborne(), full.mode.freq_hz, 5.0, SPHERE_KG))
    assert flying.modal_mass_kg(layout) == pytest.approx(full.mode.modal_mass_kg, rel=1e-12)
    assert flying.frequency_hz(layout) > full.frequency_hz(layout)
    # at 2 g the cells' G lies between 1.5 and 2 g: part of the bed's mass, more where |phi| is small
    half = loss_with(SurrogateEffectiveMass(Airborne(), full.mode.freq_hz, 2.0, SPHERE_KG))
    added = half.modal_mass_kg(layout) - full.mode.modal_mass_kg
    assert 0.25 * bed < added < 0.75 * bed
    # below the surrogate's lowest G (1 g) every bed rests: the whole mass, as without m_eff
    resting = loss_with(SurrogateEffectiveMass(Airborne(), full.mode.freq_hz, 0.5, SPHERE_KG))
    assert resting.modal_mass_kg(layout) == pytest.approx(full.modal_mass_kg(layout), rel=1e-12)


def test_the_dem_tables_m_eff_lowers_the_loaded_modal_mass_at_5_g():
    table = read_ceq_table(DEM_TABLE)
    m_eff = fit_m_eff(table)
    full, _ = mode_loss()
    layout = antinode_layout(full.phi, 800, 50.0)
    measured = loss_with(SurrogateEffectiveMass(m_eff, full.mode.freq_hz, 5.5, SPHERE_KG))
    bed = full.modal_mass_kg(layout) - full.mode.modal_mass_kg
    added = measured.modal_mass_kg(layout) - full.mode.modal_mass_kg
    # at 5 g a 50 % bed is mostly airborne: m_eff ~ 0.1 of its mass (tests/fixtures' table)
    assert 0.0 < added < 0.5 * bed
    assert measured.frequency_hz(layout) > full.frequency_hz(layout)


def test_an_m_eff_surrogate_of_another_table_is_refused_as_stale(tmp_path):
    table = read_ceq_table(DEM_TABLE)
    ceq = fit_surrogate(table, method="gp", source="table")
    check_m_eff_surrogate(fit_m_eff(table), ceq, "same.json")            # same table: accepted
    other = table.assign(ceq_coupon_ns_m=1.1 * table["ceq_coupon_ns_m"])
    path = tmp_path / "surrogate_m_eff.json"
    save_surrogate(fit_m_eff(other), path)
    with pytest.raises(TableError, match=r"surrogate_m_eff.json is stale: .*their C_eq differ"):
        panel_m_eff_surrogate(path, ceq)


def test_a_missing_m_eff_surrogate_falls_back_to_the_beds_mass_in_one_line(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="pidpipe.campaign"):
        assert panel_m_eff_surrogate(tmp_path / "surrogate_m_eff.json", object()) is None
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and "no m_eff surrogate" in lines[0] and "bed's mass" in lines[0]


def test_the_panel_command_uses_the_tables_m_eff_and_says_so(tmp_path, capsys):
    table_path = write_table(tmp_path / "table.csv")
    table = pd.read_csv(table_path)
    bed = 21 * table.fill_pct / 100.0 * SPHERE_KG
    table["m_eff_cell_kg"] = bed * np.clip((3.0 - table.accel_g) / 2.0, 0.0, 1.0)
    table["m_eff_cell_sem_kg"] = 0.02 * bed
    table.to_csv(table_path, index=False)
    config = write_config(tmp_path / "config.yaml",
                          environments=[{"name": "250-300 Hz, 5-6 g", "freq_hz": [250, 300],
                                         "accel_g": [5, 6]}],
                          panel={"regions": 3, "starts": 0, "surrogate_draws": 0,
                                 "modal_force_n": [0.3]},
                          optimisation={"starts": 2})
    out = tmp_path / "panel"
    assert main(["panel", "--table", str(table_path), "--config", str(config),
                 "--output-dir", str(out)]) == 0
    captured = capsys.readouterr()
    assert "modal mass with the table's m_eff" in captured.err
    assert "modal mass: m_eff surrogate at 270.6 Hz and G 5.5 g" in captured.out
    designs = pd.read_csv(out / "designs.csv")
    assert designs["modal_mass_source"].str.startswith("m_eff surrogate").all()
    # the cells at 5.5 g |phi| above 3 g fly: the loaded mode is lighter than with the whole bed
    plate = pd.read_csv(out / "modes.csv").set_index(["mode_m", "mode_n"]).loc[(1, 1), "modal_mass_kg"]
    cells = pd.read_csv(out / "layout.csv")
    one = sphere_mass(1.25e-3, 1180.0)
    for (kind, name), rows in cells.groupby(["design", "layout"]):
        whole = float((rows.spheres * one * rows.phi**2).sum())
        row = designs[(designs.design == kind) & (designs.layout == name)].iloc[0]
        # (the GP through 1 g: whole, 5 g: none may undershoot zero a little in between)
        assert -0.1 * whole < row.modal_mass_kg - plate < 0.5 * whole
    assert main(["panel", "--table", str(table_path), "--config", str(config), "--output-dir",
                 str(out), "--m-eff-surrogate", str(tmp_path / "none.json")]) != 0


def test_a_mass_that_follows_the_response_rides_at_low_force_and_flies_at_high():
    """With the mass read at each amplitude's G, the swept mode peaks at the fully loaded
    frequency when the beds stay below 1 g and at the bare one when they fly above 3 g, whatever
    the G the stage reads it at (here 5 g: all flying)."""
    full, _ = mode_loss()
    layout = antinode_layout(full.phi, 500, 50.0)
    stage = loss_with(SurrogateEffectiveMass(Airborne(), full.mode.freq_hz, 5.0, SPHERE_KG))

    def small(f, g, r):                      # a dashpot only above 1 g, 1 % of the structure's
        return np.where(np.asarray(g) < 1.0, 0.0, 0.05) * np.ones_like(np.asarray(f, dtype=float))

    loaded, bare = full.frequency_hz(layout), full.mode.freq_hz
    freqs = np.linspace(0.97 * loaded, 1.03 * bare, 241)
    zeta = 0.01
    omega = 2 * np.pi * loaded
    structural = 2 * zeta * np.sqrt(full.mode.stiffness_n_m * full.mode.modal_mass_kg)
    for accel, expected in ((0.5, loaded), (8.0, bare)):
        force = accel * STANDARD_GRAVITY_M_S2 / omega * structural
        rows = response_curve(stage, small, layout, force, zeta, freqs, mass_follows_accel=True)
        peak = max(rows, key=lambda row: row["amplitude_m"])
        assert peak["freq_hz"] == pytest.approx(expected, rel=2e-3)
        fixed = max(response_curve(stage, small, layout, force, zeta, freqs),
                    key=lambda row: row["amplitude_m"])
        assert fixed["freq_hz"] == pytest.approx(bare, rel=2e-3)     # the stage's mass: none
    assert loaded < 0.95 * bare
