"""`pidpipe panel`: the modal stage alone on a C_eq table, its outputs and their columns."""

import pandas as pd

from pidpipe.cli import main
from tests.design.test_optimise_command import write_config, write_table


def test_the_panel_command_writes_modes_layouts_and_designs(tmp_path, capsys):
    table = write_table(tmp_path / "table.csv")
    config = write_config(tmp_path / "config.yaml",
                          environments=[{"name": "250-300 Hz, 5-6 g", "freq_hz": [250, 300],
                                         "accel_g": [5, 6]}],
                          panel={"regions": 4, "starts": 1, "surrogate_draws": 4,
                                 "modal_force_n": [0.3]},
                          optimisation={"starts": 4})
    out = tmp_path / "panel"
    assert main(["panel", "--table", str(table), "--config", str(config), "--output-dir", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "(1,1) 270.6 Hz" in printed
    modes = pd.read_csv(out / "modes.csv")
    assert list(modes.columns) == ["mode_m", "mode_n", "freq_hz", "modal_mass_kg"]
    assert len(modes) == 5 and modes["freq_hz"].is_monotonic_increasing
    designs = pd.read_csv(out / "designs.csv")
    assert len(designs) == 9                                   # 3 designs x 3 layouts on mode (1,1)
    assert set(designs["layout"]) == {"source_uniform", "source_antinode", "optimised"}
    assert (designs["eta_lo"] <= designs["eta"]).all() and (designs["eta"] <= designs["eta_hi"]).all()
    for _, rows in designs.groupby("design"):
        by = rows.set_index("layout")
        assert by.loc["source_uniform", "added_mass_kg"] == by.loc["source_antinode", "added_mass_kg"]
        assert by.loc["optimised", "added_mass_kg"] <= 1.0001 * by.loc["source_uniform", "added_mass_kg"]
        # on this table C_eq grows with G: the antinode beats the uniform spread, and the
        # optimisation (started from the antinode layout too) does not lose to it
        assert by.loc["source_antinode", "eta"] > 2 * by.loc["source_uniform", "eta"]
        assert by.loc["optimised", "eta"] >= 0.99 * by.loc["source_antinode", "eta"]
    layout = pd.read_csv(out / "layout.csv")
    assert {"x_mm", "y_mm", "fill_pct", "accel_g_band_lo", "accel_g_band_hi"} <= set(layout.columns)
    assert layout["x_mm"].between(0, 1050).all() and layout["y_mm"].between(0, 650).all()
    response = pd.read_csv(out / "response.csv")
    assert (response["accel_g"] < response["bare_accel_g"]).all()
    assert (out / "panel.png").stat().st_size > 0
