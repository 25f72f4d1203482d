"""The DEM check's step (rule check_panel_mode): settings refused in one line each, and a tiny
check end to end (a compiled-DEM pour, three frequencies) on a layout.csv of the antinode."""

import copy
import json
import logging

import numpy as np
import pandas as pd
import pytest
import yaml

from pidpipe.config import DEFAULT_CONFIG_PATH, validate_config
from pidpipe.config.panel import PanelCheckSettings, PanelSettings, panel_check_params
from pidpipe.design.ceq_table import read_ceq_table
from pidpipe.design.surrogate import fit_surrogate, save_surrogate
from pidpipe.errors import ConfigError
from pidpipe.panel.cells import cell_centres
from pidpipe.panel.plate import navier_mode
from pidpipe.panel.study import sandwich_of
from pidpipe.steps.panel import check_panel_mode
from tests.design.test_optimise_command import write_table


def raw():
    return yaml.safe_load(DEFAULT_CONFIG_PATH.read_text())


@pytest.mark.parametrize("change, fragment", [
    ({"design": "best"}, "panel.check.design"),
    ({"groups": 0}, "panel.check.groups"),
    ({"force_n": -1.0}, "panel.check.force_n"),
    ({"environment": 7}, "panel.check.environment = 7 is not allowed: there are 3 environments"),
    ({"measured_cycles": 3, "sem_block_cycles": 2}, "two blocks of sem_block_cycles"),
])
def test_bad_check_settings_get_one_clear_line(change, fragment):
    config = raw()
    config["panel"]["check"] = change
    with pytest.raises(ConfigError) as caught:
        PanelCheckSettings.from_config(validate_config(config))
    assert fragment in str(caught.value) and "\n" not in str(caught.value)


def test_a_tiny_check_runs_end_to_end_and_the_flying_beds_dissipate(tmp_path, caplog):
    config = raw()
    config["fidelity"]["pour_engine"] = "dem"
    config["panel"]["check"] = {"groups": 2, "cells_per_group": 1, "freq_points": 3,
                                "transient_cycles": 4, "measured_cycles": 4, "force_n": 1.0}
    config = validate_config(copy.deepcopy(config))
    settings = PanelSettings.from_config(config)
    mode = navier_mode(sandwich_of(settings), settings.length_m, settings.width_m, 1, 1)
    centres = cell_centres(settings.length_m, settings.width_m, settings.cell_inscribed_diameter_m)
    phi = mode.shape(centres[:, 0], centres[:, 1])
    cells = np.argsort(-phi)[:600]
    pd.DataFrame({"environment": "250-300 Hz, 5-6 g", "mode_m": 1, "mode_n": 1,
                  "design": "band_mean", "layout": "optimised", "cell": cells, "phi": phi[cells],
                  "fill_pct": 25.0}).to_csv(tmp_path / "layout.csv", index=False)
    surrogate = fit_surrogate(read_ceq_table(write_table(tmp_path / "table.csv")), method="gp")
    save_surrogate(surrogate, tmp_path / "surrogate.json")
    out = {name: tmp_path / "check" / name for name in ("curves.csv", "summary.csv", "check.json")}
    with caplog.at_level(logging.INFO, logger="pidpipe.campaign"):
        check_panel_mode(panel_check_params(config), str(tmp_path / "surrogate.json"),
                         str(tmp_path / "layout.csv"), str(out["curves.csv"]),
                         str(out["summary.csv"]), str(out["check.json"]), str(tmp_path / "packings"),
                         m_eff_surrogate_path=str(tmp_path / "surrogate_m_eff.json"))
    messages = " ".join(r.getMessage() for r in caplog.records)
    assert "no m_eff surrogate" in messages and "panel check: coupled" in messages
    meta = json.loads(out["check.json"].read_text())
    assert meta["layout"]["spheres_per_cell"] == 5                 # 25 % of the poured capacity 21
    assert sum(meta["groups"]["cells"]) == 600 and meta["force_n"] == 1.0
    curves = pd.read_csv(out["curves.csv"])
    assert set(curves.model) == {"coupled", "panel", "panel_full_mass", "panel_largest",
                                 "panel_ceq_minus_sd", "panel_ceq_plus_sd"}     # the GP's std
    spread = curves[curves.model.str.startswith("panel_ceq")].groupby("model").loss_factor.mean()
    assert spread["panel_ceq_minus_sd"] < curves[curves.model == "panel"].loss_factor.mean() \
        < spread["panel_ceq_plus_sd"]
    assert set(curves.sweep) == {"up", "down"} and meta["reported_sweep"] == "up"
    assert len(curves[(curves.model == "coupled") & (curves.sweep == "down")]) == 3
    coupled = curves[(curves.model == "coupled") & (curves.sweep == "up")]
    assert len(coupled) == 3
    # 1 N on the 0.38 kg mode with zeta 0.01 drives the antinode past 1 g (1.8-5.6 g): the beds
    # fly and dissipate more than a fifth of the structure's own loss factor (resting beds: 4 %,
    # tests/panel/test_check.py), the energy balance closes, and the beds add less than their
    # whole projected mass (600 x 5 spheres x 9.65e-6 kg x phi^2 = 30 g), at 5.6 g a fifth of it
    structural = coupled.loss_factor - coupled.particle_loss_factor
    assert (coupled.accel_g > 1.5).all() and (coupled.particle_loss_factor > 0.2 * structural).all()
    assert (coupled.m_eff_kg < coupled.panel_m_eff_kg).all()
    flying = coupled.loc[coupled.accel_g.idxmax()]
    assert flying.accel_g > 4.0 and flying.m_eff_kg < 0.2 * flying.panel_m_eff_kg
    assert (coupled.balance_residual_fraction < 0.01).all()
