"""The compiled DEM's pour: the LIGGGHTS pour's protocol, settled, fitting, reproducible, and its
bulk measures those of the LIGGGHTS pour.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from pidpipe.cell.packing import SETTLED_SPEED_M_S, check_packing
from pidpipe.cell.pour_protocol import plan_pour
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings
from pidpipe.dem import compiled
from pidpipe.dem.pour import pour, pour_scenes
from pidpipe.dem.run import start
from pidpipe.liggghts.pour import pour as liggghts_pour

GOLDEN = Path(__file__).parent.parent / "golden"


@pytest.fixture(scope="module")
def settings() -> PourSettings:
    return PourSettings.from_config(load_config())


@pytest.fixture(scope="module")
def half_fill(settings):
    """The default config's 50 % packing (11 spheres), replicate 0, poured by the DEM."""
    return pour(settings, 50, 0)


def test_a_dem_pour_is_settled_fits_and_names_its_engine(settings, half_fill):
    assert half_fill.pour_engine == "dem"
    assert half_fill.n_spheres == settings.fill.spheres(50) == 11
    assert half_fill.seed == settings.pouring.seed + 0 and half_fill.fill_pct == 50.0
    assert half_fill.max_speed_m_s <= SETTLED_SPEED_M_S
    check_packing(half_fill, "f500Hz_G5_r50pct_rep0")
    # every sphere inside the closed cell (an overlap with a wall of at most Hertz's few um)
    cell = plan_pour(settings, 50, 0).scene.cell
    assert np.all(cell.contains_spheres(half_fill.centres(), half_fill.radius_m, tol_m=1e-5))
    # the same settling time, in the same steps of the same timestep, as the LIGGGHTS pour's
    assert half_fill.settle_time_s == json.loads((GOLDEN / "pack_r50pct_rep0.json").read_text())["settle_time_s"]


def test_a_dem_pour_is_reproducible_from_its_seed_and_another_seed_differs(settings, half_fill):
    again = pour(settings, 50, 0)
    assert again == half_fill                       # every field, positions bit for bit
    other = pour(settings, 50, 1)
    assert other.seed == half_fill.seed + 1
    assert other.positions_m != half_fill.positions_m


def test_the_open_cell_has_the_cells_floor_and_its_lid_at_the_liggghts_side_walls_top(settings):
    plan = plan_pour(settings, 90, 0)
    still, tapping, shift = pour_scenes(plan)
    floor = plan.start_m[:, 2].min() - plan.scene.radius_m
    assert tapping.cell.floor_z_m == pytest.approx(plan.scene.cell.floor_z_m + shift[2], abs=1e-15)
    assert tapping.cell.lid_z_m - shift[2] == pytest.approx(plan.top_z_m, abs=1e-15)
    assert floor - plan.scene.cell.floor_z_m < 0.1 * plan.scene.radius_m
    assert still.timestep_s == tapping.timestep_s == plan.timestep.timestep_s
    assert np.all(still.amplitude_m == 0.0)
    assert tapping.amplitude_m[0] == pytest.approx(plan.tap_amplitude_m, rel=1e-12)


def test_the_base_motion_can_change_only_its_amplitude(settings):
    plan = plan_pour(settings, 25, 0)
    still, tapping, shift = pour_scenes(plan)
    _, _, ws = start(still, plan.start_m + shift)
    compiled.set_base_motion(ws, tapping)
    assert ws.amplitude[0] == pytest.approx(plan.tap_amplitude_m, rel=1e-12)
    with pytest.raises(ValueError, match="more than"):
        compiled.set_base_motion(ws, dataclasses.replace(tapping, timestep_s=0.5 * tapping.timestep_s))


#: Seeds (replicates) and fills of the comparison with LIGGGHTS: half full and nearly full.
COMPARED = {50: range(6), 90: range(4)}


@pytest.mark.engine
@pytest.mark.slow
@pytest.mark.parametrize("fill", sorted(COMPARED))
def test_the_dem_pile_is_the_liggghts_pile_in_bulk(settings, fill, tmp_path):
    """Mean pile height and centre-of-mass height over seeds agree between the two engines.

    The engines integrate the same protocol and contact law with different arithmetic (mesh
    triangles against planes, their own order of operations), and a pour is chaotic, so the
    sphere positions of one seed differ; the bulk of a pile is what must agree. Two bounds,
    fixed before measuring: the difference of the means is within 3 standard errors of the
    difference (both engines draw from one distribution of piles), and below a quarter of a
    sphere radius (0.31 mm), under a third of what one more sphere adds to the pile (about
    1.1 mm per sphere at every default fill), so finer than the fill itself is resolved.
    benchmarks/bench_pour.py compares 8 seeds of every default fill.
    """
    dem, lig = [], []
    for replicate in COMPARED[fill]:
        for out, packing in ((dem, pour(settings, fill, replicate)),
                             (lig, liggghts_pour(settings, fill, replicate, tmp_path / f"r{replicate}"))):
            check_packing(packing, f"r{fill}pct_rep{replicate}")
            centres = packing.centres()
            out.append((packing.pile_height_m, centres[:, 2].mean() + 0.5 * packing.lid_height_m))
    dem, lig = np.array(dem), np.array(lig)
    n = len(dem)
    for column, name in enumerate(("pile height", "centre-of-mass height")):
        difference = dem[:, column].mean() - lig[:, column].mean()
        standard_error = np.sqrt((dem[:, column].var(ddof=1) + lig[:, column].var(ddof=1)) / n)
        assert abs(difference) <= 3.0 * standard_error, (name, difference, standard_error)
        assert abs(difference) <= 0.25 * settings.materials.particle.radius_m, (name, difference)
