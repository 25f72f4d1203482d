"""The compiled DEM's pour: the LIGGGHTS pour's protocol, settled, fitting, reproducible, and its
bulk measures those of the LIGGGHTS pour.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from pidpipe.cell.packing import MAX_FURTHER_SETTLING, SETTLED_SPEED_M_S, check_packing
from pidpipe.cell.pour_protocol import plan_pour, settled_packing
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings
from pidpipe.dem import compiled
from pidpipe.dem.pour import pour, pour_replicates, pour_scenes
from pidpipe.dem.run import advance, start
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


def _pour_alone(settings, fill, replicate):
    """One replicate poured alone, the protocol written out step by step (one cell in every
    kernel call, as pidpipe.dem.pour poured before it batched): the reference of the batch."""
    plan = plan_pour(settings, fill, replicate)
    still, tapping, shift = pour_scenes(plan)
    scene, state, ws = start(still, plan.start_m + shift)
    advance(scene, state, ws, plan.settle_steps)
    compiled.set_base_motion(ws, tapping)
    state.step = 0
    advance(tapping, state, ws, plan.tap_steps)
    compiled.set_base_motion(ws, scene)
    advance(scene, state, ws, plan.settle_steps)
    chunks = 1
    while np.linalg.norm(state.v[:, 0, :], axis=0).max() > SETTLED_SPEED_M_S and chunks <= MAX_FURTHER_SETTLING:
        advance(scene, state, ws, plan.settle_steps)
        chunks += 1
    return settled_packing(plan, state.x[:, 0, :].T - shift, state.v[:, 0, :].T, chunks, "dem")


def test_batched_pours_are_the_single_pours_bit_for_bit(settings):
    """At 25 % every seed's open cell is the closed cell (its highest start more than 4 radii
    below the lid), so replicates 0-5 pour as one batch; at 50 % each seed's open cell differs
    and they pour one by one. A settle time of 0.02 s leaves the 25 % cells settling for 2 to 5
    periods (the cap), so each cell's own settle check inside the batch is tested too."""
    short = dataclasses.replace(settings, pouring=dataclasses.replace(settings.pouring, settle_time_s=0.02))
    assert len({plan_pour(short, 25, k).top_z_m for k in range(6)}) == 1
    assert len({plan_pour(short, 50, k).top_z_m for k in (3, 1)}) == 2
    for fill, replicates in ((25, [5, 0, 1, 2, 3, 4]), (50, [3, 1])):
        batched = pour_replicates(short, fill, replicates)
        alone = [_pour_alone(short, fill, k) for k in replicates]
        assert batched == alone                      # every field, positions bit for bit
        assert [p.seed for p in batched] == [short.pouring.seed + k for k in replicates]
        if fill == 25:
            chunks = {round(p.settle_time_s / plan_pour(short, 25, 0).settle_period_s) for p in batched}
            assert min(chunks) >= 2 and max(chunks) == 1 + MAX_FURTHER_SETTLING and len(chunks) >= 3
    assert pour(short, 50, 3) == alone[0]


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
