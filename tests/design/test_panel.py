"""panel.n_cells: the structure being designed may have more cells than the simulated coupon."""

import math

import numpy as np
import pytest

from pidpipe.config import (
    budget_spheres,
    coupon_mass_kg,
    load_config,
    panel_n_cells,
    validate_config,
)
from pidpipe.design.designs import Search, optimise_designs
from pidpipe.design.optimisation import (
    Budget,
    BudgetError,
    Environment,
    optimise_environment,
)
from pidpipe.errors import ConfigError
from pidpipe.physics.contact import sphere_mass

DOMAIN = {"freq_hz": (50.0, 1000.0), "accel_g": (1.0, 10.0), "fill_pct": (25.0, 90.0)}
ENV = Environment("250-300 Hz, 5-6 g", (250.0, 300.0), (5.0, 6.0))


class FewerIsBetter:
    """C_eq = f G r exp(-r/30) / 1000: C/r falls with r, so the lowest fill in the most cells wins."""

    domain = DOMAIN

    def predict(self, freq_hz, accel_g, fill_pct):
        r = np.asarray(fill_pct, dtype=float)
        return np.asarray(freq_hz) * np.asarray(accel_g) * r * np.exp(-r / 30.0) / 1000.0


def test_a_budget_needing_more_cells_than_the_coupon_is_spent_on_the_panel():
    # the source's 15876 spheres, 36 to a full cell: 441 cells at 90 % hold only 14288
    with pytest.raises(BudgetError, match="cannot be spent: all 441 cells at the highest fill 90 %"):
        optimise_environment(FewerIsBetter(), ENV, Budget(15876, 36, 441), starts=4)
    panel = Budget(15876, 36, 441, n_cells_panel=1764)
    assert panel.max_cells == 1764
    results = optimise_designs(FewerIsBetter(), [ENV], panel, Search(starts=6, seed=2))
    for res in results:
        d = res.design
        assert d.n_cells == 1764 and d.fill_pct == pytest.approx(25.0)  # 9 spheres in each cell
        assert d.whole_spheres_per_cell == 9 and d.spheres_left_over == 0
        assert d.n_cells * d.spheres_per_cell == pytest.approx(15876)
        assert res.bounds["n_cells"] == (1.0, 1764.0)
        # C_eq per cell is the coupon's / 441 whatever the panel: total = per cell x 1764
        per_cell = FewerIsBetter().predict(300.0, 6.0, 25.0) / 441
        assert res.band.best_total_ceq_ns_m == pytest.approx(per_cell * 1764, rel=1e-9)
    # a panel too small for the budget keeps the clear error, naming the panel
    with pytest.raises(BudgetError, match="all 450 cells of the panel at the highest fill 90 %"):
        optimise_environment(FewerIsBetter(), ENV, Budget(15876, 36, 441, n_cells_panel=450), starts=4)


def test_the_mass_budget_scales_with_the_panel_and_the_key_is_validated():
    config = load_config()
    assert config["panel"]["n_cells"] is None and panel_n_cells(config) == 441
    coupon = budget_spheres(config)
    particle = config["materials"][config["particle_material"]]
    one = sphere_mass(particle["radius_m"], particle["density_kg_m3"])
    assert coupon == math.floor(0.1 * coupon_mass_kg(config) / one) == 229
    config["panel"]["n_cells"] = 1764
    assert budget_spheres(validate_config(config)) == math.floor(0.1 * 4 * coupon_mass_kg(config) / one)
    config["budget"] = {"mode": "spheres", "spheres": 15876}
    assert budget_spheres(validate_config(config)) == 15876  # a count does not scale
    config["panel"]["n_cells"] = 0
    with pytest.raises(ConfigError, match="panel.n_cells"):
        validate_config(config)
