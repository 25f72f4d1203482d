"""A patch of cells in one LIGGGHTS run against the same packings shaken one cell at a time.

The walls are rigid and prescribed, so spheres in different cells cannot interact: a cell of a
patch must behave as the same packing alone. In this 3-cell patch, cell 0 sits at the origin
with the same wall triangles as alone and its arithmetic does not change, so its series must
match exactly (in larger patches the box, and so the neighbour binning, changes, and even cell 0
then differs by rounding: bench_scene.py counts such cells). The other cells are translated,
which changes the rounding, and DEM trajectories diverge from there, so they must agree within
the statistics (3 combined standard errors, fixed before running).
"""

import math

import numpy as np
import pytest

from pidpipe.cell.patch import place_in_cells, ring_centres, spheres_in_own_cells
from pidpipe.cell.scene import CellScene
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.liggghts.patch_run import CONTAINMENT_TOL_RADII, run_patch
from pidpipe.liggghts.pour import pour
from tests.conftest import short_config

pytestmark = pytest.mark.engine

FREQ_HZ, ACCEL_G = 1000.0, 10.0   # the liveliest bed of the grid: spheres hit the side walls
AGREE_SEMS = 3.0
LEDGER_TOL = 0.01                 # of the mean E_d (mean) and of the gross work (largest cycle)


@pytest.fixture(scope="module")
def runs(tmp_path_factory, half_fill_packing):
    cfg = short_config(transient=3, measured=12)
    folder = tmp_path_factory.mktemp("scene")
    packings = [half_fill_packing] + [pour(PourSettings.from_config(cfg), 50, k, folder / f"pour{k}") for k in (1, 2)]
    centres = ring_centres(CellScene.from_config(cfg).cell, 1)[:3]    # the centre cell and two neighbours
    patch = run_patch(ShakeSettings.from_config(cfg), FREQ_HZ, ACCEL_G, packings, centres, folder / "patch", "patch3")
    singles = [run_patch(ShakeSettings.from_config(cfg), FREQ_HZ, ACCEL_G, [p], np.zeros((1, 2)), folder / f"single{k}",
                         f"single{k}") for k, p in enumerate(packings)]
    return {"config": cfg, "packings": packings, "centres": centres, "patch": patch,
            "singles": singles}


def test_spheres_start_and_stay_in_their_own_cells(runs):
    cfg = runs["config"]
    positions, owner = place_in_cells([p.centres() for p in runs["packings"]], runs["centres"])
    radius = runs["packings"][0].radius_m
    # settled spheres press on the walls by a few 0.01 um: the run's tolerance (0.02 radii)
    assert spheres_in_own_cells(CellScene.from_config(cfg).cell, runs["centres"], positions, owner, radius,
                                CONTAINMENT_TOL_RADII * radius).all()
    assert runs["patch"]["contained"]
    assert all(single["contained"] for single in runs["singles"])


def test_centre_cell_of_the_patch_is_the_single_cell_exactly(runs):
    in_patch, alone = runs["patch"]["cells"][0], runs["singles"][0]["cells"][0]
    assert in_patch["ed_cycle_mean_j"] == alone["ed_cycle_mean_j"]
    assert in_patch["ceq_cell_ns_m"] == alone["ceq_cell_ns_m"]


def test_translated_cells_agree_with_the_same_packings_alone(runs):
    for k in (1, 2):
        in_patch, alone = runs["patch"]["cells"][k], runs["singles"][k]["cells"][0]
        combined = math.hypot(in_patch["ceq_cell_sem_ns_m"], alone["ceq_cell_sem_ns_m"])
        assert abs(in_patch["ceq_cell_ns_m"] - alone["ceq_cell_ns_m"]) <= AGREE_SEMS * combined, k
    total_patch = runs["patch"]["total"]
    total_alone = sum(s["total"]["ed_cycle_mean_j"] for s in runs["singles"])
    combined = math.sqrt(total_patch["ed_cycle_sem_j"] ** 2
                         + sum(s["total"]["ed_cycle_sem_j"] ** 2 for s in runs["singles"]))
    assert abs(total_patch["ed_cycle_mean_j"] - total_alone) <= AGREE_SEMS * combined


def test_per_cell_ledger_adds_up_to_the_mesh_ledger(runs):
    for record in (runs["patch"], *runs["singles"]):
        mismatch = record["ledger_mismatch"]
        assert abs(mismatch["of_dissipation"]) <= LEDGER_TOL
        assert mismatch["largest_cycle_of_gross_work"] <= LEDGER_TOL
    patch = runs["patch"]
    summed = sum(c["ed_cycle_mean_j"] for c in patch["cells"])
    assert summed == pytest.approx(patch["total"]["ed_cycle_mean_j"], rel=LEDGER_TOL)
    assert patch["total"]["ed_cycle_mean_j"] > 0
    assert patch["per_cell"]["ceq_ns_m"] == pytest.approx(
        np.mean([c["ceq_cell_ns_m"] for c in patch["cells"]]))
    assert patch["cell_cycles"] == 3 * (3 + 12) and patch["engine"]["cpu_time_s"] > 0
